"""Reports of evaluations: plain-text tables, and the per-episode CSV and JSON files.

NaN becomes "-" in the tables, an empty CSV cell and JSON ``null``; files are written
atomically.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

import numpy as np

from dlo_bench.evaluation import EpisodeRecord, Evaluation
from dlo_env.core.atomic import write_text_atomic

#: The threshold the report's first table shows (and the designed cells run at).
HEADLINE_THRESHOLD = 0.01
#: Columns of the printed table: (summary key, header, format).
TABLE_COLUMNS = (
    ("agent", "agent", "{}"),
    ("suite", "suite", "{}"),
    ("difficulty", "diff", "{}"),
    ("episodes", "episodes", "{}"),
    ("success_rate", "success", "{:.0%}"),
    ("median_rest_error", "median err at rest (cm)", "{:.2f}"),
    ("mean_rest_error", "mean err at rest (cm)", "{:.2f}"),
    ("median_rest_max_error", "max point (cm)", "{:.2f}"),
    ("median_rest_direction_free_error", "direction-free (cm)", "{:.2f}"),
    ("mean_steps", "steps", "{:.1f}"),
    ("median_planning_seconds", "plan s (median)", "{:.3f}"),
    ("planning_failures", "plan fails", "{}"),
    ("mean_fidelity", "fidelity (cm)", "{:.2f}"),
)
#: What the columns of ``TABLE_COLUMNS`` that need a word mean (printed by ``format_legend``).
TABLE_LEGEND = (
    ("success", "the cord at rest within {threshold} (mean point distance) of the goal"),
    ("err at rest", "mean point distance to the goal once the cord is at rest"),
    ("max point", "the largest point distance to the goal at rest (median over episodes)"),
    ("direction-free", "the smaller of the errors against the goal and the reversed goal"),
    ("steps", "actions per episode"),
    ("plan s", "planning seconds per episode (the median over episodes)"),
    ("fidelity", "mean distance of the latent tree's first plan to the simulated cord"),
)
_CENTIMETRES = {"median_rest_error", "mean_rest_error", "median_rest_direction_free_error",
                "median_rest_max_error", "mean_fidelity"}
def aligned(rows: list[list[str]]) -> str:
    """Rows of cells as right-aligned text columns, the first row a header underlined."""
    widths = [max(len(r[c]) for r in rows) for c in range(len(rows[0]))]
    lines = ["  ".join(cell.rjust(w) for cell, w in zip(r, widths)) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def format_table(summaries: list[dict[str, Any]]) -> str:
    """A plain-text table of summaries, one row each (errors and fidelity in centimetres)."""
    rows = [[header for _, header, _ in TABLE_COLUMNS]]
    for s in summaries:
        row = []
        for key, _, fmt in TABLE_COLUMNS:
            value = s.get(key, "")
            if (isinstance(value, float) and math.isnan(value)) or (
                    key == "difficulty" and value == 0):  # a designed goal: made by no moves
                row.append("-")
                continue
            if key in _CENTIMETRES and isinstance(value, float):
                value = 100.0 * value
            row.append(fmt.format(value) if value != "" else "")
        rows.append(row)
    return aligned(rows)


def format_legend(threshold: float) -> str:
    """What the table's columns mean, one line each; ``threshold`` in metres."""
    width = max(len(name) for name, _ in TABLE_LEGEND)
    return "\n".join(f"{name.rjust(width)}: {text.format(threshold=f'{100 * threshold:g} cm')}"
                     for name, text in TABLE_LEGEND)


