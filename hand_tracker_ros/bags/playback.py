"""Playback timing, topic selection and remapping for a bag player (pure; no rclpy).

Mirrors ``ros2 bag play``'s options ``--rate``, ``--start-offset``, ``--playback-duration``,
``--loop``, ``--delay``, ``--topics``, ``--exclude-regex`` and ``--remap``. A player node
reads the messages of :attr:`PlaybackSchedule.window_ns` on :meth:`PlaybackSchedule.
select_topics`, sleeps until ``start + delay_ns(stamp_ns, loop)`` and publishes on
:meth:`PlaybackSchedule.output_topic`.

Timing. With bag start ``t_b`` (first stamp), ``t_0 = t_b + start_offset``, playback window
``[t_0, t_1)`` where ``t_1 = t_0 + duration`` (or the bag end when ``duration_s < 0``), rate
``r`` and pre-roll delay ``d``, a message stamped ``t`` in pass ``k`` (0-based) is published at
wall time, from the playback start,

    delay(t, k) = k * T + d + (t - t_0) / r,    T = d + (min(t_1, t_end) - t_0) / r,

with ``t_end`` = last stamp + 1 ns. So one pass lasts ``T``, and with ``--loop`` the next pass
starts at once, with its own pre-roll delay (as ``ros2 bag play -d`` does each loop).
All times are int ns; delays are rounded to the nearest ns.
"""
from __future__ import annotations

import itertools
import logging
import re
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

from hand_tracker_ros.config import param, validate
from hand_tracker_ros.errors import ConfigError

logger = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
# A ROS 2 topic name: optional leading '/', tokens of [A-Za-z0-9_] not starting with a digit.
_TOPIC = re.compile(r'/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*')


@dataclass(frozen=True)
class PlaybackConfig:
    """Bag player settings (names follow ``ros2 bag play``)."""

    rate: float = param(1.0, 'playback speed factor (2.0 = twice as fast)', low=1e-6)
    start_offset_s: float = param(0.0, 'bag time skipped at the start', unit='s', low=0.0)
    duration_s: float = param(-1.0, 'bag time played from the start offset; negative = to '
                              'the end', unit='s')
    loop: bool = param(False, 'restart from the start offset after the end')
    delay_s: float = param(0.0, 'wall time waited before each pass', unit='s', low=0.0)
    topics: tuple[str, ...] = param((), 'topics to play; empty = all')
    exclude_regex: str = param('', 'topics fully matching this regex are not played; '
                               "'' = none")
    remap: tuple[str, ...] = param((), "topic remappings 'old:=new'")


@dataclass(frozen=True, slots=True)
class ScheduledMessage:
    """One publication planned by :meth:`PlaybackSchedule.plan`.

    Attributes
    ----------
    index : int
        Position of the message in the sequence given to ``plan``.
    topic : str
        Topic to publish on (after remapping).
    source_topic : str
        Topic in the bag.
    stamp_ns : int
        Bag time of the message, ns.
    delay_ns : int
        Wall time from the playback start until publication, ns.
    loop : int
        Pass number, 0 for the first.
    """

    index: int
    topic: str
    source_topic: str
    stamp_ns: int
    delay_ns: int
    loop: int


def parse_remaps(remaps: Sequence[str]) -> dict[str, str]:
    """Parse ``'old:=new'`` strings into ``{old: new}``.

    Raises
    ------
    ConfigError
        For a missing ``:=``, an invalid topic name on either side, or ``old`` given twice.
    """
    out: dict[str, str] = {}
    for rule in remaps:
        old, sep, new = rule.partition(':=')
        if not sep or not _TOPIC.fullmatch(old) or not _TOPIC.fullmatch(new):
            msg = f"`remap` entry {rule!r} must be 'old:=new' with two valid topic names"
            raise ConfigError(msg)
        if old in out:
            msg = f'`remap` maps {old!r} twice ({out[old]!r} and {new!r})'
            raise ConfigError(msg)
        out[old] = new
    return out


