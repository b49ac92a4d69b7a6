"""`ros2 run hand_tracker_ros <exe>` resolves every executable, and `--help` runs."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from hand_tracker_ros.ament import executable, share_file
from hand_tracker_ros.graph_nodes import NODES

EXECUTABLES = (*NODES, 'hand-tracker')


@pytest.mark.parametrize('name', EXECUTABLES)
def test_ament_lookup_finds_executable_and_help_runs(name: str) -> None:
    from ament_index_python.packages import get_package_prefix

    path = Path(get_package_prefix('hand_tracker_ros')) / 'lib' / 'hand_tracker_ros' / name
    assert path.is_file() and os.access(path, os.X_OK)
    assert executable(name) == path
    result = subprocess.run([str(path), '--help'], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith('usage:')


def test_share_files_are_installed() -> None:
    from ament_index_python.packages import get_package_share_directory

    share = Path(get_package_share_directory('hand_tracker_ros'))
    for rel in ('package.xml', 'config/fastdds_large_data.xml', 'config/tracker.yaml',
                'launch/tracker.launch.py', 'urdf/hand.urdf',
                'msg_defs/hand_tracker_msgs/msg/HandState.msg'):
        assert (share / rel).is_file(), rel
    assert share_file('config/tracker.yaml').is_file()
