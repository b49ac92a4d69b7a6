"""Live graph throughput: a 4-camera synthetic bag played in real time through the graph.

Usage: python bench/bench_live_graph.py [--frames 120] [--width 320 --height 240] [--rate 1.0]
Prints the estimates per second the tracker published, the share of input sets it processed
(it always takes the newest set and skips what it cannot keep up with), its per-set
processing time (HandState.processing_time: receipt of the set to the estimate), the
end-to-end latency (input stamp to the recorder's receipt, in sim time scaled back to wall
time by the playback rate) and the peak resident memory of the tracker process.
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import threading
from pathlib import Path

from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.evaluation.replay import replay
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import write_sequence


def _rss_mb(name: str) -> float:
    """Largest VmRSS (MiB) of the running processes whose command line ends with ``name``."""
    best = 0.0
    for status in Path('/proc').glob('[0-9]*/status'):
        try:
            cmd = (status.parent / 'cmdline').read_bytes().split(b'\0')
            if any(part.endswith(name.encode()) for part in cmd[:2]):
                for line in status.read_text().splitlines():
                    if line.startswith('VmRSS'):
                        best = max(best, int(line.split()[1]) / 1024)
        except OSError:
            continue
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--frames', type=int, default=120)
    parser.add_argument('--width', type=int, default=320)
    parser.add_argument('--height', type=int, default=240)
    parser.add_argument('--rate', type=float, default=1.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bag = write_sequence(SyntheticSequence(SynthConfig(
            motion='random', n_frames=args.frames, width=args.width, height=args.height)),
            Path(tmp) / 'synthetic')
        samples: list[float] = []
        done = threading.Event()

        def sample() -> None:
            while not done.wait(0.5):
                samples.append(_rss_mb('/tracker'))
        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        outcome = replay(bag, Path(tmp) / 'replay', rate=args.rate)
        done.set()
        with BagReader(outcome.recorded_bag) as reader:
            stamps = [(s, recv) for _, _, recv, m in reader.decoded(topics=['/hand_state'])
                      for s in [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec]]
    duration_s = args.frames / 30.0 / args.rate
    processing = [1e3 * st.processing_time_s for st in outcome.states.values()]
    latency = [(recv - stamp) / 1e6 / args.rate for stamp, recv in stamps]
    print(f'4 x {args.width}x{args.height}, {args.frames} frames at rate {args.rate}: '
          f'{len(outcome.states) / duration_s:.1f} estimates/s, '
          f'{100 * len(outcome.states) / outcome.input_sets:.0f} % of the input sets')
    print(f'  tracker per set: median {statistics.median(processing):.0f} ms '
          f'(min {min(processing):.0f}, max {max(processing):.0f})')
    print(f'  latency input stamp -> recorded estimate: median {statistics.median(latency):.0f}'
          f' ms (max {max(latency):.0f})')
    live = [s for s in samples if s > 0]
    if live:
        print(f'  tracker resident memory: first {live[0]:.0f} MiB, peak {max(live):.0f} MiB, '
              f'last {live[-1]:.0f} MiB ({len(live)} samples)')
    if outcome.scores is not None:
        print(f'  mean 3D joint error {outcome.scores.joint_mean_mm:.2f} mm')


if __name__ == '__main__':
    main()
