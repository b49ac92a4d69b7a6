"""Progress bars: drawn on a terminal only, and never change what is iterated."""
from __future__ import annotations

import io

import pytest

from hand_tracker_ros import progress as progress_module
from hand_tracker_ros.progress import progress


class _Stream(io.StringIO):
    def __init__(self, tty: bool) -> None:
        super().__init__()
        self._tty = tty

    def isatty(self) -> bool:
        return self._tty


@pytest.mark.parametrize('stdout_tty, stderr_tty, drawn', [
    (True, True, True), (False, True, False), (True, False, False), (False, False, False)])
def test_bar_only_on_a_terminal(monkeypatch, stdout_tty, stderr_tty, drawn) -> None:
    stdout, stderr = _Stream(stdout_tty), _Stream(stderr_tty)
    monkeypatch.setattr(progress_module.sys, 'stdout', stdout)
    monkeypatch.setattr(progress_module.sys, 'stderr', stderr)
    monkeypatch.delenv('TQDM_DISABLE', raising=False)
    assert list(progress(iter(range(5)), total=5, desc='synth', unit='frame')) == list(range(5))
    assert ('synth' in stderr.getvalue()) == drawn
    assert stdout.getvalue() == ''
