"""The README's features figure: one synthetic camera frame, its features and detected tips.

Left: the frame with the edges (green), the detected fingertips (magenta circles, radius 8 px,
the bench's match radius) and the true visible tips (yellow crosses); middle: the optical flow
from the previous frame (colour wheel, ``vision/visualize.py``; full brightness at the largest
flow on the hand); right: the foreground mask.

Usage: python bench/figure_features.py [--motion tapping] [--frame 60] [--camera 0]
       [--out docs/images/features_cam0_tapping_f60.png]
"""
from __future__ import annotations

import argparse

import cv2
import numpy as np

from hand_tracker_ros.render.fingertips import cap_slack_m, visible_fingertips
from hand_tracker_ros.render.rasterizer import render
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.vision.detector.detector import FingertipDetector
from hand_tracker_ros.vision.features import FeatureExtractor, FeaturesConfig
from hand_tracker_ros.vision.visualize import edge_image, flow_image, flow_to_rgb, mask_image


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--motion', default='tapping')
    parser.add_argument('--frame', type=int, default=60)
    parser.add_argument('--camera', type=int, default=0)
    parser.add_argument('--out', default='docs/images/features_cam0_tapping_f60.png')
    args = parser.parse_args()
    sequence = SyntheticSequence(SynthConfig(motion=args.motion, n_frames=args.frame + 1))
    camera = sequence.rig.cameras[args.camera]
    extractor = FeatureExtractor(camera.name, FeaturesConfig())
    previous, current = (sequence.frame(k) for k in (args.frame - 1, args.frame))
    extractor.process(previous.images[args.camera], previous.stamp_ns)
    image = current.images[args.camera]
    features = extractor.process(image, current.stamp_ns)
    detections = FingertipDetector.load().detect(image)

    posed = sequence.model.pose(current.theta, jacobian=False)
    raster = render(camera, posed.vertices_m, sequence.model.faces)
    tips = posed.fingertip_vertex_ids
    visible = visible_fingertips(raster, tips, cap_slack_m(sequence.model))

    left = image.copy()
    left[edge_image(features.edges) > 0] = (40, 230, 40)
    for u, v in detections.uv_px:
        cv2.circle(left, (round(u), round(v)), 8, (230, 40, 230), 2, cv2.LINE_AA)
    for (u, v), seen in zip(raster.uv_px[tips], visible):
        if seen:
            cv2.drawMarker(left, (round(u), round(v)), (255, 240, 0), cv2.MARKER_CROSS, 7, 1)
    flow_px = flow_image(features.flow)
    on_hand = np.linalg.norm(flow_px[features.mask], axis=1)   # full brightness: hand motion
    flow = flow_to_rgb(flow_px, float(np.nanmax(on_hand, initial=1e-3)))
    mask = np.repeat(mask_image(features.mask)[..., None], 3, axis=2)
    cv2.imwrite(args.out, cv2.cvtColor(np.hstack([left, flow, mask]), cv2.COLOR_RGB2BGR))
    print(f'wrote {args.out}: {len(detections.score)} detections, {int(visible.sum())} '
          f'visible tips')


if __name__ == '__main__':
    main()
