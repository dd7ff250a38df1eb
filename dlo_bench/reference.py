"""Reference errors of designed tasks: the best that a long-budget physics search reaches.

Whether a cord can be shaped into a drawn goal at all is unknown (no moves made the goal), so
the success of an agent on a designed suite (``dlo_env.designed_suites``) is read beside a
*reference*: for every test task, the smallest direction-free error at rest that physics-mpc
reached with a long budget (:data:`REFERENCE_CONFIG`, planning on the true simulator, ``max
steps`` :data:`REFERENCE_MAX_STEPS`, 1.5 times an agent's episode). After every step, the shape
the cord would rest in if the grippers stopped (``settled_metrics``) is scored, and the best
is kept: each is a shape the cord reaches at rest from the start. Two searches run on every
task (:data:`REFERENCE_SEARCHES`: 3-move plans, and 5-move plans while the cord is far from
the goal, as latent-mpc plans); neither reached lower on every task, so the reference is the
better of the two.

``dlo reference`` makes the files (one JSON per suite and environment) with worker processes,
resuming from the tasks a folder already holds; the shipped ones live in
``dlo_bench/references/`` and are refreshed with ``dlo reference --out dlo_bench/references``.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.core.atomic import write_text_atomic
from dlo_env.designed_suites import designed_suite_seeds, designed_task
from dlo_env.errors import InputError
from planners.physics_mpc import PhysicsMPCConfig

#: The search's budget: twice physics-mpc's samples, more elites and iterations (2.7 times its
#: simulations per plan), sampling focused near the goal, so it refines where the agents'
#: budget stops.
REFERENCE_CONFIG = PhysicsMPCConfig(samples=64, elites=6, iterations=4, focus=2.0)
#: The searches of every task; its reference is the best error any of them reached.
REFERENCE_SEARCHES = (REFERENCE_CONFIG,
                      PhysicsMPCConfig(samples=64, elites=6, iterations=4, focus=2.0,
                                       far_moves=5, far_error=0.06))
#: Steps of a search episode (an agent's designed episode has ``DESIGNED_MAX_STEPS``).
REFERENCE_MAX_STEPS = 300
#: The search stops once a shape at rest is this close (metres, direction-free).
REFERENCE_STOP = 0.002
#: Folder of the shipped reference files.
SHIPPED_REFERENCES = Path(__file__).resolve().parent / "references"


def reference_file(folder: str | Path, suite: str, env_id: str) -> Path:
    """``folder/<suite>-<env>.json`` (``shapes-curves-endpoint.json``)."""
    from dlo_env.envs import ENVIRONMENTS

    return Path(folder) / f"{suite}-{ENVIRONMENTS[env_id][1]}.json"


def search_task(env_id: str, suite: str, seed: int, *, config: PhysicsMPCConfig = REFERENCE_CONFIG,
                max_steps: int = REFERENCE_MAX_STEPS, stop: float = REFERENCE_STOP
                ) -> dict[str, Any]:
    """Run the reference search on the designed task ``seed`` of ``suite``.

    Returns:
        ``seed``, ``family``, ``error`` (the best direction-free error at rest, metres),
        ``step`` (the step after which the cord reached it), ``steps`` run and ``seconds``.
    """
    import gymnasium as gym

    import dlo_env  # noqa: F401  (registers the environments)
    from planners.physics_mpc import PhysicsMPCPolicy

    t0 = time.perf_counter()
    from dlo_bench.evaluation import task_env_kwargs

    # the suite's environment (its cord, direction-free scoring), with the search's budget
    kwargs = {**task_env_kwargs(suite=suite), "success_threshold": stop,
              "max_episode_steps": max_steps}
    with gym.make(env_id, **kwargs) as env:
        task = designed_task(suite, seed, env.unwrapped.cord.grasp)
        obs, _ = env.reset(options=task.options())
        policy = PhysicsMPCPolicy.for_env(env, config)
        best = env.unwrapped.settled_metrics()["direction_free_error"]
        best_step, steps, start = 0, 0, True
        done = False
        while not done:
            action, _ = policy.predict(obs, episode_start=np.array([start]), deterministic=True)
            start = False
            obs, _, terminated, truncated, _ = env.step(action)
            steps += 1
            done = terminated or truncated
            rest = env.unwrapped.settled_metrics()["direction_free_error"]
            if rest < best:
                best, best_step = rest, steps
    return {"seed": int(seed), "family": task.family, "error": float(best),
            "step": best_step, "steps": steps, "seconds": time.perf_counter() - t0}


def _search(args: tuple[str, str, int, int, PhysicsMPCConfig, int, float]
            ) -> tuple[int, dict[str, Any]]:
    env_id, suite, seed, index, config, max_steps, stop = args
    return index, search_task(env_id, suite, seed, config=config, max_steps=max_steps,
                              stop=stop)


def _config_of(fields: dict[str, Any]) -> Any:
    """A search's settings as saved, with the fields a file made by an older version lacks
    set to their defaults (which keep what that version did); None for unknown fields."""
    try:
        config = PhysicsMPCConfig(**{k: tuple(v) if isinstance(v, list) else v
                                     for k, v in fields.items()})
    except (TypeError, ValueError):
        return None
    return json.loads(json.dumps(asdict(config)))


def _upgraded(old: dict[str, Any], searches: int) -> dict[str, Any]:
    """A file of one search (``settings["config"]``, before several searches) as one whose
    first search is done: its rows keep their results as ``searches[0]``."""
    settings = dict(old["settings"])
    settings["searches"] = [settings.pop("config")]
    tasks = [{"seed": t["seed"], "family": t["family"], "error": t["error"],
              "searches": [{k: t[k] for k in ("error", "step", "steps", "seconds")}]
              + [None] * (searches - 1)} for t in old["tasks"]]
    return {**old, "settings": settings, "tasks": tasks}


def make_references(suite: str, env_id: str, out: str | Path, *, split: str = "test",
                    limit: int | None = None, jobs: int = 1, progress: bool = False,
                    searches: tuple[PhysicsMPCConfig, ...] = REFERENCE_SEARCHES,
                    max_steps: int = REFERENCE_MAX_STEPS, stop: float = REFERENCE_STOP) -> Path:
    """Search every task of a designed suite's split; write ``out/<suite>-<env>.json``.

    Every task is searched with each of ``searches``; a task's ``error`` is the best they
    reached so far, and its ``searches`` hold each one's result (None: not run yet). The file
    is rewritten (atomically) after every search, so an interrupted run resumes from it:
    searches it holds are not run again (a file of the first search alone, as made before
    there were several, is taken up).

    Raises:
        ValueError: For an unknown suite or environment, or when ``out`` holds a file made
            by another search.

    Args:
        suite, env_id, split: The tasks.
        out: Output folder.
        limit: Only the first ``limit`` tasks.
        jobs: Worker processes.
        progress: Print a line per task.
        searches, max_steps, stop: The searches (the defaults make the shipped files).
    """
    from dlo_env.designed_suites import DESIGNED_SUITES
    from dlo_env.envs import ENVIRONMENTS

    if suite not in DESIGNED_SUITES:
        raise InputError(f"suite must be one of {tuple(DESIGNED_SUITES)}, got {suite!r}")
    if env_id not in ENVIRONMENTS:
        raise InputError(f"env must be one of {tuple(ENVIRONMENTS)}, got {env_id!r}")
    if not (isinstance(jobs, int) and jobs >= 1):
        raise InputError(f"jobs must be an int >= 1, got {jobs!r}")
    seeds = [int(s) for s in designed_suite_seeds(suite, split)]
    if limit is not None:
        seeds = seeds[:limit]
    path = reference_file(out, suite, env_id)
    if not searches:
        raise InputError("searches must hold at least one PhysicsMPCConfig")
    settings = {"searches": [asdict(c) for c in searches], "max_steps": max_steps,
                "stop": stop}
    data: dict[str, Any] = {"suite": suite, "env_id": env_id, "split": split,
                            "settings": settings, "tasks": []}
    if path.is_file():  # resume what the same searches made; never overwrite another's
        old = json.loads(path.read_text())
        if "config" in old.get("settings", {}):
            old = _upgraded(old, len(searches))
        same = {k: old.get(k) for k in ("suite", "env_id", "split")}
        mine = json.loads(json.dumps(settings))
        theirs = old.get("settings", {})
        done = [_config_of(c) for c in theirs.get("searches", [])]
        ok = same == {k: data[k] for k in same} and all(
            theirs.get(k) == mine[k] for k in ("max_steps", "stop")) and (
            done == [_config_of(c) for c in mine["searches"][:len(done)]])
        if not ok:
            raise InputError(f"out holds {path}, made by another search (settings or split "
                             "differ): pass another --out, or remove the file to redo it")
        data["tasks"] = old["tasks"]
        for task in data["tasks"]:  # searches added since: not run yet
            task["searches"] += [None] * (len(searches) - len(task["searches"]))
    rows = {t["seed"]: t for t in data["tasks"]}
    todo = [(env_id, suite, s, k, c, max_steps, stop) for s in seeds
            for k, c in enumerate(searches)
            if s not in rows or rows[s]["searches"][k] is None]
    path.parent.mkdir(parents=True, exist_ok=True)

    def save(index: int, result: dict[str, Any]) -> None:
        seed = result["seed"]
        if seed not in rows:
            rows[seed] = {"seed": seed, "family": result["family"], "error": math.inf,
                          "searches": [None] * len(searches)}
            data["tasks"].append(rows[seed])
            data["tasks"].sort(key=lambda t: t["seed"])
        row = rows[seed]
        row["searches"][index] = {k: result[k] for k in ("error", "step", "steps", "seconds")}
        row["error"] = min(r["error"] for r in row["searches"] if r is not None)
        write_text_atomic(path, json.dumps(data, indent=1) + "\n")
        if progress:
            print(f"{suite} {env_id} seed {seed} ({row['family']}), search {index + 1}: "
                  f"{100 * result['error']:.2f} cm after {result['step']} steps, "
                  f"{result['seconds']:.0f} s (best {100 * row['error']:.2f} cm)", flush=True)

    if jobs == 1:
        for args in todo:
            save(*_search(args))
    else:
        from multiprocessing import get_context

        from dlo_env.core.process_backend import watch_parent

        # workers end with a parent killed outright (finished searches are in the file)
        with get_context("spawn").Pool(jobs, initializer=watch_parent) as pool:
            for index, result in pool.imap_unordered(_search, todo):
                save(index, result)
    return path


def load_references(suite: str, env_id: str, folder: str | Path | None = None
                    ) -> dict[int, dict[str, Any]]:
    """Seed -> reference row of a designed suite's test tasks whose every search has run
    ({} without a file)."""
    path = reference_file(folder or SHIPPED_REFERENCES, suite, env_id)
    if not path.is_file():
        return {}
    data = json.loads(path.read_text())
    if "config" in data.get("settings", {}):  # a file of one search, made before there were several
        data = _upgraded(data, len(REFERENCE_SEARCHES))
    return {int(t["seed"]): t for t in data["tasks"]
            if all(r is not None for r in t["searches"]) and math.isfinite(t["error"])}
