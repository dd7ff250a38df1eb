"""The benchmark's report: the Markdown table, the speed ratios, the machine, the chart.

A planning-time ratio compares cells timed in one run (one invocation of ``dlo benchmark``:
the same machine and load); cells of several runs make it "not comparable", never a number.

``write_results`` writes ``results.json``, ``results.md`` and ``results.png`` atomically.
"""

from __future__ import annotations

import json
import math
import os
import platform
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dlo_bench.benchmark.cells import CELLS_DIR, cell_name
from dlo_bench.benchmark.config import CORD_AGENTS
from dlo_bench.benchmark.provenance import code_file, recorded_path
from dlo_bench.benchmark.rows import NEAR_REFERENCE
from dlo_bench.cell_store import find_cell, read_cell
from dlo_bench.report import (
    cell_label,
    headline_first,
    json_ready,
    threshold_label,
    thresholds_of,
)
from dlo_env.core.atomic import file_digest, write_text_atomic


@dataclass(frozen=True)
class TimeRatio:
    """Total planning seconds of one agent over another's on the same episodes, over the cells
    whose two timings come from one run (the same machine and load: the ratio measures the
    agents rather than the day they ran).

    Attributes:
        slow, fast: The two agents.
        cells: Cell label (``endpoint d1 @ 1 cm``...) -> the ratio in that cell, for the cells
            both agents ran in one recorded run.
        overall: The ratio of the totals over those cells (NaN without any).
        runs: The runs that timed those cells.
        mixed: The cells both ran, but in different runs (or runs not recorded): no ratio.
    """

    slow: str
    fast: str
    cells: dict[str, float]
    overall: float
    runs: tuple[str, ...]
    mixed: tuple[str, ...] = ()

    @property
    def comparable(self) -> bool:
        """Whether some cell of both agents was timed in one recorded run."""
        return bool(self.cells)


def _cell(row: dict[str, Any]) -> str:
    """A cell with its threshold: ``endpoint d3 @ 1 cm`` (no threshold: ``endpoint d3``)."""
    label = cell_label(row)
    t = row.get("threshold")
    return label if t is None else f"{label} @ {threshold_label(t)}"


def planning_time_ratios(rows: list[dict[str, Any]], slow: str = "physics-mpc",
                         fast: str = "latent-tree") -> TimeRatio | None:
    """Total planning seconds of ``slow`` over ``fast`` on the same episodes.

    Returns:
        The ratio in every cell both agents ran with the same episodes and overall, with the
        runs that timed them; None when they share no cell.
    """
    by = {(r["agent"], _cell(r)): r for r in rows if r["status"] == "ok"}
    cells, mixed, runs, slow_total, fast_total = {}, [], set(), 0.0, 0.0
    for r in rows:
        if r["agent"] != slow or r["status"] != "ok":
            continue
        other = by.get((fast, _cell(r)))
        if other is None or other["episodes"] != r["episodes"]:
            continue
        run = r.get("run") or ""
        if not run or run != (other.get("run") or ""):
            mixed.append(_cell(r))
            continue
        if other["total_seconds"] > 0:
            cells[_cell(r)] = r["total_seconds"] / other["total_seconds"]
        slow_total += r["total_seconds"]
        fast_total += other["total_seconds"]
        runs.add(run)
    if not cells and not mixed:
        return None
    overall = slow_total / fast_total if fast_total > 0 else math.nan
    return TimeRatio(slow, fast, cells, overall, tuple(sorted(runs)), tuple(mixed))


#: The planning-time ratios the report states: physics-mpc over each cheaper planner.
RATIO_PAIRS = (("physics-mpc", "latent-mpc"), ("physics-mpc", "latent-tree-kino"),
               ("physics-mpc", "latent-tree"), ("physics-mpc", "latent-tree-closed"))


