"""tools/setup.sh builds msg_defs/tf2_msgs only when no tf2_msgs is installed
(tools/find_tf2_msgs.sh): an installed one on AMENT_PREFIX_PATH or in the venv wins, our own
build in the workspace does not count."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / 'tools' / 'find_tf2_msgs.sh'


def _prefix(root: Path, with_tf2_msgs: bool) -> Path:
    index = root / 'share' / 'ament_index' / 'resource_index' / 'packages'
    index.mkdir(parents=True)
    if with_tf2_msgs:
        (index / 'tf2_msgs').touch()
    return root


def _find(venv: Path, ws: Path, *prefixes: Path) -> str:
    env = {**os.environ, 'AMENT_PREFIX_PATH': os.pathsep.join(map(str, prefixes))}
    if not prefixes:
        env.pop('AMENT_PREFIX_PATH')
    return subprocess.run(['bash', str(SCRIPT), str(venv), str(ws)], env=env, check=True,
                          capture_output=True, text=True).stdout.strip()


def test_an_installed_tf2_msgs_is_found_and_our_build_is_not(tmp_path: Path) -> None:
    venv = _prefix(tmp_path / 'venv', False)
    ws = tmp_path / 'ws'
    ours = _prefix(ws / 'install' / 'tf2_msgs', True)
    ros = _prefix(tmp_path / 'opt_ros', True)
    assert _find(venv, ws) == ''
    assert _find(venv, ws, ours) == ''                   # our own build: build it again
    assert _find(venv, ws, ours, ros) == str(ros)        # a full ROS install: use it
    assert _find(_prefix(tmp_path / 'venv2', True), ws) == str(tmp_path / 'venv2')
