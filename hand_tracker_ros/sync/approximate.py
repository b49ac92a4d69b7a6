"""Approximate-time synchronizer for N hardware-triggered cameras (``message_filters`` is not
on PyPI, so this is our own; it follows the C++ ApproximateTime policy's guarantees with a
fixed slop suited to one trigger clock).

Policy
------
- One queue per input, keyed by ``stamp_ns``, at most ``queue_size`` entries; when full the
  oldest entry is dropped (counted ``overflow``). Arrival order across inputs is free, and
  within one input it may be out of order too (stamps are sorted).
- Candidate sets: for every queued stamp ``p`` (the *pivot*, any input) the set takes, per
  input, the queued stamp nearest to ``p``. A candidate is *complete* when its span
  ``max(s_i) - min(s_i) <= slop_ns`` (so every member is within ``slop_ns`` of the pivot and of
  each other) and its reference stamp is newer than the last emitted set's.
- Among complete candidates the newest wins (largest oldest member), ties broken by the
  smallest span. It is emitted at once and its members leave the queues; messages of each
  input older than that input's member are dropped (counted ``unmatched``), because sets
  never go backwards in time. ``unmatched_sets`` grows by the largest number of messages one
  input dropped this way (one message per input per trigger), an estimate of the trigger
  instants that were never emitted (e.g. a frame lost by one camera).
- A message not newer than the member its input gave to the last emitted set, or a duplicate
  stamp, is dropped (counted ``late``).
- A message more than ``jump_back_ns`` older than the newest stamp seen on its own input
  *jumped back*. Time jumps (bag ``--loop``, sim time reset) move every input back, so only
  when the latest message of every input jumped back are all queues and the time floor
  cleared (counted in ``resets``; the cleared messages count as ``unmatched``) and
  synchronization restarts from that message; until then a jumped-back message is dropped as
  ``late``. One input's stale message (a frame delayed by a scheduling hiccup) therefore
  never empties the queues; a loop costs the sets of the first messages after it.

Reference stamp of a set: the lower median of its member stamps,
``sorted(stamps)[(N - 1) // 2]``. It is always the stamp of a real input message (so outputs
stamped with it match an image), and one jittery camera cannot move it past the others.

Cost per :meth:`ApproximateTimeSync.add`: ``O(N^2 Q log Q)`` for N inputs and queue size Q;
measured 7 us per message for N = 4, Q = 5, negligible next to one frame's processing.
"""
from __future__ import annotations

import bisect
import logging
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from hand_tracker_ros.config import param, validate
from hand_tracker_ros.errors import ConfigError

logger = logging.getLogger(__name__)

_COUNTERS = ('received', 'late', 'unmatched', 'overflow')


@dataclass(frozen=True)
class SyncConfig:
    """Approximate-time synchronizer settings."""

    slop_ns: int = param(16_000_000, 'largest stamp spread within one set (~half a period)',
                         unit='ns', low=0)
    queue_size: int = param(5, 'messages kept per input while waiting for a set', low=1)
    # Shorter than any bag one would loop, longer than any reordering within one input.
    jump_back_ns: int = param(250_000_000, 'backward stamp jump on one input that resets '
                              'the synchronizer (bag loop, sim time reset)', unit='ns', low=1)


@dataclass(frozen=True, slots=True)
class SyncedSet:
    """One synchronized set: one message per input.

    Attributes
    ----------
    stamp_ns : int
        Reference stamp: the lower median of ``stamps`` (a real member stamp).
    items : Mapping[str, Any]
        Input name -> the message given to :meth:`ApproximateTimeSync.add`.
    stamps : Mapping[str, int]
        Input name -> that message's stamp, ns.
    """

    stamp_ns: int
    items: Mapping[str, Any]
    stamps: Mapping[str, int]


@dataclass(frozen=True, slots=True)
class InputStats:
    """Counters of one input: received messages and the three ways of dropping one."""

    received: int
    late: int
    unmatched: int
    overflow: int

    @property
    def dropped(self) -> int:
        """Messages of this input that were never part of an emitted set (so far)."""
        return self.late + self.unmatched + self.overflow


@dataclass(frozen=True, slots=True)
class SyncStats:
    """Snapshot of the synchronizer's counters (for diagnostics)."""

    inputs: Mapping[str, InputStats]
    emitted: int
    unmatched_sets: int
    resets: int

    def summary(self) -> str:
        """One line: each input's messages, how many are in no set, the sets emitted."""
        received = ', '.join(f'{name} {s.received}' for name, s in self.inputs.items())
        dropped = sum(s.dropped for s in self.inputs.values())
        return f'frames {received} ({dropped} in no set); {self.emitted} sets synchronized'


def _nearest(stamps: list[int], pivot: int) -> int:
    """The stamp of sorted, non-empty ``stamps`` closest to ``pivot`` (earlier on a tie)."""
    i = bisect.bisect_left(stamps, pivot)
    if i == 0:
        return stamps[0]
    if i == len(stamps) or pivot - stamps[i - 1] <= stamps[i] - pivot:
        return stamps[i - 1]
    return stamps[i]