def ratio_lines(rows: list[dict[str, Any]]) -> list[str]:
    """One sentence per pair of ``RATIO_PAIRS`` that both ran: the ratio and the run that timed
    its cells, or, when the cells were timed in several runs (or runs not recorded), that it
    is not comparable."""
    lines = []
    for slow, fast in RATIO_PAIRS:
        ratio = planning_time_ratios(rows, slow, fast)
        if ratio is None:
            continue
        head = f"Planning time {slow} / {fast} on the same episodes"
        if ratio.comparable:
            parts = ", ".join(f"{k} {_ratio(v)}" for k, v in ratio.cells.items())
            where = (f"timed in one run ({ratio.runs[0]})" if len(ratio.runs) == 1 else
                     f"each cell timed in one run ({', '.join(ratio.runs)})")
            line = f"{head}, {where}: {_ratio(ratio.overall)} overall ({parts})."
            if ratio.mixed:
                line += (f" Not comparable, timed in different runs: "
                         f"{', '.join(ratio.mixed)}.")
            lines.append(line)
            continue
        commits = sorted({r.get("commit") or "unknown" for r in rows
                          if r["agent"] in (slow, fast) and r["status"] == "ok"})
        timed = sorted({r.get("run") or "not recorded" for r in rows
                        if r["agent"] in (slow, fast) and r["status"] == "ok"})
        lines.append(f"{head}: not comparable, its cells were timed in different runs "
                     f"({', '.join(timed)}; commits {', '.join(commits)}); run both agents in "
                     "one invocation to measure it.")
    return lines


def _ratio(value: float) -> str:
    return f"{value:.0f}x" if value >= 10 else f"{value:.2g}x"


def run_summary(rows: list[dict[str, Any]]) -> str:
    """The runs that timed the cells, how many cells each, by the machine they ran on:
    ``R1 (40 cells), R2 (8 cells) on X; R3 (2 cells) on machine not recorded``."""
    machines: dict[str, dict[str, int]] = {}
    for r in rows:
        if r["status"] == "ok":
            counts = machines.setdefault(r.get("machine") or "machine not recorded", {})
            run = r.get("run") or "not recorded"
            counts[run] = counts.get(run, 0) + 1
    return "; ".join(", ".join(f"{run} ({n} cell{'s' * (n != 1)})"
                               for run, n in sorted(counts.items())) + f" on {machine}"
                     for machine, counts in sorted(machines.items()))


def success_table(rows: list[dict[str, Any]], threshold: float | None = None) -> list[str]:
    """Markdown: one row per agent, one column per cell, success rate (– when missing), of the
    rows at ``threshold`` (None: rows without one, or all when they have a single one)."""
    rows = [r for r in rows if is_main_row(r)]  # the others: cords_section, pegs_section
    if threshold is not None or len(thresholds_of(rows)) > 1:
        rows = [r for r in rows if r.get("threshold") == threshold]
    cells = list(dict.fromkeys(cell_label(r) for r in rows))
    agents = list(dict.fromkeys(r["agent"] for r in rows))
    by = {(r["agent"], cell_label(r)): r for r in rows}
    lines = ["| agent | " + " | ".join(cells) + " | sample cost |",
             "|---|" + "---|" * (len(cells) + 1)]
    for agent in agents:
        values, cost = [], ""
        for cell in cells:
            r = by.get((agent, cell))
            ok = r is not None and r["status"] == "ok"
            values.append(_fmt(r["success_rate"], "{:.0%}") if ok else _status(r))
            cost = cost or (r.get("sample_cost", "") if ok else "")
        lines.append(f"| {agent} | " + " | ".join(values) + f" | {cost or '–'} |")
    return lines


def _suite(row: dict[str, Any]) -> str:
    """The suite of a row without its split: ``linear-3``, ``shapes-curves``."""
    return str(row.get("suite", f"linear-{row['difficulty']}")).split("/")[0]


def _status(row: dict[str, Any] | None) -> str:
    """What a cell without a result shows: "n/a" (the agent cannot act there), else "–"."""
    return "n/a" if row is not None and row["status"] == "n/a" else "–"


def is_cords_row(row: dict[str, Any]) -> bool:
    """Whether ``row`` is a cell of the ``cords`` section (a cord suite)."""
    from dlo_env.cord_suites import CORD_SUITES

    return _suite(row) in CORD_SUITES


def is_pegs_row(row: dict[str, Any]) -> bool:
    """Whether ``row`` is a cell of the ``pegs`` section (a suite with pegs on the table)."""
    from dlo_env.peg_suites import PEGGED_SUITES

    return _suite(row) in PEGGED_SUITES


