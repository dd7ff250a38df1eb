"""How good a transition model is, measured on held-out simulator transitions.

Errors are the project's ``error`` (mean per-point distance), reported in centimetres: one-,
two- and three-move errors (the model rolled out from the real start along consecutive moves
of one cord, each move from its own previous prediction), by grasp and, for one move, by the
length of the move. Plus the rank correlation between the ensemble's spread and the error.
"""

from __future__ import annotations

import csv
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from dlo_env.core.atomic import atomic_path
from dlo_env.dataset.transitions import GRASP_NAMES, TransitionDataset
from dlo_env.errors import InputError
from dlo_env.shapes import error
from latent_model.transition_model import TransitionModel
from latent_model.transition_training import chain_starts

#: Move-length bins of the one-move rows, centimetres.
LENGTH_BINS = ((0, 5), (5, 15), (15, 25), (25, 36))
#: A prediction within this of the simulator is "within 1 cm", metres.
WITHIN = 0.01
#: The transition model's floors (measured by ``benchmarks/transition_model.py``): one-move
#: mean errors (cm) and shares within 1 cm of single-end and both-ends moves, the chained
#: linear-3 moves and analytic shapes (cm), and the speed-up over the simulator.
FLOORS = {"single_mean_cm": 0.15, "single_within": 0.995, "both_mean_cm": 0.25,
          "both_within": 0.99, "chain_cm": 0.5, "curves_cm": 0.3, "speedup": 1000.0}
#: Resamples of the bootstrap interval of a mean, and its seed (the interval is reproducible).
BOOTSTRAP = 2000
BOOTSTRAP_SEED = 0


def mean_interval(errors: np.ndarray, groups: np.ndarray | None = None, level: float = 0.95
                  ) -> tuple[float, float]:
    """Bootstrap interval of the mean of ``errors``: where the expected error of moves drawn
    like these lies (a few large misses move a mean a lot).

    Args:
        errors: One value per prediction.
        groups: Optional ``(len(errors),)`` labels of correlated predictions (the episode of
            each move: moves of one cord are not independent); whole groups are resampled.
            None: every prediction its own group.
        level: Coverage of the interval, in (0, 1).
    """
    if not 0.0 < level < 1.0:
        raise InputError(f"level must be in (0, 1), got {level!r}")
    e = np.asarray(errors, dtype=np.float64)
    labels = np.arange(len(e)) if groups is None else np.asarray(groups)
    if labels.shape != e.shape:
        raise InputError(f"groups must have shape {e.shape}, got {labels.shape}")
    _, which = np.unique(labels, return_inverse=True)
    sums = np.bincount(which, weights=e)
    counts = np.bincount(which).astype(np.float64)
    if len(sums) < 2:
        return float("nan"), float("nan")
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    means = np.empty(BOOTSTRAP)
    for lo in range(0, BOOTSTRAP, 250):  # bounded memory for large files
        pick = rng.integers(0, len(sums), (min(250, BOOTSTRAP - lo), len(sums)))
        means[lo:lo + len(pick)] = sums[pick].sum(axis=1) / counts[pick].sum(axis=1)
    tail = 100 * (1 - level) / 2
    low, high = np.percentile(means, [tail, 100 - tail])
    return float(low), float(high)


@dataclass(frozen=True)
class ErrorRow:
    """Error statistics of one group of predictions, centimetres; ``mean_low_cm`` and
    ``mean_high_cm`` bound the 95 % bootstrap interval of the mean (over episodes), and
    ``within_low`` and ``within_high`` that of the share within 1 cm."""

    moves: int
    group: str
    count: int
    mean_cm: float
    median_cm: float
    p99_cm: float
    within_1cm: float
    mean_low_cm: float = float("nan")
    mean_high_cm: float = float("nan")
    within_low: float = float("nan")
    within_high: float = float("nan")

    @classmethod
    def of(cls, moves: int, group: str, errors: np.ndarray,
           episodes: np.ndarray | None = None) -> ErrorRow:
        """Statistics of ``errors`` (metres); ``episodes`` labels correlated predictions for
        the intervals (:func:`mean_interval`)."""
        e = np.asarray(errors, dtype=np.float64)
        if len(e) == 0:
            return cls(moves, group, 0, *(float("nan"),) * 4)
        low, high = mean_interval(e, episodes)
        within = (e <= WITHIN).astype(np.float64)
        return cls(moves, group, len(e), 100 * e.mean(), 100 * float(np.median(e)),
                   100 * float(np.percentile(e, 99)), float(within.mean()),
                   100 * low, 100 * high, *mean_interval(within, episodes))


def cords_of(model: TransitionModel, data: TransitionDataset, idx: np.ndarray
             ) -> np.ndarray | None:
    """The cords of transitions ``idx`` for a model that sees cords (``cord_inputs``); None,
    its own cord, for a model of one cord."""
    return data.params[idx] if model.config.cord_inputs else None


def pegs_of(data: TransitionDataset, idx: np.ndarray) -> np.ndarray | None:
    """The pegs of transitions ``idx`` (``PEG_FAR`` in empty slots), None without pegs."""
    return data.peg_rows(idx) if data.pegs.shape[1] else None


