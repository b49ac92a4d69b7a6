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
A process that creates its files at that very moment, before it locks them, could lose them
(the same race as that tool's); the launcher calls this before it starts its own processes.
"""
from __future__ import annotations

import fcntl
import os
import re
from collections import defaultdict
from pathlib import Path

SHM_DIR = Path('/dev/shm')
_LOCK_FILE = re.compile(r'^(fastdds_(?:[0-9a-z]{16}|port\d{1,5}))_(?:el|sl)$')


def _held(lock_file: Path) -> bool:
    """Whether a live process holds ``lock_file`` (True when it cannot be opened)."""
    try:
        with lock_file.open('rb') as handle:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    return False


def remove_stale_segments(shm_dir: Path = SHM_DIR) -> list[str]:
    """Remove the Fast DDS files in ``shm_dir`` whose every lock file is free; returns the
    names removed (none when the directory cannot be read)."""
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
        if any(_held(shm_dir / lock) for lock in lock_files):
            continue
        for name in (base, f'sem.{base}_mutex', *lock_files):
            if name in names:
                try:
                    (shm_dir / name).unlink()
                except OSError:
                    continue
                removed.append(name)
    return removed