def is_main_row(row: dict[str, Any]) -> bool:
    """Whether ``row`` belongs in the main success tables and chart (not in a section of its
    own: unknown cords, pegs)."""
    return not (is_cords_row(row) or is_pegs_row(row))


def pegs_section(rows: list[dict[str, Any]]) -> list[str]:
    """Markdown: per environment and threshold, each agent's success and median error at rest
    on every suite with pegs, its planning seconds per episode (mean over those cells) and
    sample cost; [] without peg rows."""
    pegs = [r for r in rows if is_pegs_row(r)]
    if not pegs:
        return []
    from dlo_env.peg_suites import SUITE_MAX_PEGS

    lines = [
        "## Pegs",
        "",
        f"`pegs-K`: goals made by K straight moves with 1 to {SUITE_MAX_PEGS} pegs near the "
        "start; `route-K`: of those, goals that rest against a peg and that one straight move "
        "of the held end(s) misses by more than 2 cm (`dlo_env.peg_suites`). The environment "
        f"observes {SUITE_MAX_PEGS} peg slots; its RL agents are the ones trained there "
        "(`dlo baseline --max-pegs`). Success at the threshold, judged at rest (median error "
        "at rest, cm).",
        "",
    ]
    for key in dict.fromkeys((r["env"], r.get("threshold")) for r in pegs):
        group = [r for r in pegs if (r["env"], r.get("threshold")) == key]
        suites = list(dict.fromkeys(_suite(r) for r in group))
        by = {(r["agent"], _suite(r)): r for r in group}
        t = "–" if key[1] is None else threshold_label(key[1])
        lines += [f"**{key[0]}, {t}**", "",
                  "| agent | " + " | ".join(suites) + " | seconds/episode | sample cost |",
                  "|---|" + "---|" * (len(suites) + 2)]
        for agent in dict.fromkeys(r["agent"] for r in group):
            cells, seconds, cost = [], [], ""
            for suite in suites:
                r = by.get((agent, suite))
                if r is None or r["status"] != "ok":
                    cells.append(_status(r))
                    continue
                cells.append(f"{_fmt(r['success_rate'], '{:.0%}')} "
                             f"({_fmt(r.get('median_rest_error'), '{:.2f}', 100)})")
                seconds.append(r["seconds_per_episode"])
                cost = cost or r.get("sample_cost", "")
            mean = _fmt(sum(seconds) / len(seconds), "{:.2f}") if seconds else "–"
            lines.append(f"| {agent} | " + " | ".join(cells) + f" | {mean} | {cost or '–'} |")
        lines.append("")
    return lines


def cords_section(rows: list[dict[str, Any]]) -> list[str]:
    """Markdown: per cord suite and environment, each agent's success and median error at
    rest, over all tasks and per held-out cord; [] without cord rows."""
    cords = [r for r in rows if is_cords_row(r)]
    if not cords:
        return []
    from dlo_env.randomize import TEST_CORDS

    def label(cord: dict[str, float]) -> str:
        return (f"{cord['length']:g} m, {cord['bending_stiffness'] * 1e3:g}e-3 N m², "
                f"μ {cord['friction']:g}, {cord['mass'] * 1e3:g} g")

    lines = [
        "## Unknown cords",
        "",
        "Each task of `cords-K` is a `linear-K` task made on one of six held-out cords "
        "(`dlo_env.randomize.TEST_CORDS`, in turn), whose parameters the agents are not told; "
        "physics-mpc simulates the default cord (what an untuned simulator gives), "
        "physics-mpc-true-cord the task's own. Success at the threshold, judged at rest; per "
        "cord: success (median error at rest, cm). Cords: "
        + "; ".join(f"{i} = {label(c)}" for i, c in enumerate(TEST_CORDS)) + ".",
        "",
    ]
    order = {name: i for i, name in enumerate(CORD_AGENTS)}
    for key in dict.fromkeys((_suite(r), r["env"], r.get("threshold")) for r in cords):
        group = sorted((r for r in cords if (_suite(r), r["env"], r.get("threshold")) == key),
                       key=lambda r: order.get(r["agent"], len(order)))
        t = "–" if key[2] is None else threshold_label(key[2])
        lines += [f"**{key[0]}, {key[1]}, {t}**", "",
                  "| agent | success | median rest error (cm) | seconds/episode | "
                  + " | ".join(f"cord {i}" for i in range(len(TEST_CORDS)))
                  + " | sample cost |", "|---|" + "---|" * (len(TEST_CORDS) + 4)]
        for r in group:
            if r["status"] != "ok":
                lines.append(f"| {r['agent']} | {r['status']} | – | – | "
                             + " | ".join("–" for _ in TEST_CORDS) + " | – |")
                continue
            per = r.get("cords", {})
            lines.append(
                f"| {r['agent']} | {_fmt(r['success_rate'], '{:.0%}')} | "
                f"{_fmt(r.get('median_rest_error'), '{:.2f}', 100)} | "
                f"{_fmt(r['seconds_per_episode'], '{:.2f}')} | " + " | ".join(
                    f"{_fmt(per[str(i)]['success_rate'], '{:.0%}')} "
                    f"({_fmt(per[str(i)]['median_rest_error'], '{:.2f}', 100)})"
                    if str(i) in per else "–" for i in range(len(TEST_CORDS)))
                + f" | {r.get('sample_cost') or '–'} |")
        lines.append("")
    return lines


