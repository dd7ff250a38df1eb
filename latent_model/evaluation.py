"""The shipped model's quality report: every floor, measured the same way everywhere.

``quality_report`` is what ``dlo train`` prints at the end, what ``benchmarks/train_quality.py``
logs and what docs/shape_model.md quotes. ``foreign_shapes`` draws the cord-like shapes that do not
come from the collector (arcs, S-curves, clothoids) for the generalisation floor.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
import torch

import latent_model.metrics as metrics
from dlo_env.errors import InputError
from dlo_env.shapes import TABLE_HALF, is_cord_like, shape_from_headings
from latent_model.dataset import SHAPE_GROUPS, evaluation_subsets
from latent_model.shape_model import ShapeModel

#: Floors of the shipped model (docs/shape_model.md).
FLOORS = {
    "cov": (">=", 0.85),
    "mmd": ("<=", 0.015),
    "nna": ("<=", 0.70),
    "spacing_cv": ("<=", 0.05),
    "length_error": ("<=", 0.03),
    "inversion": (">=", 0.95),
    "foreign_inversion": (">=", 0.90),
}
#: Largest curvature of the foreign shapes, 1/m (an arc of 1 m at 6/m turns by 344 degrees).
FOREIGN_MAX_CURVATURE = 6.0
FOREIGN_KINDS = ("arc", "s-curve", "clothoid")


def foreign_shapes(
    n: int, seed: int, *, n_points: int = 20, length: float = 1.0, margin: float = 0.05,
    max_curvature: float = FOREIGN_MAX_CURVATURE,
) -> tuple[np.ndarray, np.ndarray]:
    """Cord-like shapes not made by the simulator: arcs, S-curves and clothoids.

    Curvature along the arc length ``s in [0, 1]``: arc ``k(s) = a``; S-curve
    ``k(s) = a cos(pi s)`` (one inflection in the middle); clothoid ``k(s) = a + (b - a) s``;
    ``a, b`` uniform in ``[-max_curvature, max_curvature]``. Each shape is turned uniformly and
    placed uniformly where it fits on the table with ``margin``; kinds cycle in that order.

    Returns:
        Shapes ``(n, n_points, 2)`` float32 and their kind index ``(n,)`` into ``FOREIGN_KINDS``.
    """
    rng = np.random.default_rng(seed)
    segment = length / (n_points - 1)
    s = (np.arange(n_points - 2) + 1.0) / (n_points - 1)  # arc position of the inner joints
    half = TABLE_HALF - margin
    shapes, kinds = [], []
    while len(shapes) < n:
        kind = len(shapes) % 3
        a, b = rng.uniform(-max_curvature, max_curvature, size=2)
        kappa = {0: np.full_like(s, a), 1: a * np.cos(np.pi * s), 2: a + (b - a) * s}[kind]
        headings = rng.uniform(-np.pi, np.pi) + np.concatenate([[0.0], np.cumsum(kappa * segment)])
        shape = shape_from_headings(headings, segment, np.zeros(2))
        lo, hi = shape.min(axis=0), shape.max(axis=0)
        room_lo, room_hi = -half - lo, half - hi
        if (room_lo > room_hi).any() or not is_cord_like(shape):
            continue
        shapes.append(shape + rng.uniform(room_lo, room_hi))
        kinds.append(kind)
    return np.asarray(shapes, dtype=np.float32), np.asarray(kinds)


@dataclass(frozen=True)
class QualityReport:
    """Every number the floors are about (see ``latent_model.metrics`` for definitions).

    Attributes:
        cov, mmd, nna, spacing_cv, length, length_error: Set metrics of ``5 * n_reference``
            samples against ``n_reference`` held-out shapes, pose-aligned.
        inversion_encoder: Share of held-out shapes within 1 cm from the Encoder alone.
        inversion: Same after refinement (``ShapeModel.invert``).
        foreign_inversion_encoder, foreign_inversion: The same on ``foreign_shapes``.
        inversion_median_error: Median refined error on the held-out shapes, metres.
        n_reference, n_inversion: Sample sizes.
        groups: The break-down by ``SHAPE_GROUPS`` when the held-out shapes record their moves:
            ``group -> {"cov", "mmd", "nna", "inversion", "n_reference", "n_inversion"}``
            (``metrics.grouped_quality``; inversion after refinement). Empty otherwise.
    """

    cov: float
    mmd: float
    nna: float
    spacing_cv: float
    length: float
    length_error: float
    inversion_encoder: float
    inversion: float
    foreign_inversion_encoder: float
    foreign_inversion: float
    inversion_median_error: float
    n_reference: int
    n_inversion: int
    groups: dict[str, dict[str, float]] = field(default_factory=dict)

    def checks(self) -> dict[str, tuple[float, str, float, bool]]:
        """``name -> (value, op, floor, passed)`` for every floor."""
        out = {}
        for name, (op, floor) in FLOORS.items():
            value = getattr(self, name)
            out[name] = (value, op, floor, value >= floor if op == ">=" else value <= floor)
        return out

    def format(self) -> str:
        """A plain-text table of values against floors."""
        lines = [f"{'metric':<28}{'value':>10}  floor"]
        for name, (value, op, floor, ok) in self.checks().items():
            shown = f"{100 * value:.2f} cm" if name == "mmd" else f"{value:.3f}"
            floor_s = f"{100 * floor:.1f} cm" if name == "mmd" else f"{floor}"
            lines.append(f"{name:<28}{shown:>10}  {op} {floor_s}  {'ok' if ok else 'BELOW FLOOR'}")
        lines.append(f"{'inversion_encoder':<28}{self.inversion_encoder:>10.3f}  (encoder only)")
        lines.append(f"{'foreign_inversion_encoder':<28}{self.foreign_inversion_encoder:>10.3f}"
                     "  (encoder only)")
        lines.append(f"{'inversion_median_error':<28}{100 * self.inversion_median_error:>7.2f} cm")
        lines.append(f"{'length':<28}{self.length:>8.4f} m")
        lines.append(f"(n_reference={self.n_reference}, generated={5 * self.n_reference}, "
                     f"n_inversion={self.n_inversion})")
        if self.groups:
            lines.append(f"{'by the ends driven':<16}{'cov':>7}{'mmd cm':>8}{'nna':>7}"
                         f"{'inversion':>11}{'reference':>11}{'inverted':>10}")
            for name, g in self.groups.items():
                lines.append(f"{name:<16}{g['cov']:>7.3f}{100 * g['mmd']:>8.2f}{g['nna']:>7.3f}"
                             f"{g['inversion']:>11.3f}{g['n_reference']:>11d}"
                             f"{g['n_inversion']:>10d}")
        return "\n".join(lines)

    def as_dict(self) -> dict[str, float]:
        """The report as a plain dict."""
        return asdict(self)


def quality_report(
    model: ShapeModel,
    heldout: np.ndarray,
    *,
    n_reference: int = 2000,
    n_inversion: int = 1000,
    seed: int = 0,
    groups: np.ndarray | None = None,
) -> QualityReport:
    """Measure ``model`` against held-out simulator shapes and foreign shapes.

    ``n_reference`` random held-out shapes are the reference set and ``n_inversion`` others are
    inverted (``evaluation_subsets``, seeded by ``seed``); ``n_inversion`` foreign shapes are
    inverted too. ``groups`` (``(M,)`` indices into ``SHAPE_GROUPS``, as
    ``latent_model.dataset.load_labelled_shapes`` reads them) adds the break-down by group.
    """
    heldout = np.asarray(heldout, dtype=np.float32)
    sizes = (n_reference, n_inversion)
    reference_np, targets = evaluation_subsets(heldout, sizes, seed)
    reference = torch.from_numpy(reference_np)
    generated = torch.from_numpy(model.sample(5 * n_reference, seed=seed))
    q = metrics.set_quality(generated, reference, model.cord_length)
    _, err_e, _ = model.invert(targets, refine=False)
    _, err, _ = model.invert(targets, seed=seed)
    foreign, _ = foreign_shapes(n_inversion, seed, n_points=model.n_points,
                                length=model.cord_length)
    _, ferr_e, _ = model.invert(foreign, refine=False)
    _, ferr, _ = model.invert(foreign, seed=seed)
    rate = metrics.success_rate
    by_group: dict[str, dict[str, float]] = {}
    if groups is not None:
        groups = np.asarray(groups)
        if groups.shape != (len(heldout),):
            raise InputError(f"groups must have shape ({len(heldout)},), got {groups.shape}")
        ref_groups, target_groups = evaluation_subsets(groups, sizes, seed)
        broken = metrics.grouped_quality(generated, reference, torch.from_numpy(ref_groups))
        for g, (cov, mmd, nna) in broken.items():
            mine = target_groups == g
            by_group[SHAPE_GROUPS[g]] = {
                "cov": cov, "mmd": mmd, "nna": nna,
                "inversion": rate(torch.as_tensor(np.asarray(err)[mine])) if mine.any()
                else float("nan"),
                "n_reference": int((ref_groups == g).sum()), "n_inversion": int(mine.sum())}
    return QualityReport(
        cov=q.cov, mmd=q.mmd, nna=q.nna, spacing_cv=q.spacing_cv, length=q.length,
        length_error=q.length_error,
        inversion_encoder=rate(torch.as_tensor(err_e)), inversion=rate(torch.as_tensor(err)),
        foreign_inversion_encoder=rate(torch.as_tensor(ferr_e)),
        foreign_inversion=rate(torch.as_tensor(ferr)),
        inversion_median_error=float(np.median(err)),
        n_reference=n_reference, n_inversion=n_inversion, groups=by_group,
    )
