"""A chain-local transition network: residual dilated 1-D convolutions along the cord's points.

The MLP of ``latent_model.transition_model`` sees the whole chain as one flat vector, so it
must learn again at every point how a point follows its neighbours. ``EnsembleChainNet`` shares
its weights along the chain: every point sees its own features (position, the segments on
either side, its rim vector, where it lies along the chain) and the move's global features
(how far the lead end goes, the other end's move, whether both ends are held, the rim near the
targets), and residual convolutions with growing dilation (1, 2, 4, 8, 1, 2, ...) carry
information along the chain: a point sees ``reach`` points on either side (the dilations'
sum; 7 blocks reach 22, the whole of a 20-point cord), and the move's features everywhere.

It takes the same flat input as the MLP (``TransitionModel.features``) and unflattens it with
the layout of its ``TransitionModelConfig``, so the model around it (move frame, mirroring,
pinned ends, training) is the same for both designs. Like ``EnsembleMLP`` it holds ``members``
independent networks evaluated as one batched network (grouped convolutions).
"""

from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F

from dlo_env.errors import InputError

#: Width of the convolutions along the chain (points on either side seen by one layer: 1).
KERNEL = 3


def chain_layout(rim_targets: int, rim_blocks: int, extra_globals: int = 0) -> tuple[int, int]:
    """``(point_features, global_features)`` of the flat input of this layout: per point its
    position (2), the segments before and after it (4), its rim vectors (2 per block) and its
    place along the chain (1); globally the targets' rim vectors, ``extra_globals`` (the cord's
    parameters), the lead length, the other end's move and the both-ends flag."""
    return 2 + 4 + 2 * rim_blocks + 1, 2 * rim_targets * rim_blocks + extra_globals + 4


