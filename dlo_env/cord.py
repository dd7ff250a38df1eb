"""The cord simulator: a planar chain on a table seen from above (pymunk).

The cord is ``n - 1`` rigid segments joined end to end by pivot joints (inextensible links).
Bending stiffness is a damped rotary spring at every joint. Table friction uses pymunk's
top-down idiom: every segment is tied to the static body by a pivot joint and a gear joint
with ``max_bias = 0`` and a ``max_force`` equal to the Coulomb friction force (torque), so a
segment sticks until the net force exceeds friction and slides against a bounded force
otherwise. Grippers are kinematic bodies pinned to the head and/or the tail; they move at a
bounded speed and are kept on the table. The table has a hard rim: static walls stop the
cord, and a link the grippers force into a wall is shifted back, so no point ever leaves it.
The cord may cross over itself: self-contact is not modelled. Pegs (fixed round posts of
``peg_radius``, none by default) are static circles the links collide with: a gripper stops
where it would touch one (:func:`reachable_targets`), and a link pressed into one is shifted
out, so no point of the cord ever lies inside a peg.

Time advances in control periods of ``dt`` seconds, each split into ``substeps`` equal
physics steps; the solver is single-threaded, so the same inputs give the same numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pymunk
import pymunk.batch

from dlo_env.core.checks import all_finite, fractions, non_negative, positive, positive_ints
from dlo_env.errors import InputError
from dlo_env.shapes import TABLE_HALF, at_segment_length, validate_shape

Grasp = Literal["head", "tail", "both", "none"]
_GRASPS = ("head", "tail", "both", "none")
#: Collision radius of a link around its centre line, metres.
LINK_RADIUS = 0.005
#: Half-thickness of the rim walls, metres (thick, so no fast link passes through one).
RIM_THICKNESS = 0.05
#: Overlap the contact solver tolerates before pushing apart, metres (pymunk's default, 0.1,
#: is scaled for pixels: on a metre-scale table it let the cord sink 5 mm into the rim).
COLLISION_SLOP = 5e-4
#: Points are kept this far inside the edge (float32 rounding of a point on the edge).
RIM_GUARD = 1e-6
#: Radius of a peg, metres (the default of ``Cord`` and of the environments' ``peg_radius``).
PEG_RADIUS = 0.02
#: The most pegs an environment observes (``max_pegs``) and a collection places.
MAX_PEGS = 16
#: Where an empty peg slot lies (a batch of moves with different numbers of pegs): too far
#: from the table to touch anything.
PEG_FAR = 1e3
#: A point pressed into a peg is moved out to this far beyond its surface, metres; a gripper
#: stops at ``LINK_RADIUS`` plus this from it.
PEG_GUARD = 1e-4


@dataclass(frozen=True)
class CordParams:
    """Physical and numerical parameters of the cord; defaults are the documented cord.

    Attributes:
        n_points: Points of the chain (``n_points - 1`` segments).
        length: Rest length, metres.
        mass: Total mass, kg.
        friction: Coulomb friction coefficient between cord and table.
        bending_stiffness: Flexural rigidity EI, N m^2 (a spring of EI / segment at each joint).
        bending_damping: Damping of each joint spring, N m s / rad.
        gravity: m / s^2, only used for the friction force.
        inertia_scale: Factor on each segment's moment of inertia. The motion is quasi-static
            (friction dominated), so inflating rotational inertia changes the shapes little and
            keeps the explicit joint springs stable at this ``dt / substeps``.
        velocity_retention: pymunk ``Space.damping``, the share of velocity kept per second
            (1.0: no extra damping; table friction dissipates the motion).
        joint_error_bias: pymunk ``error_bias`` of the link and gripper joints, the fraction of
            a joint's drift left after one second (small: links stay at rest length).
        dt: Control period, seconds (one environment step).
        substeps: Equal physics steps per control period.
        iterations: Constraint solver iterations per physics step.
        max_speed: Largest gripper speed, m/s.
        rim_margin: Grippers stay this far inside the table edge, metres.
        max_span: With both ends grasped, the grippers stay at most ``max_span * length`` apart.
        peg_friction: Coulomb friction coefficient between the cord and the pegs (0: the pegs
            are frictionless). A cord wrapped round a peg then holds by the capstan effect.
    """

    n_points: int = 20
    length: float = 1.0
    mass: float = 0.1
    friction: float = 0.4
    bending_stiffness: float = 0.01
    bending_damping: float = 0.002
    gravity: float = 9.81
    inertia_scale: float = 10.0
    velocity_retention: float = 1.0
    joint_error_bias: float = 1e-6
    dt: float = 0.1
    substeps: int = 20
    iterations: int = 30
    max_speed: float = 0.2
    rim_margin: float = 0.02
    max_span: float = 0.9
    peg_friction: float = 0.0

    def __post_init__(self) -> None:
        positive(self, "length", "mass", "gravity", "inertia_scale", "dt", "max_speed")
        non_negative(self, "friction", "bending_stiffness", "bending_damping", "rim_margin",
                     "peg_friction")
        fractions(self, "velocity_retention", "joint_error_bias", "max_span")
        if self.n_points < 3:
            raise InputError(f"CordParams.n_points must be >= 3, got {self.n_points!r}")
        positive_ints(self, "substeps", "iterations")

    @property
    def segment(self) -> float:
        """Rest length of one segment, metres."""
        return self.length / (self.n_points - 1)


def check_pegs(pegs: object, name: str = "pegs", radius: float = 0.0) -> np.ndarray:
    """``pegs`` as float64 ``(k, 2)`` peg centres on the table (metres), or ``ValueError``;
    with ``radius``, every peg wholly on the table."""
    arr = np.zeros((0, 2)) if pegs is None else np.asarray(pegs, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, 2))
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise InputError(f"{name} must be an array of peg centres, shape (k, 2) metres, "
                         f"got shape {arr.shape}")
    if not np.isfinite(arr).all():
        bad = arr[~np.isfinite(arr).all(axis=1)][0]
        raise InputError(f"{name} must be finite, got {bad.tolist()}")
    off = (np.abs(arr) + radius >= TABLE_HALF).any(axis=1)
    if off.any():
        less = f" less the radius {radius} m" if radius else ""
        raise InputError(f"{name} must lie on the table (|x|, |y| < {TABLE_HALF} m{less}), "
                         f"got {arr[off][0].tolist()}")
    return arr


def peg_clearance(shape: np.ndarray, pegs: np.ndarray, peg_radius: float = PEG_RADIUS) -> float:
    """The least distance from the cord's centre line (the polyline of ``shape``, ``(n, 2)``)
    to a peg's surface, metres (``inf`` without pegs; negative when it crosses a peg)."""
    pegs = np.asarray(pegs, dtype=np.float64).reshape(-1, 2)
    if len(pegs) == 0:
        return math.inf
    pts = np.asarray(shape, dtype=np.float64).reshape(-1, 2)
    a, seg = pts[:-1], np.diff(pts, axis=0)  # (s, 2)
    rel = pegs[:, None, :] - a  # (k, s, 2)
    t = np.clip((rel * seg).sum(-1) / np.maximum((seg * seg).sum(-1), 1e-18), 0.0, 1.0)
    gap = rel - t[..., None] * seg
    return float(np.sqrt((gap * gap).sum(-1)).min()) - peg_radius


