"""Tables (Markdown, JSON) and plots of evaluation results."""
from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hand_tracker_ros.evaluation.metrics import FAILURE_MM
from hand_tracker_ros.evaluation.runner import RunResult

COLUMNS = (('joint_mean_mm', 'mean 3D joint (mm)'), ('joint_median_mm', 'median (mm)'),
           ('joint_p95_mm', 'p95 (mm)'), ('joint_max_mm', 'max frame (mm)'),
           ('fingertip_mean_mm', 'fingertip (mm)'), ('reprojection_px', '2D reproj. (px)'),
           ('max_interpenetration_mm', 'max interpen. (mm)'), ('failures', 'failures'),
           ('ms_per_frame', 'ms/frame'))


def summarize(results: Sequence[RunResult]) -> dict[str, dict[str, float]]:
    """Per configuration: frame-weighted means over motions (max for max-type columns)."""
    by_label: dict[str, list[RunResult]] = defaultdict(list)
    for result in results:
        by_label[result.label].append(result)
    table = {}
    for label, runs in by_label.items():
        errors = np.concatenate([r.errors_mm for r in runs])
        frames = np.array([r.scores.frames for r in runs], float)
        row = {key: float(np.average([getattr(r.scores, key) for r in runs], weights=frames))
               for key, _ in COLUMNS}
        row.update(joint_mean_mm=float(errors.mean()), joint_median_mm=float(np.median(errors)),
                   joint_p95_mm=float(np.percentile(errors, 95)),
                   joint_max_mm=float(errors.max()),
                   max_interpenetration_mm=max(r.scores.max_interpenetration_mm for r in runs),
                   failures=float(sum(r.scores.failures for r in runs)),
                   ms_per_frame=float(np.median([r.scores.ms_per_frame for r in runs])))
        table[label] = row
    return table


def markdown_table(table: dict[str, dict[str, float]]) -> str:
    """The summary as a Markdown table."""
    lines = ['| configuration | ' + ' | '.join(title for _, title in COLUMNS) + ' |',
             '|---' * (len(COLUMNS) + 1) + '|']
    for label, row in table.items():
        cells = [f'{int(row[k])}' if k == 'failures' else f'{row[k]:.2f}' for k, _ in COLUMNS]
        lines.append(f'| {label} | ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines) + '\n'


def error_figure(results: Sequence[RunResult]) -> Any:
    """Error over frames, one panel per motion and one line per configuration, each
    configuration's LOST frames marked with crosses of its colour, the failure threshold
    dashed (a matplotlib Figure)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    motions = sorted({r.motion for r in results})
    fig, axes = plt.subplots(len(motions), 1, figsize=(9, 2.6 * len(motions)), squeeze=False)
    for ax, motion in zip(axes[:, 0], motions):
        for r in (r for r in results if r.motion == motion):
            frames = np.arange(1, r.errors_mm.size + 1)
            (line,) = ax.plot(frames, r.errors_mm, label=r.label, lw=1)
            lost = np.asarray(r.lost, dtype=bool)
            ax.plot(frames[lost], r.errors_mm[lost], 'x', ms=4, color=line.get_color())
        ax.axhline(FAILURE_MM, ls='--', lw=0.8, color='gray')
        ax.set_title(motion)
        ax.set_ylabel('joint error (mm)')
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel('frame')
    handles, labels = axes[0, 0].get_legend_handles_labels()
    handles += [Line2D([], [], marker='x', ls='', color='k'),
                Line2D([], [], ls='--', lw=0.8, color='gray')]
    labels += ['reported LOST', f'failure threshold ({FAILURE_MM:g} mm)']
    axes[0, 0].legend(handles, labels, fontsize=7, ncol=3)
    fig.tight_layout()
    return fig


def write_report(results: Sequence[RunResult], out_dir: Path, name: str) -> str:
    """Write ``name``.md, ``name``.json and ``name``_error.png (:func:`error_figure`); return
    the Markdown."""
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    table = summarize(results)
    text = markdown_table(table)
    (out_dir / f'{name}.md').write_text(text)
    per_run = [{'configuration': r.label, 'motion': r.motion, **r.scores.as_dict()}
               for r in results]
    (out_dir / f'{name}.json').write_text(json.dumps({'summary': table, 'runs': per_run},
                                                     indent=2))
    fig = error_figure(results)
    fig.savefig(out_dir / f'{name}_error.png', dpi=110)
    plt.close(fig)
    return text
