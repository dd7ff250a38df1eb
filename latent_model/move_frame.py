"""The frame attached to a move: what makes the transition model equivariant by construction.

A move of the held end(s) is described in its own frame: the cord is reordered so that the
end that moves farther is point 0 (a tail move is a head move of the reversed cord), point 0
is the origin and its displacement points along +x. Anything computed in that frame and mapped
back with :func:`from_frame` turns and shifts exactly with the input; :func:`handedness`
mirrors it onto one side of the move's line, so it mirrors exactly too. Batched torch code, so
multi-move chains can be rolled out and differentiated through.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

#: Grasp codes, as in the transition data files.
GRASP_CODES = {"head": 0, "tail": 1, "both": 2}


@dataclass
class MoveFrame:
    """Where each move's frame sits in the world.

    Attributes:
        origin: ``(B, 2)`` world position of the frame's point 0 (the leading end).
        cos: ``(B,)`` cosine of the frame's angle in the world.
        sin: ``(B,)`` sine of the frame's angle.
        reversed: ``(B,)`` bool, the cord's point order is reversed in the frame.
    """

    origin: torch.Tensor
    cos: torch.Tensor
    sin: torch.Tensor
    reversed: torch.Tensor


def _rotate(points: torch.Tensor, cos: torch.Tensor, sin: torch.Tensor) -> torch.Tensor:
    # points (B, ..., 2); cos, sin (B,): elementwise 2-D rotation, no tiny matmuls.
    shape = (-1,) + (1,) * (points.dim() - 2)
    c, s = cos.reshape(shape), sin.reshape(shape)
    x, y = points[..., 0], points[..., 1]
    return torch.stack([c * x - s * y, s * x + c * y], dim=-1)


def _flip(points: torch.Tensor, flip: torch.Tensor) -> torch.Tensor:
    # Reverse the point order of the shapes where ``flip``; points (B, n, 2).
    return torch.where(flip[:, None, None], points.flip(1), points)


def to_frame(shapes: torch.Tensor, grasp: torch.Tensor, moves: torch.Tensor
             ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, MoveFrame]:
    """Express shapes and moves in the frames of the moves.

    Args:
        shapes: ``(B, n, 2)`` world shapes at rest.
        grasp: ``(B,)`` int64 grasp codes (0 head, 1 tail, 2 both).
        moves: ``(B, 2, 2)`` displacement of [head, tail] in the world (zero if not held).

    Returns:
        ``points`` ``(B, n, 2)`` in the frame; ``lead`` ``(B,)`` the length of the leading
        end's move (its direction is +x); ``other`` ``(B, 2)`` the other end's move in the
        frame (zero unless both ends are held); and the frames.
    """
    head_len = moves[:, 0].norm(dim=-1)
    tail_len = moves[:, 1].norm(dim=-1)
    flip = (grasp == 1) | ((grasp == 2) & (tail_len > head_len))
    lead_move = torch.where(flip[:, None], moves[:, 1], moves[:, 0])
    other_move = torch.where(flip[:, None], moves[:, 0], moves[:, 1])
    other_move = torch.where((grasp == 2)[:, None], other_move, torch.zeros_like(other_move))
    ordered = _flip(shapes, flip)
    lead = lead_move.norm(dim=-1)
    safe = lead > 0
    cos = torch.where(safe, lead_move[:, 0] / lead.clamp_min(1e-12), torch.ones_like(lead))
    sin = torch.where(safe, lead_move[:, 1] / lead.clamp_min(1e-12), torch.zeros_like(lead))
    origin = ordered[:, 0]
    points = _rotate(ordered - origin[:, None], cos, -sin)
    other = _rotate(other_move, cos, -sin)
    return points, lead, other, MoveFrame(origin, cos, sin, flip)


def from_frame(points: torch.Tensor, frame: MoveFrame) -> torch.Tensor:
    """Map ``(B, n, 2)`` points from the frames back to world shapes (point order restored)."""
    world = _rotate(points, frame.cos, frame.sin) + frame.origin[:, None]
    return _flip(world, frame.reversed)


def into_frame(vectors: torch.Tensor, frame: MoveFrame, reorder: bool = True) -> torch.Tensor:
    """World direction vectors ``(B, k, 2)`` turned into the frames; with ``reorder`` they are
    one per point of the cord and take the frame's point order too."""
    if reorder:
        vectors = _flip(vectors, frame.reversed)
    return _rotate(vectors, frame.cos, -frame.sin)


def out_of_frame(vectors: torch.Tensor, frame: MoveFrame) -> torch.Tensor:
    """Direction vectors ``(B, k, 2)`` in the frames turned back into the world (the inverse
    of ``into_frame(..., reorder=False)``)."""
    return _rotate(vectors, frame.cos, frame.sin)


def handedness(points: torch.Tensor) -> torch.Tensor:
    """``(B, 2)`` factors ``(1, +-1)`` that mirror cords in the frames ``(B, n, 2)`` whose
    centroid lies on the right of the move's line (y < 0) onto its left; applying them twice
    is the identity, so the same factors map a prediction back."""
    sign = torch.where(points[..., 1].mean(dim=-1) < 0, -1.0, 1.0).to(points.dtype)
    return torch.stack([torch.ones_like(sign), sign], dim=-1)


def rim_vectors(points: torch.Tensor, half: float, reach: float) -> torch.Tensor:
    """How close each world point ``(..., 2)`` is to the table's rim, as a vector.

    Each edge within ``reach`` adds its outward normal scaled by ``1 - distance / reach``, so
    the vector is exactly zero farther than ``reach`` from every edge: there the model sees
    no rim and stays exactly equivariant, as the physics is.
    """
    near_high = torch.relu(1.0 - (half - points) / reach)
    near_low = torch.relu(1.0 - (half + points) / reach)
    return near_high - near_low
