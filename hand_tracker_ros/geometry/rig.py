"""A rig of C calibrated cameras: YAML/mapping I/O and the default synthetic ring.

YAML schema (one file per rig; all numbers plain floats, lengths in metres, pixels in px)::

    world_frame: world            # name of the frame the extrinsics map from
    cameras:
      - name: cam0                # unique; also the ROS namespace /cam0/...
        width: 320                # image size (px)
        height: 240
        K: [fx, 0, cx, 0, fy, cy, 0, 0, 1]        # row-major, zero skew
        distortion_model: plumb_bob               # or rational_polynomial
        D: [k1, k2, p1, p2, k3]                   # 5 (plumb_bob) or 8 (rational_polynomial)
        T_cam_world: [16 numbers, row-major]      # p_cam = T_cam_world @ p_world, rigid

Camera axes follow REP 103 optical (z forward, x right, y down). Any bad or missing field
raises :class:`CalibrationError` naming the camera and the field, e.g.
``cam2: missing field `K` `` or ``cam1: `T_cam_world` must have 16 numbers, got 12``.

:meth:`CameraRig.ring` places n cameras on a sphere of radius r around a target: camera i
sits at azimuth ``45 deg + 360 deg * i / n`` and elevation cycling through 15, 30 and
45 deg above the world xy plane (z is up), looking at the target with z up in the image.
"""
from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from hand_tracker_ros.errors import CalibrationError
from hand_tracker_ros.geometry.camera import DISTORTION_MODELS, PinholeCamera
from hand_tracker_ros.geometry.transforms import look_at

_FIELDS = ('name', 'width', 'height', 'K', 'distortion_model', 'D', 'T_cam_world')
_ELEVATIONS_DEG = (15.0, 30.0, 45.0)
_MAX_RING_CAMERAS = 8


def _numbers(cam: str, entry: Mapping[str, Any], field: str, count: int) -> list[float]:
    value = entry[field]
    if not isinstance(value, (list, tuple)):
        msg = f'{cam}: `{field}` must be a list of {count} numbers, got {type(value).__name__}'
        raise CalibrationError(msg)
    if len(value) != count:
        msg = f'{cam}: `{field}` must have {count} numbers, got {len(value)}'
        raise CalibrationError(msg)
    if any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value):
        msg = f'{cam}: `{field}` must hold only numbers, got {value!r}'
        raise CalibrationError(msg)
    return [float(v) for v in value]


def _camera_from_entry(index: int, entry: Any) -> PinholeCamera:
    if not isinstance(entry, Mapping):
        msg = f'camera {index}: must be a mapping, got {type(entry).__name__}'
        raise CalibrationError(msg)
    cam = str(entry['name']) if 'name' in entry else f'camera {index}'
    missing = [f for f in _FIELDS if f not in entry]
    if missing:
        msg = f'{cam}: missing field `{missing[0]}`'
        raise CalibrationError(msg)
    unknown = sorted(set(entry) - set(_FIELDS))
    if unknown:
        msg = f'{cam}: unknown field `{unknown[0]}`'
        raise CalibrationError(msg)
    model = entry['distortion_model']
    if model not in DISTORTION_MODELS:
        msg = (f'{cam}: unsupported `distortion_model` {model!r}; '
               f'expected one of {sorted(DISTORTION_MODELS)}')
        raise CalibrationError(msg)
    K = _numbers(cam, entry, 'K', 9)
    D = _numbers(cam, entry, 'D', DISTORTION_MODELS[model])
    T = np.reshape(_numbers(cam, entry, 'T_cam_world', 16), (4, 4))
    return PinholeCamera.from_camera_info(entry['name'], entry['width'], entry['height'],
                                          K, D, model, T)


