"""latent-mpc-distilled: a network that proposes latent-mpc's next straight move in one call.

The network sees the cord and the goal in a frame attached to the cord (origin at the head,
x-axis from the head towards the cord's centroid), so it turns and shifts with the task by
construction, and answers with the first move of the plan latent-mpc would make from there
(``dlo_bench.distillation`` trains it by DAgger in the surrogate). The policy executes that move
as latent-mpc executes its plans (``split_move`` actions, then zero actions while the cord comes
to rest) and asks again: a millisecond-scale decision instead of a search.
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
FORMAT_VERSION = 1


@dataclass(frozen=True)
class DistilledConfig:
    """The network's size and the setting it was trained for.

    Attributes:
        grasp: The held end(s): ``"head"`` or ``"both"``.
        n_points: Points of the cord.
        width: Hidden units per layer.
        depth: Hidden layers.
        move_scale: Moves are output in units of this, metres.
        max_step: The environments' ``max_step``, metres.
    """

    grasp: str = "head"
    n_points: int = 20
    width: int = 256
    depth: int = 3
    move_scale: float = 0.2
    max_step: float = DEFAULT_MAX_STEP

    @property
    def outputs(self) -> int:
        """Numbers of one move: 2 per held end."""
        return 2 * len(GRASP_ENDS[self.grasp])


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


def to_world(moves: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Moves ``(B, ends * 2)`` in the cords' frames -> world ``(B, ends, 2)``."""
    m = moves.reshape(len(moves), -1, 2)
    return np.einsum("bji,bej->bei", rotation, m)


def to_frame(moves: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """World moves ``(B, ends, 2)`` -> ``(B, ends * 2)`` in the cords' frames."""
    return np.einsum("bij,bej->bei", rotation, moves).reshape(len(moves), -1)


class MoveNetwork(nn.Module):
    """An MLP from ``features`` to a move in the cord's frame (units of ``move_scale``)."""

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
    def moves(self, shapes: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """World moves ``(B, ends, 2)`` (metres) from cords and goals ``(B, n, 2)``."""
        x, rotation = features(shapes, goals)
        out = self(torch.from_numpy(x)).numpy() * self.config.move_scale
        return to_world(out, rotation)

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

    def plan(self, shape: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """The network's move ``(1, ends, 2)``; its error is not predicted (NaN)."""
        t0 = time.perf_counter()
        move = self.network.moves(shape[None].astype(np.float32), goal[None].astype(np.float32))
        self.stats.plans += 1
        self.stats.seconds += time.perf_counter() - t0
        return move.astype(np.float64), float("nan")

    def _execute(self, plan: np.ndarray) -> list[np.ndarray]:
        zero = np.zeros(2 * len(self.ends), dtype=np.float32)
        return self._actions(plan[:1]) + [zero] * self.config.settle_actions