def check_not_crossing(shape: np.ndarray, pegs: np.ndarray, peg_radius: float, name: str
                       ) -> None:
    """Refuse (one-line ``ValueError`` naming ``name``) a shape whose centre line passes
    inside a peg; one resting against a peg (closer than ``LINK_RADIUS``, as the simulator
    leaves it) is fine."""
    if len(pegs) and peg_clearance(shape, pegs, peg_radius) < 0:
        raise InputError(f"{name} crosses a peg (its centre line passes inside one)")


def peg_contact(starts: np.ndarray, moves: np.ndarray, pegs: np.ndarray, reach: float
                ) -> np.ndarray:
    """The share of a straight move at which a held end first comes within ``reach`` of a peg.

    Args:
        starts: ``(..., k, 2)`` positions of the ``k`` held ends.
        moves: ``(..., k, 2)`` their displacements.
        pegs: ``(m, 2)`` peg centres, or ``(..., m, 2)``: each move's own (a slot far off the
            table, ``PEG_FAR``, holds no peg).
        reach: Distance from a centre that counts as touching, metres.

    Returns:
        ``(...,)`` in ``[0, 1]``: 1 when no end touches a peg on the way; 0 when an end starts
        touching one and moves towards its centre.
    """
    starts, moves = np.asarray(starts, dtype=np.float64), np.asarray(moves, dtype=np.float64)
    pegs = np.asarray(pegs, dtype=np.float64)
    if pegs.size == 0:
        return np.ones(starts.shape[:-2])
    rel = starts[..., :, None, :] - pegs[..., None, :, :]  # (..., k, m, 2)
    d = moves[..., :, None, :]
    a = (d * d).sum(-1)
    b = 2.0 * (d * rel).sum(-1)
    c = (rel * rel).sum(-1) - reach * reach
    disc = b * b - 4.0 * a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        enter = (-b - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a)
    hit = (c > 0) & (a > 0) & (disc > 0) & (enter >= 0) & (enter <= 1)
    t = np.where(hit, enter, np.inf)
    t = np.where((c <= 0) & (b < 0), 0.0, t)  # touching already and pressing in: no move
    return np.minimum(t.min(axis=(-2, -1)), 1.0)


