"""The transition model as a batched, differentiable step function of torch tensors.

:class:`CordDynamics` is the learned cord's ``(shapes, displacement) -> shapes`` in torch:
no numpy round trip, so gradients flow from the returned shapes to the displacements (and to
the shapes), and ``torch.func.grad`` / ``jacrev`` work through it. It applies the same rules as
``TransitionModel.predict`` for one straight move of the held end(s) (the grippers' clipping
to the table and the span, the network in the move's frame, the held ends set where they were
sent, the projection onto segments of rest length, a cord that does not move staying where it
is, the shape kept on the table), so a one-move prediction agrees with ``predict`` to float32
rounding. The surrogate environments (:mod:`latent_model.surrogate_env`) step it, and
gradient planners differentiate through it.

Example:
    >>> dyn = CordDynamics(TransitionModel.load_pretrained(), grasp="head")
    >>> d = torch.zeros(8, 2, requires_grad=True)
    >>> nxt = dyn.step(shapes, d)                        # (8, n, 2), (8, 2) -> (8, n, 2)
    >>> nxt.sum().backward()                             # d.grad: (8, 2)
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from dlo_env.cord import CordParams
from dlo_env.errors import InputError
from dlo_env.shapes import TABLE_HALF
from latent_model.inextensible import DAMPING, ITERATIONS, MAX_MOVE, make_inextensible
from latent_model.move_frame import GRASP_CODES, from_frame
from latent_model.transition_model import GraspRoutedMLP, TransitionModel, cord_features

#: The held ends' indices of each grasp: head is point 0, tail point n - 1.
_HELD = {"head": (True, False), "tail": (False, True), "both": (True, True)}


def inextensible(points: torch.Tensor, rest: float | torch.Tensor, pin_first: bool,
                 pin_last: bool, iterations: int = ITERATIONS) -> torch.Tensor:
    """``points`` ``(B, n, 2)`` moved onto nearby shapes with segments of length ``rest``.

    The torch twin of :func:`latent_model.inextensible.make_inextensible`: the same fast
    projection (a Gauss-Newton step on the segment lengths, one tridiagonal solve per shape by
    the Thomas algorithm, all shapes at once), the same step cap and damping, and
    differentiable (no in-place updates of tensors that carry gradients).

    Args:
        points: The shapes.
        rest: Rest length of a segment, a number or ``(B,)``.
        pin_first, pin_last: The first / last point is held (does not move), for every shape.
        iterations: Linearise-and-solve steps.

    Returns:
        ``(B, n, 2)``, a new tensor; the held points are unchanged.
    """
    b, n = points.shape[:2]
    if n < 2 or b == 0 or iterations <= 0:
        return points.clone()
    m = n - 1
    # Coordinates as (n, B) rows: every step below is a few whole-row operations.
    x, y = points[..., 0].T, points[..., 1].T
    free = [1.0] * n
    free[0], free[-1] = (0.0 if pin_first else 1.0), (0.0 if pin_last else 1.0)
    diag = [free[i] + free[i + 1] + DAMPING for i in range(m)]
    free_col = points.new_tensor(free)[:, None]  # (n, 1)
    rest = torch.as_tensor(rest, dtype=points.dtype, device=points.device).reshape(1, -1)
    longest = MAX_MOVE * rest
    for _ in range(iterations):
        ex, ey = x[1:] - x[:-1], y[1:] - y[:-1]
        # sqrt of a clamped square: finite gradients where a length or a step is exactly 0
        length = torch.sqrt((ex * ex + ey * ey).clamp_min(1e-24))
        ex, ey = ex / length, ey / length
        excess = length - rest
        off = -(ex[:-1] * ex[1:] + ey[:-1] * ey[1:])  # (m - 1, B)
        pivot = diag[0]
        lam = [excess[0] / pivot]
        ratio = []
        for i in range(1, m):
            ratio.append(off[i - 1] / pivot)
            pivot = diag[i] - off[i - 1] * ratio[-1]
            lam.append((excess[i] - off[i - 1] * lam[-1]) / pivot)
        for i in range(m - 2, -1, -1):
            lam[i] = lam[i] - ratio[i] * lam[i + 1]
        lam_rows = torch.stack(lam)  # (m, B): each segment pulls its two points together
        px, py = ex * lam_rows, ey * lam_rows
        zero = px.new_zeros(1, b)
        dx = (torch.cat([px, zero]) - torch.cat([zero, px])) * free_col
        dy = (torch.cat([py, zero]) - torch.cat([zero, py])) * free_col
        step = torch.sqrt((dx * dx + dy * dy).amax(dim=0, keepdim=True).clamp_min(1e-24))
        scale = longest / torch.maximum(step, longest)
        x, y = x + dx * scale, y + dy * scale
    return torch.stack([x.T, y.T], dim=-1)


class CordDynamics:
    """One straight move of the held end(s) of a batch of cords at rest, in torch.

    Args:
        model: The transition model (its mean network makes the prediction when it has one;
            its ensemble gives the spread).
        grasp: The held end(s): ``"head"``, ``"tail"`` or ``"both"``.
        params: The cord (None: the model's). A model of one cord takes only its own.
        inextensible_iterations: Projection steps onto rest-length segments (0: none).
    """

    def __init__(self, model: TransitionModel, grasp: str = "head",
                 params: CordParams | None = None, inextensible_iterations: int = ITERATIONS
                 ) -> None:
        if not isinstance(model, TransitionModel):
            raise InputError(f"model must be a latent_model.TransitionModel, got "
                             f"{type(model).__name__}")
        if grasp not in _HELD:
            raise InputError(f"grasp must be one of {tuple(_HELD)}, got {grasp!r}")
        if model.config.peg_reach:
            raise InputError("model: a model that sees pegs needs the pegs of every move; "
                             "CordDynamics steps the empty table (give a model without "
                             "peg_reach)")
        self.model = model
        self.grasp = grasp
        self.params = params if params is not None else model.cord_params
        rows = model.cord_rows(self.params, 1)  # checks a model of one cord gets its own
        self.device = model.device
        self._code = GRASP_CODES[grasp]
        self._ends = [i for i, held in zip((0, -1), _HELD[grasp]) if held]
        self._cord = (torch.from_numpy(cord_features(rows)).to(self.device)
                      if model.config.cord_inputs else None)
        self.iterations = int(inextensible_iterations)
        self.rest = self.params.length / (model.config.n_points - 1)
        self.limit = TABLE_HALF - self.params.rim_margin
        self.span = self.params.max_span * self.params.length
        #: A gripper's displacement per action, metres (moves are walked in such actions).
        self.max_step = float(model.config.max_step)
        net = model.mean_net
        if isinstance(net, GraspRoutedMLP):  # every row is of one grasp: call its network
            net = _Member(net.routes, 1 if grasp == "both" else 0)
        self._net = net

    @property
    def action_width(self) -> int:
        """Numbers in one displacement: 2 per held end."""
        return 2 * len(self._ends)

    def reachable(self, shapes: torch.Tensor, displacement: torch.Tensor) -> torch.Tensor:
        """``(B, 2, 2)`` moves of [head, tail] the grippers really make (zero for an end not
        held): ``TransitionModel.reachable_moves``' rule (``Cord.move``'s for each of the
        move's ``split_move`` actions): targets clipped to the table less the rim margin and,
        with both ends held, pulled in about their middle to the span. Both rules are convex,
        so a move whose start and end obey them is clipped at its end alone; a move of both
        ends that the span (or the table) clips is walked action by action, as the
        environment carries it out."""
        start = shapes[:, self._ends]  # (B, k, 2)
        d = displacement.reshape(len(shapes), -1, 2)
        target = self._clip(start + d)
        if len(self._ends) == 2:
            walk = ((self._clip(start) != start) | (target != start + d)).flatten(1).any(dim=1)
            if bool(walk.any()):
                longest = d.detach().norm(dim=-1).amax(dim=-1)
                actions = torch.ceil(longest / self.max_step - 1e-6).clamp_min(1.0)
                step = d / actions[:, None, None]
                path = start
                for j in range(int(actions[walk].max())):
                    going = (walk & (actions > j))[:, None, None]
                    path = torch.where(going, self._clip(path + step), path)
                target = torch.where(walk[:, None, None], path, target)
        move = target - start
        zero = torch.zeros_like(move[:, :1])
        if self.grasp == "head":
            return torch.cat([move, zero], dim=1)
        if self.grasp == "tail":
            return torch.cat([zero, move], dim=1)
        return move

    def _clip(self, target: torch.Tensor) -> torch.Tensor:
        """``dlo_env.cord.reachable_targets`` (without pegs) in torch: ``(B, k, 2)`` targets
        on the table less the rim margin, two ends farther apart than the span pulled in
        about their middle."""
        target = target.clamp(-self.limit, self.limit)
        if target.shape[1] != 2:
            return target
        gap = target[:, 1] - target[:, 0]
        dist = gap.norm(dim=-1, keepdim=True)
        too_far = dist > self.span
        mid = 0.5 * (target[:, 0] + target[:, 1])
        half = 0.5 * self.span * gap / torch.where(too_far, dist, torch.ones_like(dist))
        return torch.where(too_far[:, None], torch.stack([mid - half, mid + half], dim=1),
                           target)

    def step(self, shapes: torch.Tensor, displacement: torch.Tensor,
             return_std: bool = False) -> torch.Tensor | tuple[torch.Tensor, torch.Tensor]:
        """The shapes at rest after moving the held end(s) by ``displacement``.

        Args:
            shapes: ``(B, n, 2)`` world shapes at rest, metres.
            displacement: ``(B, 2)`` (one end) or ``(B, 4)`` (head dx, dy, then tail), metres.
            return_std: Also return the ensemble's spread ``(B,)`` (metres; it runs every
                member, so costs ``members`` more networks).

        Returns:
            ``(B, n, 2)`` shapes, differentiable in ``shapes`` and ``displacement``; with
            ``return_std`` also the spread (no gradient).
        """
        b = len(shapes)
        if shapes.dim() != 3 or shapes.shape[-1] != 2:
            raise InputError(f"shapes must have shape (B, n, 2), got {tuple(shapes.shape)}")
        if tuple(displacement.shape) != (b, self.action_width):
            raise InputError(f"displacement must have shape ({b}, {self.action_width}) for "
                             f"grasp={self.grasp!r}, got {tuple(displacement.shape)}")
        moves = self.reachable(shapes, displacement)
        grasp = torch.full((b,), self._code, dtype=torch.int64, device=shapes.device)
        cord = None if self._cord is None else self._cord.expand(b, -1)
        net = self._net if self._net is not None else self.model.net
        moved, frame = self.model.in_frame(shapes, grasp, moves, net=net, cord=cord)
        world = from_frame(moved.mean(dim=0), frame)
        if self.iterations:
            world = self._inextensible(world)
        still = (moves.abs().sum(dim=(1, 2)) == 0)[:, None, None]
        world = torch.where(still, shapes, world).clamp(-TABLE_HALF, TABLE_HALF)
        if not return_std:
            return world
        with torch.no_grad():
            members, _ = self.model.in_frame(shapes, grasp, moves, cord=cord)
            spread = members.var(dim=0, unbiased=False).sum(dim=-1).sqrt().mean(dim=-1)
        return world, torch.where(still[:, 0, 0], torch.zeros_like(spread), spread)

    def _inextensible(self, world: torch.Tensor) -> torch.Tensor:
        pins = _HELD[self.grasp]
        if world.requires_grad or world.device.type != "cpu":
            return inextensible(world, self.rest, *pins, self.iterations)
        # No gradient wanted, on the CPU: numpy's Thomas sweep along the chain is several
        # times faster than torch's for these (n,)-long loops of small row operations.
        b = len(world)
        held = (np.full(b, pins[0]), np.full(b, pins[1]))
        return torch.from_numpy(make_inextensible(world.numpy(), self.rest, *held,
                                                  iterations=self.iterations))

    def __call__(self, shapes: torch.Tensor, displacement: torch.Tensor) -> torch.Tensor:
        return self.step(shapes, displacement)


class _Member(torch.nn.Module):
    """Network ``index`` of an ``EnsembleMLP`` as a one-network ensemble."""

    def __init__(self, routes: Any, index: int) -> None:
        super().__init__()
        self.routes = routes
        self.index = index

    @property
    def members(self) -> int:
        return 1

    def forward(self, x: torch.Tensor, members: int | None = None) -> torch.Tensor:
        return self.routes.member(x[0] if x.dim() == 3 else x, self.index)[None]
