"""Config dataclasses: one frozen dataclass per component, documented field by field.

Every field is declared with :func:`param`, which stores its documentation, unit and
allowed range in the dataclass field ``metadata``. From that single declaration:

- :func:`from_mapping` builds a validated config from a (possibly nested) mapping, e.g. a
  ``ros__parameters`` YAML section or the ROS parameters of a node (dotted names);
- :func:`flatten` gives the dotted ``name -> value`` view that nodes declare as ROS
  parameters (with :func:`describe` for the ``ParameterDescriptor`` text and range);
- :func:`validate` checks ranges and choices and raises :class:`ConfigError` naming the
  dotted field.

Nested dataclass fields become dotted names (``lm.max_iterations``), as in ROS 2 YAML.
"""
from __future__ import annotations

import dataclasses
import re
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar

import yaml

from hand_tracker_ros.errors import ConfigError

T = TypeVar('T')

_SCALARS = (bool, int, float, str)
# A number in YAML 1.2's core schema without a dot, e.g. ``1e-3``, is a string in YAML 1.1.
_YAML12_FLOAT = re.compile(r'[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?')


def param(default: Any, doc: str, *, unit: str = '', low: float | None = None,
          high: float | None = None, choices: tuple[Any, ...] | None = None) -> Any:
    """Declare a documented config field.

    Parameters
    ----------
    default : bool | int | float | str | tuple
        Default value (tuples hold lists of scalars, e.g. camera names).
    doc : str
        One-line meaning of the field.
    unit : str
        Unit of the value ('m', 'rad', 'px', 'ms', ...); '' for unitless.
    low, high : float, optional
        Inclusive numeric range.
    choices : tuple, optional
        Allowed values for an enumeration-like field.
    """
    meta = {'doc': doc, 'unit': unit, 'low': low, 'high': high, 'choices': choices}
    if isinstance(default, (list, dict, set)):
        msg = f'mutable default {default!r}: use a tuple'
        raise TypeError(msg)
    return dataclasses.field(default=default, metadata=meta)


def nested(factory: Callable[[], T]) -> Any:
    """Declare a nested config dataclass field (its fields get a dotted prefix)."""
    return dataclasses.field(default_factory=factory, metadata={'nested': True})


def _field_types(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _coerce(name: str, value: Any, hint: Any) -> Any:
    """Coerce a YAML/ROS value to the field's declared scalar type."""
    origin = typing.get_origin(hint)
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            msg = f'`{name}` must be a list, got {type(value).__name__}'
            raise ConfigError(msg)
        (item_hint, *_rest) = typing.get_args(hint) or (Any,)
        return tuple(_coerce(name, v, item_hint) for v in value)
    if origin in (typing.Union, types.UnionType):
        return value
    if hint is bool:
        if not isinstance(value, bool):
            msg = f'`{name}` must be a bool, got {value!r}'
            raise ConfigError(msg)
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            msg = f'`{name}` must be an integer, got {value!r}'
            raise ConfigError(msg)
        return value
    if hint is float:
        if isinstance(value, str) and _YAML12_FLOAT.fullmatch(value):
            value = float(value)      # e.g. 1e-3: PyYAML (YAML 1.1) reads it as a string
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            msg = f'`{name}` must be a number, got {value!r}'
            raise ConfigError(msg)
        return float(value)
    if hint is str:
        if not isinstance(value, str):
            msg = f'`{name}` must be a string, got {value!r}'
            raise ConfigError(msg)
        return value
    return value


def from_mapping(cls: type[T], mapping: Mapping[str, Any] | None = None, *,
                 prefix: str = '') -> T:
    """Build and validate ``cls`` from a nested or dotted mapping.

    Unknown keys raise :class:`ConfigError` (a typo must not be silently ignored).
    """
    mapping = dict(mapping or {})
    # Expand dotted keys ('lm.max_iterations') into nested dicts.
    tree: dict[str, Any] = {}
    for key, value in mapping.items():
        node = tree
        *parents, leaf = str(key).split('.')
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = value
    return _build(cls, tree, prefix)


def overrides(items: Sequence[str]) -> dict[str, Any]:
    """``KEY=VALUE`` strings (dotted keys, YAML values) as a mapping for :func:`from_mapping`,
    e.g. ``['tracker.schedule.full_rounds=1']`` for the benches' command lines.

    Raises
    ------
    ConfigError
        An item without ``=`` or with a value that is not YAML.
    """
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition('=')
        if not sep or not key:
            msg = f'override {item!r}: expected KEY=VALUE'
            raise ConfigError(msg)
        try:
            out[key] = yaml.safe_load(text)
        except yaml.YAMLError as err:
            msg = f'override {item!r}: the value is not YAML ({err})'
            raise ConfigError(msg) from err
    return out


def _build(cls: type[T], tree: dict[str, Any], prefix: str) -> T:
    hints = _field_types(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(tree) - set(fields))
    if unknown:
        names = ', '.join(prefix + u for u in unknown)
        msg = f'unknown parameter(s) {names} for {cls.__name__}'
        raise ConfigError(msg)
    kwargs: dict[str, Any] = {}
    for name, value in tree.items():
        f = fields[name]
        dotted = prefix + name
        if f.metadata.get('nested'):
            if not isinstance(value, Mapping):
                msg = f'`{dotted}` must be a mapping'
                raise ConfigError(msg)
            kwargs[name] = _build(hints[name], dict(value), dotted + '.')
        else:
            kwargs[name] = _coerce(dotted, value, hints[name])
    cfg = cls(**kwargs)
    validate(cfg, prefix=prefix)
    return cfg


def validate(cfg: Any, *, prefix: str = '') -> None:
    """Check every field's range and choices; raise :class:`ConfigError` naming it."""
    for f in dataclasses.fields(cfg):
        value = getattr(cfg, f.name)
        dotted = prefix + f.name
        if f.metadata.get('nested'):
            validate(value, prefix=dotted + '.')
            continue
        low, high = f.metadata.get('low'), f.metadata.get('high')
        choices = f.metadata.get('choices')
        items = value if isinstance(value, tuple) else (value,)
        for item in items:
            if choices is not None and item not in choices:
                msg = f'`{dotted}` must be one of {list(choices)}, got {item!r}'
                raise ConfigError(msg)
            if isinstance(item, (int, float)) and not isinstance(item, bool):
                if item != item:  # NaN
                    msg = f'`{dotted}` must be a finite number, got {item!r}'
                    raise ConfigError(msg)
                if low is not None and item < low or high is not None and item > high:
                    msg = f'`{dotted}` must be in [{low}, {high}], got {item!r}'
                    raise ConfigError(msg)


def flatten(cfg: Any, *, prefix: str = '') -> dict[str, Any]:
    """Dotted ``name -> value`` view of a config (what a node declares as parameters)."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(cfg):
        value = getattr(cfg, f.name)
        if f.metadata.get('nested'):
            out.update(flatten(value, prefix=prefix + f.name + '.'))
        else:
            out[prefix + f.name] = value
    return out


def describe(cls: type, *, prefix: str = '') -> dict[str, dict[str, Any]]:
    """Dotted ``name -> metadata`` (doc, unit, low, high, choices) of a config class."""
    hints = _field_types(cls)
    out: dict[str, dict[str, Any]] = {}
    for f in dataclasses.fields(cls):
        if f.metadata.get('nested'):
            out.update(describe(hints[f.name], prefix=prefix + f.name + '.'))
        else:
            out[prefix + f.name] = dict(f.metadata)
    return out
