"""The trained fingertip network as an ONNX file, run with ONNX Runtime.

The file is the export of :class:`.network.ExportedNetwork`: input ``image``, (1, H, W, 3)
uint8 RGB of any size; output ``maps``, (1, 3, ceil(H / STRIDE), ceil(W / STRIDE)) float32:
the tip probability and the sub-cell offset (du, dv) of each cell, in cells. Cell (i, j) is
centred on pixel ``(u, v) = STRIDE * (j, i)`` (two stride-2 convolutions with
``padding = 1``), so a tip at cell (i, j) with offset (du, dv) is at
``STRIDE * (j + du, i + dv)``.

Why ONNX Runtime rather than OpenCV's ``cv2.dnn``, which would need no extra dependency:
the network alone (same architecture at 16 / 32 channels, 50 M multiply-accumulates) took
1.7 ms per 320 x 240 image on one thread with ONNX Runtime and 3.8 ms with ``cv2.dnn`` on the
shared 2-core machine in an earlier, slower hour (0.81 ms with ONNX Runtime in the tenth
session), 2.5-3.5x slower for every size we tried; PyTorch would work too but is
a 700 MB dependency for a model of 50-90 kB.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

import onnxruntime

from hand_tracker_ros._typing import Float32Array, UInt8Array
from hand_tracker_ros.errors import ConfigError

DEFAULT_MODEL_NAME = 'fingertip_cnn.onnx'
STRIDE = 4
INPUT_NAME = 'image'
OUTPUT_NAME = 'maps'


def default_model_path() -> Path:
    """Path of the model shipped in ``hand_tracker_ros/vision/models``."""
    return Path(str(resources.files('hand_tracker_ros.vision') / 'models' / DEFAULT_MODEL_NAME))


class DetectorModel:
    """An ONNX Runtime session of a trained fingertip network.

    Parameters
    ----------
    model_bytes : bytes
        The ONNX file's contents.
    threads : int
        Intra-op threads of the session.

    Raises
    ------
    ConfigError
        The bytes are no ONNX model with one (1, H, W, 3) uint8 input ``image`` and the
        output ``maps``.
    """

    def __init__(self, model_bytes: bytes, threads: int = 1) -> None:
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = threads
        options.inter_op_num_threads = 1
        try:
            self._session = onnxruntime.InferenceSession(
                model_bytes, options, providers=['CPUExecutionProvider'])
        except Exception as error:  # onnxruntime raises its own, unexported exception types
            msg = f'not a detector model: {error}'
            raise ConfigError(msg) from error
        inputs, outputs = self._session.get_inputs(), self._session.get_outputs()
        if ([i.name for i in inputs] != [INPUT_NAME] or inputs[0].type != 'tensor(uint8)'
                or [o.name for o in outputs] != [OUTPUT_NAME]):
            msg = (f'not a detector model: inputs {[(i.name, i.type) for i in inputs]}, '
                   f'outputs {[o.name for o in outputs]}')
            raise ConfigError(msg)

    @classmethod
    def load(cls, path: str | Path | None = None, threads: int = 1) -> DetectorModel:
        """Read a model (default: the shipped one).

        Raises
        ------
        ConfigError
            The file is missing or no detector model.
        """
        path = Path(path) if path is not None else default_model_path()
        if not path.is_file():
            msg = f'detector model {path} does not exist (train one with `hand-tracker ' \
                  f'train-detector`)'
            raise ConfigError(msg)
        return cls(path.read_bytes(), threads)

    def maps(self, image_rgb: UInt8Array) -> Float32Array:
        """Tip probability and offset maps (3, ceil(H/4), ceil(W/4)) float32 of one
        (H, W, 3) uint8 image (unchecked)."""
        return self._session.run([OUTPUT_NAME], {INPUT_NAME: image_rgb[None]})[0][0]
