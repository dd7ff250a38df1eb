"""The surrogate environments: throughput against the pymunk cord, and fidelity to it.

Three measurements, all in this run:

1. **Steps/s.** Random actions (autoresets included) in ``DLOEndpointSurrogate-v0`` made with
   ``gym.make_vec(..., vectorization_mode="vector_entry_point")`` at each ``--num-envs``,
   against ``DLOEndpoint-v0`` in one process (``gym.make``, resets included) and under
   ``gym.make_vec(..., vectorization_mode="async")``. The pymunk rate and the surrogate's are
   measured in turn, three times, and each speed-up is the median of the three ratios, so
   load that comes and goes during the run falls on both sides. Floors: >= 100x the
   one-process pymunk rate at 1 024 environments, >= 20x at 64.
2. **Oracle fidelity.** The test splits' reference actions replayed in the surrogate (each
   task's actions in one batch, shorter ones padded with zero actions, which leave a cord at
   rest where it is): the final error to the goal, median and share within 2, 1 and 0.5 cm, on
   both environments. Floor: >= 90 % within 1 cm on linear-3, in both. On linear-3 also
   with ``merge_runs=False`` (every step predicted as a move of its own), the ablation of the
   surrogate's straight-run rule.
3. **Drift.** From the linear-3 test starts, the same random actions in pymunk and in the
   surrogate; after 10, 20 and 50 steps, the error between the surrogate's shape and the shape
   the pymunk cord comes to rest in (``settled_metrics``), median and 90th percentile.

Usage::

    python benchmarks/surrogate_env.py [--device cpu] [--num-envs 1 64 1024 8192] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

import dlo_env  # noqa: F401  (registers the environments)
from dlo_env.shapes import error
from dlo_env.tasks import load_suite

REAL = {"head": "dlo_env/DLOEndpoint-v0", "both": "dlo_env/DLODualEndpoint-v0"}
SURROGATE = {"head": "dlo_env/DLOEndpointSurrogate-v0",
             "both": "dlo_env/DLODualEndpointSurrogate-v0"}
#: (num_envs, floor on the speed-up over one pymunk process; 0: none).
FLOORS = {64: 20.0, 1024: 100.0}
ORACLE_FLOOR = 0.90  # share of linear-3 test tasks within 1 cm
UNREACHABLE = 1e-9  # a success threshold no rollout meets: episodes never end early


@dataclass(frozen=True)
class Args:
    """Benchmark settings."""

    device: str = "cpu"
    num_envs: tuple[int, ...] = (1, 64, 1024, 8192)
    repeats: int = 3
    pymunk_steps: int = 600
    surrogate_seconds: float = 1.5
    async_envs: int = 2
    async_steps: int = 300
    suites: tuple[str, ...] = ("linear-1", "linear-3", "linear-5")
    drift_tasks: int = 50
    drift_steps: tuple[int, ...] = (10, 20, 50)
    seed: int = 0
    out: str = "runs/benchmarks/surrogate_env.json"


# ------------------------------------------------------------------ 1. throughput
def pymunk_rate(steps: int, seed: int) -> float:
    """Steps/s of the pymunk endpoint env in this process, random actions, resets included."""
    env = gym.make(REAL["head"])
    actions = np.random.default_rng(seed).uniform(-1, 1, (steps, 2)).astype(np.float32)
    env.reset(seed=seed)
    t = time.perf_counter()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - t)


def async_rate(num_envs: int, steps: int, seed: int) -> float:
    """Steps/s of ``num_envs`` pymunk envs under ``make_vec(..., "async")``."""
    envs = gym.make_vec(REAL["head"], num_envs=num_envs, vectorization_mode="async")
    try:
        envs.reset(seed=seed)
        rng = np.random.default_rng(seed)
        actions = rng.uniform(-1, 1, (steps, num_envs, 2)).astype(np.float32)
        envs.step(actions[0])
        t = time.perf_counter()
        for a in actions:
            envs.step(a)
        return num_envs * steps / (time.perf_counter() - t)
    finally:
        envs.close()


def surrogate_rate(num_envs: int, seconds: float, device: str, seed: int) -> float:
    """Steps/s of the surrogate vector env (random actions, autoresets included)."""
    venv = gym.make_vec(SURROGATE["head"], num_envs=num_envs,
                        vectorization_mode="vector_entry_point", device=device)
    venv.reset(seed=seed)
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-1, 1, (64, num_envs, 2)).astype(np.float32)
    for a in actions[:3]:
        venv.step(a)
    steps, t = 0, time.perf_counter()
    while time.perf_counter() - t < seconds or steps < 10:
        venv.step(actions[steps % len(actions)])
        steps += 1
    if device.startswith("cuda"):
        torch.cuda.synchronize()
    return num_envs * steps / (time.perf_counter() - t)


def throughput(args: Args) -> dict:
    """Part 1: every rate, the speed-ups and the floors' verdicts. The pymunk rate and the
    surrogate's are measured in turn ``repeats`` times, so load that comes and goes falls on
    both; each speed-up is the median over the repeats of surrogate / pymunk."""
    base_rates, rates = [], {n: [] for n in args.num_envs}
    for r in range(args.repeats):
        base_rates.append(pymunk_rate(args.pymunk_steps, args.seed + r))
        for n in args.num_envs:
            rates[n].append(surrogate_rate(n, args.surrogate_seconds, args.device, args.seed))
    base = float(np.median(base_rates))
    asyn = async_rate(args.async_envs, args.async_steps, args.seed)
    print(f"pymunk DLOEndpoint-v0, one process: {', '.join(f'{b:,.0f}' for b in base_rates)} "
          f"steps/s in {args.repeats} turns (median {base:,.0f})")
    print(f"pymunk under make_vec async, {args.async_envs} envs: {asyn:,.0f} steps/s "
          f"({asyn / base:.2f}x one process)")
    ok = True
    rows = []
    for n, measured in rates.items():
        speedup = float(np.median([m / b for m, b in zip(measured, base_rates)]))
        rate = float(np.median(measured))
        floor = FLOORS.get(n, 0.0)
        passed = speedup >= floor
        ok &= passed
        verdict = f"floor {floor:.0f}x: {'PASS' if passed else 'FAIL'}" if floor else ""
        print(f"surrogate num_envs={n:5d}: {rate:12,.0f} steps/s  {speedup:7.1f}x pymunk  "
              f"{rate / asyn:7.1f}x async  {verdict}")
        rows.append({"num_envs": n, "steps_per_s": rate, "speedup": speedup,
                     "floor": floor, "pass": passed})
    return {"pymunk_steps_per_s": base, "pymunk_turns": base_rates,
            "async_steps_per_s": asyn, "async_envs": args.async_envs, "surrogate": rows,
            "pass": ok if all(n in rates for n in FLOORS) else None}


# ------------------------------------------------------------------ 2. oracle fidelity
def oracle_errors(grasp: str, suite: str, device: str, merge_runs: bool = True) -> np.ndarray:
    """Final surrogate error to the goal of each test task after its reference actions."""
    tasks = load_suite(suite, "test", grasp=grasp)
    longest = max(len(t.reference_actions) for t in tasks)
    width = tasks[0].reference_actions.shape[1]
    actions = np.zeros((longest, len(tasks), width), dtype=np.float32)
    for i, t in enumerate(tasks):
        actions[:len(t.reference_actions), i] = t.reference_actions
    venv = gym.make_vec(SURROGATE[grasp], num_envs=len(tasks),
                        vectorization_mode="vector_entry_point", device=device,
                        success_threshold=UNREACHABLE, max_episode_steps=longest + 1,
                        merge_runs=merge_runs)
    obs, _ = venv.reset(options={"task": tasks})
    for a in actions:
        obs = venv.step(a)[0]
    return np.asarray(error(obs["achieved_goal"], obs["desired_goal"]))


def fidelity(args: Args) -> dict:
    """Part 2: the oracle's final errors in the surrogate, per environment and suite."""
    rows, ok = [], True
    print("oracle actions in the surrogate, test splits (final error to the goal):")
    for grasp in ("head", "both"):
        for suite in args.suites:
            e = oracle_errors(grasp, suite, args.device)
            within = {cm: float((e <= cm / 100).mean()) for cm in (2, 1, 0.5)}
            line = (f"  {SURROGATE[grasp].split('/')[1]:28s} {suite:9s} median "
                    f"{100 * np.median(e):.2f} cm  within 2/1/0.5 cm: "
                    f"{within[2]:.0%} / {within[1]:.0%} / {within[0.5]:.0%}")
            if suite == "linear-3":
                passed = within[1] >= ORACLE_FLOOR
                ok &= passed
                line += f"  (floor {ORACLE_FLOOR:.0%} at 1 cm: {'PASS' if passed else 'FAIL'})"
            print(line)
            rows.append({"grasp": grasp, "suite": suite, "tasks": len(e), "merge_runs": True,
                         "median_cm": 100 * float(np.median(e)),
                         "within_cm": {str(k): v for k, v in within.items()}})
            if suite == "linear-3":  # the ablation: every step a move of its own
                e = oracle_errors(grasp, suite, args.device, merge_runs=False)
                print(f"  {'':28s} {'':9s} median {100 * np.median(e):.2f} cm  within 1 cm: "
                      f"{(e <= 0.01).mean():.0%}  with merge_runs=False (each step its own "
                      f"move)")
                rows.append({"grasp": grasp, "suite": suite, "tasks": len(e),
                             "merge_runs": False, "median_cm": 100 * float(np.median(e)),
                             "within_cm": {"1": float((e <= 0.01).mean())}})
    return {"rows": rows, "pass": ok if "linear-3" in args.suites else None}


