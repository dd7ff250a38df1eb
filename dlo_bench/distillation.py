"""Distil latent-mpc into a network by DAgger in the surrogate (``latent-mpc-distilled``).

Each round draws tasks in the surrogate (``latent_model.surrogate_env.SurrogateCords``), rolls
them out plan by plan (the expert's plans in the first round, the network's after, each
executed whole through the model), and asks the expert, planning afresh from every state the
rollout visits, for its plan there (Ross et al. 2011). The network is trained on every label so
far. No pymunk step is taken: the rollouts are the transition model's, and the labels cost the
expert's planning only (its calls are counted as the sample cost).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dlo_env.core.checks import positive, positive_ints
from dlo_env.errors import InputError
from dlo_env.shapes import error

if TYPE_CHECKING:
    from planners.distilled import MoveNetwork

#: File name of a distilled network in its folder and in ``dlo_bench/pretrained``.
NETWORK_FILE = "distilled.pt"
#: File name of a run's state after its last finished round (``distil`` resumes from it).
STATE_FILE = "distil-state.pt"
STATE_FORMAT = "dlo-distil-state"


@dataclass(frozen=True)
class DistillConfig:
    """A DAgger run.

    Attributes:
        grasp: ``"head"`` (``DLOEndpoint-v0``) or ``"both"`` (``DLODualEndpoint-v0``).
        difficulties: Task difficulties drawn in the surrogate.
        rounds: DAgger rounds (the first rolls out the expert).
        tasks_per_round: Tasks rolled out each round.
        horizon: Most plans (decisions) of a rollout.
        threshold: Success threshold of the expert and the rollouts, metres.
        epochs: Passes over all labels after each round.
        batch_size: Training minibatch.
        learning_rate: Adam's step size.
        width: Hidden units of the network.
        mirror: Train on every label's mirror image too (the cord's frame reflected about
            its x-axis: the mirrored cord and goal, the mirrored plan; the table's physics is
            mirror-symmetric).
        seed: Seed of the tasks, the expert and the network.
    """

    grasp: str = "head"
    difficulties: tuple[int, ...] = (1, 2, 3, 4, 5)
    rounds: int = 5
    tasks_per_round: int = 400
    horizon: int = 4
    threshold: float = 0.01
    epochs: int = 40
    batch_size: int = 256
    learning_rate: float = 1e-3
    width: int = 256
    mirror: bool = True
    seed: int = 0

    def __post_init__(self) -> None:
        positive_ints(self, "rounds", "tasks_per_round", "horizon", "epochs", "batch_size",
                      "width")
        positive(self, "threshold", "learning_rate")
        if self.grasp not in ("head", "both"):
            raise InputError(f"DistillConfig.grasp must be 'head' or 'both', got "
                             f"{self.grasp!r}")


def _expert_plans(expert: Any, shapes: np.ndarray, goals: np.ndarray, moves: int
                  ) -> np.ndarray:
    """The expert's plan ``(B, moves, ends, 2)`` from each state, planned afresh (a shorter
    horizon's plan ends in still moves)."""
    out = np.zeros((len(shapes), moves, len(expert.ends), 2), dtype=np.float32)
    for i, (shape, goal) in enumerate(zip(shapes.astype(np.float64), goals.astype(np.float64))):
        expert.reset()
        plan, _ = expert.plan(shape, goal)
        out[i, :len(plan)] = plan[:moves]
    return out


def _roll_out(dynamics: Any, shapes: np.ndarray, plans: np.ndarray) -> np.ndarray:
    """The shapes at rest after every move of ``plans`` ``(B, moves, ends, 2)``, through the
    model (a still move leaves a cord where it is)."""
    import torch

    state = torch.from_numpy(np.ascontiguousarray(shapes, dtype=np.float32))
    with torch.no_grad():
        for j in range(plans.shape[1]):
            move = torch.from_numpy(plans[:, j].reshape(len(shapes), -1).astype(np.float32))
            state = dynamics.step(state, move)
    return state.numpy()


def _fit(net: MoveNetwork, x: np.ndarray, y: np.ndarray, config: DistillConfig,
         rng: np.random.Generator) -> float:
    """Train ``net`` on every label (and its mirror image); the last epoch's mean loss."""
    import torch

    from planners.distilled import mirrored

    if config.mirror:
        x, y = np.concatenate([x, mirrored(x)]), np.concatenate([y, mirrored(y)])
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


def _load_state(path: Path, config: DistillConfig) -> dict[str, Any]:
    """A run's state, refused (one line) when it is another config's."""
    from latent_model.checkpoint import load_checkpoint

    state = load_checkpoint(path, str(path), kind=STATE_FORMAT, version=1)
    if {**state["config"], "rounds": config.rounds} != asdict(config):
        raise InputError(f"{path} is the state of another distillation (config "
                         f"{state['config']}): give another out folder, or the same config")
    return state


