"""The latent-tree planner: the paper's constrained transition search, batched.

A rapidly-exploring random tree grows in the model's latent space from the inverted start
towards the inverted goal. Every candidate edge Q -> R is decoded into shapes and accepted
only if (paper) consecutive shapes are similar and the manipulated end moves along a straight
line, and (this project, physical sense checked on the decoded shapes) no point of the cord
moves much farther than the end that drags it, and every shape is a cord. Candidates are
evaluated in batches, one decoder call for many edges. After every batch the new nodes nearest
the goal try to connect straight to it; the start tries first, so a transition that one
straight end move can make needs a single decoder call. The path found is shortened by
shortcuts checked with the same constraints, because every corner of the end's path is a place
where the real cord's friction can make it part ways with the surrogate.

All tolerances are in metres, measured on decoded shapes, so they mean the same thing whatever
the latent parametrisation; only ``step_length`` and ``sample_margin`` are latent units.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, fields, replace
from typing import Any, Protocol

import numpy as np

from dlo_env.core.deprecation import renamed_argument, renamed_field
from dlo_env.errors import InputError
from dlo_env.shapes import (
    COSINE_THRESHOLD,
    error,
    is_cord_like,
    segment_lengths,
    turning_cosines,
)
from planners.interfaces import Plan, ShapeSurrogate
from planners.observation import as_shape
from planners.surrogate import Surrogate

#: Grasp -> the indices of the held points: one end, or both (head first).
ENDS = {"head": (0,), "tail": (-1,), "both": (0, -1)}
#: The edge types of the tree (``TreeConfig.edges``).
EDGES = ("latent", "moves")
#: ``"moves"`` edges: a move must change the cord by more than this (``error``, metres) to
#: make a node; moves that leave it where it was add nothing to the tree.
MIN_NODE_CHANGE = 0.005


@renamed_field("end", "grasp")
@dataclass(frozen=True)
class TreeConfig:
    """Parameters of the latent-tree planner; the defaults are the documented ones.

    Attributes:
        step_length: The paper's ``l``: latent distance from the nearest node Q to a candidate R.
        edge_points: Shapes decoded along a tree edge (after Q); longer edges (goal connections,
            shortcuts) are decoded at the same latent spacing ``step_length / edge_points``.
        similarity: Largest ``error`` between consecutive decoded shapes on an edge, metres.
        straightness: Largest distance of a manipulated end from the straight line between
            its positions at the two nodes of an edge (and largest backward motion along it),
            metres, for an edge of zero length; with both ends held, each end is checked.
        straightness_ratio: The tolerance grows by this fraction of the end's displacement over
            the edge: long goal connections and shortcuts bend as much, relatively, as short
            tree edges (0 keeps the absolute ``straightness``).
        follow_ratio: No point may move more than ``follow_ratio`` times the manipulated end's
            displacement (the larger of the two with both ends held; plus ``follow_slack``)
            over an edge: a cord on a table moves only where it is dragged. ``None``
            disables the check (the paper does not have it).
        follow_slack: Metres added to the allowed displacement (decoder noise).
        max_stretch: Largest relative deviation of a decoded segment from the start shape's mean
            segment length; ``None`` disables it. Keeps the path among cord-like shapes.
        cord_like: Reject edges through shapes that fail the paper's cosine filter.
        goal_threshold: A node whose decoded shape is within this ``error`` of the decoded goal
            has reached the goal, metres.
        goal_bias: Probability that a sample is the goal latent itself.
        connect_attempts: New nodes (nearest the goal) that try a direct goal connection
            after every batch.
        batch_size: Candidates decoded per model call.
        max_nodes: Node budget of the tree.
        max_seconds: Time budget of one ``plan`` call, seconds (inversion included).
        sample_margin: Samples are drawn in the box around the start and goal latents widened
            by ``max(sample_margin, |z_goal - z_start|)`` (latent units) on every axis.
        max_edge_points: Cap on the shapes decoded along one long edge.
        shortcut: Shorten the path found with straight connections that pass the checks.
        grasp: The manipulated end(s): ``"head"`` (point 0), ``"tail"`` (point n-1) or
            ``"both"`` (``DLODualEndpoint-v0``: both ends move, each in straight lines).
        invert_steps: Refinement steps of the start (and goal) inversion, passed to
            ``model.invert(steps=...)``; ``None`` keeps the model's default. Inversion is most
            of a plan's time: 60 steps cost a quarter of the default 150 for ~0.3 mm more error.
        invert_restarts: Restarts of the inversion (``model.invert(restarts=...)``).
        edges: What an edge of the tree is. ``"latent"`` (the paper's): a straight line in
            latent space, decoded and checked. ``"moves"`` (kinodynamic): one straight move of
            the held end whose outcome the transition model predicts; the GAN proposes the
            targets and is the space in which nearest nodes are found. Needs a
            ``transition_model``.
        move_samples: ``"moves"`` edges: moves tried per extension (around the one that takes
            the end to the target's end) and per goal connection.
        move_noise: ``"moves"`` edges: standard deviation of the sampled moves, metres.
        max_move: ``"moves"`` edges: longest straight move of the end, metres.
    """

    step_length: float = 0.15
    edge_points: int = 4
    similarity: float = 0.03
    straightness: float = 0.01
    straightness_ratio: float = 0.05
    follow_ratio: float | None = 1.5
    follow_slack: float = 0.01
    max_stretch: float | None = 0.25
    cord_like: bool = True
    goal_threshold: float = 0.01
    goal_bias: float = 0.1
    connect_attempts: int = 8
    batch_size: int = 64
    max_nodes: int = 2000
    max_seconds: float = 0.5
    sample_margin: float = 0.3
    max_edge_points: int = 64
    shortcut: bool = True
    grasp: str = "head"
    invert_steps: int | None = 60
    invert_restarts: int | None = 2
    edges: str = "latent"
    move_samples: int = 32
    move_noise: float = 0.05
    max_move: float = 0.3

    def __post_init__(self) -> None:
        positive = ("step_length", "similarity", "straightness", "goal_threshold", "max_seconds",
                    "sample_margin", "move_noise", "max_move")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and value > 0):
                raise InputError(f"TreeConfig.{name} must be a number > 0, got {value!r}")
        for name in ("edge_points", "connect_attempts", "batch_size", "max_nodes",
                     "max_edge_points", "move_samples"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise InputError(f"TreeConfig.{name} must be an int >= 1, got {value!r}")
        if self.max_edge_points < self.edge_points:
            raise InputError(
                f"TreeConfig.max_edge_points must be >= edge_points ({self.edge_points}), "
                f"got {self.max_edge_points}"
            )
        if not 0.0 <= self.goal_bias <= 1.0:
            raise InputError(f"TreeConfig.goal_bias must be in [0, 1], got {self.goal_bias!r}")
        if self.follow_ratio is not None and not self.follow_ratio > 0:
            raise InputError(
                f"TreeConfig.follow_ratio must be > 0 or None, got {self.follow_ratio!r}"
            )
        if not self.straightness_ratio >= 0:
            raise InputError(
                f"TreeConfig.straightness_ratio must be >= 0, got {self.straightness_ratio!r}"
            )
        if not self.follow_slack >= 0:
            raise InputError(f"TreeConfig.follow_slack must be >= 0, got {self.follow_slack!r}")
        if self.max_stretch is not None and not self.max_stretch > 0:
            raise InputError(
                f"TreeConfig.max_stretch must be > 0 or None, got {self.max_stretch!r}"
            )
        for name in ("invert_steps", "invert_restarts"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, int) and value >= 0):
                raise InputError(f"TreeConfig.{name} must be None or an int >= 0, got {value!r}")
        if self.grasp not in ENDS:
            raise InputError(f"TreeConfig.grasp must be one of {tuple(ENDS)}, got "
                             f"{self.grasp!r}")
        if self.edges not in EDGES:
            raise InputError(f"TreeConfig.edges must be one of {EDGES}, got {self.edges!r}")


#: The kinodynamic tree of the ``latent-tree-kino`` agent: straight-move edges predicted by the
#: transition model. A plan predicted within 1.5 cm of the goal is accepted (chosen on the train
#: splits, 30 tasks each: 100 / 97 / 100 % against 100 / 90 / 90 % with 1 cm; docs/history.md).
KINO_CONFIG = TreeConfig(edges="moves", goal_threshold=0.015)


@dataclass(frozen=True)
class _CordLimits:
    """What a decoded shape must satisfy to count as a cord, for one plan.

    The decoded start and goal always pass: where the model's own decodings of them bend more
    sharply or stretch more than the defaults allow, the limits widen to include them (with a
    small margin), so an imperfect decoder cannot make every edge fail.
    """

    rest: float
    cosine: float
    stretch: float

    @classmethod
    def of(cls, start: np.ndarray, ends: np.ndarray, max_stretch: float | None) -> _CordLimits:
        rest = float(segment_lengths(start).mean())
        cosine = min(COSINE_THRESHOLD, float(turning_cosines(ends).min()) - 0.05)
        stretch = float(np.abs(segment_lengths(ends) / rest - 1.0).max()) + 0.05
        return cls(rest, max(cosine, -1.0), max(max_stretch or 0.0, stretch))


class _Tree:
    """Growing arrays of nodes: latent, decoded shape, parent, end path length, edge points."""

    def __init__(self, capacity: int, latent_dim: int, n_points: int) -> None:
        self.latents = np.zeros((capacity, latent_dim), dtype=np.float32)
        self.shapes = np.zeros((capacity, n_points, 2), dtype=np.float32)
        self.parent = np.full(capacity, -1, dtype=np.int64)
        self.cost = np.zeros(capacity)
        self.edge_points = np.zeros(capacity, dtype=np.int64)
        self.size = 0

    def add(
        self, latents: np.ndarray, shapes: np.ndarray, parents: np.ndarray, cost: np.ndarray,
        edge_points: np.ndarray,
    ) -> np.ndarray:
        count = min(len(latents), len(self.latents) - self.size)
        idx = np.arange(self.size, self.size + count)
        self.latents[idx] = latents[:count]
        self.shapes[idx] = shapes[:count]
        self.parent[idx] = parents[:count]
        self.cost[idx] = cost[:count]
        self.edge_points[idx] = edge_points[:count]
        self.size += count
        return idx

    def path(self, node: int) -> list[int]:
        out = [node]
        while self.parent[out[-1]] >= 0:
            out.append(int(self.parent[out[-1]]))
        return out[::-1]


class _Edges(Protocol):
    """One edge type of the tree (``TreeConfig.edges``): how nodes connect to the goal and
    extend, and how the tree becomes a plan. ``LatentTreePlanner._grow`` runs the search.

    Attributes:
        z_start, z_goal: The latents of the start and the goal.
        root_shape: The shape of the tree's root.
        reached: A node within ``goal_threshold`` of the goal (None: none yet).
        connect_after_reach: Whether a reached node makes one more goal connection attempt
            before the search ends (else it ends at once).
    """

    z_start: np.ndarray
    z_goal: np.ndarray
    root_shape: np.ndarray
    reached: int | None
    connect_after_reach: bool

    def connect(self, tree: _Tree, candidates: np.ndarray) -> bool:
        """Try to connect the ``candidates`` nearest the goal to it; True when one does."""

    def extend(self, tree: _Tree, samples: np.ndarray, nearest: np.ndarray) -> np.ndarray:
        """Extend the ``nearest`` nodes towards the latent ``samples``; returns the nodes
        added."""

    def plan(self, tree: _Tree, iterations: int, stop: str, t0: float, calls0: int) -> Plan:
        """The plan the grown tree gives."""


class LatentTreePlanner:
    """Search the latent space for a transition the manipulated end makes by straight moves.

    Args:
        model: A shape model (``latent_model.ShapeModel`` or the same interface).
        config: Parameters; ``None`` uses ``TreeConfig()``.
        seed: Seed of the sampling; ``plan`` starts from it on every call, so a plan is a
            function of (start, goal, seed).
        transition_model: A ``latent_model.TransitionModel`` (needed by ``edges="moves"``).
        cord: The cord a transition model of several cords is told (``predict``'s
            ``params``; ``TransitionModel.told``); None: the model's own cord.
        **overrides: Any ``TreeConfig`` field, overriding ``config``
            (``LatentTreePlanner(model, step_length=0.1)``; ``end`` is the deprecated name of
            ``grasp``).

    Example:
        >>> plan = LatentTreePlanner(model, seed=0).plan(start_shape, goal_shape)
        >>> plan.success, plan.moves  # straight displacements of the head, metres
    """

    @renamed_argument("end", "grasp")
    def __init__(
        self, model: ShapeSurrogate, config: TreeConfig | None = None, *, seed: int = 0,
        transition_model: Any = None, cord: Any = None, **overrides: Any,
    ) -> None:
        known = {f.name for f in fields(TreeConfig)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise InputError(f"unknown LatentTreePlanner parameters {unknown}; expected some of "
                             f"{sorted(known)}")
        self.config = replace(config if config is not None else TreeConfig(), **overrides)
        self.surrogate = Surrogate(model)
        self.model = model
        self.seed = int(seed)
        self._end = list(ENDS[self.config.grasp])  # indices of the held points
        self.transition_model = transition_model
        #: ``(m, 2)`` centres of the pegs on the table (None: none): the straight-move edges'
        #: grippers stop at them (``PlannerPolicy`` sets them from each observation).
        self.pegs: np.ndarray | None = None
        if self.config.edges == "moves":
            if transition_model is None:
                raise InputError('edges="moves" needs a transition_model (a '
                                 'latent_model.TransitionModel)')
            if transition_model.config.n_points != self.n_points:
                raise InputError(f"transition_model must be for {self.n_points} points, got "
                                 f"{transition_model.config.n_points}")
        if cord is not None and transition_model is None:
            raise InputError("cord is told to a transition_model; none was given")
        #: The cord told to the transition model (``predict``'s ``params``), or None.
        self.cord = None if cord is None else transition_model.told(cord)

    @property
    def n_points(self) -> int:
        """Points of the shapes the planner plans for."""
        return self.surrogate.n_points

    def invert(self, shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The model's verified inversion with this planner's options: ``(z, err, ok)``."""
        cfg = self.config
        return self.surrogate.invert(shapes, steps=cfg.invert_steps, restarts=cfg.invert_restarts)

    # ------------------------------------------------------------------ checks
    def _check_edges(
        self, chains: np.ndarray, limits: _CordLimits, counts: dict[str, int]
    ) -> np.ndarray:
        """Which decoded edges ``(B, K+1, n, 2)`` (node shape first) pass every check."""
        cfg = self.config
        step = error(chains[:, 1:], chains[:, :-1])  # (B, K)
        ok_similar = step.max(axis=1) <= cfg.similarity
        ends = chains[:, :, self._end, :].astype(np.float64)  # (B, K+1, E, 2)
        rel = ends - ends[:, :1]
        chord = rel[:, -1]  # (B, E, 2)
        length = np.linalg.norm(chord, axis=-1)  # (B, E)
        unit = chord / np.maximum(length, 1e-12)[..., None]
        along = (rel * unit[:, None]).sum(axis=-1)  # (B, K+1, E)
        across = np.abs(rel[..., 0] * unit[:, None, :, 1] - rel[..., 1] * unit[:, None, :, 0])
        backwards = np.maximum(np.diff(along, axis=1).min(axis=1) * -1.0, 0.0)
        deviation = np.where(length > 1e-9, across.max(axis=1),
                             np.linalg.norm(rel, axis=-1).max(axis=1))
        tolerance = cfg.straightness + cfg.straightness_ratio * length
        ok_straight = ((deviation <= tolerance) & (backwards <= tolerance)).all(axis=1)
        length = length.max(axis=1)  # the end that moves most drags the cord
        ok = ok_similar & ok_straight
        counts["similarity"] += int((~ok_similar).sum())
        counts["straightness"] += int((ok_similar & ~ok_straight).sum())
        if cfg.follow_ratio is not None:
            moved = np.linalg.norm(chains[:, -1] - chains[:, 0], axis=-1).max(axis=1)
            ok_follow = moved <= cfg.follow_ratio * length + cfg.follow_slack
            counts["follow"] += int((ok & ~ok_follow).sum())
            ok &= ok_follow
        inner = chains[:, 1:]
        b, k = inner.shape[:2]
        ok_cord = np.ones(b, dtype=bool)
        if cfg.cord_like:
            flat = inner.reshape(b * k, -1, 2)
            ok_cord &= np.asarray(is_cord_like(flat, limits.cosine)).reshape(b, k).all(axis=1)
        if cfg.max_stretch is not None:
            stretch = np.abs(segment_lengths(inner) / limits.rest - 1.0).max(axis=(1, 2))
            ok_cord &= stretch <= limits.stretch
        counts["cord"] += int((ok & ~ok_cord).sum())
        return ok & ok_cord

    def _edge_count(self, distance: np.ndarray) -> np.ndarray:
        cfg = self.config
        spacing = cfg.step_length / cfg.edge_points
        k = np.ceil(np.asarray(distance) / spacing - 1e-9).astype(np.int64)
        return np.clip(k, cfg.edge_points, cfg.max_edge_points)

    def _try_edges(
        self, z_from: np.ndarray, shape_from: np.ndarray, z_to: np.ndarray, limits: _CordLimits,
        counts: dict[str, int], points: int | None = None,
    ) -> tuple[np.ndarray, np.ndarray, int]:
        """Decode and check edges ``(B, d) -> (B, d)`` in one model call.

        Returns:
            Which pass ``(B,)``, the decoded end shapes ``(B, n, 2)`` and the points per edge.
        """
        if points is None:
            points = int(self._edge_count(np.linalg.norm(z_to - z_from, axis=1)).max())
        fractions = np.arange(1, points + 1) / points
        latents = self.surrogate.segment(z_from, z_to, fractions)  # (B, K, d)
        decoded = self.surrogate.decode(latents)  # (B, K, n, 2)
        chains = np.concatenate([shape_from[:, None], decoded], axis=1)
        return self._check_edges(chains, limits, counts), decoded[:, -1], points

    # ------------------------------------------------------------------ search
    def plan(
        self,
        start: np.ndarray,
        goal: np.ndarray,
        *,
        goal_latent: np.ndarray | None = None,
        seed: int | None = None,
    ) -> Plan:
        """Plan a transition from ``start`` to ``goal``.

        Args:
            start: ``(n, 2)`` or flat start shape, metres.
            goal: ``(n, 2)`` or flat goal shape, metres.
            goal_latent: The goal's latent if already inverted (closed-loop replanning).
            seed: Seed of this call's sampling (default: the planner's seed).

        Returns:
            The plan. On failure (budget spent) ``success`` is False and the path leads to the
            node whose shape came closest to the goal.
        """
        t0 = time.perf_counter()
        calls0 = self.surrogate.decoder_calls
        n = self.n_points
        start = as_shape(start, n, "start")
        goal = as_shape(goal, n, "goal")
        rng = np.random.default_rng(self.seed if seed is None else seed)
        edges: _Edges = (_MoveEdges(self, start, goal, goal_latent, rng)
                         if self.config.edges == "moves"
                         else _LatentEdges(self, start, goal, goal_latent))
        tree = _Tree(self.config.max_nodes + 1, len(edges.z_goal), n)
        tree.add(edges.z_start[None], edges.root_shape[None], np.array([-1]), np.zeros(1),
                 np.zeros(1, np.int64))
        iterations, stop = self._grow(tree, edges, rng, t0)
        return edges.plan(tree, iterations, stop, t0, calls0)

    def _grow(self, tree: _Tree, edges: _Edges, rng: np.random.Generator, t0: float
              ) -> tuple[int, str]:
        """Grow ``tree`` until the goal is reached or the budget is spent.

        Every round, the newest nodes nearest the goal first try to connect to it; then a
        batch of targets is drawn (``_sample_targets``) and ``edges`` extends each one's
        nearest node towards it. Both edge types share this loop.

        Returns:
            The rounds of extension, and why the search stopped: ``"goal"``, ``"time"`` or
            ``"nodes"``.
        """
        low, high = self._sample_box(edges.z_start, edges.z_goal)
        candidates = np.array([0])
        iterations = 0
        while True:
            if len(candidates) and edges.connect(tree, candidates):
                return iterations, "goal"
            if edges.reached is not None:
                return iterations, "goal"
            spent = self._budget_spent(t0, tree)
            if spent:
                return iterations, spent
            iterations += 1
            samples, nearest = self._sample_targets(rng, low, high, edges.z_goal, tree)
            candidates = edges.extend(tree, samples, nearest)
            if edges.reached is not None and not edges.connect_after_reach:
                return iterations, "goal"

    def _budget_spent(self, t0: float, tree: _Tree) -> str:
        """``"time"`` or ``"nodes"`` when the search budget is spent, else ""."""
        if time.perf_counter() - t0 > self.config.max_seconds:
            return "time"
        return "nodes" if tree.size > self.config.max_nodes else ""

    def _sample_targets(self, rng: np.random.Generator, low: np.ndarray, high: np.ndarray,
                        z_goal: np.ndarray, tree: _Tree) -> tuple[np.ndarray, np.ndarray]:
        """A batch of latent targets (uniform in the box, or the goal with ``goal_bias``) and
        the index of each one's nearest node in latent space."""
        cfg = self.config
        samples = rng.uniform(low, high, size=(cfg.batch_size, len(z_goal)))
        samples[rng.random(cfg.batch_size) < cfg.goal_bias] = z_goal
        nodes = tree.latents[: tree.size]
        d2 = ((samples[:, None, :] - nodes[None]) ** 2).sum(axis=-1)  # (B, N)
        return samples, d2.argmin(axis=1)

    def _sample_box(self, z_start: np.ndarray, z_goal: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
        """The box latent targets are drawn from: around start and goal, within the model's
        training range when it reports one (but always holding start and goal)."""
        spread = np.abs(z_goal - z_start)
        margin = max(self.config.sample_margin, float(np.linalg.norm(spread)))
        low = np.minimum(z_start, z_goal) - margin
        high = np.maximum(z_start, z_goal) + margin
        bounds = self.surrogate.latent_bounds()
        if bounds is not None:  # stay where the model was trained (but keep start and goal)
            low = np.minimum(np.maximum(low, bounds[0]), np.minimum(z_start, z_goal))
            high = np.maximum(np.minimum(high, bounds[1]), np.maximum(z_start, z_goal))
        return low, high

    # ------------------------------------------------------------------ kinodynamic edges
    def _encode(self, shapes: np.ndarray) -> np.ndarray:
        """Latents of predicted shapes for the nearest-node search: the encoder alone."""
        z, _, _ = self.surrogate.invert(shapes, steps=0, restarts=1)
        return np.asarray(z, dtype=np.float32)

    def _best_moves(self, shapes: np.ndarray, targets: np.ndarray, rng: np.random.Generator
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For each ``(shape, target)`` pair, the best of ``move_samples`` straight moves.

        The moves are the one that takes the end to the target's end, and samples around it,
        all predicted in one batched call of the transition model.

        Returns:
            ``(B, E, 2)`` moves of the E held ends, ``(B, n, 2)`` predicted shapes, ``(B,)``
            their errors to the targets.
        """
        cfg = self.config
        b, m, e = len(shapes), cfg.move_samples, len(self._end)
        toward = targets[:, self._end] - shapes[:, self._end]  # (B, E, 2)
        moves = toward[:, None] + rng.normal(0.0, cfg.move_noise, (b, m, e, 2))
        moves[:, 0] = toward
        norms = np.linalg.norm(moves, axis=-1, keepdims=True)
        moves *= np.minimum(1.0, cfg.max_move / np.maximum(norms, 1e-12))
        flat = moves.reshape(b * m, 2 * e)
        # Raw predictions (inextensible=False): the setting the tree was tuned and benchmarked
        # with; the projection's fixed cost per call adds up over the tree's many small calls.
        predicted = self.transition_model.predict(
            np.repeat(shapes, m, axis=0), self.config.grasp, flat, inextensible=False,
            **({} if self.pegs is None else {"pegs": self.pegs}),
            **({} if self.cord is None else {"params": self.cord}),
        ).reshape(b, m, self.n_points, 2)
        errs = np.asarray(error(predicted, targets[:, None])).reshape(b, m)
        pick = errs.argmin(axis=1)
        rows = np.arange(b)
        return moves[rows, pick], predicted[rows, pick], errs[rows, pick]

    def _shortcut(
        self, latents: np.ndarray, points: list[int], limits: _CordLimits, counts: dict[str, int]
    ) -> tuple[np.ndarray, list[int]]:
        """Greedy shortcuts: from each kept node, jump to the farthest node reachable directly."""
        keep, keep_points = [0], []
        i, last = 0, len(latents) - 1
        while i < last:
            targets = np.arange(last, i + 1, -1)  # farthest first
            if len(targets):
                shape_i = self.surrogate.decode(latents[i][None])
                ok, _, k = self._try_edges(
                    np.repeat(latents[i][None], len(targets), axis=0),
                    np.repeat(shape_i, len(targets), axis=0), latents[targets], limits, counts,
                )
                if ok.any():
                    j = int(targets[np.argmax(ok)])
                    keep.append(j)
                    keep_points.append(k)
                    i = j
                    continue
            keep.append(i + 1)
            keep_points.append(points[i])
            i += 1
        return latents[keep], keep_points

    def _build_plan(
        self, path: np.ndarray, points: list[int], start: np.ndarray, goal: np.ndarray,
        success: bool, stats: dict[str, Any], t0: float, calls0: int,
    ) -> Plan:
        """Decode the path edge by edge and anchor the end's waypoints to the real shapes."""
        latents = [path[:1]]
        nodes = [0]
        for a, b, k in zip(path[:-1], path[1:], points):
            fractions = np.arange(1, k + 1) / k
            latents.append(self.surrogate.segment(a[None], b[None], fractions)[0])
            nodes.append(nodes[-1] + k)
        latents = np.concatenate(latents).astype(np.float32)
        shapes = self.surrogate.decode(latents)
        decoded_ends = shapes[:, self._end].astype(np.float64)  # (T, E, 2)
        corners = decoded_ends[nodes].copy()
        corners[0] = start[self._end]
        if success:
            corners[-1] = goal[self._end]
        waypoints = np.empty_like(decoded_ends)
        waypoints[0] = corners[0]
        for e, (a, b) in enumerate(zip(nodes[:-1], nodes[1:])):
            idx = np.arange(a + 1, b + 1)
            for j in range(len(self._end)):  # each end on the straight line between corners
                chord = decoded_ends[b, j] - decoded_ends[a, j]
                length2 = float(chord @ chord)
                if length2 > 1e-18:
                    t = np.clip((decoded_ends[idx, j] - decoded_ends[a, j]) @ chord / length2,
                                0.0, 1.0)
                else:
                    t = (idx - a) / (b - a)
                waypoints[idx, j] = corners[e, j] + t[:, None] * (corners[e + 1, j] - corners[e, j])
        if len(self._end) == 1:
            waypoints = waypoints[:, 0]
        stats = dict(stats)
        stats["path_nodes"] = len(nodes)
        stats["direct"] = len(nodes) == 2
        stats["decoder_calls"] = self.surrogate.decoder_calls - calls0
        stats["seconds"] = time.perf_counter() - t0
        return Plan(
            shapes=shapes,
            latents=latents,
            waypoints=waypoints.astype(np.float32),
            nodes=np.array(nodes, dtype=np.int64),
            success=bool(success),
            stats=stats,
            grasp=self.config.grasp,
        )


# ---------------------------------------------------------------------- edge types
class _LatentEdges:
    """Edges of ``edges="latent"``: straight latent segments, decoded and checked.

    Start and goal are inverted (the goal's latent may be given); nodes are latents, and
    a node within ``goal_threshold`` of the decoded goal ends the search after one more goal
    connection attempt, which (when it passes) ends the path at the goal's latent itself.
    """

    connect_after_reach = True

    def __init__(self, planner: LatentTreePlanner, start: np.ndarray, goal: np.ndarray,
                 goal_latent: np.ndarray | None) -> None:
        self.planner, self.start, self.goal = planner, start, goal
        self.counts = {"similarity": 0, "straightness": 0, "follow": 0, "cord": 0}
        self.z_start, self.z_goal, self.inversion = self._invert(start, goal, goal_latent)
        ends = planner.surrogate.decode(np.stack([self.z_start, self.z_goal]))
        self.root_shape, self.shape_goal = ends[0], ends[1]
        self.limits = _CordLimits.of(start, ends, planner.config.max_stretch)
        self.goal_edge: tuple[int, int] | None = None  # (node, points) connected to the goal
        self.reached: int | None = None  # a node within goal_threshold (the paper's stop)

    def _invert(self, start: np.ndarray, goal: np.ndarray, goal_latent: np.ndarray | None
                ) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        """The latents of start and goal, and the inversions' errors for the plan's stats."""
        planner = self.planner
        if goal_latent is None:
            z, inv_err, inv_ok = planner.invert(np.stack([start, goal]))
            z_start, z_goal = z[0], z[1]
            goal_err, goal_ok = float(inv_err[1]), bool(inv_ok[1])
        else:
            latent_dim = planner.surrogate.latent_dim
            z_goal = np.asarray(goal_latent, dtype=np.float32).reshape(-1)
            if z_goal.shape != (latent_dim,):
                raise InputError(f"goal_latent must have shape ({latent_dim},), "
                                 f"got {np.shape(goal_latent)}")
            z, inv_err, inv_ok = planner.invert(start[None])
            z_start = z[0]
            goal_err, goal_ok = math.nan, True
        return z_start, z_goal, {
            "start_inversion_error": float(inv_err[0]), "start_verified": bool(inv_ok[0]),
            "goal_inversion_error": goal_err, "goal_verified": goal_ok}

    def connect(self, tree: _Tree, candidates: np.ndarray) -> bool:
        planner = self.planner
        dist = np.linalg.norm(tree.latents[candidates] - self.z_goal, axis=1)
        candidates = candidates[np.argsort(dist)[: planner.config.connect_attempts]]
        ok, _, points = planner._try_edges(
            tree.latents[candidates], tree.shapes[candidates],
            np.broadcast_to(self.z_goal, (len(candidates), len(self.z_goal))), self.limits,
            self.counts,
        )
        if not ok.any():
            return False
        passing = candidates[ok]
        head_goal = self.shape_goal[planner._end]
        total = tree.cost[passing] + np.linalg.norm(
            tree.shapes[passing][:, planner._end] - head_goal, axis=-1).sum(axis=1)
        self.goal_edge = (int(passing[np.argmin(total)]), points)
        return True

    def extend(self, tree: _Tree, samples: np.ndarray, nearest: np.ndarray) -> np.ndarray:
        planner, cfg = self.planner, self.planner.config
        nodes = tree.latents[: tree.size]
        direction = samples - nodes[nearest]
        dist = np.linalg.norm(direction, axis=1)
        keep = dist > 1e-6
        nearest, direction, dist = nearest[keep], direction[keep], dist[keep]
        if len(nearest) == 0:
            return np.array([], dtype=np.int64)
        step = np.minimum(dist, cfg.step_length)
        targets = nodes[nearest] + direction * (step / dist)[:, None]
        ok, shapes, points = planner._try_edges(
            nodes[nearest], tree.shapes[nearest], targets, self.limits, self.counts,
            points=cfg.edge_points,
        )
        parents = nearest[ok]
        moved = np.linalg.norm(shapes[ok][:, planner._end] - tree.shapes[parents][:, planner._end],
                               axis=-1).sum(axis=1)
        added = tree.add(targets[ok].astype(np.float32), shapes[ok], parents,
                         tree.cost[parents] + moved, np.full(len(parents), points))
        if len(added):
            close = np.asarray(error(tree.shapes[added], self.shape_goal)) <= cfg.goal_threshold
            if close.any():
                self.reached = int(added[np.argmax(close)])
        return added

    def _path(self, tree: _Tree) -> tuple[np.ndarray, list[int], bool]:
        """The path's latents and points per edge: to the goal latent, else to the reached
        node, else to the closest node; and whether it reaches the goal."""
        if self.goal_edge is not None:
            node, points = self.goal_edge
            path = tree.path(node)
            latents = [tree.latents[i] for i in path] + [self.z_goal]
            return (np.array(latents, dtype=np.float32),
                    [int(tree.edge_points[i]) for i in path[1:]] + [points], True)
        if self.reached is None:
            gaps = np.asarray(error(tree.shapes[: tree.size], self.shape_goal)).reshape(-1)
            node, success = int(np.argmin(gaps)), False
        else:
            node, success = self.reached, True
        path = tree.path(node)
        return (np.array([tree.latents[i] for i in path], dtype=np.float32),
                [int(tree.edge_points[i]) for i in path[1:]], success)

    def plan(self, tree: _Tree, iterations: int, stop: str, t0: float, calls0: int) -> Plan:
        planner = self.planner
        path_latents, path_points, success = self._path(tree)
        if planner.config.shortcut and len(path_latents) > 2:
            path_latents, path_points = planner._shortcut(path_latents, path_points,
                                                          self.limits, self.counts)
        stats = {
            "nodes": int(tree.size),
            "iterations": iterations,
            "stop": stop if not success else "goal",
            **self.inversion,
            "rejected": dict(self.counts),
        }
        return planner._build_plan(path_latents, path_points, self.start, self.goal, success,
                                   stats, t0, calls0)


class _MoveEdges:
    """Edges of ``edges="moves"``: straight moves whose outcome the transition model predicts.

    Targets are drawn from the GAN's latent box around start and goal (or are the goal), the
    nearest node in latent space is extended by the best of a batch of moves towards the
    decoded target, and after every batch the nodes nearest the goal try to reach it in one
    move. Nodes are predicted shapes at rest (their latents the encoder's); a node within
    ``goal_threshold`` of the goal ends the search at once. The plan is the moves from the
    start.
    """

    connect_after_reach = False

    def __init__(self, planner: LatentTreePlanner, start: np.ndarray, goal: np.ndarray,
                 goal_latent: np.ndarray | None, rng: np.random.Generator) -> None:
        self.planner, self.start, self.goal, self.rng = planner, start, goal, rng
        if goal_latent is None:
            goal_latent = planner._encode(goal[None])[0]
        self.z_goal = np.asarray(goal_latent, dtype=np.float32).reshape(-1)
        self.z_start = planner._encode(start[None])[0]
        self.root_shape = start
        self.moves = np.zeros((planner.config.max_nodes + 1, len(planner._end), 2))
        self.best_node, self.best_err = 0, float(error(start, goal))
        self.connection: tuple[int, np.ndarray, np.ndarray] | None = None  # (node, move, shape)
        self.reached: int | None = None

    def connect(self, tree: _Tree, candidates: np.ndarray) -> bool:
        planner, cfg = self.planner, self.planner.config
        gaps = np.asarray(error(tree.shapes[candidates], self.goal)).reshape(-1)
        candidates = candidates[np.argsort(gaps)[: cfg.connect_attempts]]
        move, shape, err = planner._best_moves(
            tree.shapes[candidates],
            np.broadcast_to(self.goal, (len(candidates), planner.n_points, 2)), self.rng)
        k = int(np.argmin(err))
        if err[k] <= cfg.goal_threshold:
            self.connection = (int(candidates[k]), move[k], shape[k])
            return True
        return False

    def extend(self, tree: _Tree, samples: np.ndarray, nearest: np.ndarray) -> np.ndarray:
        planner = self.planner
        targets = planner.surrogate.decode(samples.astype(np.float32))
        move, shape, _ = planner._best_moves(tree.shapes[nearest], targets, self.rng)
        new = np.asarray(error(shape, tree.shapes[nearest])).reshape(-1) > MIN_NODE_CHANGE
        parents = nearest[new]
        added = tree.add(planner._encode(shape[new]) if new.any()
                         else np.zeros((0, len(self.z_goal))),
                         shape[new], parents, tree.cost[parents] + 1,
                         np.ones(len(parents), np.int64))
        self.moves[added] = move[new][: len(added)]
        if len(added):
            gaps = np.asarray(error(tree.shapes[added], self.goal)).reshape(-1)
            if gaps.min() < self.best_err:
                self.best_node, self.best_err = int(added[np.argmin(gaps)]), float(gaps.min())
            if gaps.min() <= planner.config.goal_threshold:
                self.reached = self.best_node
        return added

    def plan(self, tree: _Tree, iterations: int, stop: str, t0: float, calls0: int) -> Plan:
        planner, e = self.planner, len(self.planner._end)
        success = self.connection is not None or self.reached is not None
        node = self.connection[0] if self.connection is not None else self.best_node
        path = tree.path(node)
        path_moves = [self.moves[i] for i in path[1:]]
        path_shapes = [tree.shapes[i] for i in path]
        if self.connection is not None and np.any(self.connection[1]):
            path_moves.append(self.connection[1])
            path_shapes.append(self.connection[2])
        shapes = np.array(path_shapes, dtype=np.float32)
        corners = np.concatenate([self.start[planner._end][None], shapes[1:][:, planner._end]])
        if e == 1:
            corners = corners[:, 0]
        stats = {
            "nodes": int(tree.size),
            "iterations": iterations,
            "stop": stop if not success else "goal",
            "edges": "moves",
            "path_nodes": len(shapes),
            "direct": len(shapes) == 2,
            "predicted_error": float(error(shapes[-1], self.goal)),
            "moves": np.array(path_moves).reshape(-1, 2 * e).tolist(),
            "decoder_calls": planner.surrogate.decoder_calls - calls0,
            "seconds": time.perf_counter() - t0,
        }
        return Plan(shapes=shapes, latents=planner._encode(shapes), waypoints=corners.astype(
            np.float32), nodes=np.arange(len(shapes), dtype=np.int64), success=success,
            stats=stats, grasp=planner.config.grasp)
