"""Helpers for the one image type the vision core works with: ``(H, W, 3) uint8`` RGB.

Its checks (:func:`~hand_tracker_ros.checks.check_rgb`) live in :mod:`hand_tracker_ros.checks`.

Decoding camera messages into that type is :mod:`hand_tracker_ros.bags.image_codec`.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import cv2

from hand_tracker_ros._typing import UInt8Array
from hand_tracker_ros.checks import check_rgb
from hand_tracker_ros.errors import ImageFormatError

# A region of interest (u0, v0, u1, v1): the half-open pixel box [u0, u1) x [v0, v1).
Box = tuple[int, int, int, int]


def clip_roi(name: str, roi_px: Sequence[int] | None, width: int, height: int) -> Box:
    """Clip a region of interest to the image.

    Parameters
    ----------
    name : str
        Camera or argument name used in the message.
    roi_px : (u0, v0, u1, v1) ints, or None
        Half-open pixel box ``[u0, u1) x [v0, v1)``; None means the whole image.
    width, height : int
        Image size in px.

    Returns
    -------
    (u0, v0, u1, v1) : ints
        The box clipped to ``[0, width) x [0, height)``, non-empty.

    Raises
    ------
    ImageFormatError
        The box does not overlap the image.
    """
    if roi_px is None:
        return (0, 0, width, height)
    if len(roi_px) != 4:
        msg = f'{name}: roi_px must be (u0, v0, u1, v1), got {tuple(roi_px)}'
        raise ImageFormatError(msg)
    u0, v0 = max(int(roi_px[0]), 0), max(int(roi_px[1]), 0)
    u1, v1 = min(int(roi_px[2]), width), min(int(roi_px[3]), height)
    if u1 <= u0 or v1 <= v0:
        msg = (f'{name}: roi_px {tuple(int(x) for x in roi_px)} does not overlap the '
               f'{width}x{height} image')
        raise ImageFormatError(msg)
    return (u0, v0, u1, v1)


def to_gray(image_rgb: UInt8Array) -> UInt8Array:
    """Luma of an RGB image (ITU-R BT.601 weights, as cv2).

    Parameters
    ----------
    image_rgb : (H, W, 3) uint8

    Returns
    -------
    gray : (H, W) uint8
    """
    check_rgb('image_rgb', image_rgb)
    return cast(UInt8Array, cv2.cvtColor(image_rgb, cv2.COLOR_RGB2GRAY))