@dataclass(frozen=True, eq=False)
class CameraRig:
    """C calibrated cameras sharing one world frame.

    Attributes
    ----------
    cameras : tuple of PinholeCamera
        The cameras, in a fixed order (the order of residual blocks and topics).
    world_frame : str
        Name of the world frame (the ROS frame id of the extrinsics' source).
    """

    cameras: tuple[PinholeCamera, ...]
    world_frame: str = 'world'

    def __post_init__(self) -> None:
        cams = tuple(self.cameras)
        if not cams:
            msg = 'a camera rig needs at least one camera'
            raise CalibrationError(msg)
        if not all(isinstance(c, PinholeCamera) for c in cams):
            msg = '`cameras` must hold PinholeCamera objects'
            raise CalibrationError(msg)
        names = [c.name for c in cams]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            msg = f'duplicate camera name(s) {duplicates}'
            raise CalibrationError(msg)
        object.__setattr__(self, 'cameras', cams)

    @property
    def names(self) -> tuple[str, ...]:
        """Camera names in rig order."""
        return tuple(c.name for c in self.cameras)

    def __len__(self) -> int:
        return len(self.cameras)

    def __iter__(self) -> Iterator[PinholeCamera]:
        return iter(self.cameras)

    def __getitem__(self, key: str | int) -> PinholeCamera:
        """Camera by name, or by position in the rig."""
        if isinstance(key, str):
            for cam in self.cameras:
                if cam.name == key:
                    return cam
            msg = f'no camera named {key!r} in rig {list(self.names)}'
            raise KeyError(msg)
        return self.cameras[key]

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any]) -> CameraRig:
        """Build a rig from the YAML schema above (already parsed)."""
        if not isinstance(data, Mapping):
            msg = f'rig: expected a mapping with `cameras`, got {type(data).__name__}'
            raise CalibrationError(msg)
        unknown = sorted(set(data) - {'world_frame', 'cameras'})
        if unknown:
            msg = f'rig: unknown field `{unknown[0]}`'
            raise CalibrationError(msg)
        if 'cameras' not in data:
            msg = 'rig: missing field `cameras`'
            raise CalibrationError(msg)
        entries = data['cameras']
        if not isinstance(entries, list) or not entries:
            msg = 'rig: `cameras` must be a non-empty list'
            raise CalibrationError(msg)
        world_frame = data.get('world_frame', 'world')
        if not isinstance(world_frame, str) or not world_frame:
            msg = f'rig: `world_frame` must be a non-empty string, got {world_frame!r}'
            raise CalibrationError(msg)
        cams = tuple(_camera_from_entry(i, e) for i, e in enumerate(entries))
        return cls(cams, world_frame)

    def to_mapping(self) -> dict[str, Any]:
        """The rig as plain Python values in the YAML schema above."""
        return {
            'world_frame': self.world_frame,
            'cameras': [{
                'name': c.name,
                'width': c.width,
                'height': c.height,
                'K': [float(v) for v in c.K.ravel()],
                'distortion_model': c.distortion_model,
                'D': [float(v) for v in c.dist],
                'T_cam_world': [float(v) for v in c.T_cam_world.ravel()],
            } for c in self.cameras],
        }

    @classmethod
    def from_yaml(cls, path: str | Path) -> CameraRig:
        """Load a rig YAML file (schema in the module docstring)."""
        path = Path(path)
        try:
            text = path.read_text(encoding='utf-8')
        except OSError as err:
            msg = f'cannot read rig file {path}: {err.strerror}'
            raise CalibrationError(msg) from err
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as err:
            msg = f'rig file {path} is not valid YAML: {err}'
            raise CalibrationError(msg) from err
        try:
            return cls.from_mapping(data)
        except CalibrationError as err:
            msg = f'{path}: {err}'
            raise CalibrationError(msg) from err

    def to_yaml(self, path: str | Path) -> None:
        """Write the rig to a YAML file that :meth:`from_yaml` reads back exactly."""
        # Numbers go through repr (shortest round-trip form), so loading gives equal floats.
        text = yaml.safe_dump(self.to_mapping(), sort_keys=False, default_flow_style=None,
                              width=200)
        Path(path).write_text(text, encoding='utf-8')

    @classmethod
    def ring(cls, n_cameras: int = 4, width: int = 320, height: int = 240, *,
             radius_m: float = 0.45, target_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
             fov_deg: float = 50.0, seed: int | None = None) -> CameraRig:
        """The default synthetic rig: cameras around and above a target, looking at it.

        Parameters
        ----------
        n_cameras : int
            1 to 8 cameras, named cam0 ... cam{n-1}.
        width, height : int
            Image size (px); square pixels, principal point at the image centre.
        radius_m : float
            Distance from each camera centre to the target.
        target_m : (3,) float
            World point every optical axis passes through.
        fov_deg : float
            Horizontal field of view.
        seed : int, optional
            If given, azimuths and elevations are jittered by up to +-10 deg and the radius by
            +-10 % (deterministically per seed); if None the placement is exactly regular.
        """
        if not 1 <= n_cameras <= _MAX_RING_CAMERAS:
            msg = f'`n_cameras` must be in [1, {_MAX_RING_CAMERAS}], got {n_cameras}'
            raise CalibrationError(msg)
        if not 0.0 < fov_deg < 180.0 or radius_m <= 0.0:
            msg = f'ring needs 0 < fov_deg < 180 and radius_m > 0, got {fov_deg}, {radius_m}'
            raise CalibrationError(msg)
        f = 0.5 * width / math.tan(math.radians(fov_deg) / 2.0)
        K = np.array([[f, 0.0, (width - 1) / 2.0], [0.0, f, (height - 1) / 2.0], [0, 0, 1]])
        jitter = (np.random.default_rng(seed).uniform(-1.0, 1.0, (n_cameras, 3))
                  if seed is not None else np.zeros((n_cameras, 3)))
        target = np.asarray(target_m, dtype=np.float64)
        cams = []
        for i in range(n_cameras):
            azimuth = math.radians(45.0 + 360.0 * i / n_cameras + 10.0 * jitter[i, 0])
            elevation = math.radians(_ELEVATIONS_DEG[i % 3] + 10.0 * jitter[i, 1])
            r = radius_m * (1.0 + 0.1 * jitter[i, 2])
            eye = target + r * np.array([math.cos(elevation) * math.cos(azimuth),
                                         math.cos(elevation) * math.sin(azimuth),
                                         math.sin(elevation)])
            cams.append(PinholeCamera(f'cam{i}', width, height, K, np.zeros(5),
                                      look_at(eye, target)))
        return cls(tuple(cams))
