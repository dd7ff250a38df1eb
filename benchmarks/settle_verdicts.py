"""The at-rest verdicts of replayed suite episodes: record them, or compare them with a record.

    python benchmarks/settle_verdicts.py [--out runs/settle_verdicts.json]
    python benchmarks/settle_verdicts.py --compare runs/settle_verdicts_before.json

Replays the first tasks of linear, designed, peg and route suites in both environments
(``DLOEndpoint-v0``, ``DLODualEndpoint-v0``) with deterministic agents: the straight-line
agent, and the tasks' reference actions where a task has them (then zero actions). Episodes
last at most ``--max-steps`` steps (fewer when the suite says so): after their moves the agents
only send zero actions to a cord at rest. For every episode it records the verdicts: success,
the steps taken, the errors of the last step, the errors of the shape the cord rests in
(``settled_metrics``), how often the environment judged a moving cord near the goal (the at-rest
trial) and what it decided, and a digest of the whole episode (every shape, reward, termination
and ``settle_actions``), then writes them as JSON.

To check a change of the environments, record with the code before it (a ``git worktree`` of
that commit on ``PYTHONPATH``) and compare with the code after it: every verdict and every
digest must be equal (exit status 1 otherwise).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import build_agent
from dlo_bench.evaluation import suite_tasks, task_env_kwargs
from dlo_env.tasks import REST_CHECK_MARGIN

ENVS = ("dlo_env/DLOEndpoint-v0", "dlo_env/DLODualEndpoint-v0")
#: Suite -> tasks replayed per environment and agent.
SUITES = {"linear-1": 12, "linear-3": 12, "shapes-curves": 14, "pegs-2": 12, "route-2": 8}
MAX_STEPS = 60
METRICS = ("error", "max_error", "direction_free_error", "bead_share")


def replay(env: gym.Env, options: dict[str, Any], policy: Any) -> dict[str, Any] | None:
    """One episode on the task of ``options``: ``policy`` acts, or with None the task's
    reference actions (then zero actions). Returns its verdicts (None: no reference actions)."""
    base = env.unwrapped
    obs, info = env.reset(options=options)
    width = env.action_space.shape[0]
    queue = list(info["reference_actions"])
    if policy is None and not queue:
        return None
    digest = hashlib.sha256(np.asarray(obs["achieved_goal"]).tobytes())
    trials = {"settled": 0, "declined": 0}
    steps, start = 0, True
    while True:
        if policy is not None:
            action, _ = policy.predict(obs, episode_start=np.array([start]), deterministic=True)
        else:
            action = queue.pop(0) if queue else np.zeros(width, dtype=np.float32)
        start = False
        obs, reward, terminated, truncated, info = env.step(np.asarray(action).reshape(-1))
        steps += 1
        digest.update(np.asarray(obs["achieved_goal"]).tobytes())
        digest.update(np.array([reward, terminated, truncated, info["settle_actions"]],
                               dtype=np.float64).tobytes())
        # A trial runs on a moving cord near the goal: it settles the cord or declines.
        near = info[base.success_metric] <= base.success_threshold + REST_CHECK_MARGIN
        if info["settle_actions"]:
            trials["settled"] += 1
        elif near and not info["at_rest"]:
            trials["declined"] += 1
        if terminated or truncated:
            break
    rest = base.settled_metrics()
    return {
        "success": bool(info["is_success"]),
        "steps": steps,
        "at_rest": bool(info["at_rest"]),
        **{f"final_{k}": float(info[k]) for k in METRICS},
        **{f"rest_{k}": float(rest[k]) for k in METRICS},
        "rest_at_rest": bool(rest["at_rest"]),
        "trials": trials,
        "digest": digest.hexdigest(),
    }


def record(max_steps: int) -> dict[str, Any]:
    """Every episode's verdicts, keyed ``env suite agent index``."""
    episodes = {}
    for env_id in ENVS:
        for suite, count in SUITES.items():
            kwargs = task_env_kwargs(suite=suite)
            kwargs["max_episode_steps"] = min(kwargs["max_episode_steps"], max_steps)
            env = gym.make(env_id, **kwargs)
            tasks = suite_tasks(suite, "test", env.unwrapped.grasp, limit=count)
            for agent, policy in (("straight-line", build_agent("straight-line", env)),
                                  ("reference", None)):
                for i, task in enumerate(tasks):
                    verdict = replay(env, task.options(), policy)
                    if verdict is not None:
                        episodes[f"{env_id} {suite} {agent} {i}"] = verdict
            env.close()
            print(f"{env_id} {suite}: {len(episodes)} episodes so far", flush=True)
    return episodes


def compare(new: dict[str, Any], old: dict[str, Any]) -> int:
    """Print how the verdicts of ``new`` differ from ``old``; the number of episodes that do."""
    differ = 0
    for key in sorted(set(new) | set(old)):
        a, b = old.get(key), new.get(key)
        if a != b:
            differ += 1
            fields = sorted(k for k in set(a or {}) | set(b or {})
                            if (a or {}).get(k) != (b or {}).get(k))
            print(f"  differs: {key}: {', '.join(fields)}")
    return differ


def main() -> int:
    """Record the verdicts; compare them with a record when asked."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("runs/settle_verdicts.json"))
    parser.add_argument("--compare", type=Path, default=None,
                        help="a record to compare with (written by this script)")
    parser.add_argument("--max-steps", type=int, default=MAX_STEPS)
    args = parser.parse_args()
    t = time.perf_counter()
    episodes = record(args.max_steps)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(episodes, indent=1, sort_keys=True))
    settled = sum(e["trials"]["settled"] for e in episodes.values())
    declined = sum(e["trials"]["declined"] for e in episodes.values())
    print(f"{len(episodes)} episodes in {time.perf_counter() - t:.0f} s "
          f"({sum(e['success'] for e in episodes.values())} solved); at-rest trials: "
          f"{settled} settled, {declined} declined; written to {args.out}")
    if args.compare is None:
        return 0
    old = json.loads(args.compare.read_text())
    differ = compare(episodes, old)
    print(f"against {args.compare}: {len(old)} episodes there, {differ} differ "
          f"({'SAME' if differ == 0 else 'DIFFERENT'} verdicts and digests)")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
