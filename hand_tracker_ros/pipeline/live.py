"""The live tracking loop: the newest set is observed on one thread and tracked on another.

A node's ROS callbacks only :meth:`LivePipeline.offer` complete sets (cheap). Two threads do
the work:

- the *observer* turns the newest offered set into the tracker's observations (features,
  detections, the silhouette term's lookup tables); a set offered while an older one is
  still untaken replaces it and counts as ``skipped``, so the graph always works on the
  newest set;
- the *tracker* fits each observed set in turn and publishes (``track``).

Every observed set is tracked (optical flow and the warm start are relative to the previous
tracked set, so none may be skipped after observing). The two overlap, *just in time*: while
a fit runs, the observer waits until the fit's expected end minus the expected observation
and a margin, and only then takes the newest offered set, so that the next fit starts on a
set as fresh as possible. The throughput is one set per fit; the latency of a set is its wait
for the observer, its observation, what is left of the fit in progress, and its own fit.
Starting the observation right after the tracker took a set (the earliest policy) left the
observed set waiting for most of the fit: on the live 4 x 320x240 graph the median latency
was 127 ms, 117 ms just in time.

Both durations are predicted per *kind*, from that kind's recent ones: the coming
observation by the median of its kind's observations (``observe_kind``; the graph's is the
attention plan's: tracked or not, fingertips detected or not), the fit in progress by the
lower quartile of its kind's fits (``fit_kind``, asked as the fit starts; the graph's is the
session's status, which the previous fit left: a live search's fits or a tracking fit). A
kind without a measured duration yet starts the observation at once, and so does the end of
the fit in progress. Why per kind, and these statistics:

- A live search's fits take about 250 ms, a tracking fit 40-50 ms: predicted by the fits of
  any kind, the first tracked sets after a search waited that long (the tracked hand got one
  set in five). An observation with fingertip detection takes about 10 ms more than one
  without.
- Before, the prediction took the shortest recent fit and the longest recent observation,
  erring early on purpose (a late observation idles the tracker). Fits vary by their rounds
  (a fit over its budget skips its last one) and observations by what they detect, so it
  erred early by most of that spread. In one live run (random, 4 x 320x240, composed) an
  observed set then waited a median 13-18 ms for the fit in progress, of about 100 ms of
  latency, and the tracker idled 0.2 ms a set on average. With the median fit and
  observation the set waited 5.5 ms and the tracker idled 2 ms a set (a fit shorter than
  predicted waits for the rest of the observation), about 4 % of the throughput; with the
  lower quartile of the fits, 8 ms and 0.8-1.4 ms (docs/history.md, "Session of 2026-11-26
  (sixth)").

When the observer is due to start, the newest set is on average half a period old. While the
fits take longer than a period (the median of the fit's kind; sets are skipped anyway), when
the next set is due before the latest start that still ends a median observation by the fit
in progress's *median* end (:func:`due_set_wait_s`), the observer waits for it instead. The
wait spends the margin the schedule leaves (the margin and the spread between the lower
quartile and the median of the fits), so the tracker idles past a median fit only when the
observation runs over its median. While the fits keep up with the sets, the observer never
waits: a set queued behind one long fit is then tracked, not replaced. An earlier rule (wait
when the next set was due within 0.3 of the period, 0.1 more for its jitter) idled the
tracker 20 ms a fit when fits took 1.8 periods, and passed over a set after one long fit at
slow playback (an independent review). Composed at 1.0x, 4 x 320x240, in pairs with the loop
without it, that rule lowered the median latency in 8 of 11 runs (a median of 84 against 92
ms); the bounded rule's figures are in docs/history.md ("Session of 2026-11-26 (seventh)").

Why plain threads and not a MultiThreadedExecutor: the one-slot mailboxes state the "newest
set wins" policy directly, and the executor thread stays free for callbacks and timers
whatever the tracker costs. Both stages spend most of their time in OpenCV, ONNX Runtime,
NumPy and numba code that runs beside the other thread on a second core.
"""
from __future__ import annotations

import statistics
import threading
import time
from collections import deque
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

Item = TypeVar('Item')
Observed = TypeVar('Observed')

_POLL_S = 0.2         # longest wait of a thread before it checks for a stop
_PERIOD_EMA = 0.1     # weight of the newest gap in the moving average of the set period
_RECENT = 9           # fits and observations whose durations predict the next ones
_MARGIN = 0.2         # the observation starts early by this share of its expected duration
_MARGIN_MIN_S = 0.002


