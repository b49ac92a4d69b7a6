"""Fingertip detection on real photos with hand-labelled tips (test/fixtures/real_hands).

The labels file (YAML) lists per photo its size, the five tips (u, v) in px in
FINGER_NAMES order and whether each is visible. A labelled visible tip is *found* when a
detection lies within ``radius_px`` of it under the greedy matching of :mod:`.evaluation`
(highest score first, nearest free tip); detections matched to no tip are false positives.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import cast

import cv2
import numpy as np
import yaml

from hand_tracker_ros._typing import BoolArray, FloatArray, UInt8Array
from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.vision.detections import SalientDetections
from hand_tracker_ros.vision.detector.evaluation import DetectionTally


@dataclass(frozen=True, eq=False)
class LabelledPhoto:
    """One photo with its hand-labelled tips.

    Attributes
    ----------
    name : str
    image : (H, W, 3) uint8
        RGB, native size.
    tips_uv : (5, 2) float64
        px.
    tips_visible : (5,) bool
    skin : str
        Skin tone noted by the labeller (light, medium, dark).
    """

    name: str
    image: UInt8Array
    tips_uv: FloatArray
    tips_visible: BoolArray
    skin: str


@dataclass(frozen=True)
class PhotoResult:
    """Detections on one photo against its labels."""

    name: str
    found: int
    visible: int
    false_positives: int
    errors_px: tuple[float, ...]


def load_labelled_photos(labels_path: str | Path) -> list[LabelledPhoto]:
    """The photos of a labels file (the images are beside it).

    Raises
    ------
    ConfigError
        A photo is missing or unreadable, or its size or labels are malformed.
    """
    labels_path = Path(labels_path)
    spec = yaml.safe_load(labels_path.read_text())
    photos = []
    for name, entry in spec['photos'].items():
        bgr = cv2.imread(str(labels_path.parent / name), cv2.IMREAD_COLOR)
        if bgr is None:
            msg = f'{labels_path}: photo {name} is missing or unreadable'
            raise ConfigError(msg)
        tips = np.asarray(entry['tips_uv_px'], dtype=np.float64)
        visible = np.asarray(entry['visible'], dtype=bool)
        if list(entry['size']) != [bgr.shape[1], bgr.shape[0]] or tips.shape != (5, 2) \
                or visible.shape != (5,):
            msg = (f'{labels_path}: {name}: expected size {entry["size"]} = the image\'s '
                   f'{[bgr.shape[1], bgr.shape[0]]}, (5, 2) tips and (5,) visible, got '
                   f'{tips.shape} and {visible.shape}')
            raise ConfigError(msg)
        rgb = cast(UInt8Array, cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        photos.append(LabelledPhoto(name, rgb, tips, visible, str(entry.get('skin', ''))))
    return photos


def score_photo(photo: LabelledPhoto, detections: SalientDetections,
                radius_px: float = 12.0) -> PhotoResult:
    """Tips found within ``radius_px`` (module docstring)."""
    tally = DetectionTally()
    tally.add(detections, photo.tips_uv, photo.tips_visible, radius_px=radius_px)
    return PhotoResult(photo.name, tally.true_positives, tally.visible_tips,
                       tally.false_positives, tuple(round(e, 1) for e in tally.errors_px))
