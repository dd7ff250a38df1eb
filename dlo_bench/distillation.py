"""Distil latent-mpc into a network by DAgger in the surrogate (``latent-mpc-distilled``).

Each round draws tasks in the surrogate (``latent_model.surrogate_env.SurrogateCords``), rolls
them out move by move (the expert's moves in the first round, the network's after), and asks
the expert, planning afresh from every state the rollout visits, for its first move there
(Ross et al. 2011). The network is trained on every label so far. No pymunk step is taken: the
rollouts are the transition model's, and the labels cost the expert's planning only (its
calls are counted as the sample cost).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from dlo_env.core.checks import positive, positive_ints
from dlo_env.errors import InputError
from dlo_env.shapes import error
from planners.distilled import DistilledConfig, MoveNetwork, features, to_frame

#: File name of a distilled network in its folder and in ``dlo_bench/pretrained``.
NETWORK_FILE = "distilled.pt"


@dataclass(frozen=True)
class DistillConfig:
    """A DAgger run.

    Attributes:
        grasp: ``"head"`` (``DLOEndpoint-v0``) or ``"both"`` (``DLODualEndpoint-v0``).
        difficulties: Task difficulties drawn in the surrogate.
        rounds: DAgger rounds (the first rolls out the expert).
        tasks_per_round: Tasks rolled out each round.
        horizon: Most moves of a rollout.
        threshold: Success threshold of the expert and the rollouts, metres.
        epochs: Passes over all labels after each round.
        batch_size: Training minibatch.
        learning_rate: Adam's step size.
        width: Hidden units of the network.
        seed: Seed of the tasks, the expert and the network.
    """

    grasp: str = "head"
    difficulties: tuple[int, ...] = (1, 2, 3, 4, 5)
    rounds: int = 5
    tasks_per_round: int = 400
    horizon: int = 8
    threshold: float = 0.01
    epochs: int = 40
    batch_size: int = 256
    learning_rate: float = 1e-3
    width: int = 256
    seed: int = 0

    def __post_init__(self) -> None:
        positive_ints(self, "rounds", "tasks_per_round", "horizon", "epochs", "batch_size",
                      "width")
        positive(self, "threshold", "learning_rate")
        if self.grasp not in ("head", "both"):
            raise InputError(f"DistillConfig.grasp must be 'head' or 'both', got "
                             f"{self.grasp!r}")


def _expert_moves(expert: Any, shapes: np.ndarray, goals: np.ndarray) -> np.ndarray:
    """The expert's first move ``(B, ends, 2)`` from each state, planned afresh."""
    out = []
    for shape, goal in zip(shapes.astype(np.float64), goals.astype(np.float64)):
        expert.reset()
        plan, _ = expert.plan(shape, goal)
        out.append(plan[0])
    return np.asarray(out, dtype=np.float32)


def _fit(net: MoveNetwork, x: np.ndarray, y: np.ndarray, config: DistillConfig,
         rng: np.random.Generator) -> float:
    """Train ``net`` on every label; the last epoch's mean loss."""
    optimizer = torch.optim.Adam(net.parameters(), lr=config.learning_rate)
    xs, ys = torch.from_numpy(x), torch.from_numpy(y)
    loss_sum = 0.0
    for _ in range(config.epochs):
        order = rng.permutation(len(x))
        loss_sum = 0.0
        for lo in range(0, len(x), config.batch_size):
            idx = torch.from_numpy(order[lo:lo + config.batch_size])
            loss = torch.nn.functional.smooth_l1_loss(net(xs[idx]), ys[idx], beta=0.05)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            loss_sum += float(loss.detach()) * len(idx)
    return loss_sum / len(x)


def distil(config: DistillConfig, out: str | os.PathLike,
           log: Callable[[str], None] = print) -> Path:
    """Run DAgger and write the network to ``out/distilled.pt``.

    Returns:
        The network's path. Its ``info`` records the config, the labels (expert plans), the
        surrogate moves rolled out, the seconds, and each round's success in the surrogate.
    """
    from latent_model import TransitionModel
    from latent_model.surrogate_env import SurrogateCords
    from planners.latent_mpc import LatentMPCConfig, LatentMPCPolicy

    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    model = TransitionModel.load_pretrained(device="cpu")
    model.requires_grad_(False)
    cords = SurrogateCords(config.tasks_per_round, config.grasp, model, "cpu", None,
                           model.config.max_step)
    expert = LatentMPCPolicy(model, config.grasp, success_threshold=config.threshold,
                             config=LatentMPCConfig(seed=config.seed))
    net = MoveNetwork(DistilledConfig(grasp=config.grasp, width=config.width,
                                      max_step=model.config.max_step))
    scale = net.config.move_scale
    xs: list[np.ndarray] = []
    ys: list[np.ndarray] = []
    rounds, moves_rolled, t0 = [], 0, time.perf_counter()
    for r in range(config.rounds):
        tasks = cords.draw_tasks(rng, config.tasks_per_round, tuple(config.difficulties),
                                 config.threshold)
        shapes, goals = tasks.starts.copy(), tasks.goals
        active = np.ones(len(shapes), dtype=bool)
        for _ in range(config.horizon):
            active &= np.asarray(error(shapes, goals)) > config.threshold
            idx = np.flatnonzero(active)
            if not len(idx):
                break
            labels = _expert_moves(expert, shapes[idx], goals[idx])
            x, rotation = features(shapes[idx], goals[idx])
            xs.append(x)
            ys.append(to_frame(labels, rotation) / scale)
            moves = labels if r == 0 else net.moves(shapes[idx], goals[idx])
            with torch.no_grad():
                shapes[idx] = cords.dynamics.step(
                    torch.from_numpy(shapes[idx]),
                    torch.from_numpy(moves.reshape(len(idx), -1).astype(np.float32))).numpy()
            moves_rolled += len(idx)
        solved = float((np.asarray(error(shapes, goals)) <= config.threshold).mean())
        loss = _fit(net, np.concatenate(xs), np.concatenate(ys).astype(np.float32), config, rng)
        rounds.append({"round": r, "labels": int(sum(len(x) for x in xs)),
                       "rollout_success": solved, "loss": loss})
        log(f"round {r}: {'expert' if r == 0 else 'network'} rollouts solved {solved:.0%} in "
            f"the surrogate; {rounds[-1]['labels']} labels; loss {loss:.4f}; "
            f"{time.perf_counter() - t0:.0f} s")
    path = Path(out) / NETWORK_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    net.eval()
    return net.save(path, info={"config": asdict(config), "expert": "latent-mpc",
                                "expert_plans": rounds[-1]["labels"],
                                "surrogate_moves": moves_rolled, "real_env_steps": 0,
                                "seconds": time.perf_counter() - t0, "rounds": rounds})
