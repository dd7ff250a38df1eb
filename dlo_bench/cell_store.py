"""Benchmark cells on disk: one compressed ``.npz`` of arrays per cell, read back exactly.

A cell is the JSON-ready dictionary of one (agent, environment, suite, threshold) evaluation:
``summary``, ``records`` (one dictionary per episode), ``fidelity_profiles`` (one per plan),
the ``benchmark_key`` and the run's facts, and, for the figures, task shapes (``shapes`` with
``goals``, ``rest`` and ``pegs``; a part keeps ``goals`` and ``rest`` at the top). On disk the
episode records are columns, the profiles and shapes concatenated arrays with their lengths,
and everything else one JSON string, so a cell of 50 episodes takes ~20 KB instead of ~140 KB
of JSON. :func:`read_cell` gives back the dictionary that was written, equal value for value
(float64 columns hold the JSON's floats exactly; shapes are float32 where every coordinate is
one). Missing floats (JSON ``null``) are NaN in the arrays.

The file is a zip of ``.npy`` members (``numpy.load(path, allow_pickle=False)`` opens it) with
fixed member times, so an unchanged cell is written byte for byte the same. The columns a rerun
of the same code changes, the times, are a member of their own (``records_time``), and git's
deltas store the rest of a refreshed cell once.
"""

from __future__ import annotations

import io
import json
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.core.atomic import atomic_path
from dlo_env.errors import InputError

#: A cell's file suffix; ``LEGACY_SUFFIX`` cells (one JSON document) are still read.
CELL_SUFFIX = ".npz"
LEGACY_SUFFIX = ".json"
#: The layout's version, recorded in every file.
FORMAT_VERSION = 1
#: Per-episode columns that differ between two runs of the same code (wall times).
TIME_COLUMNS = ("seconds", "planning_seconds")
#: Lists of dictionaries stored as columns: top-level key -> array name prefix.
TABLES = {"records": "records", "fidelity_profiles": "profile"}
#: Lists of point lists (``(n_i, 2)`` each) stored concatenated: path in the cell -> array name.
POINT_LISTS = {("goals",): "goals", ("rest",): "rest", ("shapes", "goals"): "shape_goals",
               ("shapes", "rest"): "shape_rest", ("shapes", "pegs"): "shape_pegs"}
#: Member times in the zip: fixed, so equal cells are equal files.
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)


def cell_path(folder: str | os.PathLike, name: str) -> Path:
    """Where cell ``name`` is written in ``folder``."""
    return Path(folder) / f"{name}{CELL_SUFFIX}"


def find_cell(folder: str | os.PathLike, name: str) -> Path | None:
    """Cell ``name`` in ``folder``: its ``.npz``, else a ``.json`` an older version wrote, else
    None."""
    for suffix in (CELL_SUFFIX, LEGACY_SUFFIX):
        path = Path(folder) / f"{name}{suffix}"
        if path.is_file():
            return path
    return None


def write_cell(path: str | os.PathLike, cell: dict[str, Any]) -> Path:
    """Write ``cell`` (a JSON-ready dictionary: ``None`` for missing floats) to ``path``
    atomically, as :func:`read_cell` reads it back."""
    arrays: dict[str, np.ndarray] = {}
    meta: dict[str, Any] = {"format": FORMAT_VERSION, "keys": list(cell), "tables": {},
                            "points": [], "order": {}}
    rest = dict(cell)
    for key, prefix in TABLES.items():
        if key in rest:
            meta["tables"][key] = _put_table(rest.pop(key), prefix, arrays)
    for where, name in POINT_LISTS.items():
        holder = _holder(rest, where)
        if holder is not None and where[-1] in holder:
            if len(where) > 1:  # copy the holder before taking its point lists out
                meta["order"].setdefault(where[0], list(holder))
                holder = rest[where[0]] = dict(holder)
            meta["points"].append(name)
            _put_points(holder.pop(where[-1]), name, arrays)
    meta["rest"] = rest
    arrays["meta"] = np.array(json.dumps(meta, allow_nan=False))
    path = Path(path)
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as out:
        for name, array in arrays.items():
            buffer = io.BytesIO()
            np.lib.format.write_array(buffer, array, allow_pickle=False)
            out.writestr(zipfile.ZipInfo(f"{name}.npy", _ZIP_TIME), buffer.getvalue(),
                         zipfile.ZIP_DEFLATED)
    return path


def read_cell(path: str | os.PathLike) -> dict[str, Any]:
    """The dictionary :func:`write_cell` wrote to ``path`` (or an older ``.json`` cell's).

    Raises:
        InputError: If ``path`` is not a cell file of a known layout.
    """
    path = Path(path)
    if path.suffix == LEGACY_SUFFIX:
        try:
            return json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise InputError(f"{path} is not a benchmark cell: {exc}") from None
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
        meta = json.loads(arrays.pop("meta").item())
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        raise InputError(f"{path} is not a benchmark cell: {exc}") from None
    if meta.get("format") != FORMAT_VERSION:
        raise InputError(f"{path} is a benchmark cell of layout {meta.get('format')}; this "
                         f"version reads layout {FORMAT_VERSION}")
    cell = dict(meta["rest"])
    for key, table in meta["tables"].items():
        cell[key] = _get_table(table, TABLES[key], arrays)
    for where, name in POINT_LISTS.items():
        if name in meta["points"]:
            holder = cell if len(where) == 1 else cell[where[0]]
            holder[where[-1]] = _get_points(name, arrays)
    for key, keys in meta["order"].items():  # a nested dictionary's keys in their written order
        cell[key] = {k: cell[key][k] for k in keys}
    return {k: cell[k] for k in meta["keys"]}


