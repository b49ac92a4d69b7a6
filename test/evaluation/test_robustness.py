"""The robustness suite: episode and LOST scoring, and one short case end to end."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.evaluation.robustness import CaseRun, episodes, run_suite, scores, table


def test_episodes_run_from_over_15_mm_to_back_under_10_mm() -> None:
    errors = np.array([2, 16, 40, 12, 9, 3, 20, 11, 14, 31])
    assert episodes(errors) == [3, None]            # frames 1-3 recover at 4; 6- still open
    assert episodes(np.array([1.0, 2.0])) == []


def test_scores_count_lost_recall_and_false_alarms() -> None:
    run = CaseRun('random 300', 0, np.array([5.0, 5.0, 35.0, 40.0, 20.0, 5.0]),
                  np.array([False, True, True, False, True, False]), np.full(6, 0.05))
    s = scores([run])
    assert s['lost_recall'] == 0.5 and s['lost_false'] == pytest.approx(1 / 3)
    assert s['over_15mm'] == pytest.approx(0.5) and s['max_mm'] == 40.0
    assert s['episodes'] == 1 and s['recovery_median'] == 3 and s['ms_median'] == 50.0
    assert '| random 300 | 0 | 6 |' in table({'random 300': [run]})


@pytest.mark.slow
def test_a_short_case_runs_with_the_automatic_start() -> None:
    results = run_suite(['2 cameras'], [5], frames=4, workers=1)
    run, = results['2 cameras']
    assert run.errors_mm.shape == run.lost.shape == (4,)
    assert np.all(np.isfinite(run.errors_mm)) and run.errors_mm.max() < 100.0
    assert '| 2 cameras | 5 | 4 |' in table(results)