class EnsembleChainNet(nn.Module):
    """``members`` chain-local networks on the flat transition features, batched.

    Args:
        members: Networks.
        n_points: Points of the cord.
        rim_targets: Targets with rim vectors in the input (``TransitionModelConfig``).
        rim_blocks: Vectors per point and target in the layout of the rim's: the rim's, the
            contact's with ``contact_reach`` and the pegs' with ``peg_reach``.
        width: Channels of the convolutions.
        depth: Residual blocks; block ``i`` has dilation ``2 ** (i % 4)``.
        extra_globals: Global inputs between the rim vectors and the move (the cord's
            parameters of a cord-conditioned model).
    """

    def __init__(self, members: int, n_points: int, rim_targets: int, rim_blocks: int,
                 width: int, depth: int, extra_globals: int = 0) -> None:
        super().__init__()
        self.n_points, self.rim_targets, self.rim_blocks = n_points, rim_targets, rim_blocks
        self.width, self.depth, self.extra_globals = width, depth, extra_globals
        point, glob = chain_layout(rim_targets, rim_blocks, extra_globals)
        self.point_features, self.global_features = point, glob
        self.lift = self._conv(members, point + glob, width, 1)
        self.blocks = nn.ParameterList()
        for _ in range(depth):
            self.blocks.extend(self._conv(members, width, width, KERNEL))
        self.head = self._conv(members, width, 2, 1, scale=0.1)
        self.register_buffer("position", torch.linspace(-1.0, 1.0, n_points))

    @staticmethod
    def _conv(members: int, inputs: int, outputs: int, kernel: int,
              scale: float = 1.0) -> nn.ParameterList:
        # A convolution along the chain as one batched matrix product per member: the
        # ``kernel`` neighbours' features side by side, ``(members, kernel * inputs, outputs)``
        # (on a CPU several times faster than a grouped ``conv1d``).
        bound = scale / math.sqrt(inputs * kernel)
        return nn.ParameterList([
            nn.Parameter(torch.empty(members, kernel * inputs, outputs).uniform_(-bound, bound)),
            nn.Parameter(torch.zeros(members, 1, outputs))])

    @property
    def inputs(self) -> int:
        """Length of the flat input (``TransitionModelConfig.inputs`` of its layout)."""
        n, rt, rb = self.n_points, self.rim_targets, self.rim_blocks
        return 2 * n + 2 * (n - 1) + 2 * (n + rt) * rb + self.extra_globals + 4

    @property
    def reach(self) -> int:
        """Points on either side whose features reach a point's output (the dilations' sum)."""
        return sum(2 ** (i % 4) for i in range(self.depth))

    @property
    def members(self) -> int:
        """Networks in the ensemble."""
        return self.lift[0].shape[0]

    def _unflatten(self, x: torch.Tensor) -> torch.Tensor:
        """Flat inputs ``(k, B, inputs)`` -> per-point inputs ``(k, B, n, features)``."""
        k, b = x.shape[:2]
        n, rt, rb = self.n_points, self.rim_targets, self.rim_blocks
        points = x[..., :2 * n].reshape(k, b, n, 2)
        at = 2 * n
        seg = x[..., at:at + 2 * (n - 1)].reshape(k, b, n - 1, 2)
        at += 2 * (n - 1)
        zero = seg.new_zeros(k, b, 1, 2)
        before, after = torch.cat([zero, seg], dim=2), torch.cat([seg, zero], dim=2)
        rims, targets = [], []
        for _ in range(rb):
            block = x[..., at:at + 2 * (n + rt)].reshape(k, b, n + rt, 2)
            rims.append(block[:, :, :n])
            targets.append(block[:, :, n:].flatten(2))
            at += 2 * (n + rt)
        glob = torch.cat([*targets, x[..., at:]], dim=-1)  # (k, B, global): cord, move
        where = self.position.expand(k, b, n)[..., None]
        return torch.cat([points, before, after, *rims, where,
                          glob[:, :, None].expand(k, b, n, glob.shape[-1])], dim=-1)

    @staticmethod
    def _conv1d(h: torch.Tensor, conv: nn.ParameterList, k: int, dilation: int = 1
                ) -> torch.Tensor:
        # h (k, B, n, C) -> (k, B, n, out): each point with its neighbours ``dilation`` away.
        w, bias = conv[0][:k], conv[1][:k]
        kernel = w.shape[1] // h.shape[-1]
        if kernel > 1:
            pad = h.new_zeros(*h.shape[:2], dilation, h.shape[-1])
            padded = torch.cat([pad, h, pad], dim=2)
            n = h.shape[2]
            h = torch.cat([padded[:, :, i * dilation:i * dilation + n] for i in range(kernel)],
                          dim=-1)
        kb, bb, n, c = h.shape
        return torch.baddbmm(bias, h.reshape(kb, bb * n, c), w).reshape(kb, bb, n, -1)

    def _run(self, x: torch.Tensor, k: int) -> torch.Tensor:
        # x (k, B, inputs) -> (k, B, 2n), the first k networks.
        b, n = x.shape[1], self.n_points
        h = self._conv1d(self._unflatten(x), self.lift, k)
        for i in range(self.depth):
            conv = self.blocks[2 * i:2 * i + 2]
            h = h + self._conv1d(F.silu(h), conv, k, dilation=2 ** (i % 4))
        return self._conv1d(F.silu(h), self.head, k).reshape(k, b, 2 * n)

    def forward(self, x: torch.Tensor, members: int | None = None) -> torch.Tensor:
        """``(B, inputs)`` or ``(members, B, inputs)`` -> ``(members, B, 2n)``; with
        ``members`` (``x`` shared, 2-D) only the first ``members`` networks run."""
        k = self.members if members is None else members
        return self._run(x.expand(k, *x.shape) if x.dim() == 2 else x, k)

    def member(self, x: torch.Tensor, index: int) -> torch.Tensor:
        """Network ``index`` alone: ``(B, inputs)`` -> ``(B, 2n)``."""
        return self.first_from(index)._run(x[None], 1)[0]

    def first_from(self, start: int, members: int = 1) -> EnsembleChainNet:
        """A copy of ``members`` networks from network ``start`` on."""
        out = EnsembleChainNet(members, self.n_points, self.rim_targets, self.rim_blocks,
                               self.width, self.depth, self.extra_globals
                               ).to(self.lift[0].device)
        with torch.no_grad():
            for mine, theirs in zip(out.parameters(), self.parameters()):
                mine.copy_(theirs[start:start + members])
        return out

    def first(self, members: int) -> EnsembleChainNet:
        """A copy of the first ``members`` networks alone."""
        return self.first_from(0, members)

    def with_inputs(self, at: int, count: int) -> EnsembleChainNet:
        raise InputError("a chain network does not grow new inputs (--contact-reach, "
                         "--cord-inputs or --peg-reach with --init of a model without them "
                         "needs an MLP model)")
