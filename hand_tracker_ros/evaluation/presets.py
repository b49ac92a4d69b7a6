"""The configurations of the ablation (Ballan et al., Table 1 and supplementary Figs. 1-2).

Every configuration tracks with the same pipeline and differs only in its energy terms or
solver. ``LO`` is the local optimizer: warm-started box-constrained Levenberg-Marquardt with the
temporal prior T (a regulariser of the optimizer, present in every LO row, so the rows differ
exactly by the data terms the paper ablates). Joint limits are hard bounds in every row; the
full method adds the joint-limit energy L and the 3D silhouette term Sil of the second seed
(docs/references.md).

=========  =========================================================
name       terms
=========  =========================================================
LO+E       edges
LO+EC      edges, collision
LO+ECO     edges, collision, optical flow
LO+ECOS    edges, collision, optical flow, salient points
full       LO+ECOS + joint limits L + silhouette Sil
PSO        the full objective minimised by HOPE's PSO instead of LM with 16 particles x 5
           generations: at least the LM method's time budget (measured: about twice its
           time per frame)
PSO-64x25  the same at the budget of HOPE's released tracker (64 x 25), about 18 times
           the LM method's time per frame
=========  =========================================================

C is the cone distance field with its volume backstop (``collision`` and ``volume``), and
every row with C ends a frame with the separation rounds (``tracker.separation``). PSO has
no separation rounds: it minimises the objective as it is.

At the 16 x 5 budget the swarm, scattered with HOPE's spreads (10 mm, 0.1 rad) around
the previous estimate, found no particle better than that estimate (particle 0) in the frames
we checked, so that row measures holding the previous pose; at HOPE's budget it moves.
"""
from __future__ import annotations

from typing import Any

from hand_tracker_ros.config import flatten, from_mapping
from hand_tracker_ros.energies.registry import NAMES as TERMS
from hand_tracker_ros.energies.registry import ablation_terms
from hand_tracker_ros.pipeline.offline import PipelineConfig

# The rows name their data terms by the registry's keys (``energies/registry.py``).
ABLATION = {
    **{f'LO+{letters}': ablation_terms(letters) for letters in ('E', 'EC', 'ECO', 'ECOS')},
    'full': TERMS,
}
# PSO gets no less time than the full LM method: 16 x 5 objective evaluations of ~2 ms plus one
# correspondence search per generation (measured: ~186 against ~93 ms per frame); and HOPE's.
PSO_BUDGETS = {'PSO': {'tracker.pso.particles': 16, 'tracker.pso.generations': 5},
               'PSO-64x25': {'tracker.pso.particles': 64, 'tracker.pso.generations': 25}}


def preset(name: str, base: PipelineConfig, overrides: dict[str, Any] | None = None
           ) -> PipelineConfig:
    """The pipeline config of ablation row ``name`` on top of ``base``."""
    values = flatten(base)
    if name in PSO_BUDGETS:
        values.update({**PSO_BUDGETS[name], 'tracker.solver': 'pso'})
        enabled = TERMS
    else:
        enabled = ABLATION[name]
    values.update({f'tracker.terms.{t}.enabled': t in enabled for t in TERMS})
    values['auto_initialize'] = False   # the runner re-initialises from ground truth
    values.update(overrides or {})
    return from_mapping(PipelineConfig, values)


NAMES = (*ABLATION, *PSO_BUDGETS)
