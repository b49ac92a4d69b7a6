"""`hand-tracker robustness`: random motion under harder conditions, automatic start.

Runs the cases of :data:`hand_tracker_ros.evaluation.robustness.CASES` (random motion,
300 and 600 frames, 15 fps, 2 cameras, image noise 12, clutter 40) over ``--seeds`` with
the product's own tracking policy and prints one table (mean, p95, max error, frames over
15 mm, LOST recall and false alarms, failure episodes and their recovery). Writes
``robustness.md`` and ``robustness.json`` (per-frame series) to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from hand_tracker_ros.evaluation.robustness import CASES, run_suite, scores, table


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('robustness', help='run the robustness suite (auto start)',
                            description=__doc__)
    parser.add_argument('--out', default='out/robustness', help='output directory')
    parser.add_argument('--cases', nargs='+', default=list(CASES), choices=list(CASES))
    parser.add_argument('--seeds', nargs='+', type=int, default=[100, 101],
                        help='synthetic seeds (default 100 101; the tests use none of them)')
    parser.add_argument('--frames', type=int, help="override every case's length")
    parser.add_argument('--workers', type=int, default=2, help='processes (default 2)')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run the suite, print and write the table."""
    start = time.monotonic()
    results = run_suite(args.cases, args.seeds, frames=args.frames, workers=args.workers)
    text = table(results)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / 'robustness.md').write_text(text + '\n')
    series = {case: {'scores': scores(runs),
                     'runs': [{'seed': r.seed, 'errors_mm': r.errors_mm.tolist(),
                               'lost': r.lost.tolist(), 'seconds': r.seconds.tolist()}
                              for r in runs]}
              for case, runs in results.items()}
    (out / 'robustness.json').write_text(json.dumps(series))
    print(text)
    print(f'wrote {out}/robustness.{{md,json}} in {time.monotonic() - start:.0f} s')
    return 0
