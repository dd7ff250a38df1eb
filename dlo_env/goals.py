"""Designed goals: letters, curves or any polyline, as shapes the cord can rest in.

A designed goal starts as a drawing: a polyline of any size (a letter's stroke, an arc, an
S-curve, a zigzag, a spiral, or the user's own points). :func:`polyline` makes a goal of it for
a cord:

1. it rounds the drawing's corners (Chaikin's corner cutting, ``rounding`` passes) and walks
   along it with a compass whose span (found by bisection) puts the last point on its end, then
   scales the points to the cord's spacing: every point lies on the drawing;
2. it turns and moves it to the pose asked for (``center``, ``angle``) and checks that it lies
   on the table (and, both ends held, that its ends fit the grippers' span);
3. it relaxes it in the simulator (``relax=True``): the cord is laid in the drawn shape with
   its held end(s) gripped and left until it is at rest, so the goal is a shape the cord can
   rest in. A drawing the cord cannot hold (a corner sharper than it can bend, which springs
   open) is refused when the rest shape lies more than ``max_change`` from it.

Every error is one line naming the argument and why::

    from dlo_env import goals
    goal = goals.arc(span=2.5, center=(0.2, -0.1), angle=0.5)   # (20, 2) float32, at rest
    obs, info = env.reset(options={"goal": goal})                # from a random start
    goal = goals.polyline([[0, 0], [0.3, 0.1], [0.6, 0]])        # the user's own drawing
    soft = CordParams(bending_stiffness=0.001)   # the default cord springs open out of letters
    goal = goals.letter("S", params=soft)        # for gym.make(..., params=soft)

Score designed goals direction-free (``info["direction_free_error"]``, ``info["bead_share"]``):
a drawing does not say which end is the head.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import numpy as np

from dlo_env.cord import Cord, CordParams
from dlo_env.errors import InputError
from dlo_env.shapes import TABLE_HALF, error, on_table
from dlo_env.tasks import GRASP_ENDS, REST_SPEED, SPAN_MARGIN

#: The largest mean point distance between a drawing and the shape it relaxes into, metres.
MAX_CHANGE = 0.03
#: Simulated seconds the cord may take to come to rest in a drawing.
RELAX_SECONDS = 3.0


def _real(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _integer(value: object) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _arc(center: tuple[float, float], radius: float, start: float, stop: float,
         count: int = 24) -> np.ndarray:
    angles = np.linspace(start, stop, count)
    return np.stack([center[0] + radius * np.cos(angles),
                     center[1] + radius * np.sin(angles)], axis=1)


def _stroke(*parts: Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    return np.concatenate([np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in parts])


#: The gap left between the ends of the letter O, as a share of its circle: the ends meet, a
#: little apart (two held ends need room for their grippers).
O_GAP = 1 / 40

#: Each letter as one stroke (x right, y up, about a unit box; M and W three times as wide: a
#: cord of 20 points cannot rest in their narrow corners), drawn without lifting the pen; O is
#: a ring from its top whose ends meet.
LETTERS: dict[str, np.ndarray] = {
    "C": _arc((0.5, 0.5), 0.5, np.radians(50), np.radians(310)),
    "J": _stroke([[1.0, 1.0]], _arc((0.6, 0.4), 0.4, 0.0, -np.pi)),
    "L": _stroke([[0.0, 1.0], [0.0, 0.0], [0.6, 0.0]]),
    "M": _stroke([[0.0, 0.0], [0.8, 1.0], [1.6, 0.3], [2.4, 1.0], [3.2, 0.0]]),
    "S": _stroke(_arc((0.5, 0.75), 0.25, np.radians(20), np.radians(270)),
                 _arc((0.5, 0.25), 0.25, np.radians(90), np.radians(-160))),
    "U": _stroke([[0.0, 1.0]], _arc((0.5, 0.5), 0.5, np.pi, 2 * np.pi), [[1.0, 1.0]]),
    "V": _stroke([[0.0, 1.0], [0.5, 0.0], [1.0, 1.0]]),
    "W": _stroke([[0.0, 1.0], [0.8, 0.0], [1.6, 0.7], [2.4, 0.0], [3.2, 1.0]]),
    "Z": _stroke([[0.0, 1.0], [1.0, 1.0], [0.0, 0.0], [1.0, 0.0]]),
    "O": _arc((0.5, 0.5), 0.5, 0.5 * np.pi, 0.5 * np.pi + 2 * np.pi * (1 - O_GAP), 64),
}


def _rounded(drawing: np.ndarray, passes: int) -> np.ndarray:
    """Chaikin's corner cutting, ``passes`` times, the ends kept: a corner becomes a curve
    spread over several of the cord's joints instead of one bend sharper than a joint takes."""
    for _ in range(passes):
        cut = np.empty((2 * (len(drawing) - 1), 2))
        cut[0::2] = 0.75 * drawing[:-1] + 0.25 * drawing[1:]
        cut[1::2] = 0.25 * drawing[:-1] + 0.75 * drawing[1:]
        drawing = np.concatenate([drawing[:1], cut, drawing[-1:]])
    return drawing