# ------------------------------------------------------------------ 3. drift
def drift(args: Args) -> dict:
    """Part 3: how far the surrogate's random rollouts drift from pymunk's, at rest."""
    print(f"random-policy drift from {args.drift_tasks} linear-3 test starts (surrogate vs "
          f"the pymunk cord at rest):")
    out = []
    for grasp in ("head", "both"):
        tasks = load_suite("linear-3", "test", grasp=grasp, limit=args.drift_tasks)
        width = tasks[0].reference_actions.shape[1]
        horizon = max(args.drift_steps)
        rng = np.random.default_rng(args.seed)
        actions = rng.uniform(-1, 1, (horizon, len(tasks), width)).astype(np.float32)
        venv = gym.make_vec(SURROGATE[grasp], num_envs=len(tasks),
                            vectorization_mode="vector_entry_point", device=args.device,
                            success_threshold=UNREACHABLE, max_episode_steps=horizon + 1)
        obs, _ = venv.reset(options={"task": tasks})
        sur = {}
        for j, a in enumerate(actions, start=1):
            obs = venv.step(a)[0]
            if j in args.drift_steps:
                sur[j] = obs["achieved_goal"].reshape(len(tasks), -1, 2).copy()
        real = {j: [] for j in args.drift_steps}
        env = gym.make(REAL[grasp], success_threshold=UNREACHABLE,
                       max_episode_steps=horizon + 1).unwrapped
        for i, task in enumerate(tasks):
            env.reset(options={"task": task})
            for j in range(1, horizon + 1):
                env.step(actions[j - 1, i])
                if j in args.drift_steps:
                    real[j].append(env.settled_metrics()["shape"])
        for j in args.drift_steps:
            e = np.asarray(error(sur[j], np.stack(real[j])))
            print(f"  {SURROGATE[grasp].split('/')[1]:28s} after {j:3d} steps: median "
                  f"{100 * np.median(e):.2f} cm, 90th percentile {100 * np.percentile(e, 90):.2f}"
                  f" cm")
            out.append({"grasp": grasp, "steps": j, "median_cm": 100 * float(np.median(e)),
                        "p90_cm": 100 * float(np.percentile(e, 90))})
    return {"rows": out}