def _holder(cell: dict[str, Any], where: tuple[str, ...]) -> dict[str, Any] | None:
    """The dictionary that holds the point lists at ``where`` (None if there is none)."""
    holder: Any = cell
    for key in where[:-1]:
        holder = holder.get(key) if isinstance(holder, dict) else None
    return holder if isinstance(holder, dict) else None


def _put_table(rows: list[dict[str, Any]], prefix: str, arrays: dict[str, np.ndarray]
               ) -> dict[str, Any]:
    """Store a list of dictionaries (same keys) as columns; returns how to read them back."""
    keys = list(rows[0]) if rows else []
    kinds: dict[str, str] = {}
    for key in keys:
        values = [row[key] for row in rows]
        if isinstance(values[0], list):  # a list per row (a profile's errors): concatenated
            ints = [all(type(v) is int for v in value) for value in values]
            kinds[key] = "list-int" if all(ints) else "list-float"
            arrays[f"{prefix}_{key}"] = np.asarray(
                [v for value in values for v in value],
                np.int64 if kinds[key] == "list-int" else np.float64)
            arrays[f"{prefix}_{key}_length"] = np.asarray([len(v) for v in values], np.int64)
            if any(ints) and not all(ints):  # which rows held integers (a profile's moves)
                arrays[f"{prefix}_{key}_int"] = np.asarray(ints)
        elif all(type(v) is bool for v in values):
            kinds[key] = "bool"
        elif all(type(v) is int for v in values):
            kinds[key] = "int"
        elif all(v is None or isinstance(v, (int, float)) and type(v) is not bool
                 for v in values):
            kinds[key] = "float"
        else:
            kinds[key] = "json"
    for kind, dtype in (("bool", bool), ("int", np.int64), ("float", np.float64)):
        for group, names in (("time", [k for k in keys if kinds[k] == kind and k in TIME_COLUMNS]),
                             ("", [k for k in keys if kinds[k] == kind
                                   and k not in TIME_COLUMNS])):
            if names:
                arrays[f"{prefix}_{kind}{'_' + group if group else ''}"] = np.asarray(
                    [[_nan(row[k]) for row in rows] for k in names], dtype)
    json_keys = [k for k in keys if kinds[k] == "json"]
    return {"count": len(rows), "keys": keys, "kinds": kinds,
            "json": [[row[k] for k in json_keys] for row in rows] if json_keys else []}


def _get_table(table: dict[str, Any], prefix: str, arrays: dict[str, np.ndarray]
               ) -> list[dict[str, Any]]:
    """The list of dictionaries :func:`_put_table` stored."""
    keys, kinds, count = table["keys"], table["kinds"], table["count"]
    columns: dict[str, list[Any]] = {}
    for kind in ("bool", "int", "float"):
        for group in ("", "time"):
            names = [k for k in keys if kinds[k] == kind and (k in TIME_COLUMNS) == bool(group)]
            if names:
                block = arrays[f"{prefix}_{kind}{'_' + group if group else ''}"]
                for name, column in zip(names, block):
                    columns[name] = [None if kind == "float" and v != v else v
                                     for v in column.tolist()]
    for key in keys:
        if kinds[key].startswith("list"):
            flat = arrays[f"{prefix}_{key}"].tolist()
            ends = np.cumsum(arrays[f"{prefix}_{key}_length"]).tolist()
            columns[key] = [flat[a:b] for a, b in zip([0] + ends[:-1], ends)]
            if f"{prefix}_{key}_int" in arrays:
                columns[key] = [[int(v) for v in value] if is_int else value for value, is_int
                                in zip(columns[key], arrays[f"{prefix}_{key}_int"].tolist())]
    json_keys = [k for k in keys if kinds[k] == "json"]
    for j, key in enumerate(json_keys):
        columns[key] = [row[j] for row in table["json"]]
    return [{k: columns[k][i] for k in keys} for i in range(count)]


def _put_points(lists: list[list[list[float]]], name: str, arrays: dict[str, np.ndarray]
                ) -> None:
    """Store a list of point lists concatenated, float32 where that holds every value."""
    flat = np.asarray([p for points in lists for p in points], np.float64).reshape(-1, 2)
    single = flat.astype(np.float32)
    arrays[name] = single if np.array_equal(single.astype(np.float64), flat) else flat
    arrays[f"{name}_length"] = np.asarray([len(points) for points in lists], np.int64)


def _get_points(name: str, arrays: dict[str, np.ndarray]) -> list[list[list[float]]]:
    """The list of point lists :func:`_put_points` stored."""
    flat = arrays[name].astype(np.float64).tolist()
    ends = np.cumsum(arrays[f"{name}_length"]).tolist()
    return [flat[a:b] for a, b in zip([0] + ends[:-1], ends)]


def _nan(value: Any) -> Any:
    """``value``, with None as NaN (a missing float)."""
    return np.nan if value is None else value
