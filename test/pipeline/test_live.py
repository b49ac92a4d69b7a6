"""The live loop: newest set wins before observing, every observed set is tracked in order,
and a failing set does not stop either thread."""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from hand_tracker_ros.pipeline.live import (
    LatestSet,
    LivePipeline,
    NewestSetWorker,
    due_set_wait_s,
)


def test_newest_set_wins_and_skipped_sets_are_counted() -> None:
    mailbox: LatestSet[str] = LatestSet()
    assert mailbox.take(timeout_s=0.01) is None
    for k in range(3):
        mailbox.put(f'set{k}', float(k))
    assert mailbox.take(timeout_s=0.01) == ('set2', 2.0) and mailbox.skipped == 2
    taken = []
    worker = threading.Thread(target=lambda: taken.append(mailbox.take(timeout_s=10.0)))
    worker.start()
    mailbox.put('set3', 3.0)         # wakes the waiting taker at once
    worker.join(timeout=5.0)
    assert taken == [('set3', 3.0)] and mailbox.skipped == 2
    assert mailbox.wait_empty(0.01)


def test_the_set_period_is_the_moving_average_of_the_gaps_between_offers() -> None:
    live = LivePipeline(lambda k: k, lambda *_: None, lambda err: None)
    try:
        assert live.period_s is None
        live.offer(0, 100.0)
        assert live.period_s is None            # one offer: no gap yet
        for k in range(1, 50):
            live.offer(k, 100.0 + 0.033 * k)
        assert abs(live.period_s - 0.033) < 1e-9
        live.offer(50, 100.0 + 0.033 * 49 + 0.133)   # one late set moves it by a tenth
        assert abs(live.period_s - (0.9 * 0.033 + 0.1 * 0.133)) < 1e-9
    finally:
        live.close()


def test_slow_tracker_skips_sets_but_tracks_every_observed_one_in_order() -> None:
    observed, tracked, errors = [], [], []

    def observe(k: int) -> int:
        if k == 3:
            raise ValueError('bad set 3')
        observed.append(k)
        return 10 * k

    def track(k: int, obs: int, received_s: float) -> None:
        assert obs == 10 * k and received_s <= time.monotonic()
        time.sleep(0.05)              # slower than the sets arrive
        tracked.append(k)

    live = LivePipeline(observe, track, errors.append)
    try:
        for k in range(40):
            live.offer(k, time.monotonic())
            time.sleep(0.01)
        deadline = time.monotonic() + 5.0
        while (not tracked or tracked[-1] != 39) and time.monotonic() < deadline:
            time.sleep(0.01)
    finally:
        live.close()
    assert tracked == observed                    # nothing observed is dropped
    assert tracked == sorted(tracked) and tracked[-1] == 39
    assert live.skipped > 0 and len(tracked) < 40
    assert all(isinstance(e, ValueError) for e in errors)


def test_the_next_set_is_observed_just_before_the_fit_in_progress_ends() -> None:
    """A fit takes six set periods: the set fitted next is taken near the fit's end, not at
    its start (then it would be about six sets old when its fit starts)."""
    newest, lags = [-1], []

    def track(k: int, obs: int, received_s: float) -> None:
        lags.append(newest[0] - k)      # sets offered after k, when k's fit starts
        time.sleep(0.06)

    def observe(k: int) -> int:
        time.sleep(0.005)
        return k

    live = LivePipeline(observe, track, lambda err: None)
    try:
        for k in range(150):
            newest[0] = k
            live.offer(k, time.monotonic())
            time.sleep(0.01)
    finally:
        live.close()
    assert len(lags) > 10
    assert np.median(lags[3:]) <= 2, lags      # the first fits have no durations measured yet


def test_the_next_set_is_waited_for_only_when_it_can_be_observed_by_the_fits_end() -> None:
    """Sets every 33 ms, the last offered at t = 1.000 s; the observation must start by
    ``latest`` to end by the fit in progress's expected end."""
    # Due at 1.033, by the latest start 1.040: wait from 1.025 until 1.040.
    assert due_set_wait_s(1.025, 1.0, 0.033, 1.040) == pytest.approx(0.015)
    # Due at 1.033 after the latest start 1.030: observe the newest now.
    assert due_set_wait_s(1.025, 1.0, 0.033, 1.030) == 0.0
    # A set late past its due time: wait what is left until the latest start, then go.
    assert due_set_wait_s(1.038, 1.0, 0.033, 1.040) == pytest.approx(0.002)
    assert due_set_wait_s(1.045, 1.0, 0.033, 1.040) == 0.0
    assert due_set_wait_s(1.025, 1.0, None, 1.040) == 0.0     # no period measured yet


def test_a_set_due_before_the_fits_median_end_is_waited_for() -> None:
    """Sets every 100 ms; fits of 120 or 180 ms (lower quartile 120, median 180). At the
    scheduled start (about 108 ms into a fit) a set due within about 60 ms is waited for, so
    half the observed sets are at most 30 ms old (without the wait, 50-70 ms)."""
    offered: dict[int, float] = {}
    ages: list[float] = []
    fits = [0]

    def observe(k: int) -> int:
        ages.append(time.monotonic() - offered[k])
        time.sleep(0.01)
        return k

    def track(k: int, obs: int, received_s: float) -> None:
        fits[0] += 1
        time.sleep(0.12 if fits[0] % 3 == 0 else 0.18)

    live = LivePipeline(observe, track, lambda err: None)
    try:
        for k in range(45):
            offered[k] = time.monotonic()
            live.offer(k, offered[k])
            time.sleep(0.1)
    finally:
        live.close()
    assert len(ages) > 20
    assert np.median(ages[8:-1]) < 0.03, np.round(ages, 3)   # the first fits measure


