"""Evaluation figures: the error plot marks LOST frames and failures and shows a single frame;
the overlay grid names the cameras, captions each frame and has a legend."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from hand_tracker_ros.evaluation.figures import (
    error_figure,
    error_plot,
    labelled_grid,
    overlay_grid,
    row_caption,
)
from hand_tracker_ros.pipeline.frames import ground_truth, load_rig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import write_sequence


def _labels(fig) -> list[str]:
    return fig.axes[0].get_legend_handles_labels()[1]


def test_error_plot_marks_lost_frames_and_failures() -> None:
    times = np.arange(6) / 30.0
    errors = np.array([2.0, 3.0, 40.0, 20.0, 18.0, 2.5])
    lost = np.array([False, False, True, False, False, True])
    fig = error_figure(times, errors, lost, 'test')
    labels = _labels(fig)
    assert 'reported LOST (2)' in labels
    assert 'failure: tracking but > 15 mm (2)' in labels          # frames 3 and 4
    assert 'failure threshold (15 mm)' in labels
    series = dict(zip(labels, fig.axes[0].get_lines()))
    np.testing.assert_array_equal(series['reported LOST (2)'].get_xdata(), times[lost])
    assert fig.axes[0].get_xlabel() == 'time (s)'


def test_error_plot_of_one_frame_is_not_empty(tmp_path: Path) -> None:
    fig = error_figure(np.array([0.0]), np.array([3.0]), np.array([False]), 'one frame')
    line = fig.axes[0].get_lines()[0]
    assert line.get_marker() == 'o' and line.get_xdata().tolist() == [0.0]
    error_plot(np.array([0.0]), np.array([3.0]), np.array([False]), tmp_path / 'e.png', 't')
    image = cv2.imread(str(tmp_path / 'e.png'))
    assert image is not None and image.shape[1] > 500


def test_labelled_grid_has_names_captions_and_legend() -> None:
    tiles = [[np.zeros((40, 60, 3), np.uint8)] * 3 for _ in range(2)]
    grid = labelled_grid(tiles, ['cam0', 'cam1', 'cam2'], ['frame 0', 'frame 9'])
    assert grid.shape == (16 + 2 * (16 + 40) + 16, 180, 3)
    for strip in (grid[:16, :60], grid[16:32], grid[-16:]):     # text drawn on white
        assert (strip < 128).any() and (strip == 255).any()
    with pytest.raises(ValueError):
        labelled_grid(tiles, ['cam0', 'cam1', 'cam2'], ['only one caption'])


def test_overlay_grid_of_a_bag(tmp_path: Path, hand_model) -> None:
    config = SynthConfig(motion='pinch', n_frames=3, n_cameras=2, width=96, height=72)
    bag = write_sequence(SyntheticSequence(config, hand_model), tmp_path / 'seq')
    truth = ground_truth(bag)
    stamps = sorted(truth)
    overlay_grid(bag, load_rig(bag), truth, stamps[1:], tmp_path / 'o.png',
                 {stamps[1]: 1.25})
    image = cv2.imread(str(tmp_path / 'o.png'))
    assert image.shape == (16 + 2 * (16 + 72) + 16, 2 * 96, 3)
    assert row_caption(1, 1 / 30, truth[stamps[1]], 1.25) == \
        'frame 1  t=0.03 s  TRACKING  error 1.2 mm'
    assert row_caption(2, 0.0, truth[stamps[2]], None).endswith('TRACKING')


def test_ablation_error_plot_marks_each_configurations_lost_frames() -> None:
    from types import SimpleNamespace

    from hand_tracker_ros.evaluation.report import error_figure

    errors = np.array([1.0, 2.0, 30.0, 3.0])
    runs = [SimpleNamespace(label=label, motion='grasp', errors_mm=errors + k,
                            lost=np.array([False, False, True, k == 1]))
            for k, label in enumerate(('full', 'LO+E'))]
    fig = error_figure(runs)
    ax = fig.axes[0]
    assert ax.get_legend() is not None
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ['full', 'LO+E', 'reported LOST', 'failure threshold (15 mm)']
    crosses = [line for line in ax.get_lines() if line.get_marker() == 'x']
    assert [line.get_xdata().tolist() for line in crosses] == [[3], [3, 4]]
