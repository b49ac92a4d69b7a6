"""The trained fingertip detector model and its ``.npz`` file.

The file holds plain arrays only (no pickles): the feature bank, the flat Hough forest, the
flat verifier forests (``verifier_*`` and ``context_*`` members), the skin table, and the scalars the detector
needs (candidate stride and gate, positive radius, vote normaliser, peak floor and count).
It is written as a zip with fixed member timestamps, so training with the same seed writes
the same bytes (``numpy.savez`` stamps the current time).
"""
from __future__ import annotations

import io
import zipfile
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from hand_tracker_ros._typing import Int32Array, UInt8Array
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.vision.detector.channels import SKIN_BINS
from hand_tracker_ros.vision.detector.forest import ForestArrays

DEFAULT_MODEL_NAME = 'fingertip_forest.npz'
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)
_FOREST_KEYS = ('roots', 'left', 'right', 'feature', 'threshold', 'value')
_VERIFIER_KEYS = tuple(f'verifier_{k}' for k in _FOREST_KEYS)
_CONTEXT_KEYS = tuple(f'context_{k}' for k in _FOREST_KEYS)
_SCALAR_KEYS = ('stride', 'gate', 'radius_px', 'vote_norm', 'peak_floor', 'max_peaks', 'seed')


def default_model_path() -> Path:
    """Path of the model shipped in ``hand_tracker_ros/vision/models``."""
    return Path(str(resources.files('hand_tracker_ros.vision') / 'models' / DEFAULT_MODEL_NAME))


@dataclass(frozen=True, eq=False)
class DetectorModel:
    """Everything training produces.

    Attributes
    ----------
    bank : (F, 6) int32
        Pixel tests (see :mod:`.channels`).
    forest : ForestArrays
        Hough forest (value K = 3).
    verifier : ForestArrays
        Peak verifier (value K = 1) over :func:`.verifier.peak_features`.
    context : ForestArrays
        Auto-context verifier (value K = 1) over the peak features followed by
        :func:`.verifier.context_features` of the first verifier's scores: boosted trees
        whose mean leaf value (:func:`.forest.predict`) is the logit of the tip probability.
    skin_lut : (SKIN_BINS, SKIN_BINS) uint8
        Skin likelihood per chroma bin.
    stride : int
        Candidate grid step (px).
    gate : int
        Minimum skin likelihood of a candidate (0-255).
    radius_px : float
        Positive radius R of training (px); leaf offsets are stored divided by it.
    vote_norm : float
        Smoothed vote peak of a typical visible tip on training views; scores are peak
        heights divided by it.
    peak_floor : float
        Vote peaks lower than ``peak_floor * vote_norm`` are not verified.
    max_peaks : int
        At most this many highest peaks per image are verified.
    seed : int
        Training seed.
    """

    bank: Int32Array
    forest: ForestArrays
    verifier: ForestArrays
    context: ForestArrays
    skin_lut: UInt8Array
    stride: int
    gate: int
    radius_px: float
    vote_norm: float
    peak_floor: float
    max_peaks: int
    seed: int

    def __post_init__(self) -> None:
        check_shape('bank', self.bank, (None, 6))
        check_shape('skin_lut', self.skin_lut, (SKIN_BINS, SKIN_BINS))
        if (self.stride < 1 or self.radius_px <= 0.0 or self.vote_norm <= 0.0
                or self.peak_floor < 0.0 or self.max_peaks < 1):
            msg = (f'invalid detector model: stride {self.stride}, radius_px {self.radius_px}, '
                   f'vote_norm {self.vote_norm}, peak_floor {self.peak_floor}, '
                   f'max_peaks {self.max_peaks}')
            raise ConfigError(msg)

    def save(self, path: str | Path) -> None:
        """Write the model as a deterministic ``.npz`` (same model -> same bytes)."""
        arrays = {'bank': self.bank, 'skin_lut': self.skin_lut,
                  **{k: getattr(self.forest, k) for k in _FOREST_KEYS},
                  **{f'verifier_{k}': getattr(self.verifier, k) for k in _FOREST_KEYS},
                  **{f'context_{k}': getattr(self.context, k) for k in _FOREST_KEYS},
                  **{k: np.asarray(getattr(self, k)) for k in _SCALAR_KEYS}}
        for key in ('value', 'verifier_value', 'context_value'):
            arrays[key] = arrays[key].astype(np.float32)
        with zipfile.ZipFile(path, 'w', compression=zipfile.ZIP_DEFLATED) as archive:
            for name, array in arrays.items():
                buffer = io.BytesIO()
                np.lib.format.write_array(buffer, np.asarray(array, order='C'),
                                          allow_pickle=False)
                info = zipfile.ZipInfo(f'{name}.npy', date_time=_ZIP_TIME)
                info.compress_type = zipfile.ZIP_DEFLATED
                archive.writestr(info, buffer.getvalue())

    @classmethod
    def load(cls, path: str | Path | None = None) -> DetectorModel:
        """Read a model (default: the shipped one).

        Raises
        ------
        ConfigError
            The file is missing or lacks a field.
        """
        path = Path(path) if path is not None else default_model_path()
        if not path.is_file():
            msg = f'detector model {path} does not exist (train one with `hand-tracker ' \
                  f'train-detector`)'
            raise ConfigError(msg)
        with np.load(path, allow_pickle=False) as data:
            missing = sorted({'bank', 'skin_lut', *_FOREST_KEYS, *_VERIFIER_KEYS,
                              *_CONTEXT_KEYS, *_SCALAR_KEYS} - set(data))
            if missing:
                msg = f'detector model {path} lacks {", ".join(missing)}'
                raise ConfigError(msg)
            return cls(bank=data['bank'].astype(np.int32), forest=_forest(data, ''),
                       verifier=_forest(data, 'verifier_'), context=_forest(data, 'context_'),
                       skin_lut=data['skin_lut'].astype(np.uint8), stride=int(data['stride']),
                       gate=int(data['gate']), radius_px=float(data['radius_px']),
                       vote_norm=float(data['vote_norm']),
                       peak_floor=float(data['peak_floor']), max_peaks=int(data['max_peaks']),
                       seed=int(data['seed']))


def _forest(data: np.lib.npyio.NpzFile, prefix: str) -> ForestArrays:
    """The forest stored under the keys ``prefix + name``."""
    return ForestArrays(
        roots=data[f'{prefix}roots'].astype(np.int32),
        left=data[f'{prefix}left'].astype(np.int32),
        right=data[f'{prefix}right'].astype(np.int32),
        feature=data[f'{prefix}feature'].astype(np.int32),
        threshold=data[f'{prefix}threshold'].astype(np.float64),
        value=data[f'{prefix}value'].astype(np.float64))
