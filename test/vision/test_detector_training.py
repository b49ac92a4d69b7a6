from __future__ import annotations

import argparse

import numpy as np
import pytest

SKIP = 'a training requirement, not in the default install (HT_TRAIN=1 bash tools/setup.sh)'
torch = pytest.importorskip('torch', reason=f'PyTorch is {SKIP}')
pytest.importorskip('onnx', reason=f'ONNX is {SKIP}')

# Imported after the skips: network imports torch.
from hand_tracker_ros.cli import train_detector  # noqa: E402
from hand_tracker_ros.errors import ConfigError  # noqa: E402
from hand_tracker_ros.vision.detector.augment import (  # noqa: E402
    AugmentationConfig,
    plain_background,
    recolour_skin,
    scaled_crop,
)
from hand_tracker_ros.vision.detector.model import DetectorModel  # noqa: E402
from hand_tracker_ros.vision.detector.network import (  # noqa: E402
    ExportedNetwork,
    TipNetwork,
    load_onnx_weights,
)
from hand_tracker_ros.vision.detector.training import (  # noqa: E402
    TrainingConfig,
    augment,
    export_onnx,
    targets,
    train,
)

# Seconds, not minutes: few small views, a narrow network.
TINY = TrainingConfig(n_views=6, epochs=2, batch_size=3, stem_channels=4, channels=8,
                      dilations=(1, 2), threads=1)


def test_targets_peak_at_visible_tips_and_ignore_hidden_ones():
    uv = np.array([[[13.0, 9.0], [40.0, 20.0], [np.nan, np.nan], [0.0, 0.0], [0.0, 0.0]]])
    visible = np.array([[True, False, False, False, False]])
    heat, weight, cells, offsets = targets(uv, visible, (8, 12), sigma_cells=1.0)
    assert heat.shape == weight.shape == (1, 8, 12)
    np.testing.assert_array_equal(np.argwhere(heat[0] == 1.0), [[2, 3]])   # (row, col)
    np.testing.assert_allclose(offsets[0, 0], [13 / 4 - 3, 9 / 4 - 2])
    assert heat[0, 2, 4] == pytest.approx(np.exp(-0.5))
    assert weight[0, 5, 10] == 0.0 and weight[0, 5, 7] == 1.0      # 2 / 3 cells from a hidden tip
    assert weight[0, 0, 0] == 0.0 and weight[0, 2, 3] == 1.0       # hidden (0, 0); the visible tip
    assert np.isnan(cells[0, 2]).all()


def test_augmented_crops_keep_each_tip_on_its_pixel():
    rng = np.random.default_rng(3)
    images = np.zeros((8, 60, 80, 3), np.uint8)
    uv = np.tile(np.array([[10.0, 12.0], [50.0, 40.0], [70.0, 5.0], [33.0, 33.0],
                           [np.nan, np.nan]]), (8, 1, 1))
    for k, (u, v) in enumerate(uv[0, :4]):
        images[:, int(v), int(u)] = 50 * (k + 1)
    # Scale 1 and no photometric changes: every tip pixel keeps its value.
    plain = AugmentationConfig(scale_range=(1.0, 1.0), skin_probability=0.0,
                               plain_background_probability=0.0, texture_probability=0.0,
                               photometric=False)
    cfg = TrainingConfig(crop_height=40, crop_width=48, hand_crop_fraction=0.5,
                         augmentation=plain)
    masks = np.zeros(images.shape[:3], bool)
    crops, moved, _ = augment(images, masks, uv, cfg, rng)
    assert crops.shape == (8, 40, 48, 3)
    for crop, tips in zip(crops, moved):
        for k, (u, v) in enumerate(tips[:4]):
            if 0 <= u < 48 and 0 <= v < 40:
                assert crop[int(v), int(u), 0] == 50 * (k + 1)
        assert np.isnan(tips[4]).all()


