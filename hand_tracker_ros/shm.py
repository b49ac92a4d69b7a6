"""Fast DDS shared-memory files whose owners are gone, removed before a graph starts.

Fast DDS keeps each shared-memory segment and port in a file of ``/dev/shm``
(``fastdds_<16 hex>``, ``fastdds_port<N>`` with its semaphore ``sem.fastdds_port<N>_mutex``)
and, while the owning process lives, holds a ``flock`` on a companion lock file (``<name>_el``
or ``<name>_sl``). A killed process leaves them all behind: 35 MB per tracker process with the
shipped profile (``config/fastdds_large_data.xml``), so a small ``/dev/shm`` (64 MB in a
default Docker container) fills up after a few interrupted runs. Fast DDS's own ``fastdds shm
clean`` makes the same check, but it comes with the ``fastdds`` tool, which is not on PyPI:
a lock file that this process can lock exclusively has no live owner, and then the files of
its name go. A name with any lock still held, or a lock file this user cannot open, is kept.
Only segments are removed, not ports (52 kB each, reopened under fixed names, and Fast DDS
recovers a dead process's port itself), and only when their lock files are older than
``MIN_AGE_S``: a process starting at that moment takes its locks in steps (an exclusive lock
turned shared), and our brief exclusive lock could make its own attempt fail.
"""
from __future__ import annotations

import fcntl
import os
import re
import time
from collections import defaultdict
from pathlib import Path

SHM_DIR = Path('/dev/shm')
MIN_AGE_S = 10.0
_LOCK_FILE = re.compile(r'^(fastdds_[0-9a-z]{16})_(?:el|sl)$')


def _held(lock_file: Path, now_s: float) -> bool:
    """Whether a live process holds ``lock_file``, or may be about to (True when it is
    younger than ``MIN_AGE_S`` or cannot be opened)."""
    try:
        if now_s - lock_file.stat().st_mtime < MIN_AGE_S:
            return True
        with lock_file.open('rb') as handle:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    return False


def remove_stale_segments(shm_dir: Path = SHM_DIR) -> list[str]:
    """Remove the Fast DDS segments in ``shm_dir`` whose every lock file is free; returns
    the names removed (none when the directory cannot be read)."""
    now_s = time.time()
    try:
        names = set(os.listdir(shm_dir))
    except OSError:
        return []
    locks: dict[str, list[str]] = defaultdict(list)
    for name in names:
        match = _LOCK_FILE.match(name)
        if match is not None:
            locks[match.group(1)].append(name)
    removed = []
    for base, lock_files in sorted(locks.items()):
        if any(_held(shm_dir / lock, now_s) for lock in lock_files):
            continue
        for name in (base, *lock_files):
            if name in names:
                try:
                    (shm_dir / name).unlink()
                except OSError:
                    continue
                removed.append(name)
    return removed