def reference_stamp(stamps: Sequence[int]) -> int:
    """Return the lower median of ``stamps`` (int ns), the reference stamp of a set."""
    return sorted(stamps)[(len(stamps) - 1) // 2]


class ApproximateTimeSync:
    """Group messages of N inputs into sets of nearly equal stamps (policy: module docstring).

    Parameters
    ----------
    names : sequence of str
        Input names (e.g. camera names), unique, at least one.
    config : SyncConfig, optional
        Slop, queue size and time-jump threshold.

    Raises
    ------
    ConfigError
        For no or duplicate names, or an out-of-range config field.
    """

    def __init__(self, names: Sequence[str], config: SyncConfig | None = None) -> None:
        self.config = SyncConfig() if config is None else config
        validate(self.config)
        if not names or len(set(names)) != len(names):
            msg = f'`names` must be unique and non-empty, got {list(names)}'
            raise ConfigError(msg)
        self.names = tuple(names)
        self._queues: dict[str, dict[int, Any]] = {n: {} for n in self.names}
        self._counts = {n: Counter({c: 0 for c in _COUNTERS}) for n in self.names}
        self._newest: dict[str, int] = {}
        self._floor: dict[str, int] = {}
        self._jumped: set[str] = set()     # inputs whose latest message jumped back
        self._last_ref: int | None = None
        self._totals = Counter({'emitted': 0, 'unmatched_sets': 0, 'resets': 0})

    @property
    def stats(self) -> SyncStats:
        """Counters since construction (not cleared by time-jump resets)."""
        inputs = {n: InputStats(**{c: self._counts[n][c] for c in _COUNTERS})
                  for n in self.names}
        return SyncStats(inputs=MappingProxyType(inputs), **self._totals)

    def queued(self, name: str) -> int:
        """Number of messages of input ``name`` waiting for a set."""
        return len(self._queue(name))

    def _queue(self, name: str) -> dict[int, Any]:
        queue = self._queues.get(name)
        if queue is None:
            msg = f'unknown sync input {name!r} (inputs: {", ".join(self.names)})'
            raise ConfigError(msg)
        return queue

    def add(self, name: str, stamp_ns: int, item: Any) -> list[SyncedSet]:
        """Queue ``item`` of input ``name`` stamped ``stamp_ns`` (int ns); return new sets.

        Returns
        -------
        list of SyncedSet
            The set completed by this message, if any (empty or one element).

        Raises
        ------
        ConfigError
            If ``name`` is not one of the inputs.
        """
        queue = self._queue(name)
        self._counts[name]['received'] += 1
        newest = self._newest.get(name)
        if newest is not None and stamp_ns < newest - self.config.jump_back_ns:
            self._jumped.add(name)
            if len(self._jumped) < len(self.names):
                self._counts[name]['late'] += 1
                return []
            self._reset(name, stamp_ns, newest)
        self._jumped.discard(name)
        self._newest[name] = max(stamp_ns, self._newest.get(name, stamp_ns))
        if stamp_ns <= self._floor.get(name, -1) or stamp_ns in queue:
            self._counts[name]['late'] += 1
            return []
        queue[stamp_ns] = item
        if len(queue) > self.config.queue_size:
            del queue[min(queue)]
            self._counts[name]['overflow'] += 1
        members = self._best_set()
        return [] if members is None else [self._emit(members)]

    def _reset(self, name: str, stamp_ns: int, newest: int) -> None:
        logger.info('every sync input jumped back (%s by %.3f s): clearing the queues', name,
                    (newest - stamp_ns) / 1e9)
        for queue_name, queue in self._queues.items():
            self._counts[queue_name]['unmatched'] += len(queue)
            queue.clear()
        self._newest.clear()
        self._floor.clear()
        self._jumped.clear()
        self._last_ref = None
        self._totals['resets'] += 1

    def _best_set(self) -> dict[str, int] | None:
        """Members (name -> stamp) of the newest complete candidate set, or None."""
        if not all(self._queues.values()):
            return None
        stamps = {n: sorted(q) for n, q in self._queues.items()}
        best, best_key = None, None
        for pivot in {s for column in stamps.values() for s in column}:
            members = {n: _nearest(column, pivot) for n, column in stamps.items()}
            low, high = min(members.values()), max(members.values())
            if high - low > self.config.slop_ns:
                continue
            if self._last_ref is not None and reference_stamp(list(members.values())) <= \
                    self._last_ref:
                continue
            key = (low, low - high)
            if best_key is None or key > best_key:
                best, best_key = members, key
        return best

    def _emit(self, members: dict[str, int]) -> SyncedSet:
        items, most_dropped = {}, 0
        for name, stamp in members.items():
            queue = self._queues[name]
            older = [s for s in queue if s < stamp]
            for s in older:
                del queue[s]
            self._counts[name]['unmatched'] += len(older)
            most_dropped = max(most_dropped, len(older))
            items[name] = queue.pop(stamp)
            self._floor[name] = stamp
        self._last_ref = reference_stamp(list(members.values()))
        self._totals['emitted'] += 1
        self._totals['unmatched_sets'] += most_dropped
        return SyncedSet(stamp_ns=self._last_ref, items=MappingProxyType(items),
                         stamps=MappingProxyType(dict(members)))
