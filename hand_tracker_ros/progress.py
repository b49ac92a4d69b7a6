"""Progress bars for long command-line work (tqdm), shown only on a terminal.

A bar goes to stderr and is drawn only when both stdout and stderr are terminals, so logs,
pipes, CI and tests get no control characters; tqdm's own ``TQDM_DISABLE=1`` turns it off
everywhere.
"""
from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

from tqdm import tqdm

T = TypeVar('T')


def on_terminal() -> bool:
    """True when stdout and stderr are both terminals."""
    return sys.stdout.isatty() and sys.stderr.isatty()


def progress(items: Iterable[T], *, total: int | None, desc: str, unit: str) -> Iterator[T]:
    """``items``, with a progress bar of ``total`` ``unit`` labelled ``desc`` on a terminal."""
    yield from tqdm(items, total=total, desc=desc, unit=unit, disable=not on_terminal(),
                    leave=False, dynamic_ncols=True)