def rollout_errors(model: TransitionModel, data: TransitionDataset, moves: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Errors (metres) after ``moves`` chained predictions from every possible chain start.

    Returns:
        ``(first, errors)``: the index of each chain's first transition and its error.
    """
    first = chain_starts(data.episode, data.step, moves)
    errors = np.zeros(len(first))
    for code, name in enumerate(GRASP_NAMES):
        sel = first[data.grasp[first] == code]
        if not len(sel):
            continue
        shapes = data.start[sel]
        for k in range(moves):
            shapes = model.predict(shapes, name, data.end_displacement(sel + k),
                                   params=cords_of(model, data, sel + k),
                                   pegs=pegs_of(data, sel + k))
        errors[data.grasp[first] == code] = error(shapes, data.next[sel + moves - 1])
    return first, errors


def spread_rank_correlation(model: TransitionModel, data: TransitionDataset) -> float:
    """Spearman rank correlation between the ensemble's spread and the one-move error (NaN
    for a model of one network: it has no spread)."""
    if model.config.members < 2:
        return float("nan")
    spreads, errors = [], []
    for code, name in enumerate(GRASP_NAMES):
        idx = np.flatnonzero(data.grasp == code)
        if not len(idx):
            continue
        pred, spread = model.predict(data.start[idx], name, data.end_displacement(idx),
                                     params=cords_of(model, data, idx), return_std=True,
                                     pegs=pegs_of(data, idx))
        spreads.append(spread)
        errors.append(error(pred, data.next[idx]))
    s, e = np.concatenate(spreads), np.concatenate(errors)
    if len(s) < 2:
        return float("nan")
    rs, re = np.argsort(np.argsort(s)), np.argsort(np.argsort(e))
    return float(np.corrcoef(rs, re)[0, 1])


def transition_report(model: TransitionModel, data: TransitionDataset, max_moves: int = 3
                      ) -> tuple[list[ErrorRow], float]:
    """Error rows (1 to ``max_moves`` moves; all, by grasp, by length) and the spread-error
    rank correlation, on ``data``."""
    rows: list[ErrorRow] = []
    lengths = 100 * np.linalg.norm(data.displacement, axis=-1).max(axis=-1)
    for moves in range(1, max_moves + 1):
        first, errors = rollout_errors(model, data, moves)
        episodes = data.episode[first]
        rows.append(ErrorRow.of(moves, "all", errors, episodes))
        for code, name in enumerate(GRASP_NAMES):
            sel = data.grasp[first] == code
            rows.append(ErrorRow.of(moves, name, errors[sel], episodes[sel]))
        if moves == 1:
            for lo, hi in LENGTH_BINS:
                sel = (lengths[first] >= lo) & (lengths[first] < hi)
                rows.append(ErrorRow.of(1, f"{lo}-{min(hi, 35)} cm", errors[sel],
                                        episodes[sel]))
    return rows, spread_rank_correlation(model, data)


def report_lines(rows: list[ErrorRow], rank: float) -> list[str]:
    """The report as a printed table."""
    lines = [f"{'moves':>5} {'group':<10} {'count':>6} {'mean':>8} {'95% interval':>15} "
             f"{'median':>8} {'p99':>8} {'<=1cm':>7}"]
    for r in rows:
        if not r.count:  # no held-out move of this group: nothing measured
            lines.append(f"{r.moves:>5} {r.group:<10} {r.count:>6} {'-':>8}")
            continue
        interval = (f"{r.mean_low_cm:.3f}-{r.mean_high_cm:.3f}cm"
                    if np.isfinite(r.mean_low_cm) else "-")  # too few moves for an interval
        lines.append(f"{r.moves:>5} {r.group:<10} {r.count:>6} {r.mean_cm:>6.3f}cm "
                     f"{interval:>15} "
                     f"{r.median_cm:>6.3f}cm {r.p99_cm:>6.2f}cm {100 * r.within_1cm:>6.2f}%")
    lines.append(f"spread-error rank correlation (one move): {rank:.3f}")
    return lines


def write_report(rows: list[ErrorRow], rank: float, out: str | os.PathLike[str]) -> Path:
    """Write ``transition-metrics.csv`` and ``transition-metrics.png`` into ``out``."""
    out = Path(out)
    with atomic_path(out / "transition-metrics.csv") as tmp, tmp.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(asdict(rows[0])) + ["spread_rank"])
        writer.writeheader()
        for r in rows:
            writer.writerow({**asdict(r), "spread_rank": round(rank, 4)})
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = [g for g in ("all", *GRASP_NAMES)]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    width = 0.25
    for k in (1, 2, 3):
        got = {r.group: r for r in rows if r.moves == k}
        x = np.arange(len(groups)) + (k - 2) * width
        axes[0].bar(x, [got[g].mean_cm if g in got else 0 for g in groups], width,
                    label=f"{k} move{'s' if k > 1 else ''}")
        axes[0].scatter(x, [got[g].p99_cm if g in got else 0 for g in groups], marker="_",
                        s=120, color="k", zorder=3, label="99th percentile" if k == 1 else None)
    axes[0].set_xticks(np.arange(len(groups)), groups)
    axes[0].set_ylabel("error (cm, log scale)")
    for ax in axes:
        ax.set_yscale("log")
        ax.axhline(1.0, color="0.6", lw=0.8, ls="--")
    axes[0].set_title("held-out error by grasp and chain length")
    axes[0].legend(fontsize=8)
    bins = [r for r in rows if r.moves == 1 and r.group.endswith("cm")]
    axes[1].bar([r.group for r in bins], [r.mean_cm for r in bins], color="tab:blue",
                label="mean")
    axes[1].scatter([r.group for r in bins], [r.p99_cm for r in bins], marker="_", s=120,
                    color="k", zorder=3, label="99th percentile")
    axes[1].set_xlabel("move length (dashed: 1 cm)")
    axes[1].set_title(f"one move by length (spread-error rank corr. {rank:.2f})")
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    with atomic_path(out / "transition-metrics.png") as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return out
