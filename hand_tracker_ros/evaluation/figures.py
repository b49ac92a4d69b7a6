"""Pictures of a tracked sequence: error over time, and the estimate drawn on the images.

:func:`error_figure` plots the per-frame mean 3D joint error (mm) against time (s from the
first estimate) with every frame as a point, so that a single frame shows too; the frames the
tracker reported LOST and the failures (error above ``FAILURE_MM`` while reported as tracking,
:mod:`.metrics`) are marked and counted in the legend, with the threshold as a dashed line.

:func:`overlay_grid` draws the estimate on the camera images, one row per frame and one column
per camera, with the camera names above the columns, a caption per row (frame, time, status,
error) and a legend of the drawing (:mod:`hand_tracker_ros.tracking.overlay`).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, UInt8Array
from hand_tracker_ros.bags.convert import HandStateValues
from hand_tracker_ros.bags.image_codec import image_from_msg
from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.evaluation.metrics import FAILURE_MM
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.frames import camera_image_topics
from hand_tracker_ros.render.rasterizer import render
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.tracking.overlay import CONTOUR_RGB, SKELETON_RGB, draw_overlay
from hand_tracker_ros.vision.image import to_gray

_FONT = cv2.FONT_HERSHEY_SIMPLEX
_FONT_SCALE = 0.4
_STRIP_PX = 16          # height of a text strip (column names, row captions, legend)
_LEGEND = ((CONTOUR_RGB, 'model silhouette'), (SKELETON_RGB, 'model skeleton'))


def error_figure(times_s: FloatArray, errors_mm: FloatArray, lost: BoolArray, title: str,
                 failure_mm: float = FAILURE_MM) -> Any:
    """The error over time, LOST frames and failures marked (a matplotlib Figure).

    Parameters
    ----------
    times_s : (N,) float64
        Time of each scored frame, s (e.g. from the first estimate).
    errors_mm : (N,) float64
        Mean 3D joint error of each frame, mm.
    lost : (N,) bool
        The tracker reported the frame LOST.
    title : str
    failure_mm : float
        Error above which a frame reported as tracking is a failure, mm.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    times_s = np.asarray(times_s, dtype=np.float64)
    check_shape('errors_mm', np.asarray(errors_mm), times_s.shape)
    check_shape('lost', np.asarray(lost), times_s.shape)
    lost = np.asarray(lost, dtype=bool)
    failed = (np.asarray(errors_mm) > failure_mm) & ~lost
    fig, ax = plt.subplots(figsize=(8, 3.2))
    ax.plot(times_s, errors_mm, '-o', lw=1, ms=2.5, color='tab:blue',
            label=f'mean 3D joint error ({times_s.size} frames)')
    ax.axhline(failure_mm, ls='--', lw=1, color='gray',
               label=f'failure threshold ({failure_mm:g} mm)')
    ax.plot(times_s[failed], np.asarray(errors_mm)[failed], 'o', ms=6, mfc='none',
            color='tab:orange', label=f'failure: tracking but > {failure_mm:g} mm '
                                      f'({np.count_nonzero(failed)})')
    ax.plot(times_s[lost], np.asarray(errors_mm)[lost], 'x', ms=7, color='tab:red',
            label=f'reported LOST ({np.count_nonzero(lost)})')
    ax.set_xlabel('time (s)')
    ax.set_ylabel('mean 3D joint error (mm)')
    ax.set_ylim(bottom=0.0)
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc='upper left')
    fig.tight_layout()
    return fig


def error_plot(times_s: FloatArray, errors_mm: FloatArray, lost: BoolArray, path: Path,
               title: str) -> None:
    """Write :func:`error_figure` as a PNG."""
    import matplotlib.pyplot as plt

    fig = error_figure(times_s, errors_mm, lost, title)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _text_strip(width: int, texts: Sequence[str], cell_px: int) -> UInt8Array:
    """A white strip with ``texts`` left-aligned in consecutive cells of ``cell_px``."""
    strip = np.full((_STRIP_PX, width, 3), 255, np.uint8)
    for k, text in enumerate(texts):
        cv2.putText(strip, text, (k * cell_px + 3, _STRIP_PX - 4), _FONT, _FONT_SCALE,
                    (0, 0, 0), 1, cv2.LINE_AA)
    return strip


