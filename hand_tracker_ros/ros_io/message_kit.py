"""Message classes of two runtimes behind one interface, so each conversion is written once.

The conversions in :mod:`.estimates` build their messages through a :class:`MessageKit`: the
tracker node passes :class:`RclpyKit` (rclpy classes, published on the graph) and the offline
estimates bags :class:`RosbagsKit` (the rosbags classes of
:func:`hand_tracker_ros.bags.typestore.typestore`, serialized to CDR without rclpy). The two
runtimes differ in two ways that the kits absorb:

- construction: rclpy messages default every unset field; rosbags dataclasses need every
  field, so :meth:`RosbagsKit.new` fills the missing ones with the type's zero value (read from
  the type store's field definitions, nested messages recursively). Defaults declared in a
  ``.msg`` file (``Quaternion.w`` = 1) are not in those definitions: conversions set such
  fields themselves, and a test checks that both kits give the same messages;
- primitive arrays (``float64[]``): rclpy takes a sequence (``array.array``), rosbags a numpy
  array.

This module imports no ROS package: :func:`message_class` (the one resolver of rclpy classes by
type name, also for the player, recorder and topic tools) imports ``<pkg>.msg`` on first use,
as ``rosidl_runtime_py`` would (not on PyPI).
"""
from __future__ import annotations

import array
import functools
import importlib
from typing import Any, Protocol

import numpy as np
from rosbags.typesys.base import Nodetype
from rosbags.typesys.store import Typestore

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.bags.typestore import typestore
from hand_tracker_ros.errors import BagFormatError

# Primitive ROS types -> numpy dtypes of rosbags' arrays (strings are lists of str).
_DTYPES = {'bool': np.bool_, 'byte': np.uint8, 'char': np.uint8, 'int8': np.int8,
           'uint8': np.uint8, 'int16': np.int16, 'uint16': np.uint16, 'int32': np.int32,
           'uint32': np.uint32, 'int64': np.int64, 'uint64': np.uint64,
           'float32': np.float32, 'float64': np.float64}


class MessageKit(Protocol):
    """Builds messages of one runtime by type name (``pkg/msg/Name``)."""

    def new(self, msgtype: str, **fields: Any) -> Any:
        """A ``msgtype`` message with ``fields`` set and every other field at its default."""

    def constant(self, msgtype: str, name: str) -> Any:
        """The constant ``name`` of ``msgtype`` (e.g. ``Marker.LINE_LIST``)."""

    def floats(self, values: FloatArray) -> Any:
        """The value of a ``float64[]`` field holding ``values`` (N,) float64."""


@functools.cache
def message_class(msgtype: str) -> type:
    """Return the rclpy message class of a ROS 2 type name such as ``sensor_msgs/msg/Image``.

    Raises
    ------
    BagFormatError
        If the name is malformed, its ``pkg.msg`` module cannot be imported (package not
        installed or workspace not sourced), or the module has no such message.
    """
    package, kind, name = (msgtype.split('/') + ['', ''])[:3]
    if kind != 'msg' or not package or not name:
        msg = f'type {msgtype!r} is not a ROS 2 message type name (pkg/msg/Name)'
        raise BagFormatError(msg)
    try:
        module = importlib.import_module(f'{package}.msg')
    except ImportError as err:
        msg = (f'type {msgtype!r}: module {package}.msg cannot be imported ({err}); install '
               f'the {package} interface package or source the workspace that builds it')
        raise BagFormatError(msg) from err
    cls = getattr(module, name, None)
    if not isinstance(cls, type):
        msg = f'type {msgtype!r}: module {package}.msg has no message {name!r}'
        raise BagFormatError(msg)
    return cls


class RclpyKit:
    """rclpy message classes (the live graph)."""

    def new(self, msgtype: str, **fields: Any) -> Any:
        """See :meth:`MessageKit.new`."""
        return message_class(msgtype)(**fields)

    def constant(self, msgtype: str, name: str) -> Any:
        """See :meth:`MessageKit.constant`."""
        return getattr(message_class(msgtype), name)

    def floats(self, values: FloatArray) -> Any:
        """See :meth:`MessageKit.floats`."""
        out = array.array('d')
        out.frombytes(np.ascontiguousarray(values, dtype=np.float64).tobytes())
        return out


class RosbagsKit:
    """rosbags message classes (bags written without rclpy).

    Parameters
    ----------
    store : Typestore, optional
        Default: the shared type store (ROS 2 Kilted plus ``hand_tracker_msgs``).
    """

    def __init__(self, store: Typestore | None = None) -> None:
        self._store = store if store is not None else typestore()

    def new(self, msgtype: str, **fields: Any) -> Any:
        """See :meth:`MessageKit.new`."""
        for name, desc in self._store.fielddefs[msgtype][1]:
            if name not in fields:
                fields[name] = self._zero(desc)
        return self._store.types[msgtype](**fields)

    def constant(self, msgtype: str, name: str) -> Any:
        """See :meth:`MessageKit.constant`."""
        return getattr(self._store.types[msgtype], name)

    def floats(self, values: FloatArray) -> Any:
        """See :meth:`MessageKit.floats`."""
        return np.array(values, dtype=np.float64).reshape(-1)

    def _zero(self, desc: tuple[Any, Any]) -> Any:
        kind, detail = desc
        if kind == Nodetype.BASE:
            return '' if detail[0] in ('string', 'wstring') else _DTYPES[detail[0]](0).item()
        if kind == Nodetype.NAME:
            return self.new(detail)
        (sub_kind, sub), count = detail            # ARRAY (fixed count) or SEQUENCE (count 0)
        length = count if kind == Nodetype.ARRAY else 0
        if sub_kind == Nodetype.BASE and sub[0] in _DTYPES:
            return np.zeros(length, dtype=_DTYPES[sub[0]])
        return [self._zero((sub_kind, sub)) for _ in range(length)]
