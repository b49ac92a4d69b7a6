"""Stale Fast DDS shared memory (hand_tracker_ros.shm): a segment whose lock files no process
holds, and that are not fresh, is removed with them; held, fresh and other files stay."""
from __future__ import annotations

import fcntl
import os
import time

from hand_tracker_ros.shm import MIN_AGE_S, remove_stale_segments


def test_only_old_segments_with_free_locks_are_removed(tmp_path) -> None:
    gone = ['fastdds_0123456789abcdef', 'fastdds_0123456789abcdef_el']      # owner gone
    kept = ['fastdds_fedcba9876543210', 'fastdds_fedcba9876543210_el',      # owner alive
            'fastdds_00000000aaaaaaaa', 'fastdds_00000000aaaaaaaa_el',      # one lock held
            'fastdds_00000000aaaaaaaa_sl',
            'fastdds_11111111bbbbbbbb', 'fastdds_11111111bbbbbbbb_el',      # just created
            'fastdds_port7411', 'fastdds_port7411_el', 'sem.fastdds_port7411_mutex',  # a port
            'fastdds_deadbeefdeadbeef',                                    # no lock file
            'other_app_segment', 'fastdds_notalock_el']
    old = time.time() - 2 * MIN_AGE_S
    for name in gone + kept:
        (tmp_path / name).write_bytes(b'')
        if not name.startswith('fastdds_11111111'):
            os.utime(tmp_path / name, (old, old))
    with (tmp_path / 'fastdds_fedcba9876543210_el').open('rb') as live, \
            (tmp_path / 'fastdds_00000000aaaaaaaa_sl').open('rb') as shared:
        fcntl.flock(live, fcntl.LOCK_EX)
        fcntl.flock(shared, fcntl.LOCK_SH)
        removed = remove_stale_segments(tmp_path)
    assert sorted(removed) == sorted(gone)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(kept)


def test_a_missing_directory_removes_nothing(tmp_path) -> None:
    assert remove_stale_segments(tmp_path / 'absent') == []