def distil(config: DistillConfig, out: str | os.PathLike,
           log: Callable[[str], None] = print) -> Path:
    """Run DAgger and write the network to ``out/distilled.pt``.

    After every round the labels, the network and the random state are written to
    ``out/distil-state.pt``; a run of the same config in the same folder resumes after the
    last finished round (more ``rounds`` extend it; another config there is refused).

    Returns:
        The network's path. Its ``info`` records the config, the labels (expert plans), the
        surrogate moves rolled out, the seconds, and each round's success in the surrogate.
    """
    import torch

    from latent_model import TransitionModel
    from latent_model.checkpoint import save_atomic
    from latent_model.surrogate_env import SurrogateCords
    from planners.distilled import DistilledConfig, MoveNetwork, features, to_frame
    from planners.latent_mpc import LatentMPCConfig, LatentMPCPolicy

    rng = np.random.default_rng(config.seed)
    model = TransitionModel.load_pretrained(device="cpu")
    model.requires_grad_(False)
    cords = SurrogateCords(config.tasks_per_round, config.grasp, model, "cpu", None,
                           model.config.max_step)
    # The shipped networks' expert: latent-mpc's CEM without the gradient polish.
    expert = LatentMPCPolicy(model, config.grasp, success_threshold=config.threshold,
                             config=LatentMPCConfig(seed=config.seed, polish_steps=0))
    horizon = max(expert.config.moves, expert.config.far_moves)
    net = MoveNetwork(DistilledConfig(grasp=config.grasp, width=config.width, moves=horizon,
                                      max_step=model.config.max_step))
    scale = net.config.move_scale
    xs: list[np.ndarray] = []
    ys: list[np.ndarray] = []
    rounds: list[dict[str, Any]] = []
    moves_rolled, seconds = 0, 0.0
    state_path = Path(out) / STATE_FILE
    if state_path.exists():
        state = _load_state(state_path, config)
        xs, ys = [state["x"].numpy()], [state["y"].numpy()]
        net.load_state_dict(state["net"])
        rng.bit_generator.state = state["rng"]
        rounds, moves_rolled, seconds = state["rounds"], state["moves_rolled"], state["seconds"]
        log(f"resuming after round {len(rounds) - 1} ({state_path})")
    t0 = time.perf_counter() - seconds
    for r in range(len(rounds), config.rounds):
        torch.manual_seed(config.seed + r)
        tasks = cords.draw_tasks(rng, config.tasks_per_round, tuple(config.difficulties),
                                 config.threshold)
        shapes, goals = tasks.starts.copy(), tasks.goals
        active = np.ones(len(shapes), dtype=bool)
        for _ in range(config.horizon):
            active &= np.asarray(error(shapes, goals)) > config.threshold
            idx = np.flatnonzero(active)
            if not len(idx):
                break
            labels = _expert_plans(expert, shapes[idx], goals[idx], horizon)
            x, rotation = features(shapes[idx], goals[idx])
            xs.append(x)
            ys.append(to_frame(labels, rotation) / scale)
            plans = labels if r == 0 else net.plans(shapes[idx], goals[idx])
            shapes[idx] = _roll_out(cords.dynamics, shapes[idx], plans)
            moves_rolled += len(idx) * horizon
        solved = float((np.asarray(error(shapes, goals)) <= config.threshold).mean())
        loss = _fit(net, np.concatenate(xs), np.concatenate(ys).astype(np.float32), config, rng)
        rounds.append({"round": r, "labels": int(sum(len(x) for x in xs)),
                       "rollout_success": solved, "loss": loss})
        log(f"round {r}: {'expert' if r == 0 else 'network'} rollouts solved {solved:.0%} in "
            f"the surrogate; {rounds[-1]['labels']} labels; loss {loss:.4f}; "
            f"{time.perf_counter() - t0:.0f} s")
        xs, ys = [np.concatenate(xs)], [np.concatenate(ys).astype(np.float32)]
        state_path.parent.mkdir(parents=True, exist_ok=True)
        save_atomic({"format": STATE_FORMAT, "format_version": 1, "config": asdict(config),
                     "x": torch.from_numpy(xs[0]), "y": torch.from_numpy(ys[0]),
                     "net": net.state_dict(), "rng": rng.bit_generator.state,
                     "rounds": rounds, "moves_rolled": moves_rolled,
                     "seconds": time.perf_counter() - t0}, state_path)
    path = Path(out) / NETWORK_FILE
    net.eval()
    return net.save(path, info={"config": asdict(config), "expert": "latent-mpc",
                                "expert_plans": rounds[-1]["labels"],
                                "surrogate_moves": moves_rolled, "real_env_steps": 0,
                                "seconds": time.perf_counter() - t0, "rounds": rounds})
