"""Process entry shared by every node: ``--help``, DDS defaults, spin, clean shutdown.

SIGINT and SIGTERM both end the process cleanly: rclpy's signal handlers shut the context
down, the spin loop sees it, and the node is destroyed before ``rclpy.try_shutdown``. Exit code
0 on such a shutdown.

Two details make that hold under load:

- rclpy's handler chains to Python's SIGINT handler, which would raise ``KeyboardInterrupt``
  at whatever bytecode runs next, e.g. between a subscription's take and its callback (the
  recorder then loses that message). Python's handler is replaced by a latch that only notes
  the signal (:data:`hand_tracker_ros.interrupts.INTERRUPTS`), so the context shutdown alone
  ends the spin and every taken message reaches its callback. The node's console entry
  installs the same latch before its imports, so a SIGINT that came before ``rclpy.init``
  (rclpy's handler not yet installed) ends the process as soon as it is initialised.
- The loop spins with a timeout instead of ``rclpy.spin``'s unbounded wait, so a signal that
  lands between the ``context.ok()`` check and the wait (an idle node has no timer to wake it)
  is noticed within ``_SPIN_PERIOD_S``; a shutdown racing the wait-set creation raises
  rclpy's ``RCLError`` ("context is not valid", a ``RuntimeError``; rclpy does not export
  the class), which then also just ends the loop.

The executor. rclpy's ``SingleThreadedExecutor`` rebuilds its wait set in Python for every
wait (with events that come one at a time, about every callback), holding the interpreter
lock the tracker's fit needs: in the distributed
graph (24 subscriptions per tracker at 4 cameras) py-spy found the tracker's executor thread
holding the lock in 17 % of the samples, and a fit took 36.8 ms of wall time for 24.1 ms of
CPU (27.8 for 23.7 composed). rclpy's ``EventsExecutor`` (``rclpy.experimental``) queues the
middleware's events in C++ instead; with it, in pairs at 1.0x (docs/history.md, "Session of
2026-11-26 (ninth)"), the distributed graph estimated 25.8 / 27.6 / 25.0 / 17.6 sets/s
against 15.6 / 18.4 / 21.4 / 16.8 (latency p50 55-63 ms against 65-91 ms); composed, the pairs
showed no difference that the runs' spread resolves. It cannot wait on guard conditions, so a
process whose nodes made one (a player with a bag to play) keeps the single-threaded executor.
``HAND_TRACKER_EXECUTOR=single`` in the environment chooses that one everywhere, e.g. should
one of rclpy's open issues on the events executor (ros2/rclpy#1641, #1644: crashes when a
task raises, or when entities with event callbacks are destroyed while it spins; our nodes
do neither) bite.
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
from collections.abc import Callable, Sequence

import rclpy
from rclpy.context import Context
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.utilities import remove_ros_args

from hand_tracker_ros.config import describe, flatten
from hand_tracker_ros.interrupts import INTERRUPTS
from hand_tracker_ros.ros_env import apply_ros_defaults

_SPIN_PERIOD_S = 0.5
EXECUTOR_ENV = 'HAND_TRACKER_EXECUTOR'
EXECUTORS = ('events', 'single')


def _help_text(config_cls: type) -> str:
    meta, defaults = describe(config_cls), flatten(config_cls())
    lines = ['parameters (set with --ros-args -p NAME:=VALUE or --params-file FILE):']
    for name, default in defaults.items():
        unit = f" [{meta[name]['unit']}]" if meta[name]['unit'] else ''
        lines.append(f'  {name} = {default!r}{unit}\n      {meta[name]["doc"]}')
    return '\n'.join(lines)


def _executor(nodes: Sequence[Node], context: Context, choice: str) -> Executor:
    """The events executor unless a node has a guard condition or ``choice`` (one of
    :data:`EXECUTORS`, from ``HAND_TRACKER_EXECUTOR``) is ``single`` (module docstring)."""
    if choice == 'single' or any(True for node in nodes for _ in node.guards):
        return SingleThreadedExecutor(context=context)
    return EventsExecutor(context=context)


def _spin(nodes: Sequence[Node], executor_choice: str) -> None:
    """Spin ``nodes`` on one executor (:func:`_executor`) until their context shuts down."""
    context = nodes[0].context
    if not context.ok():        # a signal came while the nodes were being built
        return
    executor = _executor(nodes, context, executor_choice)
    for node in nodes:
        executor.add_node(node)
    while context.ok():
        try:
            executor.spin_once(timeout_sec=_SPIN_PERIOD_S)
        except RuntimeError:
            if context.ok():
                raise
            return


def run_node(name: str, description: str, config_cls: type,
             factory: Callable[[], Node | Sequence[Node]],
             args: Sequence[str] | None = None) -> int:
    """Parse non-ROS arguments, then create the node(s) with ``factory`` and spin them on one
    executor (several nodes: a composed process, as an rclcpp component container)."""
    argv = list(sys.argv if args is None else args)
    parser = argparse.ArgumentParser(
        prog=name, description=description, epilog=_help_text(config_cls),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.parse_args(remove_ros_args(argv)[1:])
    executor_choice = os.environ.get(EXECUTOR_ENV, EXECUTORS[0])
    if executor_choice not in EXECUTORS:
        parser.error(f'{EXECUTOR_ENV} must be one of {", ".join(EXECUTORS)}, got '
                     f'{executor_choice!r}')
    apply_ros_defaults()
    python_sigint = INTERRUPTS.install()
    rclpy.init(args=argv)
    nodes: list[Node] = []
    try:
        if INTERRUPTS.hit:      # asked to stop before rclpy's handler was in place
            return 0
        made = factory()
        nodes = [made] if isinstance(made, Node) else list(made)
        _spin(nodes, executor_choice)
    except ExternalShutdownException:
        pass
    except Exception:
        # A signal that arrives while the node or its executor is still being built shuts
        # the context down under them (rclpy then fails to create a guard condition): that
        # is a shutdown, not an error. Anything raised while the context is up is one.
        if rclpy.ok():
            raise
    finally:
        for node in reversed(nodes):
            node.destroy_node()
        rclpy.try_shutdown()
        signal.signal(signal.SIGINT, python_sigint)
        INTERRUPTS.hit = False  # consumed by this run (the CLI and tests run nodes in-process)
    return 0
