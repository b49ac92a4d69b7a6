r"""The fingertip network in PyTorch (training only: the runtime runs its ONNX export).

Layers, for an (H, W) image (MAC counts at 320 x 240 for the default widths):

1. stem: 3 x 3 convolution, stride 2, 3 -> ``stem_channels`` (12.4 M MAC at 24 channels);
   3 x 3 depthwise convolution, stride 2; 1 x 1 convolution to ``channels``, now at 1/4
   resolution (:data:`.model.STRIDE`);
2. residual blocks at 1/4 resolution, one per entry of ``dilations``: a 3 x 3 depthwise
   convolution with that dilation and a 1 x 1 convolution,
   :math:`x \leftarrow \mathrm{relu}(x + \mathrm{bn}(W_1 \ast \mathrm{relu}(\mathrm{bn}(
   W_{dw} \ast_d x))))` (13.1 M MAC each at 48 channels). Dilations 1, 2, 4, 8, 1, 2 give a
   receptive field of 151 px, a finger and its surroundings;
3. head: a 1 x 1 convolution to 3 channels: the tip logit and the sub-cell offset
   :math:`(\delta_u, \delta_v)` in cells.

Every convolution but the head is followed by batch normalisation (folded into the
convolution by the ONNX runtime) and ReLU. Depthwise-separable blocks, as in MobileNet,
because a full 3 x 3 convolution at 48 channels costs 8x the MACs of a separable one. The
default widths (24 / 48) come to 98 M MAC at 320 x 240 (16 / 32: 50 M), 1.37 against
0.81 ms per image with ONNX Runtime on one thread (``bench/bench_detector.py``).

:class:`ExportedNetwork` wraps the network with the input and output conventions of the
shipped model: (1, H, W, 3) uint8 RGB in, (1, 3, ceil(H/4), ceil(W/4)) float32 out with the
tip probability :math:`\sigma(\text{logit})` in channel 0, so the runtime needs no
preprocessing.

References: docs/references.md.
"""
from __future__ import annotations

import torch
from torch import nn

# Tip prior of the untrained head, sigma(-4.6) = 0.01: with the usual zero bias every cell
# starts at probability 0.5 and the first steps only push the background down (CenterNet).
_PRIOR_LOGIT = -4.6
# Input normalisation of uint8 RGB to roughly [-2, 2].
_MEAN, _SCALE = 128.0, 64.0


def _conv_bn_relu(c_in: int, c_out: int, kernel: int, stride: int = 1, dilation: int = 1,
                  groups: int = 1) -> list[nn.Module]:
    return [nn.Conv2d(c_in, c_out, kernel, stride, padding=dilation * (kernel // 2),
                      dilation=dilation, groups=groups, bias=False),
            nn.BatchNorm2d(c_out), nn.ReLU(inplace=True)]


class SeparableBlock(nn.Module):
    """Residual depthwise-separable block (item 2 of the module docstring)."""

    def __init__(self, channels: int, dilation: int) -> None:
        super().__init__()
        self.body = nn.Sequential(
            *_conv_bn_relu(channels, channels, 3, dilation=dilation, groups=channels),
            nn.Conv2d(channels, channels, 1, bias=False), nn.BatchNorm2d(channels))
        self.act = nn.ReLU(inplace=True)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.act(x + self.body(x))


class TipNetwork(nn.Module):
    """(B, 3, H, W) normalised RGB -> (B, 3, ceil(H/4), ceil(W/4)) tip logit and offset."""

    def __init__(self, stem_channels: int, channels: int, dilations: tuple[int, ...]) -> None:
        super().__init__()
        self.stem = nn.Sequential(
            *_conv_bn_relu(3, stem_channels, 3, stride=2),
            *_conv_bn_relu(stem_channels, stem_channels, 3, stride=2, groups=stem_channels),
            *_conv_bn_relu(stem_channels, channels, 1))
        self.blocks = nn.Sequential(*(SeparableBlock(channels, d) for d in dilations))
        self.head = nn.Conv2d(channels, 3, 1)
        with torch.no_grad():
            self.head.bias[0] = _PRIOR_LOGIT

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.blocks(self.stem(x)))


class ExportedNetwork(nn.Module):
    """(B, H, W, 3) uint8 RGB -> (B, 3, h, w): tip probability, offset (cells)."""

    def __init__(self, network: TipNetwork) -> None:
        super().__init__()
        self.network = network

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        x = (image.permute(0, 3, 1, 2).float() - _MEAN) / _SCALE
        y = self.network(x)
        return torch.cat([torch.sigmoid(y[:, :1]), y[:, 1:]], dim=1)


def load_onnx_weights(network: ExportedNetwork, model_bytes: bytes) -> None:
    r"""Start ``network`` from an exported model of the same architecture (fine-tuning).

    The export folds each batch normalisation into the convolution before it
    (:math:`W' = \gamma W / \sqrt{\sigma^2 + \epsilon}`, :math:`b' = \beta - \gamma \mu /
    \sqrt{\sigma^2 + \epsilon}`). The folded :math:`W'` goes into the convolution and
    :math:`b'` into the normalisation's :math:`\beta`, with :math:`\gamma = 1`,
    :math:`\mu = 0`, :math:`\sigma^2 = 1 - \epsilon`: the network then computes what the
    model computes as long as its normalisations stay in eval mode (:func:`freeze_batch_norm`).

    Raises
    ------
    ValueError
        The model's convolutions do not match the network's (count or shapes).
    """
    import onnx
    from onnx import numpy_helper

    graph = onnx.load_from_string(model_bytes).graph
    weights = {i.name: numpy_helper.to_array(i) for i in graph.initializer}
    folded = [(weights[n.input[1]], weights[n.input[2]]) for n in graph.node
              if n.op_type == 'Conv']
    modules = list(network.modules())
    convs = [m for m in modules if isinstance(m, nn.Conv2d)]
    if len(folded) != len(convs) or any(w.shape != tuple(c.weight.shape)
                                        for (w, _), c in zip(folded, convs)):
        msg = (f'model convolutions {[w.shape for w, _ in folded]} do not match the '
               f'network {[tuple(c.weight.shape) for c in convs]}')
        raise ValueError(msg)
    with torch.no_grad():
        for (weight, bias), conv in zip(folded, convs):
            conv.weight.copy_(torch.from_numpy(weight.copy()))
            index = modules.index(conv)
            after = modules[index + 1] if index + 1 < len(modules) else None
            if isinstance(after, nn.BatchNorm2d):
                after.weight.fill_(1.0)
                after.bias.copy_(torch.from_numpy(bias.copy()))
                after.running_mean.zero_()
                after.running_var.fill_(1.0 - after.eps)
            else:    # the head keeps its own bias
                conv.bias.copy_(torch.from_numpy(bias.copy()))


def freeze_batch_norm(network: nn.Module) -> None:
    """Put every batch normalisation in eval mode: fixed statistics, trainable affine."""
    for module in network.modules():
        if isinstance(module, nn.BatchNorm2d):
            module.eval()