def designed_section(rows: list[dict[str, Any]]) -> list[str]:
    """Markdown: per designed suite and environment, each agent's median direction-free error
    at rest per curve family, its shares within 1 and 2 cm and near the reference, under a
    first row for the reference search; [] without designed rows."""
    designed = [r for r in rows if r.get("designed")]
    if not designed:
        return []
    near = threshold_label(NEAR_REFERENCE)
    lines = [
        "## Designed shapes",
        "",
        "Drawn goals from a random start (`dlo_env.designed_suites`), scored direction-free on "
        "the cord at rest after the last step: median error (cm) per curve family, and the "
        f"shares of goals within 1 and 2 cm and within {near} of the reference. The "
        "*reference* row is the best a long-budget physics search reached on the same tasks "
        "(`dlo reference`; blank without its file).",
        "",
    ]
    for key in dict.fromkeys((_suite(r), r["env"]) for r in designed):
        group = [r for r in designed if (_suite(r), r["env"]) == key]
        families = [f for f in dict.fromkeys(f for r in group for f in r["designed"])
                    if f != "all"] + ["all"]
        lines += [f"**{key[0]}, {key[1]}**", "",
                  "| agent | " + " | ".join(families) + " | within 1 cm | within 2 cm | "
                  "near reference |", "|---|" + "---|" * (len(families) + 3)]
        first = group[0]["designed"]
        if first["all"]["reference_median"] is not None:
            known, total = first["all"]["reference_tasks"], first["all"]["episodes"]
            label = "reference" if known == total else f"reference ({known} of {total} tasks)"
            lines.append(f"| {label} | " + " | ".join(
                _fmt(first.get(f, {}).get("reference_median"), "{:.2f}", 100) for f in families)
                + f" | {_fmt(first['all']['reference_within_1cm'], '{:.0%}')} | "
                  f"{_fmt(first['all']['reference_within_2cm'], '{:.0%}')} | – |")
        for r in group:
            d = r["designed"]
            lines.append(f"| {r['agent']} | " + " | ".join(
                _fmt(d.get(f, {}).get("median_error"), "{:.2f}", 100) for f in families)
                + f" | {_fmt(d['all']['within_1cm'], '{:.0%}')} | "
                  f"{_fmt(d['all']['within_2cm'], '{:.0%}')} | "
                  f"{_fmt(d['all']['near_reference'], '{:.0%}')} |")
        lines.append("")
    return lines


#: Tasks of each curve family shown in the figure of designed shapes.
FIGURE_TASKS_PER_FAMILY = 2
#: Tasks of each suite with pegs shown in the figure of routed cords.
FIGURE_TASKS_PER_PEG_SUITE = 1