def _walk(drawing: np.ndarray, n_points: int, step: float) -> np.ndarray | None:
    """``n_points`` points along ``drawing``, each ``step`` from the last (a compass walked
    along the polyline), or None when the drawing ends first."""
    points = [drawing[0]]
    k, here = 0, drawing[0]  # the walk is on the drawing's segment k, at ``here``
    for _ in range(n_points - 1):
        centre = points[-1]
        # ``here`` is inside the compass's circle: find where the drawing leaves it.
        while float(np.linalg.norm(drawing[k + 1] - centre)) < step:
            k, here = k + 1, drawing[k + 1]
            if k + 1 >= len(drawing):
                return None
        d, f = drawing[k + 1] - here, here - centre
        qa, qb, qc = d @ d, 2 * (f @ d), f @ f - step**2
        here = here + (-qb + np.sqrt(max(qb * qb - 4 * qa * qc, 0.0))) / (2 * qa) * d
        points.append(here)
    return np.asarray(points)


def _resampled(drawing: np.ndarray, n_points: int) -> np.ndarray:
    """``n_points`` points on ``drawing`` with equal distances between neighbours, the first
    and last at its ends (the compass's span found by bisection)."""
    total = float(np.linalg.norm(np.diff(drawing, axis=0), axis=1).sum())
    end = drawing[-1]
    low, high = 0.0, total / (n_points - 1)  # chords are no longer than the drawing's arcs
    best = None
    for _ in range(60):
        step = 0.5 * (low + high)
        points = _walk(drawing, n_points, step)
        if points is None:
            high = step
        else:
            low, best = step, points
    if best is None or float(np.linalg.norm(best[-1] - end)) > 0.01 * low:
        raise InputError("points must draw a line the cord can follow with its segments: it "
                         "folds back on itself in less than one segment's length")
    best[-1] = end  # within the bisection's last bit of the end
    return best


