"""Benchmark the renderer per view: projection, raster + visibility, contours, shading.

Uses the hand model (``HandModel.build()``) at its neutral pose, centred at the origin, seen
by the 4 cameras of ``CameraRig.ring`` at 320x240 and 640x480. Prints the median (min, max)
over batches, in ms per view. Run: ``python bench/bench_render.py``.

The per-camera rows repeat one identical view, and the CPU's branch predictor learns the
raster kernel's per-triangle branches over the repeats; the "4 cameras in turn" row renders
another view each call, as the tracker does (every camera per round), and is the cost the
tracker pays: ``render()`` took 0.43 ms in turn against 0.23 ms on one repeated view at
320x240, 0.81 against 0.65 ms at 640x480 (2026-11-25).
"""
from __future__ import annotations

import itertools
import statistics
import time
from collections.abc import Callable

import numpy as np

from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.render.background import make_background
from hand_tracker_ros.render.contours import MeshEdges, contour_points, edge_image
from hand_tracker_ros.render.rasterizer import _rasterize, _visible, render
from hand_tracker_ros.render.shading import render_rgb

BATCHES = 7
BATCH_S = 0.15


def _time_ms(fn: Callable[[], object]) -> tuple[float, float, float]:
    """Median, min and max ms per call over BATCHES batches of about BATCH_S each."""
    fn()
    fn()
    start, calls = time.perf_counter(), 0
    while time.perf_counter() - start < BATCH_S / 3:
        fn()
        calls += 1
    reps = max(1, int(calls * 3))
    per_call = []
    for _ in range(BATCHES):
        t0 = time.perf_counter()
        for _ in range(reps):
            fn()
        per_call.append((time.perf_counter() - t0) / reps * 1e3)
    return statistics.median(per_call), min(per_call), max(per_call)


def _row(name: str, figures: tuple[float, float, float]) -> str:
    return f'  {name:<34s} {figures[0]:7.3f}  ({figures[1]:.3f} - {figures[2]:.3f})'


def main() -> None:
    model = HandModel.build()
    posed = model.pose(model.neutral_theta(), jacobian=False)
    verts = posed.vertices_m - posed.vertices_m.mean(axis=0)
    faces = np.ascontiguousarray(model.faces, dtype=np.int64)
    edges = MeshEdges.from_faces(faces)
    print(f'hand mesh: {len(verts)} vertices, {len(faces)} triangles; ms per view, '
          f'median (min - max) of {BATCHES} batches')
    for width, height in ((320, 240), (640, 480)):
        for cam in CameraRig.ring(4, width, height).cameras[:2]:
            uv, z = cam.project(verts)
            result = render(cam, verts, faces)
            background = make_background(width, height, seed=0)
            print(f'{width}x{height} {cam.name}: {result.mask.sum()} hand pixels')
            print(_row('project (numpy, distortion)', _time_ms(lambda: cam.project(verts))))
            print(_row('raster kernel', _time_ms(
                lambda: _rasterize(uv, z, faces, width, height, 0.01, True, True))))
            print(_row('raster kernel, no triangle ids', _time_ms(
                lambda: _rasterize(uv, z, faces, width, height, 0.01, True, False))))
            zbuf, _ = _rasterize(uv, z, faces, width, height, 0.01, True, True)
            print(_row('visibility kernel', _time_ms(
                lambda: _visible(uv, z, zbuf, 0.01, np.full(len(z), 0.002)))))
            print(_row('render() = project+raster+visibility',
                       _time_ms(lambda: render(cam, verts, faces))))
            print(_row('contour_points', _time_ms(
                lambda: contour_points(cam, verts, edges, result))))
            print(_row('edge_image', _time_ms(lambda: edge_image(result))))
            print(_row('render_rgb (given raster)', _time_ms(lambda: render_rgb(
                cam, verts, faces, posed.vertex_normals, background, raster=result))))
        turn = itertools.cycle(CameraRig.ring(4, width, height).cameras)
        print(f'{width}x{height}, the 4 cameras in turn:')
        print(_row('render()', _time_ms(lambda: render(next(turn), verts, faces))))


if __name__ == '__main__':
    main()