def reachable_targets(targets: np.ndarray, params: CordParams | None = None, *,
                      starts: np.ndarray | None = None, pegs: np.ndarray | None = None,
                      peg_radius: float = PEG_RADIUS) -> np.ndarray:
    """Where the grippers really go when sent to ``targets``: the rule of ``Cord.move``.

    Targets are clipped to the table less ``rim_margin``; with two ends (head, tail) held,
    a pair farther apart than ``max_span * length`` is pulled in symmetrically about its
    middle. With ``pegs`` (and ``starts``), the straight move from ``starts`` stops where the
    first end would touch a peg (its centre line within ``peg_radius + LINK_RADIUS +
    PEG_GUARD``), every end at the same share of its move. Batched, so a learned model
    applies exactly the simulator's rule.

    Args:
        targets: ``(..., k, 2)`` target positions of the ``k`` held ends (1, or 2: head, tail).
        params: Cord parameters (default cord if None).
        starts: ``(..., k, 2)`` where the ends are (needed with pegs).
        pegs: ``(m, 2)`` peg centres, or ``(..., m, 2)`` each move's own (``PEG_FAR`` slots
            hold none); None or empty: no pegs.
        peg_radius: Radius of the pegs, metres.

    Returns:
        float64 ``(..., k, 2)`` reachable targets.
    """
    p = params if params is not None else CordParams()
    lim = TABLE_HALF - p.rim_margin
    # minimum/maximum and the explicit norm are np.clip's and np.linalg.norm's arithmetic
    # without their call overhead (this runs once per action of every simulated move).
    out = np.minimum(np.maximum(np.asarray(targets, dtype=np.float64), -lim), lim)
    if out.shape[-2] == 2:
        gap = out[..., 1, :] - out[..., 0, :]
        dist = np.sqrt((gap * gap).sum(axis=-1, keepdims=True))
        span = p.max_span * p.length
        too_far = dist > span
        if too_far.any():
            mid = 0.5 * (out[..., 0, :] + out[..., 1, :])
            half_gap = 0.5 * span * gap / np.where(too_far, dist, 1.0)
            out[..., 0, :] = np.where(too_far, mid - half_gap, out[..., 0, :])
            out[..., 1, :] = np.where(too_far, mid + half_gap, out[..., 1, :])
    if pegs is not None and np.size(pegs):
        if starts is None:
            raise InputError("starts must be given with pegs: a move stops where it meets one")
        starts = np.asarray(starts, dtype=np.float64)
        share = peg_contact(starts, out - starts, np.asarray(pegs, dtype=np.float64),
                            peg_radius + LINK_RADIUS + PEG_GUARD)
        out = starts + share[..., None, None] * (out - starts)
    return out


