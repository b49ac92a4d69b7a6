"""Declare a node's ROS parameters from a config dataclass and keep them validated.

The dataclass is the single source of truth (house rule 9): every field becomes a parameter
with a ``ParameterDescriptor`` carrying its documentation, unit and range; the resolved config
is logged once at start-up, every value at DEBUG and one INFO line with the values that differ
from the defaults; live changes are validated by building a new config and rejected with the
validation message when it fails.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.node import Node
from rclpy.parameter import Parameter

from hand_tracker_ros.config import describe, flatten, from_mapping
from hand_tracker_ros.errors import ConfigError

T = TypeVar('T')


def _descriptor(name: str, meta: dict[str, Any], default: Any, read_only: bool
                ) -> ParameterDescriptor:
    unit = f" [{meta['unit']}]" if meta.get('unit') else ''
    choices = f" (one of {', '.join(map(str, meta['choices']))})" if meta.get('choices') else ''
    desc = ParameterDescriptor(name=name, description=f"{meta['doc']}{unit}{choices}",
                               read_only=read_only, dynamic_typing=True)
    low, high = meta.get('low'), meta.get('high')
    if (low is not None or high is not None) and not isinstance(default, bool):
        if isinstance(default, int):
            desc.integer_range = [IntegerRange(from_value=int(low if low is not None else -2**31),
                                               to_value=int(high if high is not None else 2**31),
                                               step=0)]
        elif isinstance(default, float):
            desc.floating_point_range = [FloatingPointRange(
                from_value=float(low if low is not None else -1e300),
                to_value=float(high if high is not None else 1e300), step=0.0)]
    return desc


def _log_parameters(node: Node, defaults: dict[str, Any], values: dict[str, Any]) -> None:
    """Every resolved value at DEBUG; one INFO line with the count and the values that differ
    from the defaults (the ones a reader of the log needs to reproduce the run)."""
    logger = node.get_logger()
    for name, value in values.items():
        logger.debug(f'param {name} = {value!r}')
    changed = [f'{n}={v!r}' for n, v in values.items() if v != defaults[n]]
    summary = ', '.join(changed) if changed else 'all defaults'
    logger.info(f'{len(values)} parameters ({summary}; all at debug level)')


def declare_config(node: Node, cls: type[T], *, read_only: tuple[str, ...] = (),
                   on_change: Callable[[T], None] | None = None) -> T:
    """Declare every field of ``cls`` as a parameter of ``node`` and return the config.

    Parameters
    ----------
    node : rclpy.node.Node
        The node that owns the parameters.
    cls : type
        A config dataclass declared with :func:`hand_tracker_ros.config.param`.
    read_only : tuple of str
        Dotted names that define the topology (cameras, topics) and cannot change live.
    on_change : callable, optional
        Called with the new validated config after an accepted live change; without it every
        parameter is read-only.
    """
    meta = describe(cls)
    defaults = flatten(cls())
    for name, default in defaults.items():
        value = list(default) if isinstance(default, tuple) else default
        fixed = on_change is None or name in read_only
        node.declare_parameter(name, value, _descriptor(name, meta[name], default, fixed))
    current = {name: node.get_parameter(name).value for name in defaults}
    # rcl cannot type an empty YAML list: it comes back unset (None), meaning the empty list.
    current = {n: defaults[n] if v is None and isinstance(defaults[n], tuple) else v
               for n, v in current.items()}
    try:
        config = from_mapping(cls, current)
    except ConfigError as err:
        node.get_logger().fatal(f'invalid parameters: {err}')
        raise
    _log_parameters(node, defaults, flatten(config))

    def _validate(params: list[Parameter]) -> SetParametersResult:
        candidate = dict(current)
        candidate.update({p.name: p.value for p in params if p.name in candidate})
        try:
            new_config = from_mapping(cls, candidate)
        except ConfigError as err:
            return SetParametersResult(successful=False, reason=str(err))
        current.update(candidate)
        if on_change is not None:
            on_change(new_config)
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(_validate)
    return config