class LatestSet(Generic[Item]):
    """A one-slot mailbox (newest wins); counts the items replaced before they were taken."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._item: tuple[Item, float] | None = None
        self.skipped = 0

    def put(self, item: Item, received_s: float) -> None:
        """Offer ``item`` (received at monotonic ``received_s``); replaces an untaken one."""
        with self._cond:
            self.skipped += self._item is not None
            self._item = (item, received_s)
            self._cond.notify_all()

    def take(self, timeout_s: float, on_take: Callable[[], None] | None = None
             ) -> tuple[Item, float] | None:
        """The newest item with its receipt time, or None after ``timeout_s``.
        ``on_take`` runs when an item is taken, before a waiter on the empty slot wakes."""
        with self._cond:
            if self._item is None:
                self._cond.wait(timeout_s)
            item, self._item = self._item, None
            if item is not None and on_take is not None:
                on_take()
            self._cond.notify_all()
            return item

    def wait_newer(self, than_s: float, timeout_s: float) -> bool:
        """Block until the slot holds an item received after monotonic ``than_s`` (or
        ``timeout_s``); True when it does."""
        with self._cond:
            return self._cond.wait_for(
                lambda: self._item is not None and self._item[1] > than_s, timeout_s)

    def wait_empty(self, timeout_s: float) -> bool:
        """Block until the slot is empty (or ``timeout_s``); True when it is."""
        with self._cond:
            return self._cond.wait_for(lambda: self._item is None, timeout_s)


class NewestSetWorker(Generic[Item]):
    """One thread processes the newest offered item; one offered while an older one still
    waits replaces it and counts as ``skipped``.

    For nodes that serve synchronized camera sets (the distributed graph's features and
    salient_points): one that falls behind drops whole sets. Processing each camera's frames
    as they came and letting each camera's queue overflow dropped different frames per
    camera, and their features no longer made sets (4 x 640x480: 63-67 of 150 frames per
    camera reached the tracker, 243-257 of them in no set).

    Parameters
    ----------
    process : callable
        ``process(item)``, on the worker thread.
    on_error : callable
        Called with each exception ``process`` raised; the thread keeps running.
    name : str
        The thread's name.
    """

    def __init__(self, process: Callable[[Item], None],
                 on_error: Callable[[BaseException], None], name: str) -> None:
        self._process, self._on_error = process, on_error
        self._inbox: LatestSet[Item] = LatestSet()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    @property
    def skipped(self) -> int:
        """Offered items replaced by a newer one before the worker took them."""
        return self._inbox.skipped

    def offer(self, item: Item) -> None:
        """A new item (any thread)."""
        self._inbox.put(item, time.monotonic())

    def close(self, timeout_s: float = 10.0) -> None:
        """Stop the thread (the item in progress is finished)."""
        self._stop.set()
        self._thread.join(timeout_s)

    def _run(self) -> None:
        while not self._stop.is_set():
            taken = self._inbox.take(_POLL_S)
            if taken is None:
                continue
            try:
                self._process(taken[0])
            except Exception as err:  # noqa: BLE001 - the thread must outlive one bad item
                self._on_error(err)


class LivePipeline(Generic[Item, Observed]):
    """Observe the newest set, track every observed one (module docstring).

    Parameters
    ----------
    observe : callable
        ``observe(item) -> observed``; raising drops the set (``on_error`` is told).
    track : callable
        ``track(item, observed, received_s)``: fit and publish one set.
    on_error : callable
        Called with each exception either stage raised; the threads keep running.
    observe_kind : callable, optional
        ``observe_kind() -> key``: the kind of the next observation (e.g. the attention
        plan's), asked before the observer schedules it and again as it takes the set (the
        kind its duration is filed under); default: one kind.
    fit_kind : callable, optional
        ``fit_kind() -> key``: the kind of the fit about to start (e.g. the session's status,
        which the previous fit left), asked on the tracker thread as it takes a set; default:
        one kind.
    """

    def __init__(self, observe: Callable[[Item], Observed],
                 track: Callable[[Item, Observed, float], None],
                 on_error: Callable[[BaseException], None], *,
                 observe_kind: Callable[[], Hashable] | None = None,
                 fit_kind: Callable[[], Hashable] | None = None) -> None:
        self._observe, self._track, self._on_error = observe, track, on_error
        self._observe_kind = observe_kind if observe_kind is not None else _one_kind
        self._next_fit_kind = fit_kind if fit_kind is not None else _one_kind
        self._inbox: LatestSet[Item] = LatestSet()
        self._observed: LatestSet[tuple[Item, Observed]] = LatestSet()
        self._last_offer_s: float | None = None
        self.period_s: float | None = None   # moving average of the gaps between offers, s
        # The last fits' and observations' durations (s) per kind.
        self._fit_s: dict[Hashable, deque[float]] = {}
        self._observe_s: dict[Hashable, deque[float]] = {}
        self._fit_since: float | None = None   # monotonic start of the fit in progress
        self._fit_kind: Hashable = None        # its kind
        self._fit_ended = threading.Event()    # set while no fit runs
        self._fit_ended.set()
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._observer, name='observer', daemon=True),
                         threading.Thread(target=self._tracker, name='tracker', daemon=True)]
        for thread in self._threads:
            thread.start()

    @property
    def skipped(self) -> int:
        """Offered sets replaced by a newer one before they were observed."""
        return self._inbox.skipped

    def offer(self, item: Item, received_s: float) -> None:
        """A new complete set, received at monotonic ``received_s`` (one thread)."""
        if self._last_offer_s is not None:
            gap = received_s - self._last_offer_s
            self.period_s = (gap if self.period_s is None
                             else (1.0 - _PERIOD_EMA) * self.period_s + _PERIOD_EMA * gap)
        self._last_offer_s = received_s
        self._inbox.put(item, received_s)

    def close(self, timeout_s: float = 10.0) -> None:
        """Stop both threads (the set in progress is finished)."""
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout_s)

    def observe_at(self, kind: Hashable = None) -> float | None:
        """When (monotonic s) the next observation, of ``kind``, should start: the fit in
        progress's expected end (the lower quartile of its kind's recent fits) less the
        expected observation (the median of ``kind``'s recent ones) and a margin; None (start
        at once) when no fit runs or either kind has no measured duration yet (module
        docstring)."""
        measured = self._measured(kind)
        if measured is None:
            return None
        since, fits, observations = measured
        observe_s = statistics.median(observations)
        fit_s = sorted(fits)[len(fits) // 4]
        return (since + fit_s - observe_s
                - max(_MARGIN * observe_s, _MARGIN_MIN_S))

    def _measured(self, kind: Hashable
                  ) -> tuple[float, deque[float], deque[float]] | None:
        """The fit in progress's start (monotonic s) with its kind's recent fits and
        ``kind``'s recent observations (s); None when no fit runs or either has none."""
        since, fits = self._fit_since, self._fit_s.get(self._fit_kind)
        observations = self._observe_s.get(kind)
        if since is None or not fits or not observations:
            return None
        return since, fits, observations

    def _wait_for_fit(self, kind: Hashable) -> None:
        """Sleep until :meth:`observe_at`, or until the fit in progress ends (re-read: a fit
        may end or start meanwhile)."""
        while not self._stop.is_set():
            start_at = self.observe_at(kind)
            wait_s = 0.0 if start_at is None else start_at - time.monotonic()
            if wait_s <= 0.0:
                return
            self._fit_ended.wait(min(wait_s, _POLL_S))

    def _wait_for_due_set(self, kind: Hashable) -> None:
        """Wait (at most ``_POLL_S``) for the next set if it is due in time to be observed,
        ``kind``, by the fit in progress's median end (:func:`due_set_wait_s`); only while
        the fits take longer than a period (module docstring)."""
        measured, last_s, period_s = self._measured(kind), self._last_offer_s, self.period_s
        if measured is None or last_s is None or period_s is None:
            return
        since, fits, observations = measured
        fit_s = statistics.median(fits)
        if fit_s <= period_s:
            return
        latest_s = since + fit_s - statistics.median(observations)
        wait_s = due_set_wait_s(time.monotonic(), last_s, period_s, latest_s)
        if wait_s > 0.0:
            self._inbox.wait_newer(last_s, min(wait_s, _POLL_S))

    def _fit_starts(self) -> None:
        """On the tracker thread as it takes a set, before the observer may schedule the
        next one."""
        self._fit_ended.clear()
        self._fit_kind = self._next_fit_kind()
        self._fit_since = time.monotonic()

    def _observer(self) -> None:
        while not self._stop.is_set():
            if not self._observed.wait_empty(_POLL_S):
                continue
            try:
                kind = self._observe_kind()
                self._wait_for_fit(kind)
                self._wait_for_due_set(kind)
                taken = self._inbox.take(_POLL_S)
                if taken is None:
                    continue
                item, received_s = taken
                kind, start = self._observe_kind(), time.monotonic()
                observed = self._observe(item)
            except Exception as err:  # noqa: BLE001 - the thread must outlive one bad set
                self._on_error(err)
                continue
            self._observe_s.setdefault(kind, deque(maxlen=_RECENT)).append(
                time.monotonic() - start)
            self._observed.put((item, observed), received_s)

    def _tracker(self) -> None:
        while not self._stop.is_set():
            try:
                taken = self._observed.take(_POLL_S, on_take=self._fit_starts)
            except Exception as err:  # noqa: BLE001 - e.g. from fit_kind: the set is lost
                self._fit_since = None
                self._fit_ended.set()
                self._on_error(err)
                continue
            if taken is None:
                continue
            (item, observed), received_s = taken
            start, kind = self._fit_since, self._fit_kind
            assert start is not None
            try:
                self._track(item, observed, received_s)
            except Exception as err:  # noqa: BLE001 - the thread must outlive one bad set
                self._on_error(err)
            finally:
                self._fit_s.setdefault(kind, deque(maxlen=_RECENT)).append(
                    time.monotonic() - start)
                self._fit_since = None
                self._fit_ended.set()


def due_set_wait_s(now_s: float, last_offer_s: float, period_s: float | None,
                   latest_start_s: float) -> float:
    """The longest (s) the observer waits for the next set rather than observe the newest (the
    wait ends when the set arrives): until ``latest_start_s`` (monotonic s, the latest start
    that ends the observation by the fit in progress's median end) when the next set, due a
    period after the last one offered at ``last_offer_s``, is due by then; 0 when it is not,
    or the period is unknown."""
    if period_s is None or last_offer_s + period_s > latest_start_s:
        return 0.0
    return max(latest_start_s - now_s, 0.0)


def _one_kind() -> None:
    """The kind of every observation and fit when none is told."""
