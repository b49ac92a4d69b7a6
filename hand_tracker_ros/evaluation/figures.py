"""Pictures of a tracked sequence: error over time, and the estimate drawn on the images."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.bags.convert import HandStateValues
from hand_tracker_ros.bags.image_codec import image_from_msg
from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.frames import camera_image_topic
from hand_tracker_ros.render.rasterizer import render
from hand_tracker_ros.tracking.overlay import draw_overlay
from hand_tracker_ros.vision.image import to_gray


def error_plot(errors_mm: FloatArray, path: Path, title: str) -> None:
    """Per-frame mean 3D joint error as a PNG line plot."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3))
    ax.plot(np.arange(1, errors_mm.size + 1), errors_mm, lw=1)
    ax.set_xlabel('frame')
    ax.set_ylabel('mean 3D joint error (mm)')
    ax.set_title(title)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def overlay_grid(bag: Path, rig: CameraRig, states: dict[int, HandStateValues],
                 stamps: Sequence[int], path: Path) -> None:
    """One row per stamp, one column per camera: the estimate drawn on the camera image."""
    model = HandModel.build()
    images: dict[tuple[str, int], np.ndarray] = {}
    with BagReader(bag) as reader:
        wanted = {camera_image_topic(reader.topics, c.name): c for c in rig.cameras}
        for topic, _, stamp, msg in reader.decoded(topics=list(wanted)):
            if stamp in stamps:
                images[(topic, stamp)] = image_from_msg(msg, source=topic)
    rows = []
    for stamp in stamps:
        posed = model.pose(np.asarray(states[stamp].joint_positions), jacobian=False)
        row = []
        for topic, camera in wanted.items():
            mask = render(camera, posed.vertices_m, model.faces).mask
            uv, _ = camera.project(posed.keypoints_m)
            row.append(draw_overlay(to_gray(images[(topic, stamp)]), mask, uv))
        rows.append(np.hstack(row))
    cv2.imwrite(str(path), cv2.cvtColor(np.vstack(rows), cv2.COLOR_RGB2BGR))