def _legend_strip(width: int, base_label: str) -> UInt8Array:
    strip = np.full((_STRIP_PX, width, 3), 255, np.uint8)
    x = 3
    for rgb, text in (((128, 128, 128), base_label), *_LEGEND):
        cv2.rectangle(strip, (x, 4), (x + 10, _STRIP_PX - 4), rgb, -1)
        cv2.putText(strip, text, (x + 14, _STRIP_PX - 4), _FONT, _FONT_SCALE, (0, 0, 0), 1,
                    cv2.LINE_AA)
        x += 14 + cv2.getTextSize(text, _FONT, _FONT_SCALE, 1)[0][0] + 12
    return strip


def labelled_grid(tiles: Sequence[Sequence[UInt8Array]], camera_names: Sequence[str],
                  captions: Sequence[str], base_label: str = 'camera image (gray)'
                  ) -> UInt8Array:
    """Tiles (rows x cameras, each (H, W, 3) uint8) under the camera names, a caption above
    each row and the legend below (``base_label`` names what the drawing is on):
    (16 + R (16 + H) + 16, C W, 3) uint8."""
    height, width = tiles[0][0].shape[:2]
    total = width * len(camera_names)
    parts = [_text_strip(total, camera_names, width)]
    for row, caption in zip(tiles, captions, strict=True):
        parts += [_text_strip(total, [caption], total), np.hstack(row)]
    parts.append(_legend_strip(total, base_label))
    return np.vstack(parts)


def row_caption(index: int, time_s: float, state: HandStateValues, error_mm: float | None
                ) -> str:
    """``frame 12  t=0.40 s  TRACKING  error 3.1 mm`` (no error without ground truth)."""
    status = TrackStatus(state.status).name
    error = '' if error_mm is None else f'  error {error_mm:.1f} mm'
    return f'frame {index}  t={time_s:.2f} s  {status}{error}'


def overlay_grid(bag: Path, rig: CameraRig, states: Mapping[int, HandStateValues],
                 stamps: Sequence[int], path: Path,
                 errors_mm: Mapping[int, float] | None = None) -> None:
    """One row per stamp, one column per camera: the estimate drawn on the camera image,
    labelled (:func:`labelled_grid`); ``errors_mm`` by stamp, where known."""
    images: dict[tuple[str, int], np.ndarray] = {}
    with BagReader(bag) as reader:
        wanted = {topic: rig[name] for topic, name in
                  camera_image_topics(reader.topics, rig.names, str(bag)).items()}
        for topic, _, stamp, msg in reader.decoded(topics=list(wanted)):
            if stamp in stamps:
                images[(topic, stamp)] = image_from_msg(msg, source=topic)
    order = sorted(states)
    rows, captions = [], []
    for stamp in stamps:
        model = HandModel.build(states[stamp].shape)
        posed = model.pose(np.asarray(states[stamp].joint_positions), jacobian=False)
        row = []
        for topic, camera in wanted.items():
            mask = render(camera, posed.vertices_m, model.faces).mask
            uv, _ = camera.project(posed.keypoints_m)
            row.append(draw_overlay(to_gray(images[(topic, stamp)]), mask, uv))
        rows.append(row)
        captions.append(row_caption(order.index(stamp), (stamp - order[0]) / 1e9,
                                    states[stamp], (errors_mm or {}).get(stamp)))
    grid = labelled_grid(rows, [c.name for c in wanted.values()], captions)
    cv2.imwrite(str(path), cv2.cvtColor(grid, cv2.COLOR_RGB2BGR))
