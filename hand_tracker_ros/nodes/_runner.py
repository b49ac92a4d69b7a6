"""Process entry shared by every node: ``--help``, DDS defaults, spin, clean shutdown.

SIGINT and SIGTERM both end the process cleanly: rclpy's signal handlers shut the context
down, ``spin`` raises ``ExternalShutdownException``, and the node is destroyed before
``rclpy.try_shutdown``. Exit code 0 on such a shutdown.
"""
from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.utilities import remove_ros_args

from hand_tracker_ros.config import describe, flatten
from hand_tracker_ros.ros_env import apply_ros_defaults


def _help_text(config_cls: type) -> str:
    meta, defaults = describe(config_cls), flatten(config_cls())
    lines = ['parameters (set with --ros-args -p NAME:=VALUE or --params-file FILE):']
    for name, default in defaults.items():
        unit = f" [{meta[name]['unit']}]" if meta[name]['unit'] else ''
        lines.append(f'  {name} = {default!r}{unit}\n      {meta[name]["doc"]}')
    return '\n'.join(lines)


def run_node(name: str, description: str, config_cls: type,
             factory: Callable[[], Node], args: Sequence[str] | None = None) -> int:
    """Parse non-ROS arguments, then create the node with ``factory`` and spin it."""
    argv = list(sys.argv if args is None else args)
    parser = argparse.ArgumentParser(
        prog=name, description=description, epilog=_help_text(config_cls),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.parse_args(remove_ros_args(argv)[1:])
    apply_ros_defaults()
    rclpy.init(args=argv)
    node = None
    try:
        node = factory()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