def format_divergence(summaries: list[dict[str, Any]]) -> str:
    """A plain-text table of where plans and the real cord part ways (centimetres).

    One row per summary that has plans: the mean error at the plan's first shape (the start
    inversion), by the distance the end has travelled, by straight move, at the plan's last
    shape, and between the plan's last shape and the real cord at rest after it.
    """
    rows = []
    for s in summaries:
        d = s.get("divergence") or {}
        if not d.get("shapes"):
            continue
        rows.append((s, d))
    if not rows:
        return ""
    travel_keys = list(rows[0][1]["by_travel"])
    move_keys = list(rows[0][1]["by_move"])
    header = (["agent", "diff", "plans", "at start"] + [f"travel {k}" for k in travel_keys]
              + [f"move {k}" for k in move_keys] + ["at end", "end at rest"])
    table = [header]
    for s, d in rows:
        values = ([d["at_start"]] + [d["by_travel"].get(k, math.nan) for k in travel_keys]
                  + [d["by_move"].get(k, math.nan) for k in move_keys]
                  + [d["at_end"], s.get("mean_plan_final_error", math.nan)])
        cells = ["-" if not math.isfinite(v) else f"{100 * v:.2f}" for v in values]
        difficulty = s.get("difficulty", "")
        table.append([str(s.get("agent", "")), "-" if difficulty == 0 else str(difficulty),
                      str(d["plans"])] + cells)
    return aligned(table)


def json_ready(value: Any) -> Any:
    """``value`` with non-finite floats as None (strict JSON), recursively."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, (np.integer, np.floating, np.bool_)):
        return json_ready(value.item())
    return value


def write_summaries(summaries: list[dict[str, Any]], path: str | os.PathLike) -> Path:
    """Write a list of summaries to a JSON file atomically (NaN becomes ``null``)."""
    return write_text_atomic(path, json.dumps(json_ready(summaries), indent=2) + "\n")


def write_evaluation(
    evaluation: Evaluation,
    folder: str | os.PathLike,
    name: str,
    extra: dict[str, Any] | None = None,
) -> tuple[Path, Path]:
    """Write ``<name>.csv`` (one row per episode) and ``<name>.json`` (summary, records, extra).

    Files are written atomically; NaN becomes an empty CSV cell and JSON ``null``.

    Returns:
        The CSV and JSON paths.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    names = [f.name for f in fields(EpisodeRecord)]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=names)
    writer.writeheader()
    for record in evaluation.records:
        row = asdict(record)
        writer.writerow({k: ("" if isinstance(v, float) and math.isnan(v) else v)
                         for k, v in row.items()})
    csv_path, json_path = folder / f"{name}.csv", folder / f"{name}.json"
    write_text_atomic(csv_path, buffer.getvalue())
    write_text_atomic(json_path, json.dumps(evaluation_data(evaluation, extra), indent=2) + "\n")
    return csv_path, json_path


def evaluation_data(evaluation: Evaluation, extra: dict[str, Any] | None = None
                    ) -> dict[str, Any]:
    """``evaluation`` as a JSON-ready dictionary (NaN as None): its summary, records and
    fidelity profiles, then ``extra``'s entries."""
    return json_ready({
        "summary": evaluation.summary,
        "records": [asdict(r) for r in evaluation.records],
        "fidelity_profiles": [
            {"episode": p.episode, "errors": p.errors.tolist(), "travel": p.travel.tolist(),
             "move": p.move.tolist()}
            for p in evaluation.profiles
        ],
        **(extra or {}),
    })


def cell_label(row: dict[str, Any]) -> str:
    """A benchmark cell's short name in tables and charts: ``endpoint d3``, ``dual-endpoint d1``,
    ``endpoint shapes-curves``."""
    return f"{row.get('env', 'endpoint')} {row.get('cell') or 'd' + str(row['difficulty'])}"


def threshold_label(threshold: float, space: str = " ") -> str:
    """A success threshold in tables and file names: ``1 cm``, ``0.5 cm`` (``1cm`` with
    ``space=""``)."""
    return f"{100 * threshold:g}{space}cm"


def thresholds_of(rows: list[dict[str, Any]]) -> list[float | None]:
    """The success thresholds of the rows, in row order (None: rows without one)."""
    return list(dict.fromkeys(r.get("threshold") for r in rows))


def headline_first(thresholds: list[float | None]) -> list[float | None]:
    """``thresholds`` with the headline one (1 cm) first."""
    return sorted(thresholds, key=lambda t: t != HEADLINE_THRESHOLD)