def designed_panels(rows: list[dict[str, Any]], out_dir: str | os.PathLike,
                    per_family: int = FIGURE_TASKS_PER_FAMILY, pegs: bool = False
                    ) -> list[tuple[str, dict[str, tuple[Any, ...]]]]:
    """The figure's panels from the designed cells' files in ``out_dir``: the first
    ``per_family`` tasks of each curve family, per suite and environment, with each agent's
    goal, rest shape and direction-free error (cells written without shapes are skipped).
    ``pegs``: the same of the cells with pegs (a family per suite), with the error at rest
    and the task's pegs (``(k, 2)`` centres, radius)."""
    import numpy as np

    designed = [r for r in rows if r["status"] == "ok"
                and (is_pegs_row(r) if pegs else r.get("designed"))]
    error_key = "rest_error" if pegs else "rest_direction_free_error"
    panels = []
    for suite, env_id in dict.fromkeys((_suite(r), r["env_id"]) for r in designed):
        cells = {}
        for r in designed:
            if (_suite(r), r["env_id"]) != (suite, env_id):
                continue
            path = find_cell(Path(out_dir) / CELLS_DIR,
                             cell_name(r["agent"], env_id, suite, r["threshold"]))
            data = read_cell(path) if path is not None else {}
            if data.get("shapes"):
                cells[r["agent"]] = data
        if not cells:
            continue
        first = next(iter(cells.values()))["shapes"]
        families = first["families"]
        # Panels compare agents on the same tasks: a cell of other tasks is left out.
        cells = {a: d for a, d in cells.items() if d["shapes"].get("seeds") == first.get("seeds")}
        chosen = [i for family in dict.fromkeys(families)
                  for i in [k for k, f in enumerate(families) if f == family][:per_family]]
        env = next(r["env"] for r in designed if r["env_id"] == env_id)
        for i in chosen:
            entry = {}
            for agent, data in cells.items():
                shapes = data["shapes"]
                if i < len(shapes["rest"]):
                    entry[agent] = (np.asarray(shapes["goals"][i]), np.asarray(shapes["rest"][i]),
                                    float(data["records"][i][error_key]))
                    if pegs:
                        entry[agent] += (np.asarray(shapes["pegs"][i], float).reshape(-1, 2),
                                         float(shapes["peg_radius"][i]))
            panels.append((f"{env} {families[i]} #{i}", entry))
    return panels


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


