"""The live graph in real time: composed and distributed, at three rig sizes.

Usage: python bench/bench_live_graph.py [--frames 150] [--rate 1.0] [--seed 5]
       [--motion random] [--configs 4x320x240 4x640x480 8x320x240]
       [--modes composed distributed]

For each rig size a synthetic bag of hand motion (``--motion``, ``--seed``) is played through the
graph (``hand-tracker replay-eval``'s :func:`~hand_tracker_ros.evaluation.replay.replay`,
started at the ground-truth first pose, 30 Hz input) in each mode, and one table row is
printed: estimates per second (HandState messages per second of playback), the share of the
input sets estimated and tracked, the latency from the input stamp to the recorded estimate
(p50, p95; the recorder's receive time in sim time, scaled back by the rate), the mean 3D
joint error, each process's CPU share while the player runs (CPU seconds per wall second;
2.0 = both cores) and its peak resident memory (``VmHWM``).
"""
from __future__ import annotations

import argparse
import os
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from hand_tracker_ros.evaluation.replay import replay
from hand_tracker_ros.launcher import TRACKING_PROCESSES
from hand_tracker_ros.synthetic.motions import ALL_MOTIONS
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import write_sequence

TICK_S = 1.0 / os.sysconf('SC_CLK_TCK')


def _processes(names: tuple[str, ...]) -> dict[str, tuple[float, float]]:
    """Executable name -> (CPU s, peak RSS MiB) of the running node processes."""
    found = {}
    for stat in Path('/proc').glob('[0-9]*/stat'):
        try:
            cmd = (stat.parent / 'cmdline').read_bytes().split(b'\0')
            name = next((n for n in names if any(p.endswith(f'/{n}'.encode())
                                                 for p in cmd[:2])), None)
            if name is None:
                continue
            fields = stat.read_text().rsplit(')', 1)[1].split()
            cpu_s = (int(fields[11]) + int(fields[12])) * TICK_S
            hwm = next(int(line.split()[1]) / 1024 for line
                       in (stat.parent / 'status').read_text().splitlines()
                       if line.startswith('VmHWM'))
            found[name] = (cpu_s, hwm)
        except (OSError, StopIteration, ValueError, IndexError):
            continue
    return found


class Sampler:
    """Polls the node processes' CPU time and peak memory while the bag plays."""

    def __init__(self, names: tuple[str, ...]) -> None:
        self.names = names
        self.first: dict[str, tuple[float, float]] = {}
        self.last: dict[str, tuple[float, float]] = {}
        self.t0 = self.t1 = 0.0
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> None:
        """Called when the player starts: the baseline."""
        self.t0, self.first = time.monotonic(), _processes(self.names)
        self._thread.start()

    def _run(self) -> None:
        # While the player runs: the shares are of the playback, not of the drain after it.
        while not self._done.wait(0.25):
            now = _processes(self.names)
            if 'player' in now:
                self.t1, self.last = time.monotonic(), {**self.last, **now}

    def stop(self) -> None:
        self._done.set()

    def row(self) -> str:
        """``name cpu% / MiB`` per process."""
        wall = max(self.t1 - self.t0, 1e-9)
        return ', '.join(f'{n} {(self.last[n][0] - self.first.get(n, (0.0,))[0]) / wall:.2f} '
                         f'CPU / {self.last[n][1]:.0f} MiB' for n in self.names if n in self.last)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--frames', type=int, default=150)
    parser.add_argument('--rate', type=float, default=1.0)
    parser.add_argument('--seed', type=int, default=5)
    parser.add_argument('--motion', default='random', choices=ALL_MOTIONS,
                        help='a smooth one (grasp) keeps the tracker on the hand, so that the '
                             'rows compare the graph rather than where the hand was lost')
    parser.add_argument('--configs', nargs='+', default=['4x320x240', '4x640x480', '8x320x240'])
    parser.add_argument('--modes', nargs='+', default=['composed', 'distributed'])
    args = parser.parse_args()
    print('| rig | mode | estimates/s | sets estimated | tracked | latency p50 / p95 (ms) | '
          'error (mm) | CPU share / peak memory per process |')
    print('|---|---|---|---|---|---|---|---|')
    for config in args.configs:
        cams, width, height = (int(v) for v in config.split('x'))
        with tempfile.TemporaryDirectory() as tmp:
            bag = write_sequence(SyntheticSequence(SynthConfig(
                motion=args.motion, n_frames=args.frames, n_cameras=cams, width=width,
                height=height, seed=args.seed)), Path(tmp) / 'synthetic')
            for mode in args.modes:
                sampler = Sampler((*TRACKING_PROCESSES[mode], 'player', 'recorder'))
                outcome = replay(bag, Path(tmp) / f'replay_{mode}', rate=args.rate,
                                 mode=mode, on_started=sampler.start)
                sampler.stop()
                lat = outcome.latencies_ms
                error = (f'{outcome.scores.joint_mean_mm:.1f}' if outcome.scores is not None
                         else 'n/a')
                print(f'| {cams} x {width}x{height} | {mode} | {outcome.estimates_per_s:.1f} | '
                      f'{100 * len(outcome.states) / outcome.input_sets:.0f} % | '
                      f'{100 * outcome.tracked_share:.0f} % | '
                      f'{np.median(lat):.0f} / {np.percentile(lat, 95):.0f} | {error} | '
                      f'{sampler.row()} |', flush=True)


if __name__ == '__main__':
    main()
