"""latent-mpc-distilled: a network that proposes latent-mpc's plan in one call.

The network sees the cord and the goal in a frame attached to the cord (origin at the head,
x-axis from the head towards the cord's centroid), so it turns and shifts with the task by
construction, and answers with the plan of straight moves latent-mpc would make from there,
planning afresh (``dlo_bench.distillation`` trains it by DAgger in the surrogate). The policy
executes the whole plan, each move as latent-mpc executes its moves (``split_move`` actions,
then zero actions while the cord comes to rest), and asks again from the cord at rest: a
millisecond-scale decision instead of a search.

Why the whole plan: a fresh plan spreads the way to the goal over its moves, so executing only
its first move and asking again from there approaches the goal by a fraction of the way per
decision (latent-mpc itself carries its plan over from one call to the next, which a
network of the state alone cannot).
"""

from __future__ import annotations

import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from dlo_env.cord import CordParams
from dlo_env.errors import InputError
from dlo_env.tasks import DEFAULT_MAX_STEP, GRASP_ENDS
from planners.cem import CEMPolicy
from planners.latent_mpc import LatentMPCConfig

#: Marks a distilled policy file.
FORMAT = "dlo-distilled-policy"
FORMAT_VERSION = 2

#: Moves of a plan shorter than this (metres, every end) are not executed: the network's
#: rendering of a still move.
MIN_MOVE = 0.002


@dataclass(frozen=True)
class DistilledConfig:
    """The network's size and the setting it was trained for.

    Attributes:
        grasp: The held end(s): ``"head"`` or ``"both"``.
        n_points: Points of the cord.
        width: Hidden units per layer.
        depth: Hidden layers.
        moves: Straight moves of a plan (latent-mpc's longest horizon; shorter plans end in
            still moves).
        symmetric: Answer with the mean of the plan for the task and the mirrored plan for
            its mirror image, so that the policy is exactly mirror-symmetric.
        move_scale: Moves are output in units of this, metres.
        max_step: The environments' ``max_step``, metres.
    """

    grasp: str = "head"
    n_points: int = 20
    width: int = 256
    depth: int = 3
    moves: int = 5
    symmetric: bool = True
    move_scale: float = 0.2
    max_step: float = DEFAULT_MAX_STEP

    @property
    def outputs(self) -> int:
        """Numbers of one plan: 2 per held end and move."""
        return 2 * len(GRASP_ENDS[self.grasp]) * self.moves


