from __future__ import annotations

import itertools
import logging

import pytest

from hand_tracker_ros.bags.playback import PlaybackConfig, PlaybackSchedule, parse_remaps
from hand_tracker_ros.errors import ConfigError

S = 1_000_000_000
T0 = 1_700_000_000 * S
# 3 s bag: images at 0, 1, 2 s, camera_info at 0.5, 1.5, 2.5 s, last stamp 2.5 s.
MESSAGES = [(topic, T0 + k * S + (S // 2 if topic.endswith('info') else 0))
            for k in range(3) for topic in ('/cam0/image_raw', '/cam0/camera_info')]
END = T0 + 5 * S // 2 + 1


def _schedule(**kwargs):
    return PlaybackSchedule(PlaybackConfig(**kwargs), T0, END)


def test_rate_one_reproduces_bag_timing():
    plan = list(_schedule().plan(MESSAGES))
    assert [p.delay_ns for p in plan] == [s - T0 for _, s in MESSAGES]
    assert [p.index for p in plan] == list(range(6)) and {p.loop for p in plan} == {0}


def test_rate_scales_delays():
    plan = list(_schedule(rate=2.0).plan(MESSAGES))
    assert [p.delay_ns for p in plan] == [(s - T0) // 2 for _, s in MESSAGES]


def test_start_offset_and_duration_select_a_window():
    schedule = _schedule(start_offset_s=0.75, duration_s=1.0)
    assert schedule.window_ns == (T0 + 3 * S // 4, T0 + 7 * S // 4)
    plan = list(schedule.plan(MESSAGES))
    assert [(p.stamp_ns - T0, p.delay_ns) for p in plan] == [(S, S // 4), (3 * S // 2, 3 * S // 4)]


def test_delay_applies_before_each_pass_and_loop_repeats():
    schedule = _schedule(loop=True, delay_s=0.5, rate=2.0)
    assert schedule.pass_ns == S // 2 + (5 * S // 2 + 1) // 2
    plan = list(itertools.islice(schedule.plan(MESSAGES), 14))
    assert [p.loop for p in plan] == [0] * 6 + [1] * 6 + [2] * 2
    first, second = plan[0].delay_ns, plan[6].delay_ns
    assert first == S // 2 and second == first + schedule.pass_ns
    assert all(b.delay_ns >= a.delay_ns for a, b in itertools.pairwise(plan))


def test_loop_with_nothing_selected_ends():
    assert list(_schedule(loop=True, topics=('/absent',)).plan(MESSAGES)) == []


def test_topic_include_exclude_and_remap():
    schedule = _schedule(topics=('/cam0/image_raw', '/cam0/camera_info'),
                         exclude_regex='.*info', remap=('/cam0/image_raw:=/left/image',))
    plan = list(schedule.plan(MESSAGES))
    assert {(p.source_topic, p.topic) for p in plan} == {('/cam0/image_raw', '/left/image')}
    assert len(plan) == 3


def test_exclude_regex_must_match_the_whole_name():
    schedule = _schedule(exclude_regex='info')
    assert schedule.select_topics(['/cam0/image_raw', '/cam0/camera_info']) == [
        '/cam0/image_raw', '/cam0/camera_info']


def test_select_topics_warns_about_absent_requested_topics(caplog):
    with caplog.at_level(logging.WARNING):
        chosen = _schedule(topics=('/cam0/image_raw', '/cam9/image_raw')).select_topics(
            ['/cam0/image_raw', '/cam0/camera_info'])
    assert chosen == ['/cam0/image_raw'] and '/cam9/image_raw' in caplog.text


def test_parse_remaps():
    assert parse_remaps(['/a:=/b', 'c/d:=/e_1']) == {'/a': '/b', 'c/d': '/e_1'}


@pytest.mark.parametrize('rule', ['/a=/b', '/a:=', ':=/b', '/a:=/b c', '/1a:=/b', '/a//b:=/c'])
def test_bad_remap_syntax(rule):
    with pytest.raises(ConfigError, match=r"'old:=new'"):
        parse_remaps([rule])


def test_remapping_a_topic_twice_is_an_error():
    with pytest.raises(ConfigError, match='twice'):
        parse_remaps(['/a:=/b', '/a:=/c'])


@pytest.mark.parametrize(('kwargs', 'match'), [
    ({'rate': 0.0}, '`rate` must be in'),
    ({'start_offset_s': -1.0}, '`start_offset_s`'),
    ({'start_offset_s': 3.0}, 'past the end of the bag'),
    ({'exclude_regex': '(unclosed'}, 'not a valid regular expression'),
])
def test_invalid_config(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        _schedule(**kwargs)