def main() -> None:
    """Parse arguments, run the three parts, print and save the numbers."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=Args.device, help="torch device of the surrogate")
    parser.add_argument("--num-envs", type=int, nargs="+", default=None, metavar="N",
                        help=f"surrogate batch sizes of the throughput part (default: "
                             f"{' '.join(map(str, Args.num_envs))}; 1 64 with --quick)")
    parser.add_argument("--quick", action="store_true",
                        help="a smoke run: fewer steps, one suite, 10 drift tasks")
    parser.add_argument("--out", default=Args.out, help="JSON file of the numbers")
    parsed = parser.parse_args()
    if parsed.num_envs is not None and min(parsed.num_envs) < 1:
        parser.error(f"--num-envs must be ints >= 1, got {parsed.num_envs}")
    num_envs = tuple(parsed.num_envs or ((1, 64) if parsed.quick else Args.num_envs))
    args = Args(device=parsed.device, out=parsed.out, num_envs=num_envs)
    if parsed.quick:
        args = replace(args, pymunk_steps=200, repeats=1, surrogate_seconds=0.5, async_steps=30,
                       suites=("linear-1",), drift_tasks=4, drift_steps=(10,))
    torch.set_num_threads(max(1, torch.get_num_threads()))
    print(f"torch {torch.__version__} on {args.device} ({torch.get_num_threads()} threads), "
          f"gymnasium {gym.__version__}, {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.2f}")
    result = {"args": asdict(args), "throughput": throughput(args),
              "fidelity": fidelity(args), "drift": drift(args)}
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=1))
    tmp.replace(out)
    checked = [result["throughput"]["pass"], result["fidelity"]["pass"]]
    verdict = "PASS" if all(checked) else "FAIL" if False in checked else "not all measured"
    print(f"floors (speed-up at 64 and 1 024 envs, oracle at 1 cm on linear-3): {verdict}; "
          f"numbers in {out}")


if __name__ == "__main__":
    main()