def cord_frame(shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Origins ``(B, 2)`` (the heads) and rotations ``(B, 2, 2)`` (world -> frame: the head
    to the centroid along +x) of cords ``(B, n, 2)``."""
    origin = shapes[:, 0]
    axis = shapes.mean(axis=1) - origin
    axis = axis / np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-9)
    c, s = axis[:, 0], axis[:, 1]
    rotation = np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], axis=1)  # rows: x, y
    return origin, rotation


def features(shapes: np.ndarray, goals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Network inputs ``(B, 4n)``: the cords and goals in the cords' frames; and the
    rotations (to turn the network's moves back into the world)."""
    origin, rotation = cord_frame(shapes)
    cord = np.einsum("bij,bnj->bni", rotation, shapes - origin[:, None])
    goal = np.einsum("bij,bnj->bni", rotation, goals - origin[:, None])
    return (np.concatenate([cord.reshape(len(shapes), -1), goal.reshape(len(shapes), -1)],
                           axis=1).astype(np.float32), rotation)


def mirrored(x: np.ndarray) -> np.ndarray:
    """Features or plans (interleaved x, y in the cord's frame) reflected about the frame's
    x-axis: those of the mirror image of the task (the table's physics is mirror-symmetric)."""
    out = x.copy()
    out[:, 1::2] *= -1
    return out


def to_world(plans: np.ndarray, rotation: np.ndarray, ends: int) -> np.ndarray:
    """Plans ``(B, moves * ends * 2)`` in the cords' frames -> world ``(B, moves, ends, 2)``."""
    m = plans.reshape(len(plans), -1, ends, 2)
    return np.einsum("bji,bmej->bmei", rotation, m)


def to_frame(plans: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """World plans ``(B, moves, ends, 2)`` -> ``(B, moves * ends * 2)`` in the cords'
    frames."""
    return np.einsum("bij,bmej->bmei", rotation, plans).reshape(len(plans), -1)


class MoveNetwork(nn.Module):
    """An MLP from ``features`` to a plan in the cord's frame (units of ``move_scale``)."""

    def __init__(self, config: DistilledConfig) -> None:
        super().__init__()
        self.config = config
        dims = [4 * config.n_points] + [config.width] * config.depth
        layers: list[nn.Module] = []
        for a, b in zip(dims[:-1], dims[1:]):
            layers += [nn.Linear(a, b), nn.SiLU()]
        layers.append(nn.Linear(dims[-1], config.outputs))
        self.net = nn.Sequential(*layers)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)

    @torch.no_grad()
    def plans(self, shapes: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """World plans ``(B, moves, ends, 2)`` (metres) from cords and goals ``(B, n, 2)``."""
        x, rotation = features(shapes, goals)
        if self.config.symmetric:
            both = self(torch.from_numpy(np.concatenate([x, mirrored(x)]))).numpy()
            out = 0.5 * (both[:len(x)] + mirrored(both[len(x):]))
        else:
            out = self(torch.from_numpy(x)).numpy()
        return to_world(out * self.config.move_scale, rotation,
                        len(GRASP_ENDS[self.config.grasp]))

    def save(self, path: str | os.PathLike, info: dict[str, Any] | None = None) -> Path:
        """Write the network (float32 weights, its config and ``info``) atomically."""
        from latent_model.checkpoint import save_atomic

        return save_atomic({"format": FORMAT, "format_version": FORMAT_VERSION,
                            "config": asdict(self.config), "net": self.state_dict(),
                            "info": info or {}}, Path(path))

    @classmethod
    def load(cls, path: str | os.PathLike) -> MoveNetwork:
        """A network written by ``save`` (read as data: ``weights_only``)."""
        from latent_model.checkpoint import load_checkpoint

        data = load_checkpoint(Path(path), str(path), kind=FORMAT, version=FORMAT_VERSION)
        net = cls(DistilledConfig(**data["config"]))
        net.load_state_dict(data["net"])
        net.info = data.get("info", {})
        return net.eval()


class DistilledPolicy(CEMPolicy):
    """Acts by the network's move: no search.

    Args:
        network: A trained ``MoveNetwork``.
        success_threshold: The environment's success threshold, metres (it holds still
            within it).
        params: The cord (the network's training cord).
        settle_actions: Zero actions after each move, for the cord to come to rest.
    """

    def __init__(self, network: MoveNetwork, success_threshold: float = 0.02,
                 params: CordParams | None = None, settle_actions: int = 3, *,
                 success_metric: str = "error") -> None:
        self.network = network
        c = network.config
        super().__init__(params, c.grasp, c.max_step, success_threshold,
                         LatentMPCConfig(settle_actions=settle_actions),
                         success_metric=success_metric)

    @classmethod
    def for_env(cls, env: Any, network: MoveNetwork) -> DistilledPolicy:
        """The policy for a ``dlo_env`` environment; refuses another grasp or cord."""
        base = getattr(env, "unwrapped", env)
        c = network.config
        if base.grasp != c.grasp:
            raise InputError(f"the network moves grasp {c.grasp!r}, the environment holds "
                             f"{base.grasp!r}: distil one there")
        if base.params.n_points != c.n_points or abs(base.max_step - c.max_step) > 1e-12:
            raise InputError("the network was distilled for another cord or max_step")
        return cls(network, base.success_threshold, base.params,
                   success_metric=base.success_metric)

    def training_cost(self) -> tuple[int, str]:
        """The real-env steps the network trained on (0: all in the surrogate) and its
        sample cost in words, from its file's ``info``."""
        info = getattr(self.network, "info", {})
        plans, moves = info.get("expert_plans"), info.get("surrogate_moves")
        steps = int(info.get("real_env_steps", 0))
        if plans is None:
            return steps, "unknown (the network does not record it)"
        return steps, (f"{steps} env steps + {int(moves):,} surrogate moves "
                       f"({int(plans):,} latent-mpc plans)")

    def plan(self, shape: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """The network's plan ``(moves, ends, 2)``; its error is not predicted (NaN)."""
        t0 = time.perf_counter()
        plan = self.network.plans(shape[None].astype(np.float32),
                                  goal[None].astype(np.float32))[0]
        self.stats.plans += 1
        self.stats.seconds += time.perf_counter() - t0
        return plan.astype(np.float64), float("nan")

    def _execute(self, plan: np.ndarray) -> list[np.ndarray]:
        """Every move of the plan longer than ``MIN_MOVE`` (the first one when none is), each
        followed by zero actions while the cord comes to rest."""
        zero = np.zeros(2 * len(self.ends), dtype=np.float32)
        kept = [m for m in plan if np.linalg.norm(m, axis=-1).max() > MIN_MOVE] or [plan[0]]
        return [a for m in kept for a in self._actions(m[None]) + [zero] *
                self.config.settle_actions]