def test_scaled_crops_move_each_tip_with_its_pixel():
    image = np.zeros((60, 80, 3), np.uint8)
    uv = np.array([[20.0, 30.0], [61.0, 12.0], [40.0, 40.0], [5.0, 50.0], [np.nan, np.nan]])
    for k, (u, v) in enumerate(uv[:4]):
        image[int(v) - 1:int(v) + 2, int(u) - 1:int(u) + 2] = 60 * (k + 1)
    for scale in (0.5, 1.0, 2.0):
        crop, moved = scaled_crop(image, uv, scale, np.array([3.0, 2.0]), (48, 64))
        assert crop.shape == (48, 64, 3)
        np.testing.assert_allclose(moved[:4], scale * (uv[:4] - (3.0, 2.0)))
        assert np.isnan(moved[4]).all()
        for k, (u, v) in enumerate(moved[:4]):
            if 1 <= u < 63 and 1 <= v < 47:
                # The brightest pixel near the moved tip is the tip's (blurred when shrunk).
                patch = crop[int(round(v)) - 1:int(round(v)) + 2,
                             int(round(u)) - 1:int(round(u)) + 2, 0]
                assert patch.max() >= (30 if scale < 1 else 60) * (k + 1) - 1


def test_skin_and_background_change_only_their_pixels():
    rng = np.random.default_rng(4)
    image = rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)
    mask = np.zeros((30, 40), bool)
    mask[10:20, 5:25] = True
    dark = recolour_skin(image, mask, np.array([0.4, 0.35, 0.3]))
    np.testing.assert_array_equal(dark[~mask], image[~mask])
    np.testing.assert_array_equal(dark[mask], (image[mask] * [0.4, 0.35, 0.3]).astype(np.uint8))
    plain = plain_background(image, mask, rng)
    np.testing.assert_array_equal(plain[mask], image[mask])
    assert plain[~mask].std() < image[~mask].std() / 2


def test_an_exported_model_restarts_training_where_it_was():
    torch.manual_seed(3)
    network = ExportedNetwork(TipNetwork(4, 8, (1, 2)))
    for module in network.modules():
        if isinstance(module, torch.nn.BatchNorm2d):
            module.running_mean.uniform_(-0.5, 0.5)
            module.running_var.uniform_(0.5, 2.0)
            module.weight.data.uniform_(0.5, 1.5)
    exported = export_onnx(network)
    restarted = ExportedNetwork(TipNetwork(4, 8, (1, 2)))
    load_onnx_weights(restarted, exported)
    image = np.random.default_rng(5).integers(0, 256, (40, 56, 3), dtype=np.uint8)
    np.testing.assert_allclose(DetectorModel(export_onnx(restarted)).maps(image),
                               DetectorModel(exported).maps(image), rtol=1e-4, atol=1e-5)
    with pytest.raises(ValueError, match='do not match'):
        load_onnx_weights(ExportedNetwork(TipNetwork(4, 8, (1,))), exported)


def test_onnx_export_computes_what_torch_computes():
    torch.manual_seed(1)
    network = ExportedNetwork(TipNetwork(4, 8, (1, 2)))
    for module in network.modules():      # non-trivial batch-norm statistics to fold
        if isinstance(module, torch.nn.BatchNorm2d):
            module.running_mean.uniform_(-0.5, 0.5)
            module.running_var.uniform_(0.5, 2.0)
    model = DetectorModel(export_onnx(network))
    image = np.random.default_rng(2).integers(0, 256, (57, 90, 3), dtype=np.uint8)
    with torch.no_grad():
        expected = network.eval()(torch.from_numpy(image[None]))[0].numpy()
    np.testing.assert_allclose(model.maps(image), expected, rtol=1e-4, atol=1e-5)


@pytest.mark.slow
def test_training_is_deterministic(hand_model):
    a, b, c = (train(seed, TINY, model=hand_model) for seed in (5, 5, 6))
    assert a == b
    assert a != c
    image = np.full((48, 64, 3), 120, np.uint8)
    assert DetectorModel(a).maps(image).shape == (3, 12, 16)


def test_cli_writes_a_loadable_model(tmp_path, capsys):
    out = tmp_path / 'm.onnx'
    args = argparse.Namespace(seed=1, out=str(out), views=2, epochs=1, install=False, threads=1,
                              init='', lr=6e-3)
    assert train_detector.run(args) == 0
    assert 'wrote' in capsys.readouterr().out
    DetectorModel.load(out)


def test_cli_rejects_bad_options(tmp_path):
    args = argparse.Namespace(seed=1, out=str(tmp_path / 'm.onnx'), views=0, epochs=1,
                              install=False, threads=1, init='', lr=6e-3)
    with pytest.raises(ConfigError, match='n_views'):
        train_detector.run(args)
