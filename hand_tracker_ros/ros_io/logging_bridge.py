"""Forward the core's Python ``logging`` records to a node's rclpy logger.

The core logs through ``logging.getLogger(__name__)`` and never imports rclpy (house rules 1
and 8); a node installs this handler once so those records appear in the ROS log with the
node's name and severity.
"""
from __future__ import annotations

import logging

from rclpy.node import Node


class RclpyLogHandler(logging.Handler):
    """A logging handler that writes into an rclpy logger."""

    def __init__(self, node: Node) -> None:
        super().__init__()
        self._logger = node.get_logger()

    def emit(self, record: logging.LogRecord) -> None:
        text = self.format(record)
        if record.levelno >= logging.ERROR:
            self._logger.error(text)
        elif record.levelno >= logging.WARNING:
            self._logger.warning(text)
        elif record.levelno >= logging.INFO:
            self._logger.info(text)
        else:
            self._logger.debug(text)


def bridge_core_logging(node: Node, level: int = logging.INFO) -> None:
    """Route ``hand_tracker_ros.*`` log records to ``node``'s logger."""
    core = logging.getLogger('hand_tracker_ros')
    core.setLevel(level)
    core.handlers = [h for h in core.handlers if not isinstance(h, RclpyLogHandler)]
    handler = RclpyLogHandler(node)
    handler.setFormatter(logging.Formatter('%(name)s: %(message)s'))
    core.addHandler(handler)
    core.propagate = False