def polyline(
    points: Sequence[Sequence[float]] | np.ndarray,
    *,
    params: CordParams | None = None,
    center: Sequence[float] = (0.0, 0.0),
    angle: float = 0.0,
    grasp: str = "head",
    relax: bool = True,
    max_change: float = MAX_CHANGE,
    rounding: int = 3,
) -> np.ndarray:
    """A goal shape for the cord from any drawing: resampled, placed and relaxed.

    Args:
        points: ``(k, 2)`` the drawing, k >= 2, any size and units (it is scaled to the cord's
            length); its first point becomes the head.
        params: The cord (default cord if None): its length and points.
        center: Where the goal's bounding-box centre goes on the table, metres.
        angle: Rotation of the drawing about its centre, radians (counter-clockwise).
        grasp: The end(s) held while the goal relaxes, as in the environment it is for:
            ``"head"`` (``DLOEndpoint-v0``) or ``"both"`` (``DLODualEndpoint-v0``).
        relax: Let the cord come to rest in the drawn shape in the simulator (the goal is then
            a shape the cord rests in); False returns the resampled, placed drawing.
        max_change: Refuse a drawing whose rest shape lies farther than this (mean point
            distance, metres) from it.
        rounding: Passes of corner cutting before resampling (0: the corners as drawn).

    Returns:
        float32 ``(n, 2)`` in world metres.

    Raises:
        ValueError: One line naming the argument: a drawing with fewer than two distinct
            points or not finite, a pose off the table, ends wider than the grippers' span, or
            a shape the cord cannot rest in.
    """
    p = params if params is not None else CordParams()
    if not isinstance(p, CordParams):
        raise InputError(f"params must be a CordParams or None, got {type(p).__name__}")
    if grasp not in GRASP_ENDS:
        raise InputError(f"grasp must be one of {tuple(GRASP_ENDS)}, got {grasp!r}")
    try:
        drawing = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"points must be a (k, 2) array of numbers, got {points!r:.60}") from None
    if drawing.ndim != 2 or drawing.shape[1] != 2 or len(drawing) < 2:
        raise InputError(f"points must be a (k, 2) polyline with k >= 2, got shape "
                         f"{drawing.shape}")
    if not np.isfinite(drawing).all():
        raise InputError("points must be finite, got NaN or infinite coordinates")
    steps = np.linalg.norm(np.diff(drawing, axis=0), axis=1)
    total = float(steps.sum())
    if total <= 1e-12:
        raise InputError("points must not all be the same point: the drawing has no length")
    drawing = drawing[np.concatenate([[True], steps > 1e-9 * total])]  # repeats add nothing
    try:
        centre = np.asarray(center, dtype=np.float64)
    except (TypeError, ValueError):
        centre = np.full(1, np.nan)
    if centre.shape != (2,) or not np.isfinite(centre).all():
        raise InputError(f"center must be two finite numbers (metres), got {center!r}")
    if not (_real(angle) and np.isfinite(angle)):
        raise InputError(f"angle must be a finite number (radians), got {angle!r}")
    if not (_real(max_change) and max_change > 0):
        raise InputError(f"max_change must be a number > 0 (metres), got {max_change!r}")
    if not (_integer(rounding) and 0 <= rounding <= 8):
        raise InputError(f"rounding must be an int in 0..8, got {rounding!r}")

    drawing = _rounded(drawing, rounding)
    shape = _resampled(drawing, p.n_points)
    shape = shape * (p.length / float(np.linalg.norm(np.diff(shape, axis=0), axis=1).sum()))
    c, s = np.cos(angle), np.sin(angle)
    shape = shape @ np.array([[c, s], [-s, c]])  # turned counter-clockwise
    shape = shape - 0.5 * (shape.min(axis=0) + shape.max(axis=0)) + centre
    if not on_table(shape, TABLE_HALF - p.rim_margin):
        raise InputError(f"center and angle must keep the goal on the table (within "
                         f"{TABLE_HALF - p.rim_margin:g} m of its centre on both axes, where "
                         f"the grippers reach), but it reaches {np.abs(shape).max():.3f} m")
    span = p.max_span * p.length - SPAN_MARGIN
    if grasp == "both" and np.linalg.norm(shape[-1] - shape[0]) >= span:
        raise InputError(f"points must keep the ends closer than the grippers' span ({span:.3f} "
                         f"m) for grasp='both', got {np.linalg.norm(shape[-1] - shape[0]):.3f} m")
    shape = shape.astype(np.float32)
    if not relax:
        return shape
    cord = Cord(p, grasp=grasp)
    cord.reset(shape)
    if cord.settle(tolerance=REST_SPEED, max_time=RELAX_SECONDS) >= RELAX_SECONDS:
        raise InputError(f"points must draw a shape the cord can rest in: it still moves after "
                         f"{RELAX_SECONDS:g} s")
    rest = cord.shape
    change = float(error(rest, shape))
    if change > max_change:
        raise InputError(f"points must draw a shape the cord can rest in: it relaxes "
                         f"{100 * change:.1f} cm from the drawing (max_change "
                         f"{100 * max_change:.1f} cm): bend it less (wider, more rounding) or "
                         f"use a softer cord (params)")
    if not on_table(rest, TABLE_HALF):
        raise InputError("center and angle must keep the relaxed goal on the table")
    return rest


