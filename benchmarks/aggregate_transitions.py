"""One round of data aggregation: the moves latent-mpc makes where its transition model is wrong.

latent-mpc (its defaults, the transition model given by ``--transition-model``) runs on the
train splits of the benchmark's suites up to ``linear-5`` in both environments (the round as
documented; the long horizons would add moves of the same kind). Every move it executes is
recorded with the shape it was planned from, carried out again in the simulator exactly as
transition data is made (``carry_out``: ``split_move`` actions, then zero actions until the cord
is at rest, from the shape at rest), and kept when the model's prediction is more than
``--threshold`` from what the simulator did. The kept transitions are written as a transition
file to add to the training data (test splits are never touched). ``summary.json`` states the
sample cost of the round: the environment steps of latent-mpc's rollouts and of the replayed
moves.

    python benchmarks/aggregate_transitions.py
    dlo train --stage transition --data data/transitions-train.npz \\
        data/transitions-train-2.npz runs/aggregate/aggregated.npz \\
        --heldout data/transitions-heldout.npz --init latent_model/pretrained/transition.pt \\
        --lr 3e-4 --steps 6000 --threads 1 --out runs/transition-aggregated
    dlo benchmark --agent latent-mpc --transition-model runs/transition-aggregated \\
        --out runs/benchmark-aggregated
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

#: The hardest suite a round runs.
AGGREGATE_MAX_DIFFICULTY = 5


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200,
                        help="first train tasks of each suite (the train splits have 200)")
    parser.add_argument("--threshold", type=float, default=0.005,
                        help="keep moves the model predicts worse than this, metres")
    parser.add_argument("--transition-model", default=None,
                        help="transition model file or folder (None: the shipped one)")
    parser.add_argument("--out", default="runs/aggregate",
                        help="output folder (aggregated.npz, summary.json)")
    args = parser.parse_args()

    import gymnasium as gym
    import torch

    import dlo_env  # noqa: F401  (registers the environments)
    from dlo_bench.agents import load_transition_model
    from dlo_bench.benchmark import DEFAULT_DIFFICULTIES
    from dlo_bench.evaluation import evaluate
    from dlo_env.atomic import write_text_atomic
    from dlo_env.cord import Cord
    from dlo_env.dataset.transitions import (
        GRASP_NAMES,
        TransitionDataset,
        carry_out,
        save_transitions,
    )
    from dlo_env.envs import ENVIRONMENTS
    from dlo_env.shapes import error
    from dlo_env.tasks import MAX_SETTLE_ACTIONS, SUITES, split_move
    from planners.latent_mpc import LatentMPCPolicy

    torch.set_num_threads(1)
    model = load_transition_model(args.transition_model)

    class Recording(LatentMPCPolicy):
        """latent-mpc that remembers each executed move and the shape it was planned from."""

        def __init__(self, *args, **kwargs) -> None:
            self.executed: list[tuple[np.ndarray, np.ndarray]] = []
            super().__init__(*args, **kwargs)

        def _execute(self, plan: np.ndarray) -> list[np.ndarray]:
            self.executed.append((self._planned_from, plan[0].reshape(-1).copy()))
            return super()._execute(plan)

        def plan(self, shape: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
            self._planned_from = shape.astype(np.float32).copy()
            return super().plan(shape, goal)

    rows: dict[str, list] = {k: [] for k in ("start", "next", "grasp", "displacement", "moved",
                                             "settle")}
    summary: dict[str, dict] = {}
    t0 = time.perf_counter()
    for env_id, difficulties in DEFAULT_DIFFICULTIES.items():
        grasp = ENVIRONMENTS[env_id][0]
        code = GRASP_NAMES.index(grasp)
        for difficulty in (d for d in difficulties if d <= AGGREGATE_MAX_DIFFICULTY):
            suite = next(name for name, k in SUITES.items() if k == difficulty)
            with gym.make(env_id) as env:
                policy = Recording.for_env(env, model=model)
            result = evaluate(policy, env_id, suite=suite, episodes=args.episodes, split="train",
                              agent="latent-mpc", fidelity=False)
            errors, replayed = [], 0
            for shape, move in policy.executed:
                cord = Cord(model.cord_params, grasp=grasp)
                cord.reset(shape)
                nxt, commanded, moved, settle = carry_out(cord, move, model.config.max_step)
                replayed += len(split_move(move, model.config.max_step)) + settle
                predicted = model.predict(shape, grasp, move)
                errors.append(float(error(predicted, nxt)))
                if errors[-1] > args.threshold:
                    for name, value in (("start", shape), ("next", nxt), ("grasp", code),
                                        ("displacement", commanded), ("moved", moved),
                                        ("settle", settle)):
                        rows[name].append(value)
            errors = np.array(errors) if errors else np.zeros(1)
            cell = f"{ENVIRONMENTS[env_id][1]} d{difficulty}"
            rollout = int(sum(r.steps for r in result.records))
            summary[cell] = {"train_success": result.summary["success_rate"],
                             "moves": len(policy.executed),
                             "mean_error_cm": 100 * float(errors.mean()),
                             "kept": int((errors > args.threshold).sum()),
                             "rollout_env_steps": rollout, "replayed_env_steps": replayed}
            print(f"{cell}: train success {result.summary['success_rate']:.0%}, "
                  f"{len(policy.executed)} moves, model error mean {100 * errors.mean():.2f} cm, "
                  f"{(errors > args.threshold).sum()} above {100 * args.threshold:.1f} cm "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    count = len(rows["grasp"])
    settle = np.array(rows["settle"], dtype=np.int8)
    data = TransitionDataset(
        start=np.array(rows["start"], dtype=np.float32).reshape(count, -1, 2),
        next=np.array(rows["next"], dtype=np.float32).reshape(count, -1, 2),
        grasp=np.array(rows["grasp"], dtype=np.int8),
        displacement=np.array(rows["displacement"], dtype=np.float32).reshape(count, 2, 2),
        moved=np.array(rows["moved"], dtype=np.float32).reshape(count, 2, 2),
        episode=np.arange(count, dtype=np.int64), step=np.zeros(count, dtype=np.int64),
        settle=settle, at_rest=settle < MAX_SETTLE_ACTIONS,
        metadata={"cord": asdict(model.cord_params),
                  "collect": {"max_step": model.config.max_step,
                              "source": "latent-mpc on the train splits",
                              "threshold": args.threshold}})
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    save_transitions(out / "aggregated.npz", data)
    cells = [v for v in summary.values()]
    summary["total"] = {"kept": count, "kept_env_steps": data.env_steps(),
                        "rollout_env_steps": sum(v["rollout_env_steps"] for v in cells),
                        "replayed_env_steps": sum(v["replayed_env_steps"] for v in cells),
                        "seconds": time.perf_counter() - t0}
    write_text_atomic(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    print(f"wrote {count} transitions ({data.env_steps()} env steps) to {out / 'aggregated.npz'}")


if __name__ == "__main__":
    main()
