"""`train-detector` without the training requirements: the exact pip command, or --install."""
from __future__ import annotations

import importlib.util
import subprocess
import sys

import pytest

from hand_tracker_ros.cli import train_detector
from hand_tracker_ros.cli.main import main
from hand_tracker_ros.errors import HandTrackerError


@pytest.fixture()
def without_torch(monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(train_detector.importlib.util, 'find_spec',
                        lambda name, *a: None if name == 'torch' else real(name, *a))


def test_missing_torch_prints_the_exact_pip_command(without_torch, capsys) -> None:
    assert main(['train-detector', '--seed', '0', '--out', 'unused.onnx']) == 2
    err = capsys.readouterr().err
    assert 'train-detector needs torch' in err
    assert f'{sys.executable} -m pip install -r ' in err
    assert err.split(' -r ')[1].split()[0].endswith('requirements/train.txt')
    assert 'HT_TRAIN=1' in err


def test_install_runs_that_command(without_torch, monkeypatch) -> None:
    commands = []

    def fake_run(command, check):
        commands.append(command)
        return subprocess.CompletedProcess(command, 1)

    monkeypatch.setattr(train_detector.subprocess, 'run', fake_run)
    with pytest.raises(HandTrackerError, match='installing the training requirements failed'):
        train_detector.ensure_training_requirements(install=True)
    [command] = commands
    assert command[:5] == [sys.executable, '-m', 'pip', 'install', '-r']
    assert command[5].endswith('requirements/train.txt')
