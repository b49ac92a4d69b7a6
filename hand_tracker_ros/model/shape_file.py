"""Hand shape files: a :class:`~.shape.HandShape` as a small YAML mapping.

Format (every key but ``format`` optional; a missing field keeps the default shape's value,
so ``scale: 1.1`` alone is a valid file)::

    format: hand_tracker_ros/hand_shape/1
    scale: 1.0                  # global factor on every length and radius
    palm_length_m: 0.0709       # wrist to middle MCP, before ``scale``
    palm_width_m: 0.056         # index MCP to pinky MCP, before ``scale``
    thumb_m: [0.0477, 0.0372, 0.0300]     # metacarpal, proximal, distal, before ``scale``
    index_m: [0.0504, 0.0272, 0.0184]     # proximal, middle, distal (likewise middle_m,
    radius_scale: 1.0                     # ring_m, pinky_m); extra factor on every radius

Written by ``hand-tracker calibrate`` and read by ``track --shape``, ``synth --shape``,
``urdf --shape`` and the tracker node's ``shape_file`` parameter. Invalid files raise
:class:`~hand_tracker_ros.errors.ConfigError` naming the file and the field.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import yaml

from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.model.shape import HandShape

FORMAT = 'hand_tracker_ros/hand_shape/1'
_SEGMENT_FIELDS = ('thumb_m', 'index_m', 'middle_m', 'ring_m', 'pinky_m')
_FIELDS = tuple(f.name for f in dataclasses.fields(HandShape))


def _number(path: Path, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        msg = f'{path}: `{key}` must be a number, got {value!r}'
        raise ConfigError(msg)
    return float(value)


def shape_from_mapping(data: Any, path: Path = Path('<mapping>')) -> HandShape:
    """Validated :class:`HandShape` from a parsed shape file (see the module docstring).

    Raises
    ------
    ConfigError
        Not a mapping, wrong or missing ``format``, unknown keys, non-numbers, segment lists
        that are not 3 numbers, or values that are not finite and > 0.
    """
    if not isinstance(data, dict):
        msg = f'{path}: a hand shape file must be a YAML mapping, got {type(data).__name__}'
        raise ConfigError(msg)
    if data.get('format') != FORMAT:
        msg = f'{path}: `format` must be {FORMAT!r}, got {data.get("format")!r}'
        raise ConfigError(msg)
    unknown = sorted(set(data) - set(_FIELDS) - {'format'})
    if unknown:
        msg = f'{path}: unknown key(s) {", ".join(unknown)}; known: {", ".join(_FIELDS)}'
        raise ConfigError(msg)
    values: dict[str, Any] = {}
    for key in _FIELDS:
        if key not in data:
            continue
        value = data[key]
        if key in _SEGMENT_FIELDS:
            if not isinstance(value, (list, tuple)) or len(value) != 3:
                msg = f'{path}: `{key}` must be a list of 3 lengths (m), got {value!r}'
                raise ConfigError(msg)
            values[key] = tuple(_number(path, key, v) for v in value)
        else:
            values[key] = _number(path, key, value)
    try:
        return HandShape(**values)
    except ConfigError as err:
        msg = f'{path}: {err}'
        raise ConfigError(msg) from err


def shape_to_mapping(shape: HandShape) -> dict[str, Any]:
    """The shape file mapping of ``shape`` (every field, ``format`` first)."""
    out: dict[str, Any] = {'format': FORMAT}
    for key in _FIELDS:
        value = getattr(shape, key)
        out[key] = [float(v) for v in value] if key in _SEGMENT_FIELDS else float(value)
    return out


def load_shape(path: str | Path) -> HandShape:
    """Read a hand shape file; raises ConfigError naming the path (also when it is missing)."""
    path = Path(path)
    if not path.is_file():
        msg = f'hand shape file {path} does not exist'
        raise ConfigError(msg)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as err:
        msg = f'{path}: not valid YAML: {err}'
        raise ConfigError(msg) from err
    return shape_from_mapping(data, path)


def save_shape(shape: HandShape, path: str | Path, *, comment: str = '') -> None:
    """Write ``shape`` to ``path`` so that :func:`load_shape` reads it back exactly.

    ``comment`` (optional, may span lines) is written as ``#`` lines at the top.
    """
    header = ''.join(f'# {line}\n' for line in comment.splitlines())
    text = yaml.safe_dump(shape_to_mapping(shape), sort_keys=False, default_flow_style=None)
    Path(path).write_text(header + text)


def shape_or_default(path: str | Path | None) -> HandShape:
    """The shape in ``path``, or the default :class:`HandShape` when ``path`` is empty/None."""
    return load_shape(path) if path else HandShape()