def results_markdown(rows: list[dict[str, Any]], machine: dict[str, Any], command: str,
                     seconds: float) -> str:
    """The Markdown report: success per cell, the detailed table, the speed ratios, missing
    agents, machine and command."""
    episodes = max((r["episodes"] for r in rows), default=0)
    thresholds = headline_first(thresholds_of([r for r in rows if is_main_row(r)]))
    lines = [
        "# Benchmark results",
        "",
        f"Every agent on the first {episodes} tasks of the test split of the suites `linear-K` "
        "and of the designed, cord and peg suites of the sections below "
        "(fixed tasks: every agent sees the same episodes) in `dlo_env/DLOEndpoint-v0` "
        "(*endpoint*) and `dlo_env/DLODualEndpoint-v0` (*dual-endpoint*); *dK* is difficulty "
        "K (K straight moves from start to goal). Success means the cord at rest within the "
        "threshold (`error`, the mean point distance), judged by the environment; every cell "
        "runs once per threshold, the planners taking their stopping rules from it. "
        "*Sample cost* is the data the agent's model or policy was trained on.",
        "",
    ]
    for t in thresholds:
        title = "Success" if t is None else f"Success at {threshold_label(t)}"
        lines += [f"## {title}", "", *success_table(rows, t), ""]
    lines += [
        "## Every cell",
        "",
        "*rest error* is the median over episodes of the error of the cord at rest after the "
        "last step. *seconds/episode* is planning (planners) or policy inference (RL) time, "
        "mean over episodes; the simulator's own stepping is not counted.",
        "",
        "| agent | environment | suite | threshold | episodes | success "
        "| median rest error (cm) | seconds/episode | fidelity (cm) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        env = r.get("env", "endpoint")
        t = r.get("threshold")
        tl = "–" if t is None else threshold_label(t)
        if r["status"] != "ok":
            lines.append(f"| {r['agent']} | {env} | {_suite(r)} | {tl} | – | {r['status']} | – "
                         "| – | – |")
            continue
        lines.append(
            f"| {r['agent']} | {env} | {_suite(r)} | {tl} | {r['episodes']} | "
            f"{_fmt(r['success_rate'], '{:.0%}')} | "
            f"{_fmt(r.get('median_rest_error'), '{:.2f}', 100)} | "
            f"{_fmt(r['seconds_per_episode'], '{:.3f}')} | "
            f"{_fmt(r['mean_fidelity'], '{:.2f}', 100)} |"
        )
    lines.append("")
    lines += designed_section(rows)
    lines += cords_section(rows)
    lines += pegs_section(rows)
    ratios = ratio_lines(rows)
    lines += ratios if ratios else ["Planning time ratios: not measured (physics-mpc did not "
                                    "run with a cheaper planner)."]
    for status, title in (("missing", "Missing cells"), ("n/a", "Cells where an agent cannot "
                                                             "act (n/a)")):
        notes = sorted({(r["agent"], r["note"]) for r in rows if r["status"] == status})
        if notes:
            lines += ["", f"{title}:"]
            lines += [f"- `{agent}`: {note}" for agent, note in notes]
    models = sorted({(r["agent"], m) for r in rows for m in r.get("models", [])})
    if models:
        lines += ["", "Models (SHA-256 prefix): " + "; ".join(
            f"`{a}` {_display_path(m)} ({file_digest(code_file(m))[:8] or 'gone'})"
            for a, m in models) + "."]
    evaluated = sum(r["wall_seconds"] or 0.0 for r in rows)
    commits = sorted({r["commit"] for r in rows if r.get("commit")})
    lines += [
        "",
        f"Machine: {machine['platform']}, {machine['processor']}, {machine['cpu_count']} CPUs, "
        f"Python {machine['python']}, torch {machine['torch']} "
        f"({machine['torch_threads']} thread(s)). Wall time of the evaluations "
        f"{evaluated / 60:.1f} min (this invocation {seconds / 60:.1f} min).",
        "",
        f"Code: {', '.join(commits) if commits else 'unknown'} (git commit of each cell's run). "
        f"Runs (one invocation each): {run_summary(rows) or 'none'}.",
        "",
        f"Command: `{command}`",
        "",
    ]
    return "\n".join(lines)


def write_results(rows: list[dict[str, Any]], out_dir: str | os.PathLike, command: str,
                  seconds: float) -> dict[str, Path]:
    """Write ``results.json``, ``results.md`` and ``results.png`` (the cells outside the
    sections on unknown cords and pegs; none without any) into ``out_dir`` atomically, and
    ``results_designed.png`` (designed goals and the shapes reached) with designed cells,
    ``results_pegs.png`` (goals among pegs and the shapes reached) with cells with pegs.

    Returns:
        The paths, by kind (``json``, ``md``, ``png``, ``designed_png``, ``pegs_png``).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    # cells made before models were recorded relative to the code's root
    rows = [{**r, "models": [recorded_path(m) for m in r["models"]]} if r.get("models") else r
            for r in rows]
    machine = machine_description()
    paths = {"json": out / "results.json", "md": out / "results.md"}
    write_text_atomic(paths["json"], json.dumps(json_ready(rows), indent=2) + "\n")
    write_text_atomic(paths["md"], results_markdown(rows, machine, command, seconds))
    from dlo_bench.charts import plot_results, plot_shapes

    charted = [r for r in rows if is_main_row(r)]
    if charted:
        paths["png"] = out / "results.png"
        plot_results(charted, paths["png"])
    panels = designed_panels(rows, out)
    if panels:
        paths["designed_png"] = out / "results_designed.png"
        plot_shapes(panels, paths["designed_png"])
    panels = designed_panels(rows, out, FIGURE_TASKS_PER_PEG_SUITE, pegs=True)
    if panels:
        paths["pegs_png"] = out / "results_pegs.png"
        plot_shapes(panels, paths["pegs_png"],
                    title="goals among pegs (green), the cord at rest after the last step\n"
                          "(blue, head red) and the pegs (grey); error at rest")
    return paths