def letter(name: str, aspect: float = 1.0, **pose: object) -> np.ndarray:
    """A letter of :data:`LETTERS` (C, J, L, M, S, U, V, W, Z, O) as a goal: :func:`polyline`'s
    keyword arguments place and relax it.

    Args:
        name: The letter.
        aspect: Its width is drawn ``aspect`` times as wide (its height unchanged). The cord's
            length sets a letter's size: its proportions are what a drawing chooses.

    Raises:
        ValueError: For a letter not in ``LETTERS``, an aspect not in [0.25, 4], or as
            :func:`polyline`.
    """
    key = str(name).upper()
    if key not in LETTERS:
        raise InputError(f"name must be one of the letters {', '.join(LETTERS)}, got {name!r}")
    if not (_real(aspect) and 0.25 <= aspect <= 4):
        raise InputError(f"aspect must be a number in [0.25, 4], got {aspect!r}")
    return polyline(LETTERS[key] * np.array([aspect, 1.0]), **pose)  # type: ignore[arg-type]


def arc(span: float = np.pi, **pose: object) -> np.ndarray:
    """A circular arc turning by ``span`` radians (0 < span < 2 pi) as a goal."""
    if not (_real(span) and 0 < span < 2 * np.pi):
        raise InputError(f"span must be a number in (0, 2 pi) radians, got {span!r}")
    return polyline(_arc((0.0, 0.0), 1.0, 0.0, float(span), 64), **pose)  # type: ignore[arg-type]


def s_curve(amplitude: float = 0.25, **pose: object) -> np.ndarray:
    """One full sine period, ``amplitude`` times its wavelength high, as a goal."""
    if not (_real(amplitude) and 0 < amplitude <= 1):
        raise InputError(f"amplitude must be a number in (0, 1], got {amplitude!r}")
    x = np.linspace(0.0, 1.0, 64)
    return polyline(np.stack([x, amplitude * np.sin(2 * np.pi * x)], axis=1),
                    **pose)  # type: ignore[arg-type]


def zigzag(teeth: int = 3, amplitude: float = 0.25, **pose: object) -> np.ndarray:
    """``teeth`` triangular teeth, ``amplitude`` times a tooth's width high, as a goal."""
    if not (_integer(teeth) and 1 <= teeth <= 8):
        raise InputError(f"teeth must be an int in 1..8, got {teeth!r}")
    if not (_real(amplitude) and 0 < amplitude <= 2):
        raise InputError(f"amplitude must be a number in (0, 2], got {amplitude!r}")
    x = np.arange(2 * teeth + 1) / 2.0
    y = amplitude * (np.arange(2 * teeth + 1) % 2)
    return polyline(np.stack([x, y], axis=1), **pose)  # type: ignore[arg-type]


def spiral(turns: float = 1.25, **pose: object) -> np.ndarray:
    """An Archimedean spiral of ``turns`` turns from its centre outwards, as a goal."""
    if not (_real(turns) and 0.25 <= turns <= 3):
        raise InputError(f"turns must be a number in [0.25, 3], got {turns!r}")
    t = np.linspace(0.0, 2 * np.pi * turns, 128)
    radius = 0.3 + t  # a start off the centre: the innermost turn is not sharper than the cord
    return polyline(np.stack([radius * np.cos(t), radius * np.sin(t)], axis=1),
                    **pose)  # type: ignore[arg-type]


#: The curve families by name (their default parameters): for suites and loops over families.
CURVES = {"arc": arc, "s-curve": s_curve, "zigzag": zigzag, "spiral": spiral}
