"""Gradient descent on straight-move plans through the differentiable transition model.

``latent_model.cord_dynamics.CordDynamics`` is the torch step of the transition model. A batch
of candidate plans (``(S, moves, ends, 2)`` displacements of the held end(s), metres) is rolled
out through it, and Adam moves every candidate down the gradient of its final shape's error to
the goal, each move kept at most ``max_move`` long. grad-mpc plans this way from scratch;
latent-mpc polishes the sampling search's best plan this way where that plan is not predicted
to reach the goal (``LatentMPCConfig.polish_steps``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def clip_moves(plans: np.ndarray, max_move: float) -> np.ndarray:
    """``plans`` with every move of every end at most ``max_move`` long (float32)."""
    norms = np.linalg.norm(plans, axis=-1, keepdims=True)
    return (plans * np.minimum(1.0, max_move / np.maximum(norms, 1e-12))).astype(np.float32)


def rollout_errors(dynamics: Any, origin: Any, plans: Any, target: Any,
                   direction_free: bool = False) -> Any:
    """``(S,)`` mean point distances to ``target`` of the final shapes of ``plans`` from
    ``origin`` ``(S, n, 2)`` (differentiable; the smaller of both directions when
    ``direction_free``)."""
    import torch

    shapes = origin
    for k in range(plans.shape[1]):
        shapes = dynamics.step(shapes, plans[:, k].reshape(len(plans), -1))
    errors = (shapes - target).norm(dim=-1).mean(dim=-1)
    if direction_free:
        reverse = (shapes - target.flip(0)).norm(dim=-1).mean(dim=-1)
        errors = torch.minimum(errors, reverse)
    return errors


def descend(dynamics: Any, shape: np.ndarray, goal: np.ndarray, starts: np.ndarray, *,
            steps: int, learning_rate: float, max_move: float, stop_error: float = 0.0,
            direction_free: bool = False) -> tuple[np.ndarray, float, int]:
    """Adam steps on the candidate plans ``starts`` from ``shape`` towards ``goal``.

    A move of exactly zero leaves the cord where it is and has no gradient, so the caller
    starts from moves that move the cord.

    Args:
        dynamics: A ``CordDynamics`` of the cord and the held end(s).
        shape: ``(n, 2)`` the cord at rest.
        goal: ``(n, 2)`` the goal.
        starts: ``(S, moves, ends, 2)`` the candidates' first plans, metres.
        steps: Adam steps at most.
        learning_rate: Adam's step size, metres.
        max_move: The longest move of one end.
        stop_error: Stop once a candidate is predicted within it.
        direction_free: Score the final shapes direction-free.

    Returns:
        The best plan seen (float64), its predicted error, and the plans rolled out.
    """
    import torch

    plans = torch.tensor(clip_moves(starts, max_move), requires_grad=True)
    origin = torch.from_numpy(shape.astype(np.float32)).expand(len(starts), -1, -1)
    target = torch.from_numpy(goal.astype(np.float32))
    optimizer = torch.optim.Adam([plans], lr=learning_rate)
    best_plan, best_err, rollouts = starts[0].astype(np.float64), math.inf, 0
    for step in range(steps + 1):
        errors = rollout_errors(dynamics, origin, plans, target, direction_free)
        err = errors.detach().numpy()
        i = int(np.argmin(err))
        if err[i] < best_err:
            best_err, best_plan = float(err[i]), plans.detach()[i].numpy().astype(np.float64)
        rollouts += len(starts)
        if best_err <= stop_error or step == steps:
            break
        # The gradient to the plans alone (the model's weights get none and keep no .grad).
        (plans.grad,) = torch.autograd.grad(errors.sum(), plans)
        optimizer.step()
        with torch.no_grad():
            plans.copy_(torch.from_numpy(clip_moves(plans.detach().numpy(), max_move)))
    return best_plan, best_err, rollouts