class Cord:
    """A simulated cord; read its shape, move its grasped ends.

    Args:
        params: The cord's parameters.
        grasp: Which ends grippers hold: ``"head"``, ``"tail"``, ``"both"`` or ``"none"``.
        pegs: ``(k, 2)`` centres of fixed round pegs on the table, metres (None: none).
        peg_radius: Radius of every peg, metres.

    Example:
        >>> cord = Cord()
        >>> cord.reset(straight_shape)
        >>> cord.move(head=(0.1, 0.0))
        >>> cord.shape  # (20, 2) float32, metres
    """

    def __init__(self, params: CordParams | None = None, grasp: Grasp = "head", *,
                 pegs: np.ndarray | None = None, peg_radius: float = PEG_RADIUS) -> None:
        self.params = params if params is not None else CordParams()
        self._check_grasp(grasp)
        self._grasp: Grasp = grasp
        if not (isinstance(peg_radius, (int, float, np.floating))
                and not isinstance(peg_radius, bool) and math.isfinite(peg_radius)
                and 0 < peg_radius < TABLE_HALF):
            raise InputError(f"peg_radius must be a number of metres in (0, {TABLE_HALF}), "
                             f"got {peg_radius!r}")
        self.peg_radius = float(peg_radius)
        self._pegs = check_pegs(pegs, radius=self.peg_radius)
        self._peg_shapes: list[pymunk.Circle] = []
        self.space: pymunk.Space | None = None
        self.segments: list[pymunk.Body] = []
        self.grippers: dict[str, pymunk.Body] = {}
        self._grip_joints: dict[str, pymunk.PivotJoint] = {}

    # ----------------------------------------------------------------- state
    def reset(self, shape: np.ndarray) -> None:
        """Build a fresh simulation with the cord at rest in ``shape``.

        The space is rebuilt from scratch (no cached solver impulses survive), so a reset
        followed by the same moves always gives bitwise the same shapes.

        Args:
            shape: ``(n, 2)`` metres; segments are re-projected to exact rest length along
                their directions starting from the head, and the cord is shifted back onto
                the table where that makes it poke over the rim (``at_segment_length``).
        """
        p = self.params
        arr = validate_shape(shape, n_points=p.n_points, length=p.length, name="shape")
        seg_vec = np.diff(arr.astype(np.float64), axis=0)
        headings = np.unwrap(np.arctan2(seg_vec[:, 1], seg_vec[:, 0]))
        start = at_segment_length(arr, p.segment)[0]
        half = 0.5 * p.segment
        m = p.mass / (p.n_points - 1)
        moment = p.inertia_scale * m * p.segment**2 / 12.0
        space = pymunk.Space()
        space.iterations = p.iterations
        space.damping = p.velocity_retention
        static = space.static_body
        shape_filter = pymunk.ShapeFilter(group=1)
        bodies = []
        for heading in headings:
            body = pymunk.Body(m, moment)
            direction = np.array([math.cos(heading), math.sin(heading)])
            centre = start + half * direction
            body.position = (float(centre[0]), float(centre[1]))
            body.angle = float(heading)
            start = centre + half * direction
            link = pymunk.Segment(body, (-half, 0.0), (half, 0.0), LINK_RADIUS)
            link.filter = shape_filter
            if p.peg_friction > 0:  # a contact's friction is the product of its shapes'
                link.friction = 1.0  # the rim's walls have none: only the pegs' counts
            space.add(body, link)
            slide = pymunk.PivotJoint(static, body, (0.0, 0.0), (0.0, 0.0))
            slide.max_bias = 0.0
            slide.max_force = p.friction * m * p.gravity
            spin = pymunk.GearJoint(static, body, 0.0, 1.0)
            spin.max_bias = 0.0
            spin.max_force = p.friction * m * p.gravity * p.segment / 4.0
            space.add(slide, spin)
            bodies.append(body)
        k = p.bending_stiffness / p.segment
        for a, b in zip(bodies[:-1], bodies[1:]):
            link = pymunk.PivotJoint(a, b, (half, 0.0), (-half, 0.0))
            link.error_bias = p.joint_error_bias
            space.add(link, pymunk.DampedRotarySpring(a, b, 0.0, k, p.bending_damping))
        # The rim: four thick static walls whose inner faces are the table's edges. A link is a
        # capsule of radius LINK_RADIUS around its centre line, so a point touching a wall still
        # lies LINK_RADIUS inside the table; a small collision slop keeps the solver's tolerated
        # overlap well below that, and `_keep_on_table` removes whatever overlap is left.
        h, w = TABLE_HALF, RIM_THICKNESS
        outer = h + w
        for c0, c1 in (((-outer, -outer), (outer, -outer)), ((outer, -outer), (outer, outer)),
                       ((outer, outer), (-outer, outer)), ((-outer, outer), (-outer, -outer))):
            space.add(pymunk.Segment(static, c0, c1, w))
        space.collision_slop = COLLISION_SLOP
        self.space = space
        self._peg_shapes = []
        self._add_pegs()
        self.segments = bodies
        self._make_buffer()
        self.grippers = {}
        self._grip_joints = {}
        self._attach(self._grasp)

    @property
    def pegs(self) -> np.ndarray:
        """``(k, 2)`` peg centres, metres (a copy; ``(0, 2)`` without pegs)."""
        return self._pegs.copy()

    def set_pegs(self, pegs: np.ndarray | None) -> None:
        """Place the pegs (None or empty: none), in the current simulation too."""
        self._pegs = check_pegs(pegs, radius=self.peg_radius)
        if self.space is not None:
            self.space.remove(*self._peg_shapes)
            self._peg_shapes = []
            self._add_pegs()

    def _add_pegs(self) -> None:
        assert self.space is not None
        for x, y in self._pegs.tolist():
            peg = pymunk.Circle(self.space.static_body, self.peg_radius, offset=(x, y))
            peg.friction = self.params.peg_friction
            self.space.add(peg)
            self._peg_shapes.append(peg)

    def _make_buffer(self) -> None:
        self._buffer = pymunk.batch.Buffer()
        self._buffer.clear()
        pymunk.batch.get_space_bodies(self.space, pymunk.batch.BodyFields.BODY_ID, self._buffer)
        ids = np.frombuffer(self._buffer.int_buf(), dtype=np.uintp)[: len(self.segments)]
        if ids.tolist() != [b.id for b in self.segments]:  # pragma: no cover - pymunk changed
            raise RuntimeError("pymunk.batch returned bodies in an unexpected order")

    def __getstate__(self) -> dict:
        # pymunk pickles the space with every body, joint and velocity, but not the solver's
        # cached impulses, so a copy continues close to (not bitwise like) the original.
        # The batch buffer is a C object: rebuilt on unpickle.
        state = self.__dict__.copy()
        state.pop("_buffer", None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        if self.space is not None:
            self._make_buffer()

    def _attach(self, grasp: Grasp) -> None:
        assert self.space is not None
        half = 0.5 * self.params.segment
        ends = {"head": (self.segments[0], (-half, 0.0)), "tail": (self.segments[-1], (half, 0.0))}
        wanted = {"head": ("head",), "tail": ("tail",), "both": ("head", "tail"), "none": ()}[grasp]
        for name in list(self._grip_joints):
            if name not in wanted:
                self.space.remove(self._grip_joints.pop(name), self.grippers.pop(name))
        for name in wanted:
            if name in self._grip_joints:
                continue
            body, anchor = ends[name]
            gripper = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            gripper.position = body.local_to_world(anchor)
            joint = pymunk.PivotJoint(gripper, body, (0.0, 0.0), anchor)
            joint.error_bias = self.params.joint_error_bias
            self.space.add(gripper, joint)
            self.grippers[name] = gripper
            self._grip_joints[name] = joint
        self._grasp = grasp

    @staticmethod
    def _check_grasp(grasp: str) -> None:
        if grasp not in _GRASPS:
            raise InputError(f"grasp must be one of {_GRASPS}, got {grasp!r}")

    @property
    def grasp(self) -> Grasp:
        """Which ends are held."""
        return self._grasp

    def set_grasp(self, grasp: Grasp) -> None:
        """Change which ends are held; a new gripper takes the end where it lies."""
        self._check_grasp(grasp)
        self._require_reset()
        self._attach(grasp)

    def _require_reset(self) -> None:
        if self.space is None:
            raise RuntimeError("Cord.reset(shape) must be called before using the cord")

    _POSE = pymunk.batch.BodyFields.POSITION | pymunk.batch.BodyFields.ANGLE
    _MOTION = (
        _POSE | pymunk.batch.BodyFields.VELOCITY | pymunk.batch.BodyFields.ANGULAR_VELOCITY
    )

    def _read(self, fields: pymunk.batch.BodyFields, width: int) -> np.ndarray:
        # One C call for all bodies; pymunk lists dynamic bodies first, in insertion order,
        # so the first n-1 rows are the segments (checked when the space is built).
        self._buffer.clear()
        pymunk.batch.get_space_bodies(self.space, fields, self._buffer)
        rows = np.frombuffer(self._buffer.float_buf(), dtype=np.float64).reshape(-1, width)
        return rows[: len(self.segments)]

    @property
    def shape(self) -> np.ndarray:
        """Current shape, float32 ``(n, 2)``; inner points average the two joined ends."""
        self._require_reset()
        rows = self._read(self._POSE, 3)
        return self._points(rows[:, 0:2], rows[:, 2]).astype(np.float32)

    def _half_links(self, ang: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # ang (..., n-1) -> the x and y of each link's centre-to-end vector, half * (cos, sin)
        # (the products of ``half * np.stack([cos, sin], -1)``, without the stack's copies).
        half = 0.5 * self.params.segment
        hx, hy = np.cos(ang), np.sin(ang)
        hx *= half
        hy *= half
        return hx, hy

    @staticmethod
    def _joined(centres: np.ndarray, half: np.ndarray) -> np.ndarray:
        # The links' ends, ``centres -/+ half`` (..., n-1, k), as the points (..., n, k): the
        # head is the first link's start, the tail the last link's end, an inner point the mean
        # of the two ends it joins. Works column by column: positions and velocities alike.
        starts, ends = centres - half, centres + half
        out = np.empty(centres.shape[:-2] + (centres.shape[-2] + 1, centres.shape[-1]))
        out[..., 0, :] = starts[..., 0, :]
        out[..., -1, :] = ends[..., -1, :]
        inner = out[..., 1:-1, :]
        np.add(ends[..., :-1, :], starts[..., 1:, :], out=inner)
        inner *= 0.5
        return out

    def _points(self, pos: np.ndarray, ang: np.ndarray) -> np.ndarray:
        # pos (..., n-1, 2), ang (..., n-1) -> (..., n, 2); batched for recorded moves.
        half = np.empty(pos.shape)
        half[..., 0], half[..., 1] = self._half_links(ang)
        return self._joined(pos, half)

    def _point_rows(self, rows: np.ndarray) -> np.ndarray:
        # (n-1, 6) body rows of the links' centres (x, y, angle, vx, vy, omega) -> (n, 6) rows
        # of the points: x, y, -, vx, vy, - (columns 2 and 5 hold no point quantity). The rows
        # are joined whole, contiguous, against what a link's end adds to them: the half link
        # h under (x, y), the spin's velocity omega x h = (-omega hy, omega hx) under (vx, vy)
        # (a sign flip of a product is exact: -(omega hy) is omega (-hy)), 0 elsewhere.
        hx, hy = self._half_links(rows[:, 2])
        omega = rows[:, 5]
        arm = np.zeros(rows.shape)
        arm[:, 0] = hx
        arm[:, 1] = hy
        spin_x = omega * hy
        arm[:, 3] = np.negative(spin_x, out=spin_x)
        arm[:, 4] = omega * hx
        return self._joined(rows, arm)

    def point_velocities(self) -> np.ndarray:
        """Velocity of every point, ``(n, 2)`` m/s (inner points average the two ends)."""
        self._require_reset()
        return self._point_rows(self._read(self._MOTION, 6))[:, 3:5].copy()

    @staticmethod
    def _largest_speed(points: np.ndarray) -> float:
        # (n, 6) rows of ``_point_rows`` -> the largest point speed (vx^2 + vy^2 is the sum
        # over a point's two velocity components, bit for bit).
        vx, vy = points[:, 3], points[:, 4]
        return math.sqrt(float((vx * vx + vy * vy).max()))

    def max_point_speed(self) -> float:
        """The fastest point's speed, m/s (the rest test of ``settle`` and the tasks)."""
        self._require_reset()
        return self._largest_speed(self._point_rows(self._read(self._MOTION, 6)))

    def shape_and_speed(self) -> tuple[np.ndarray, float]:
        """``shape`` and ``max_point_speed()`` from one read of the bodies (the environments'
        read-out after a reset or a settling)."""
        self._require_reset()
        return self._shape_and_speed(self._read(self._MOTION, 6))

    def _shape_and_speed(self, rows: np.ndarray) -> tuple[np.ndarray, float]:
        points = self._point_rows(rows)
        return points[:, 0:2].astype(np.float32), self._largest_speed(points)

    def gripper_positions(self) -> dict[str, np.ndarray]:
        """Positions of the grippers that are attached, by end name."""
        return {k: np.array(g.position) for k, g in self.grippers.items()}

    def gripper_forces(self) -> dict[str, float]:
        """The force each attached gripper exerted on its end in the last physics step,
        newtons (its joint's impulse over the step), by end name."""
        h = self.params.dt / self.params.substeps
        return {k: float(j.impulse) / h for k, j in self._grip_joints.items()}

    # ----------------------------------------------------------------- motion
    def _targets(self, head: np.ndarray | None, tail: np.ndarray | None
                 ) -> tuple[list[str], np.ndarray, np.ndarray]:
        # The held ends, their float64 start positions (k, 2) and reachable targets (k, 2).
        names = [name for name in ("head", "tail") if name in self.grippers]
        starts = np.empty((len(names), 2))
        moves = np.zeros((len(names), 2))
        for i, name in enumerate(names):
            starts[i] = self.grippers[name].position
            d = head if name == "head" else tail
            if d is not None:
                moves[i] = np.asarray(d, dtype=np.float64).reshape(2)
        if not all_finite(moves):
            bad = int(np.flatnonzero(~np.isfinite(moves).all(axis=1))[0])
            raise InputError(f"{names[bad]} displacement must be finite, got "
                             f"{moves[bad].tolist()}")
        if not names:
            return names, starts, starts
        return names, starts, reachable_targets(starts + moves, self.params, starts=starts,
                                                pegs=self._pegs, peg_radius=self.peg_radius)

    def move(
        self,
        head: np.ndarray | None = None,
        tail: np.ndarray | None = None,
        record_every: int = 0,
    ) -> np.ndarray:
        """Move the grasped ends by displacements along straight lines at bounded speed.

        The targets are clipped to the table (less ``rim_margin``) and, with both ends held,
        to ``max_span``. The move lasts the smallest whole number (at least one) of control
        periods that keeps every gripper at or below ``max_speed``. Displacements for ends
        that are not held are ignored.

        Args:
            head: ``(2,)`` displacement of the head gripper, metres.
            tail: ``(2,)`` displacement of the tail gripper, metres.
            record_every: If > 0, record the shape after every ``record_every`` physics steps.

        Returns:
            The recorded shapes, float32 ``(m, n, 2)`` (``m = 0`` when not recording).
        """
        self._require_reset()
        steps, names, targets = self._start_move(head, tail)
        recorded = self._run(steps, record_every)
        self._stop_grippers(names, targets)
        return recorded

    def move_and_read(self, head: np.ndarray | None = None, tail: np.ndarray | None = None
                      ) -> tuple[np.ndarray, float]:
        """``move(head, tail)``, then ``shape_and_speed()`` of the cord it leaves, from the
        read of the bodies that ends the move (the environments' step: one read, not two).

        Returns:
            The shape, float32 ``(n, 2)``, and the fastest point's speed, m/s.
        """
        self._require_reset()
        steps, names, targets = self._start_move(head, tail)
        rows = self._steps(steps)
        self._stop_grippers(names, targets)
        return self._shape_and_speed(rows)

    def _start_move(self, head: np.ndarray | None, tail: np.ndarray | None
                    ) -> tuple[int, list[str], np.ndarray]:
        # Set the held grippers going towards their targets; the physics steps the move lasts,
        # the held ends and their targets (k, 2).
        p = self.params
        names, starts, targets = self._targets(head, tail)
        # One or two ends: their travel in Python floats, the same IEEE arithmetic as numpy's
        # on (k, 2) arrays (x * x + y * y is the sum over an end's two axes) at less call cost.
        travel = (targets - starts).tolist()
        longest = max((math.sqrt(x * x + y * y) for x, y in travel), default=0.0)
        periods = max(1, math.ceil(longest / (p.max_speed * p.dt) - 1e-9))
        duration = periods * p.dt
        for name, (x, y) in zip(names, travel):
            self.grippers[name].velocity = (x / duration, y / duration)
        return periods * p.substeps, names, targets

    def _stop_grippers(self, names: list[str], targets: np.ndarray) -> None:
        # The grippers stop exactly at their targets.
        for name, target in zip(names, targets.tolist()):
            g = self.grippers[name]
            g.velocity = (0.0, 0.0)
            g.position = (target[0], target[1])

    def wait(self, periods: int = 1, record_every: int = 0) -> np.ndarray:
        """Let time pass with the grippers still, for ``periods`` control periods."""
        self._require_reset()
        return self._run(periods * self.params.substeps, record_every)

    def settle(self, tolerance: float = 1e-3, max_time: float = 2.0) -> float:
        """Wait with the grippers still until every point is slower than ``tolerance`` m/s.

        Takes at least one physics step, so a freshly reset bent cord relaxes first.

        Returns:
            The simulated time it took, seconds (``max_time`` if not at rest by then).
        """
        self._require_reset()
        p = self.params
        h = p.dt / p.substeps
        steps = 0
        # Step before testing: a freshly reset cord has zero velocities without being in
        # equilibrium (bent joints push against static friction), so "slow" alone is not "at rest".
        while steps * h < max_time:
            self.space.step(h)
            steps += 1
            if self.max_point_speed() < tolerance:
                break
        self._keep_on_table()
        return steps * h

    def _run(self, steps: int, record_every: int) -> np.ndarray:
        p = self.params
        if record_every <= 0:
            self._steps(steps)
            return np.empty((0, p.n_points, 2), dtype=np.float32)
        h = p.dt / p.substeps
        space = self.space
        assert space is not None
        # Copy the raw poses while stepping and turn them into points once per move: a
        # recorded shape then costs one batch read instead of a full ``shape`` conversion.
        poses = np.empty((steps // record_every, len(self.segments), 3))
        k = 0
        for i in range(1, steps + 1):
            space.step(h)
            if i % record_every == 0:
                poses[k] = self._keep_on_table()[:, 0:3]
                k += 1
        if steps % record_every:
            self._keep_on_table()
        return self._points(poses[..., 0:2], poses[..., 2]).astype(np.float32)

    def _steps(self, steps: int) -> np.ndarray:
        # ``steps`` physics steps, then the rim check: the body rows it leaves, (n-1, 6).
        space = self.space
        assert space is not None
        h = self.params.dt / self.params.substeps
        for _ in range(steps):
            space.step(h)
        return self._keep_on_table()

    def _peg_shift(self, rows: np.ndarray, passes: int = 5) -> np.ndarray:
        """``(n - 1, 2)`` shifts of the links that move every point out of the pegs.

        A point inside a peg is pushed radially to ``PEG_GUARD`` beyond its surface by
        shifting both links it joins (a link pushed by both its points takes the larger push);
        a few passes settle points that one shift left inside.
        """
        total = np.zeros((len(rows), 2))
        for _ in range(passes):
            points = self._points(rows[:, 0:2] + total, rows[:, 2])  # (n, 2)
            rel = points[:, None, :] - self._pegs  # (n, k, 2)
            dist = np.sqrt((rel * rel).sum(-1))
            depth = self.peg_radius + PEG_GUARD - dist
            if not (depth > 0).any():
                break
            peg = np.argmax(depth, axis=1)
            idx = np.arange(len(points))
            deepest = np.clip(depth[idx, peg], 0.0, None)
            push = deepest[:, None] * rel[idx, peg] / np.maximum(dist[idx, peg], 1e-12)[:, None]
            size = (push * push).sum(-1)
            # Link i joins points i and i + 1: it takes the larger of their pushes.
            take = np.where(size[:-1] >= size[1:], 0, 1)
            total += np.where(take[:, None] == 0, push[:-1], push[1:])
        return total

    def _keep_on_table(self) -> np.ndarray:
        """Push any link that overlaps the rim back onto the table, and any link with a point
        inside a peg out of it; return the poses.

        The walls (and pegs) stop the cord LINK_RADIUS from their surface; only a link forced
        against one harder than the contact solver resolves in one step overlaps it further.
        Shifting that link back (its angle kept) makes the rim and the pegs hard: no point
        ever leaves the table or lies inside a peg.

        Returns:
            ``(n - 1, 6)`` rows of the links after the correction: pose (x, y, angle) and
            motion (vx, vy, omega), the read-out of the move it ends.
        """
        rows = self._read(self._MOTION, 6).copy()
        near_rim = np.abs(rows[:, 0:2]).max() >= TABLE_HALF - 0.5 * self.params.segment
        if not near_rim and not len(self._pegs):
            return rows  # no link reaches the rim: the common case, checked cheaply
        pos = rows[:, 0:2]
        half = np.empty(pos.shape)
        half[:, 0], half[:, 1] = self._half_links(rows[:, 2])
        ends = np.empty((len(rows), 2, 2))  # (n-1, 2, 2): each link's start and end
        np.subtract(pos, half, out=ends[:, 0])
        np.add(pos, half, out=ends[:, 1])
        shift = np.zeros((len(rows), 2))
        if len(self._pegs):
            shift = self._peg_shift(rows)
            ends = ends + shift[:, None, :]
        lim = TABLE_HALF - RIM_GUARD
        # Only an end past the rim moves its link back (its shift is 0 otherwise): most links
        # near the rim are inside it, so this test spares the shifts' array work.
        if (near_rim or shift.any()) and np.abs(ends).max() > lim:
            shift = shift + (np.clip(-lim - ends, 0.0, None).max(axis=1)
                             - np.clip(ends - lim, 0.0, None).max(axis=1))  # (n-1, 2)
        elif not len(self._pegs):
            return rows
        for i in np.flatnonzero(np.abs(shift).sum(axis=1)):
            body = self.segments[i]
            x, y = body.position
            body.position = (x + float(shift[i, 0]), y + float(shift[i, 1]))
            rows[i, 0:2] += shift[i]
        return rows
