"""`hand-tracker calibrate` recovers the size of a synthetic hand 1.1x the default (24 frames,
4 of them fitted; about 40 s on the shared 2-core machine)."""
from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import numpy as np
import pytest

from hand_tracker_ros.cli.main import main
from hand_tracker_ros.model.shape import HandShape
from hand_tracker_ros.model.shape_file import load_shape, save_shape


@pytest.mark.slow
def test_calibrate_recovers_a_larger_hand(tmp_path: Path) -> None:
    true = HandShape(scale=1.1)
    save_shape(true, tmp_path / 'true.yaml')
    assert main(['synth', '--out', str(tmp_path / 'seq'), '--motion', 'grasp', '--frames', '24',
                 '--seed', '3', '--shape', str(tmp_path / 'true.yaml')]) == 0
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(['calibrate', str(tmp_path / 'seq' / 'bag'), '--out',
                     str(tmp_path / 'fitted.yaml'), '--frames', '4']) == 0
    text = printed.getvalue()
    assert 'fitted 4 frames' in text and 'RMS residual of the frames' in text
    fitted = load_shape(tmp_path / 'fitted.yaml')
    assert abs(fitted.scale / true.scale - 1.0) < 0.02
    error_mm = 1e3 * np.abs(fitted.finger_lengths_m() - true.finger_lengths_m())
    assert error_mm.max() < 3.0
    # The model of the right size matches the image edges better.
    line = next(li for li in text.splitlines() if li.strip().startswith('edges'))
    before, after = (float(v) for v in re.findall(r'([0-9.]+) px', line))
    assert after < before, line