@pytest.mark.parametrize('long_fit_s', [0.25, 0.95])
def test_a_backlog_after_one_long_fit_is_worked_off_without_passing_a_set(long_fit_s) -> None:
    """Slow playback (a set every 100 ms, 10 ms fits) and one long fit: the sets that queued
    behind it are all tracked, as the fits keep up with the sets."""
    tracked: list[int] = []

    def track(k: int, obs: int, received_s: float) -> None:
        time.sleep(long_fit_s if k == 6 else 0.01)
        tracked.append(k)

    live = LivePipeline(lambda k: (time.sleep(0.005), k)[1], track, lambda err: None)
    try:
        for k in range(14):
            live.offer(k, time.monotonic())
            time.sleep(0.1)
        time.sleep(0.3)
    finally:
        live.close()
    # Of the sets offered during the long fit (7, 8, ...) the first is observed during it
    # and the last is tracked after it; only those between are replaced. (Waiting for set
    # 9 while 8 waited, as a rule unbounded by the fit's expected end did, lost set 8.)
    during = min(int(long_fit_s / 0.1), 7)
    assert live.skipped <= max(during - 2, 0), tracked
    assert len(tracked) == 14 - live.skipped and tracked == sorted(tracked), tracked


def test_each_kind_of_observation_is_scheduled_by_its_own_durations() -> None:
    """Long and short observations alternate (as with fingertip detection in every second
    set): a short one starts late enough that its set does not wait for the fit in progress
    for the long one's duration."""
    durations = {'long': 0.04, 'short': 0.004}
    ended: dict[int, tuple[str, float]] = {}
    waits: dict[str, list[float]] = {'long': [], 'short': []}
    count = [0]

    def kind() -> str:
        return 'long' if count[0] % 2 == 0 else 'short'

    def observe(k: int) -> int:
        name = kind()
        count[0] += 1
        time.sleep(durations[name])
        ended[k] = (name, time.monotonic())
        return k

    def track(k: int, obs: int, received_s: float) -> None:
        name, end = ended[k]
        waits[name].append(time.monotonic() - end)
        time.sleep(0.08)

    live = LivePipeline(observe, track, lambda err: None, observe_kind=kind)
    try:
        for k in range(120):
            live.offer(k, time.monotonic())
            time.sleep(0.01)
    finally:
        live.close()
    assert len(waits['short']) > 4, waits
    # Scheduled by the long ones' duration, a short observation would end ~36 ms early.
    assert np.median(waits['short'][2:]) < 0.02, waits


def test_the_first_tracking_fits_after_a_search_are_not_scheduled_by_the_search() -> None:
    """A fit's kind is the state the previous fit left: tracking fits take 20 ms, the fits of
    a search 200 ms, an observation 15 ms. Ten tracking fits, then a loss, six search fits,
    and the hand found again: the observer schedules the tracking fits that follow by the
    tracking fits' own durations, so their sets are observed before the fit in progress
    ends. Scheduled by the search's fits, each would start only when the fit in progress
    ended (the observer wakes then) and the tracker would idle for the observation."""
    state = ['track']
    fits: list[tuple[str, float, float]] = []

    def track(k: int, observed: int, received_s: float) -> None:
        kind, start = state[0], time.monotonic()
        time.sleep(0.2 if kind == 'search' else 0.02)
        fits.append((kind, start, time.monotonic()))
        searched = sum(f[0] == 'search' for f in fits)
        if len(fits) == 10:
            state[0] = 'search'          # this fit lost the hand
        elif kind == 'search' and searched == 6:
            state[0] = 'track'           # this one found it

    def observe(k: int) -> int:
        time.sleep(0.015)
        return k

    live = LivePipeline(observe, track, lambda err: None, fit_kind=lambda: state[0])
    try:
        k, end = 0, None
        while end is None or time.monotonic() < end:
            live.offer(k, time.monotonic())
            k += 1
            time.sleep(0.01)
            if end is None and sum(f[0] == 'search' for f in fits) == 6:
                end = time.monotonic() + 1.0
    finally:
        live.close()
    last_search = max(i for i, f in enumerate(fits) if f[0] == 'search')
    after = fits[last_search:last_search + 7]
    idle = [b[1] - a[2] for a, b in zip(after, after[1:])]
    assert len(after) == 7 and all(f[0] == 'track' for f in after[1:]), fits
    assert np.median(idle) < 0.008, idle


def test_the_set_worker_serves_the_newest_set_drops_whole_ones_and_outlives_errors() -> None:
    started, release = threading.Event(), threading.Event()
    served, errors = [], []

    def process(item: int) -> None:
        if item == 0:
            started.set()
            release.wait(5.0)
        if item == 3:
            raise ValueError('bad set')
        served.append(item)

    worker = NewestSetWorker(process, errors.append, 'test-sets')
    worker.offer(0)
    assert started.wait(5.0)
    for item in (1, 2, 3):      # offered while 0 is processed: only the newest waits
        worker.offer(item)
    release.set()
    deadline = time.monotonic() + 5.0
    while not errors and time.monotonic() < deadline:
        time.sleep(0.01)
    worker.offer(4)
    while 4 not in served and time.monotonic() < deadline:
        time.sleep(0.01)
    worker.close()
    assert served == [0, 4]
    assert [str(e) for e in errors] == ['bad set']
    assert worker.skipped == 2
