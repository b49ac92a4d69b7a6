"""Benchmark: forward kinematics, LBS, and LBS + vertex Jacobian of the hand model.

Prints median / min / max milliseconds per call over repeated batches after warm-up.
Target: skinning with Jacobian, including FK, <= 2 ms.
Run: ``python bench/bench_skinning.py``.
"""
from __future__ import annotations

import time

import numpy as np

from hand_tracker_ros.model import kinematics
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.skinning import skin, skin_with_jacobian

BATCHES = 9
MIN_BATCH_S = 0.15


def _time_ms(fn) -> tuple[float, float, float]:
    for _ in range(3):
        fn()
    per_call = []
    for _ in range(BATCHES):
        n, start = 0, time.perf_counter()
        while time.perf_counter() - start < MIN_BATCH_S:
            fn()
            n += 1
        per_call.append((time.perf_counter() - start) / n * 1e3)
    return float(np.median(per_call)), float(np.min(per_call)), float(np.max(per_call))


def main() -> None:
    start = time.perf_counter()
    model = HandModel.build()
    build_s = time.perf_counter() - start
    theta = model.neutral_theta(translation_m=(0.0, 0.0, 0.5))
    rest, rest_inv = model.rest, np.linalg.inv(model.rest_bone_transforms)
    verts, w_bones, w = model.rest_vertices_m, model.influence_bones, model.influence_weights

    def fk():
        return kinematics.forward_kinematics(rest, theta)

    def fk_lbs():
        f = fk()
        return skin(f.bone_transforms @ rest_inv, verts, w_bones, w)

    def fk_lbs_jac():
        f = fk()
        return skin_with_jacobian(f.bone_transforms @ rest_inv, verts, w_bones, w,
                                  model.bone_dofs, f.axes, f.pivots)

    print(f'model: V={len(verts)} F={len(model.faces)} B={len(model.part_names)} '
          f'P={model.layout.P}; build (incl. numba cache load) {build_s:.2f} s')
    for name, fn in (('FK', fk), ('FK + LBS', fk_lbs), ('FK + LBS + Jacobian', fk_lbs_jac),
                     ('HandModel.pose(jacobian=False)',
                      lambda: model.pose(theta, jacobian=False)),
                     ('HandModel.pose(jacobian=True)', lambda: model.pose(theta))):
        med, lo, hi = _time_ms(fn)
        print(f'{name:32s} median {med:7.3f} ms   min {lo:7.3f}   max {hi:7.3f}')


if __name__ == '__main__':
    main()
