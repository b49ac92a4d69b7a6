"""Stale Fast DDS shared memory (hand_tracker_ros.shm): files whose lock no process holds are
removed with their segment and semaphore; held ones and other files stay."""
from __future__ import annotations

import fcntl

from hand_tracker_ros.shm import remove_stale_segments


def test_only_the_files_of_free_locks_are_removed(tmp_path) -> None:
    names = ['fastdds_0123456789abcdef', 'fastdds_0123456789abcdef_el',     # owner gone
             'fastdds_port7411', 'fastdds_port7411_el', 'sem.fastdds_port7411_mutex',
             'fastdds_fedcba9876543210', 'fastdds_fedcba9876543210_el',     # owner alive
             'fastdds_port7000', 'fastdds_port7000_el', 'fastdds_port7000_sl',
             'sem.fastdds_port7000_mutex',                                  # one lock held
             'fastdds_deadbeefdeadbeef',                                    # no lock file
             'other_app_segment', 'fastdds_notalock_el']
    for name in names:
        (tmp_path / name).write_bytes(b'')
    with (tmp_path / 'fastdds_fedcba9876543210_el').open('rb') as live, \
            (tmp_path / 'fastdds_port7000_sl').open('rb') as shared:
        fcntl.flock(live, fcntl.LOCK_EX)
        fcntl.flock(shared, fcntl.LOCK_SH)
        removed = remove_stale_segments(tmp_path)
    assert sorted(removed) == sorted(names[:5])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names[5:])


def test_a_missing_directory_removes_nothing(tmp_path) -> None:
    assert remove_stale_segments(tmp_path / 'absent') == []