def compile_exclude(pattern: str) -> re.Pattern[str] | None:
    """The compiled topic-exclusion regex (None when empty); ConfigError when invalid."""
    if not pattern:
        return None
    try:
        return re.compile(pattern)
    except re.error as err:
        msg = f'`exclude_regex` {pattern!r} is not a valid regular expression: {err}'
        raise ConfigError(msg) from err


class PlaybackSchedule:
    """Timing and topic mapping of one playback of a bag (formulas: module docstring).

    Parameters
    ----------
    config : PlaybackConfig
    bag_start_ns : int
        Stamp of the bag's first message, ns.
    bag_end_ns : int
        Stamp of the bag's last message + 1, ns (``BagReader.end_ns``).

    Attributes
    ----------
    window_ns : tuple of (int, int or None)
        Bag-time window ``[start_ns, stop_ns)`` to read (``BagReader.messages(start_ns=...,
        stop_ns=...)``); ``stop_ns`` None = to the end.
    pass_ns : int
        Wall time of one pass, pre-roll delay included, ns.
    remaps : dict of str to str
        Parsed ``config.remap``.

    Raises
    ------
    ConfigError
        For an invalid config field, or a start offset at or past the bag's end.
    """

    def __init__(self, config: PlaybackConfig, bag_start_ns: int, bag_end_ns: int) -> None:
        validate(config)
        self.config = config
        self.remaps = parse_remaps(config.remap)
        self._exclude = compile_exclude(config.exclude_regex)
        start = bag_start_ns + round(config.start_offset_s * NS_PER_S)
        if start >= bag_end_ns:
            msg = (f'`start_offset_s` {config.start_offset_s} s is past the end of the bag '
                   f'({(bag_end_ns - bag_start_ns) / NS_PER_S:.3f} s long)')
            raise ConfigError(msg)
        stop = None if config.duration_s < 0 else start + round(config.duration_s * NS_PER_S)
        self.window_ns: tuple[int, int | None] = (start, stop)
        span_ns = (bag_end_ns if stop is None else min(stop, bag_end_ns)) - start
        self.pass_ns = round(config.delay_s * NS_PER_S) + round(span_ns / config.rate)

    def selects(self, topic: str) -> bool:
        """True if ``topic`` (a bag topic) is played."""
        if self.config.topics and topic not in self.config.topics:
            return False
        return self._exclude is None or self._exclude.fullmatch(topic) is None

    def select_topics(self, bag_topics: Iterable[str]) -> list[str]:
        """The bag topics to play, in the given order; warns about requested absent ones."""
        bag_topics = list(bag_topics)
        if missing := sorted(set(self.config.topics) - set(bag_topics)):
            logger.warning('requested topics not in the bag: %s', ', '.join(missing))
        return [t for t in bag_topics if self.selects(t)]

    def output_topic(self, topic: str) -> str:
        """The topic a bag topic is published on, after remapping."""
        return self.remaps.get(topic, topic)

    def in_window(self, stamp_ns: int) -> bool:
        """True if a message stamped ``stamp_ns`` is inside the playback window."""
        start, stop = self.window_ns
        return start <= stamp_ns and (stop is None or stamp_ns < stop)

    def delay_ns(self, stamp_ns: int, loop: int = 0) -> int:
        """Wall time from the playback start until the message is published, ns."""
        offset = round((stamp_ns - self.window_ns[0]) / self.config.rate)
        return loop * self.pass_ns + round(self.config.delay_s * NS_PER_S) + offset

    def plan(self, messages: Sequence[tuple[str, int]]) -> Iterator[ScheduledMessage]:
        """Yield the publications of ``messages`` ((topic, stamp_ns) in bag-time order).

        Endless when ``config.loop`` is set and at least one message is selected.
        """
        chosen = [(i, topic, stamp) for i, (topic, stamp) in enumerate(messages)
                  if self.in_window(stamp) and self.selects(topic)]
        passes = itertools.count() if self.config.loop and chosen else range(1)
        for loop in passes:
            for i, topic, stamp in chosen:
                yield ScheduledMessage(index=i, topic=self.output_topic(topic),
                                       source_topic=topic, stamp_ns=stamp,
                                       delay_ns=self.delay_ns(stamp, loop), loop=loop)
