"""The benchmark's report: the Markdown table, the speed ratios, the machine, the chart.

``write_results`` writes ``results.json``, ``results.md`` and ``results.png`` atomically.
"""

from __future__ import annotations

import json
import math
import os
import platform
from pathlib import Path
from typing import Any

from dlo_bench.benchmark import file_digest
from dlo_bench.report import json_ready
from dlo_env.atomic import write_text_atomic


def planning_time_ratios(rows: list[dict[str, Any]], slow: str = "physics-mpc",
                         fast: str = "latent-tree") -> dict[str, float]:
    """Total planning seconds of ``slow`` over ``fast`` on the same episodes, per difficulty.

    Returns:
        ``{"d1": ratio, ..., "all": ratio}`` for the difficulties both agents ran.
    """
    by = {(r["agent"], r["difficulty"]): r for r in rows if r["status"] == "ok"}
    ratios, slow_total, fast_total = {}, 0.0, 0.0
    for (agent, difficulty), row in sorted(by.items(), key=lambda kv: kv[0][1]):
        other = by.get((fast, difficulty))
        if agent != slow or other is None or other["episodes"] != row["episodes"]:
            continue
        if other["total_seconds"] > 0:
            ratios[f"d{difficulty}"] = row["total_seconds"] / other["total_seconds"]
        slow_total += row["total_seconds"]
        fast_total += other["total_seconds"]
    if ratios and fast_total > 0:
        ratios["all"] = slow_total / fast_total
    return ratios


def machine_description() -> dict[str, Any]:
    """The machine the numbers were measured on."""
    import torch

    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "torch": torch.__version__,
        "torch_threads": torch.get_num_threads(),
    }


def _display_path(path: str) -> str:
    """``path`` relative to the working directory when it lies below it."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return path


def _fmt(value: Any, fmt: str, scale: float = 1.0) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return fmt.format(value * scale)


def results_markdown(rows: list[dict[str, Any]], ratios: dict[str, float],
                     machine: dict[str, Any], command: str, seconds: float) -> str:
    """The Markdown report: the table, the speed ratio, missing agents, machine and command."""
    lines = [
        "# Benchmark results",
        "",
        "Every agent on the first N tasks of the test split of `linear-1`, `linear-2`, "
        "`linear-3` (fixed tasks: every agent sees the same episodes) in "
        "`dlo_env/DLOEndpoint-v0`; success means `error <= 2 cm` (mean point distance). "
        "*seconds/episode* is planning (planners) or policy inference (RL) time, mean over "
        "episodes; the simulator's own stepping is not counted.",
        "",
        "| agent | difficulty | episodes | success | median error (cm) | seconds/episode "
        "| training env steps | fidelity (cm) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r["status"] != "ok":
            lines.append(f"| {r['agent']} | {r['difficulty']} | – | missing | – | – | – | – |")
            continue
        steps = r["training_env_steps"]
        lines.append(
            f"| {r['agent']} | {r['difficulty']} | {r['episodes']} | "
            f"{_fmt(r['success_rate'], '{:.0%}')} | {_fmt(r['median_error'], '{:.2f}', 100)} | "
            f"{_fmt(r['seconds_per_episode'], '{:.3f}')} | "
            f"{'–' if steps is None else f'{steps:,}'} | "
            f"{_fmt(r['mean_fidelity'], '{:.2f}', 100)} |"
        )
    lines.append("")
    if ratios:
        parts = ", ".join(f"{k} {v:.1f}x" for k, v in ratios.items() if k != "all")
        lines.append(f"**Planning time, physics-mpc / latent-tree on the same episodes:** "
                     f"{ratios.get('all', float('nan')):.1f}x ({parts}).")
        closed = planning_time_ratios(rows, fast="latent-tree-closed")
        if closed:
            parts = ", ".join(f"{k} {v:.1f}x" for k, v in closed.items() if k != "all")
            lines.append(f"Against the closed loop (latent-tree-closed, which replans): "
                         f"{closed.get('all', float('nan')):.1f}x ({parts}).")
    else:
        lines.append("**Planning time ratio:** not measured (physics-mpc and latent-tree did "
                     "not both run).")
    missing = sorted({(r["agent"], r["note"]) for r in rows if r["status"] != "ok"})
    if missing:
        lines += ["", "Missing agents:"]
        lines += [f"- `{agent}`: {note}" for agent, note in missing]
    models = sorted({(r["agent"], r["model"]) for r in rows if r["model"]})
    if models:
        lines += ["", "Models (SHA-256 prefix): " + "; ".join(
            f"`{a}` {_display_path(m)} ({file_digest(m)[:8] or 'gone'})" for a, m in models) + "."]
    evaluated = sum(r["wall_seconds"] or 0.0 for r in rows)
    commits = sorted({r["commit"] for r in rows if r.get("commit")})
    lines += [
        "",
        f"Machine: {machine['platform']}, {machine['processor']}, {machine['cpu_count']} CPUs, "
        f"Python {machine['python']}, torch {machine['torch']} "
        f"({machine['torch_threads']} thread(s)). Wall time of the evaluations "
        f"{evaluated / 60:.1f} min (this invocation {seconds / 60:.1f} min).",
        "",
        f"Code: {', '.join(commits) if commits else 'unknown'} (git commit of each cell's run).",
        "",
        f"Command: `{command}`",
        "",
    ]
    return "\n".join(lines)


def write_results(rows: list[dict[str, Any]], out_dir: str | os.PathLike, command: str,
                  seconds: float) -> dict[str, Path]:
    """Write ``results.json``, ``results.md`` and ``results.png`` into ``out_dir`` atomically.

    Returns:
        The paths, by kind (``json``, ``md``, ``png``).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ratios = planning_time_ratios(rows)
    machine = machine_description()
    paths = {"json": out / "results.json", "md": out / "results.md", "png": out / "results.png"}
    write_text_atomic(paths["json"], json.dumps(json_ready(rows), indent=2) + "\n")
    write_text_atomic(paths["md"], results_markdown(rows, ratios, machine, command, seconds))
    from dlo_bench.charts import plot_results

    plot_results(rows, paths["png"])
    return paths
