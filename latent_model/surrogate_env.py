"""The learned cord as Gymnasium environments: ``dlo_env/DLOEndpointSurrogate-v0`` and
``dlo_env/DLODualEndpointSurrogate-v0``.

Each step is one prediction of the transition model (:class:`~latent_model.cord_dynamics.
CordDynamics`) instead of a pymunk simulation: the shape at rest after the held end(s) moved by
the action. The vector environments step every cord of the batch in one torch call, on the CPU
or CUDA, following Gymnasium's ``CartPoleVectorEnv`` (registered as a ``vector_entry_point``;
next-step autoreset by default). The single environments are a batch of one, through the same
step function. Spaces, reward, ``compute_reward``, the success rule, ``info`` keys and reset
options are those of the pymunk environments (:mod:`dlo_env.envs.goal_env`); what differs is
listed in :class:`SurrogateCordVectorEnv` and measured in ``docs/surrogate.md``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import torch
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from dlo_env.cord import PEG_RADIUS, CordParams
from dlo_env.envs.goal_api import (
    GoalReward,
    check_goal_args,
    check_task,
    goal_metrics,
    goal_spaces,
    option_difficulty,
)
from dlo_env.errors import InputError
from dlo_env.shapes import (
    BEAD_TOLERANCE,
    SUCCESS_METRICS,
    TABLE_HALF,
    error,
    random_cord_shapes,
    validate_shape,
)
from dlo_env.tasks import (
    DEFAULT_MAX_STEP,
    GRASP_ENDS,
    MOVE_LENGTH,
    SPAN_MARGIN,
    SUCCESS_THRESHOLD,
    TARGET_MARGIN,
    Task,
    check_difficulty,
)
from latent_model.cord_dynamics import CordDynamics
from latent_model.transition_model import TransitionModel

#: Reset options the surrogate understands (the vector envs also take ``reset_mask``).
OPTIONS = ("difficulty", "start", "goal", "task", "params", "pegs")
#: Tasks drawn at once when the stock of autoreset tasks runs out (at least ``num_envs``).
TASK_BATCH = 256
#: Redraws of a task's moves (then of its start) before giving up.
REDRAWS = 100
_AUTORESET = {"next_step": AutoresetMode.NEXT_STEP, "same_step": AutoresetMode.SAME_STEP}


@dataclass
class TaskBatch:
    """Tasks made in the surrogate, as arrays.

    Attributes:
        starts: ``(B, n, 2)`` float32 start shapes.
        goals: ``(B, n, 2)`` float32 goal shapes (the model's shapes after ``moves``).
        moves: ``(B, K, action_dim)`` float32 straight moves, metres (``K`` 0: given goals).
        difficulty: ``(B,)`` int moves per task (0: a given goal).
        given: The ``Task`` objects of ``options["task"]``, one per row (None: made here):
            their seeds and reference actions are reported as they are.
    """

    starts: np.ndarray
    goals: np.ndarray
    moves: np.ndarray
    difficulty: np.ndarray
    given: list[Task] | None = None

    @staticmethod
    def concat(batches: list[TaskBatch]) -> TaskBatch:
        """The tasks of ``batches`` in order (moves zero-padded to the most any has)."""
        k = max(b.moves.shape[1] for b in batches)
        moves = [np.pad(b.moves, ((0, 0), (0, k - b.moves.shape[1]), (0, 0))) for b in batches]
        return TaskBatch(np.concatenate([b.starts for b in batches]),
                         np.concatenate([b.goals for b in batches]), np.concatenate(moves),
                         np.concatenate([b.difficulty for b in batches]))

    def take(self, index: np.ndarray) -> TaskBatch:
        """The tasks at ``index``."""
        given = None if self.given is None else [self.given[i] for i in index]
        return TaskBatch(self.starts[index], self.goals[index], self.moves[index],
                         self.difficulty[index], given)

    def __len__(self) -> int:
        return len(self.starts)


def load_model(model: TransitionModel | str | None, device: str | torch.device
               ) -> TransitionModel:
    """``model`` itself when loaded, else ``TransitionModel.load_or_pretrained(model)``."""
    if isinstance(model, TransitionModel):
        return model
    if model is not None and not isinstance(model, (str, bytes)) and not hasattr(
            model, "__fspath__"):
        raise InputError(f"model must be a TransitionModel, a file path or None (the shipped "
                         f"model), got {type(model).__name__}")
    loaded = TransitionModel.load_or_pretrained(model, device=device)
    loaded.requires_grad_(False)
    return loaded


def goal_metrics_torch(shapes: torch.Tensor, goals: torch.Tensor) -> dict[str, torch.Tensor]:
    """``dlo_env.envs.goal_api.goal_metrics`` of a batch ``(B, n, 2)`` in torch, on the cords'
    device: ``error``, ``max_error``, ``direction_free_error`` and ``bead_share`` (the same
    formulas; float32, so within float32 rounding of the float64 numpy ones)."""
    dist = (shapes - goals).norm(dim=-1)  # (B, n)
    err = dist.mean(dim=-1)
    reverse = (shapes - goals.flip(1)).norm(dim=-1).mean(dim=-1)
    # Bead share: each point's distance to the goal's polyline, coordinates kept apart.
    px, py = shapes[:, :, 0, None], shapes[:, :, 1, None]  # (B, n, 1)
    sx, sy = goals[:, None, :-1, 0], goals[:, None, :-1, 1]  # (B, 1, m - 1)
    seg = goals[:, 1:] - goals[:, :-1]
    dx, dy = seg[:, None, :, 0], seg[:, None, :, 1]
    rx, ry = px - sx, py - sy
    t = ((rx * dx + ry * dy) / (dx * dx + dy * dy).clamp_min(1e-18)).clamp(0.0, 1.0)
    ox, oy = rx - t * dx, ry - t * dy
    near = (ox * ox + oy * oy).amin(dim=-1) <= BEAD_TOLERANCE ** 2
    return {"error": err, "max_error": dist.amax(dim=-1),
            "direction_free_error": torch.minimum(err, reverse),
            "bead_share": near.to(shapes.dtype).mean(dim=-1)}


class SurrogateCords:
    """A batch of learned cords and their goals: the state and the step the surrogate
    environments share.

    Args:
        count: Cords in the batch.
        grasp: Held ends, ``"head"`` or ``"both"``.
        model: The transition model, a file, or None (the shipped one).
        device: Torch device (``"auto"``: CUDA when available).
        params: The cord (None: the model's); a model of one cord takes only its own.
        max_step: Gripper displacement of an action of 1.0, metres.
        merge_runs: Equal consecutive actions are one straight move (see ``step``).
    """

    def __init__(self, count: int, grasp: str, model: TransitionModel | str | None,
                 device: str | torch.device, params: CordParams | None, max_step: float,
                 merge_runs: bool = True) -> None:
        self.model = load_model(model, device)
        self.params = params if params is not None else self.model.cord_params
        self.dynamics = CordDynamics(self.model, grasp, self.params)
        self.device = self.model.device
        self.grasp = grasp
        self.ends = [0 if end == "head" else -1 for end in GRASP_ENDS[grasp]]
        self.max_step = float(max_step)
        n = self.params.n_points
        self.shapes = torch.zeros((count, n, 2), device=self.device)
        self.goals = np.zeros((count, n, 2), dtype=np.float32)
        #: ``goals`` on the device.
        self.goals_torch = torch.zeros((count, n, 2), device=self.device)
        #: Whether an action equal to the previous one continues its straight move.
        self.merge_runs = bool(merge_runs)
        width = 2 * len(self.ends)
        self._running = np.zeros(count, dtype=bool)  # a straight move is under way
        self._last = np.zeros((count, width), dtype=np.float32)  # its action
        self._travel = np.zeros((count, width), dtype=np.float32)  # its displacement so far
        self._anchor = torch.zeros_like(self.shapes)  # the shape it began in

    # ------------------------------------------------------------- stepping
    def start(self, index: np.ndarray, starts: np.ndarray) -> None:
        """Put the cords ``index`` at rest in ``starts`` ``(k, n, 2)``; no move is under way."""
        shapes = torch.from_numpy(np.ascontiguousarray(starts, dtype=np.float32)).to(
            self.device)
        if len(index) == len(self.shapes):
            self.shapes = shapes.clone()
        else:
            self.shapes[torch.from_numpy(index).to(self.device)] = shapes
        self._running[index] = False

    def step(self, actions: np.ndarray, spread: bool = False) -> np.ndarray | None:
        """Move every cord's held end(s) by ``clip(actions, -1, 1) * max_step``; with
        ``spread``, return the ensemble's spread of each prediction (metres).

        With ``merge_runs``, an action equal to the cord's previous one continues that
        straight move: the prediction is the model's for the whole move so far, from the shape
        it began in (the move the model was trained on: equal actions, then rest). A zero
        action leaves a cord where it is and ends its move.
        """
        a = np.clip(actions, -1.0, 1.0).astype(np.float32)
        d = a * np.float32(self.max_step)
        if self.merge_runs:
            same = self._running & (a == self._last).all(axis=1)
            if not same.all():
                fresh = torch.from_numpy(~same).to(self.device)
                self._anchor = torch.where(fresh[:, None, None], self.shapes, self._anchor)
                self._travel[~same] = 0.0
            self._travel += d
            self._last = a
            self._running = a.any(axis=1)
            start, d = self._anchor, self._travel
        else:
            start = self.shapes
        moves = torch.from_numpy(np.ascontiguousarray(d)).to(self.device)
        with torch.no_grad():
            out = self.dynamics.step(start, moves, return_std=spread)
        shapes, std = out if spread else (out, None)
        if self.merge_runs:  # a zero action: the cord stays (the model would too, from the
            still = torch.from_numpy(~self._running).to(self.device)  # move's start)
            shapes = torch.where(still[:, None, None], self.shapes, shapes)
        self.shapes = shapes
        return None if std is None else std.cpu().numpy()

    def set_goals(self, index: np.ndarray, goals: np.ndarray) -> None:
        """Give the cords ``index`` these goals ``(k, n, 2)``."""
        self.goals[index] = goals
        self.goals_torch[torch.from_numpy(index).to(self.device)] = torch.from_numpy(
            np.ascontiguousarray(goals, dtype=np.float32)).to(self.device)

    def shapes_numpy(self) -> np.ndarray:
        """``(B, n, 2)`` float32 shapes on the CPU."""
        return self.shapes.cpu().numpy()

    def observe(self, shapes: np.ndarray) -> dict[str, np.ndarray]:
        """The batched observation of ``shapes`` ``(B, n, 2)``: the points, then the held ends
        (the grippers, which the model puts exactly where they were sent)."""
        b = len(shapes)
        flat = shapes.reshape(b, -1)
        grippers = shapes[:, self.ends].reshape(b, -1)
        return {"observation": np.concatenate([flat, grippers], axis=1),
                "achieved_goal": flat.copy(),
                "desired_goal": self.goals.reshape(b, -1).copy()}

    # ------------------------------------------------------------- tasks
    def draw_tasks(self, rng: np.random.Generator, count: int,
                   difficulty: int | tuple[int, ...], min_error: float,
                   starts: np.ndarray | None = None) -> TaskBatch:
        """``count`` tasks made in the surrogate: starts from the shape sampler
        (``random_cord_shapes``, or ``starts``), goals ``difficulty`` random straight moves
        away through the model (each move U(5, 30) cm, targets ``TARGET_MARGIN`` inside the
        table, both ends within the span), redrawn until farther than ``min_error``. A tuple
        of difficulties: each task draws one of them uniformly."""
        if isinstance(difficulty, tuple):
            drawn = rng.choice(np.asarray(difficulty), size=count)
            order = np.argsort(drawn, kind="stable")
            parts = [self.draw_tasks(rng, int((drawn == k).sum()), int(k), min_error,
                                     None if starts is None else starts[drawn == k])
                     for k in np.unique(drawn)]
            batch = TaskBatch.concat(parts)
            return batch.take(np.argsort(order, kind="stable"))
        p = self.params
        n = p.n_points
        out_starts = np.empty((count, n, 2), dtype=np.float32)
        out_goals = np.empty((count, n, 2), dtype=np.float32)
        out_moves = np.empty((count, difficulty, 2 * len(self.ends)), dtype=np.float32)
        todo = np.arange(count)
        given = starts is not None
        fresh = np.ones(count, dtype=bool)
        for _ in range(REDRAWS):
            if given:
                out_starts[todo] = starts[todo]
            else:
                out_starts[todo[fresh[todo]]] = self._draw_starts(rng, int(fresh[todo].sum()))
            moves = self._draw_moves(rng, out_starts[todo], difficulty)
            goals = self._apply_moves(out_starts[todo], moves)
            far = np.asarray(error(goals, out_starts[todo])) > min_error
            out_moves[todo[far]] = moves[far]
            out_goals[todo[far]] = goals[far]
            todo = todo[~far]
            fresh[:] = False
            if not len(todo):
                return TaskBatch(out_starts, out_goals, out_moves,
                                 np.full(count, difficulty, dtype=np.int64))
        raise RuntimeError(f"no goal farther than {min_error} m from the start in {REDRAWS} "
                           f"draws of the moves")

    def _draw_starts(self, rng: np.random.Generator, count: int) -> np.ndarray:
        p = self.params
        if self.grasp != "both":
            return random_cord_shapes(rng, count, n_points=p.n_points, length=p.length)
        # The dual environment's starts: the ends within the span (drawn in surplus, since
        # many shapes are too straight for it).
        span = p.max_span * p.length - SPAN_MARGIN
        kept: list[np.ndarray] = []
        need = count
        for _ in range(REDRAWS):
            shapes = random_cord_shapes(rng, 3 * need + 8, n_points=p.n_points,
                                        length=p.length)
            ok = shapes[np.linalg.norm(shapes[:, -1] - shapes[:, 0], axis=-1) < span][:need]
            kept.append(ok)
            need -= len(ok)
            if need == 0:
                return np.concatenate(kept)
        raise RuntimeError("could not draw starts whose ends are within the span")

    def _draw_moves(self, rng: np.random.Generator, starts: np.ndarray, difficulty: int
                    ) -> np.ndarray:
        """``(B, difficulty, dim)`` moves whose targets stay ``TARGET_MARGIN`` inside the table
        (and, both ends held, within the span), as ``dlo_env.tasks`` draws them."""
        p = self.params
        lim = TABLE_HALF - max(TARGET_MARGIN, p.rim_margin)
        span = p.max_span * p.length - SPAN_MARGIN
        b, k = len(starts), len(self.ends)
        pos = starts[:, self.ends].astype(np.float64)  # (B, k, 2)
        moves = np.zeros((b, difficulty, k, 2))
        for j in range(difficulty):
            todo = np.arange(b)
            for _ in range(200):
                angle = rng.uniform(-np.pi, np.pi, size=(len(todo), k))
                length = rng.uniform(*MOVE_LENGTH, size=(len(todo), k))
                d = length[..., None] * np.stack([np.cos(angle), np.sin(angle)], axis=-1)
                target = pos[todo] + d
                ok = (np.abs(target) <= lim).all(axis=(1, 2))
                if k == 2:
                    ok &= np.linalg.norm(target[:, 1] - target[:, 0], axis=-1) < span
                moves[todo[ok], j] = d[ok]
                todo = todo[~ok]
                if not len(todo):
                    break
            else:  # an end no move keeps on the table: stay (the goal check redraws)
                moves[todo, j] = 0.0
            pos = pos + moves[:, j]
        return moves.reshape(b, difficulty, 2 * k).astype(np.float32)

    def _apply_moves(self, starts: np.ndarray, moves: np.ndarray) -> np.ndarray:
        shapes = torch.from_numpy(starts).to(self.device)
        with torch.no_grad():
            for j in range(moves.shape[1]):
                shapes = self.dynamics.step(shapes, torch.from_numpy(moves[:, j]).to(
                    self.device))
        return shapes.cpu().numpy()

    def reference_actions(self, moves: np.ndarray, counts: np.ndarray) -> list[np.ndarray]:
        """Each task's ``(T, dim)`` actions that carry out its first ``counts[i]`` moves of
        ``moves`` ``(B, K, dim)``, every move split as ``dlo_env.tasks.split_move`` splits it
        (equal actions, none moving an end farther than ``max_step``), for the whole batch."""
        b, k, dim = moves.shape
        d = moves.astype(np.float64)
        longest = np.linalg.norm(d.reshape(b, k, dim // 2, 2), axis=-1).max(axis=-1)  # (B, K)
        steps = np.maximum(1, np.ceil(longest / self.max_step - 1e-9)).astype(np.int64)
        steps[np.arange(k)[None] >= counts[:, None]] = 0  # moves past a task's own
        action = np.clip(d / (np.maximum(steps, 1)[..., None] * self.max_step), -1.0, 1.0)
        flat = np.repeat(action.reshape(-1, dim).astype(np.float32), steps.reshape(-1), axis=0)
        return np.split(flat, np.cumsum(steps.sum(axis=1))[:-1])

    # ------------------------------------------------------------- options
    def tasks_from_options(self, options: dict[str, Any], count: int,
                           rng: np.random.Generator, difficulty: int, min_error: float
                           ) -> TaskBatch:
        """The ``count`` tasks of a reset's ``options`` (see the environments' Reset Options)."""
        difficulty = option_difficulty(options, OPTIONS, difficulty)
        if "pegs" in options and len(np.asarray(options["pegs"]).reshape(-1)):
            raise InputError("options['pegs']: the surrogate environments model the empty "
                             "table (no pegs); use the pymunk environment for pegs")
        if "params" in options and options["params"] != self.params:
            raise InputError(f"options['params']: this surrogate's model predicts one cord "
                             f"({self.params}); make the environment with params=... and a "
                             f"model of that cord")
        if "task" in options:
            return self._given_tasks(options["task"], count)
        starts = self._shape_option(options, "start", count)
        goals = self._shape_option(options, "goal", count)
        if goals is None:
            return self.draw_tasks(rng, count, difficulty, min_error, starts)
        if starts is None:
            starts = self._draw_starts(rng, count)
        return TaskBatch(starts, goals, np.zeros((count, 0, 2 * len(self.ends)), np.float32),
                         np.zeros(count, dtype=np.int64))

    def _shape_option(self, options: dict[str, Any], name: str, count: int
                      ) -> np.ndarray | None:
        if name not in options:
            return None
        p = self.params
        arr = np.asarray(options[name], dtype=np.float32)
        single = arr.ndim == 1 or (arr.ndim == 2 and arr.shape == (p.n_points, 2))
        rows = arr[None] if single else arr
        if not single and len(rows) != count:
            raise InputError(f"options['{name}'] must be one shape or one per environment "
                             f"({count}), got {len(rows)}")
        shapes = self._checked(rows, f"options['{name}']")
        return np.broadcast_to(shapes, (count,) + shapes.shape[1:]).astype(np.float32)

    def _checked(self, rows: np.ndarray, name: str) -> np.ndarray:
        """Shapes ``rows`` checked as the pymunk environment checks them (``validate_shape``;
        with both ends held, the ends within the span); ``(k, n, 2)`` float32."""
        p = self.params
        shapes = np.stack([validate_shape(r, n_points=p.n_points, length=p.length, name=name)
                           for r in rows])
        if self.grasp == "both":
            span = np.linalg.norm(shapes[:, -1] - shapes[:, 0], axis=-1)
            if (span >= p.max_span * p.length).any():
                raise InputError(f"{name} must have its head and tail closer than "
                                 f"max_span * length = {p.max_span * p.length:.3f} m when both "
                                 f"ends are held, got {span.max():.3f} m")
        return shapes.astype(np.float32)

    def _given_tasks(self, tasks: Any, count: int) -> TaskBatch:
        tasks = [tasks] if isinstance(tasks, Task) else list(tasks)
        if len(tasks) not in (1, count):
            raise InputError(f"options['task'] must be one Task or one per environment "
                             f"({count}), got {len(tasks)}")
        for task in tasks:
            check_task(task, self.grasp, self.max_step)
            if len(task.pegs):
                raise InputError("options['task'] has pegs: the surrogate environments model "
                                 "the empty table")
        tasks = tasks * count if len(tasks) == 1 else tasks
        k = max(t.difficulty for t in tasks)
        moves = np.zeros((count, k, 2 * len(self.ends)), dtype=np.float32)
        for i, t in enumerate(tasks):
            moves[i, :t.difficulty] = t.moves
        starts = self._checked(np.stack([t.start for t in tasks]), "options['task'].start")
        goals = self._checked(np.stack([t.goal for t in tasks]), "options['task'].goal")
        return TaskBatch(starts, goals, moves,
                         np.array([t.difficulty for t in tasks], dtype=np.int64), tasks)


class _SurrogateArgs:
    """The constructor arguments the single and the vector surrogate environments share."""

    grasp: ClassVar[str] = "head"
    metadata: ClassVar[dict[str, Any]]
    #: Metrics in torch for the batch (vector envs) or in numpy (single envs).
    _batched: ClassVar[bool] = True

    def _setup(self, count: int, *, model: Any, device: str, params: CordParams | None,
               max_step: float, reward_type: str, success_threshold: float,
               success_metric: str, judge_at_rest: bool, difficulty: int | tuple[int, ...],
               max_pegs: int,
               uncertainty_penalty: float, merge_runs: bool, render_mode: str | None) -> None:
        check_goal_args(params=params, max_step=max_step, reward_type=reward_type,
                        success_threshold=success_threshold, success_metric=success_metric,
                        judge_at_rest=judge_at_rest, max_pegs=max_pegs, render_mode=render_mode,
                        render_modes=self.metadata["render_modes"])
        if max_pegs:
            raise InputError(f"max_pegs must be 0: the surrogate environments model the empty "
                             f"table, got {max_pegs!r}")
        if not (isinstance(uncertainty_penalty, (int, float)) and not isinstance(
                uncertainty_penalty, bool) and 0 <= uncertainty_penalty < float("inf")):
            raise InputError(f"uncertainty_penalty must be a finite number >= 0, got "
                             f"{uncertainty_penalty!r}")
        if not isinstance(merge_runs, (bool, np.bool_)):
            raise InputError(f"merge_runs must be True or False, got {merge_runs!r}")
        self.cords = SurrogateCords(count, self.grasp, model, device, params, max_step,
                                    merge_runs)
        self.params = self.cords.params
        self.max_step = float(max_step)
        self.reward_type = reward_type
        self.success_threshold = float(success_threshold)
        self.success_metric = success_metric
        self._distance = SUCCESS_METRICS[success_metric]
        self.judge_at_rest = bool(judge_at_rest)
        if isinstance(difficulty, (tuple, list)):
            if not difficulty:
                raise InputError("difficulty must be an int from 1 to 10 or a non-empty tuple "
                                 "of them, got ()")
            self.difficulty = tuple(check_difficulty(k) for k in difficulty)
        else:
            self.difficulty = check_difficulty(difficulty)
        self.max_pegs = 0
        self.peg_radius = PEG_RADIUS  # as the pymunk environment's (no peg is ever placed)
        self.uncertainty_penalty = float(uncertainty_penalty)
        self.render_mode = render_mode
        self._renderer = None

    @property
    def model(self) -> TransitionModel:
        """The transition model the cords step with."""
        return self.cords.model

    @property
    def dynamics(self) -> CordDynamics:
        """The differentiable step function (torch in and out)."""
        return self.cords.dynamics

    def _step_info(self, shapes: np.ndarray, spread: np.ndarray | None
                   ) -> tuple[dict[str, Any], np.ndarray, np.ndarray]:
        """Batched ``info``, rewards and successes of the cords against their goals: by
        ``goal_metrics_torch`` on the device in the vector environments, by numpy's
        ``goal_metrics`` (what ``compute_reward`` computes, bit for bit) in the single ones."""
        if self._batched:
            with torch.no_grad():
                metrics = goal_metrics_torch(self.cords.shapes, self.cords.goals_torch)
            metrics = {k: v.cpu().numpy().astype(np.float64) for k, v in metrics.items()}
        else:
            metrics = goal_metrics(shapes, self.cords.goals)
        solved = np.asarray(metrics[self.success_metric]) <= self.success_threshold
        b = len(shapes)
        info = {"is_success": solved, "at_rest": np.ones(b, dtype=bool),
                "settle_actions": np.zeros(b, dtype=np.int64), **metrics}
        dist = np.asarray(metrics[self.success_metric], dtype=np.float64)
        reward = -dist if self.reward_type == "dense" else -(~solved).astype(np.float64)
        if spread is not None:
            info["model_spread"] = spread
            reward = reward - self.uncertainty_penalty * spread
        return info, reward, solved

    def _reset_info(self, tasks: TaskBatch) -> dict[str, Any]:
        """Batched reset ``info``: the tasks' ``difficulty``, ``task_seed`` (-1: made in the
        surrogate), ``moves`` and ``reference_actions`` (object arrays: their lengths vary)."""
        b = len(tasks)
        moves = np.empty(b, dtype=object)
        actions = np.empty(b, dtype=object)
        moves[:] = [m[:k] for m, k in zip(tasks.moves, tasks.difficulty)]
        seeds = np.full(b, -1)
        if tasks.given is not None:  # the suites' tasks, as they are
            actions[:] = [t.reference_actions for t in tasks.given]
            seeds[:] = [t.seed for t in tasks.given]
        else:
            actions[:] = self.cords.reference_actions(tasks.moves, tasks.difficulty)
        return {"difficulty": tasks.difficulty.copy(), "task_seed": seeds,
                "moves": moves, "reference_actions": actions}

    def _render_one(self, shape: np.ndarray, goal: np.ndarray) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() was called without a render_mode; pass "
                            "render_mode='rgb_array' to the constructor")
            return None
        if self._renderer is None:
            from dlo_env.rendering import CordRenderer

            self._renderer = CordRenderer(self.render_mode, fps=10)
        grippers = [shape[e] for e in self.cords.ends]
        return self._renderer.draw(shape, goal, grippers)

    def close(self, **kwargs: Any) -> None:
        """Close the renderer, if any; safe to call more than once."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        super().close(**kwargs)  # a vector env marks itself closed


def _check_actions(actions: Any, shape: tuple[int, ...]) -> np.ndarray:
    a = np.asarray(actions, dtype=np.float64)  # clipped before float32: 1e39 is finite
    if a.shape != shape:
        raise InputError(f"action must have shape {shape}, got {a.shape}")
    if not np.isfinite(a).all():
        raise InputError("action must be finite, got NaN or infinite values")
    return np.clip(a, -1.0, 1.0)


class SurrogateCordVectorEnv(_SurrogateArgs, GoalReward, VectorEnv):
    """``num_envs`` learned cords stepped in one batched torch call.

    Spaces, reward, ``compute_reward``, success rule, ``info`` keys and reset options are the
    pymunk environment's (``dlo_env/DLOEndpoint-v0``, ``DLODualEndpoint-v0``). Differences:

    * A step is one prediction of the transition model: the shape **at rest** after the held
      end(s) moved. Every state is at rest, so success is ``error <= success_threshold``,
      ``info["at_rest"]`` is always True and ``info["settle_actions"]`` 0 (``judge_at_rest``
      is accepted and changes nothing). The pymunk cord may still be moving after a step; the
      two agree when the agent's moves let it rest.
    * The model's error: ``docs/surrogate.md`` measures how far a rollout drifts from the
      simulator's.
    * Drawn tasks are made in the surrogate: starts from ``random_cord_shapes`` (not settled
      in a simulator), goals ``difficulty`` straight moves away, each one prediction of the
      model. Their ``reference_actions`` split the moves into actions, which the surrogate
      composes a little differently from one long move; ``task_seed`` is -1. Tasks given with
      ``options["task"]`` (the suites' tasks) are used as they are.
    * The empty table only (``max_pegs=0``), and the model's cord (``params``: a model of
      several cords, ``cords=True``, predicts others).
    * ``uncertainty_penalty`` > 0 subtracts that many times the ensemble's spread (metres) from
      each reward and reports ``info["model_spread"]`` (MOPO's penalty); ``compute_reward``
      does not know it, so hindsight relabelling drops it.

    Args:
        num_envs: Cords in the batch.
        model: A ``TransitionModel``, a file, or None (the shipped model).
        device: Torch device of the model and the cords (``"auto"``: CUDA when available).
        max_episode_steps: Steps before truncation (the registered 100).
        autoreset_mode: ``"next_step"`` (Gymnasium's default: the step after an episode ends
            resets it) or ``"same_step"`` (the ending step resets it and puts the last
            observation in ``info["final_obs"]``, as SB3's VecEnv expects).
        uncertainty_penalty: Reward penalty per metre of ensemble spread (0: none, and the
            ensemble is not run).
        merge_runs: An action equal to the previous one continues its straight move, and the
            cord is predicted after the whole move from where it began, as the model was
            trained (default). False: every step is a move of its own from the last shape
            (errors compose over a long move's many small steps).
        params, max_step, reward_type, success_threshold, success_metric, judge_at_rest,
        max_pegs, render_mode: As the pymunk environment's.
        difficulty: Straight moves of a drawn task (1-10), or a tuple of them: each drawn
            task draws one uniformly (a curriculum of several difficulties).
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 10,
                                          "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, *, model: TransitionModel | str | None = None,
                 device: str = "auto", params: CordParams | None = None,
                 max_step: float = DEFAULT_MAX_STEP, reward_type: str = "dense",
                 success_threshold: float = SUCCESS_THRESHOLD, success_metric: str = "error",
                 judge_at_rest: bool = True, difficulty: int | tuple[int, ...] = 1,
                 max_pegs: int = 0, max_episode_steps: int = 100, autoreset_mode: str = "next_step",
                 uncertainty_penalty: float = 0.0, merge_runs: bool = True,
                 render_mode: str | None = None) -> None:
        if not (isinstance(num_envs, (int, np.integer)) and not isinstance(num_envs, bool)
                and num_envs >= 1):
            raise InputError(f"num_envs must be an int >= 1, got {num_envs!r}")
        if not (isinstance(max_episode_steps, (int, np.integer)) and not isinstance(
                max_episode_steps, bool) and max_episode_steps >= 1):
            raise InputError(f"max_episode_steps must be an int >= 1, got {max_episode_steps!r}")
        mode = autoreset_mode.value if isinstance(autoreset_mode, AutoresetMode) else (
            autoreset_mode)
        if mode not in _AUTORESET:
            raise InputError(f"autoreset_mode must be one of {tuple(_AUTORESET)}, got "
                             f"{autoreset_mode!r}")
        self._setup(int(num_envs), model=model, device=device, params=params,
                    max_step=max_step, reward_type=reward_type,
                    success_threshold=success_threshold, success_metric=success_metric,
                    judge_at_rest=judge_at_rest, difficulty=difficulty, max_pegs=max_pegs,
                    uncertainty_penalty=uncertainty_penalty, merge_runs=merge_runs,
                    render_mode=render_mode)
        self.num_envs = int(num_envs)
        self.max_episode_steps = int(max_episode_steps)
        self.autoreset_mode = _AUTORESET[mode]
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        self.single_action_space, self.single_observation_space = goal_spaces(
            self.params.n_points, len(self.cords.ends))
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.steps = np.zeros(self.num_envs, dtype=np.int64)
        self._prev_done = np.zeros(self.num_envs, dtype=bool)
        self._stock: TaskBatch | None = None
        self._stock_settings: tuple[Any, float] | None = None
        self._started = False

    # ------------------------------------------------------------- tasks
    def _autoreset_tasks(self, count: int) -> TaskBatch:
        """``count`` tasks of the default difficulty, from a stock drawn in large batches."""
        settings = (self.difficulty, self.success_threshold)
        if settings != self._stock_settings:  # drawn for other settings: not these
            self._stock, self._stock_settings = None, settings
        if self._stock is None or len(self._stock) < count:
            fresh = self.cords.draw_tasks(self.np_random, max(TASK_BATCH, self.num_envs, count),
                                          self.difficulty, self.success_threshold)
            if self._stock is not None and len(self._stock):
                fresh = TaskBatch.concat([self._stock, fresh])
            self._stock = fresh
        taken = self._stock.take(np.arange(count))
        self._stock = self._stock.take(np.arange(count, len(self._stock)))
        return taken

    def _begin(self, index: np.ndarray, tasks: TaskBatch) -> None:
        self.cords.start(index, tasks.starts)
        self.cords.set_goals(index, tasks.goals)
        self.steps[index] = 0

    # ------------------------------------------------------------- gym API
    def reset(self, *, seed: int | list[int] | None = None,
              options: dict[str, Any] | None = None) -> tuple[dict[str, np.ndarray], dict]:
        """Start episodes in every environment (or those of ``options["reset_mask"]``).

        ``seed``: an int seeds the batch's generator (a list is refused: the batch draws from
        one generator). ``options``: as the pymunk environment's, where ``start``, ``goal``
        and ``task`` may be one for every environment or a sequence of ``num_envs``.
        """
        if isinstance(seed, (list, tuple)):
            raise InputError("seed must be an int or None: the surrogate's cords draw from one "
                             "generator")
        super().reset(seed=seed)
        if seed is not None:
            self._stock = None
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        if mask is None:
            index = np.arange(self.num_envs)
        else:
            mask = np.asarray(mask)
            if mask.shape != (self.num_envs,) or mask.dtype != np.bool_ or not mask.any():
                raise InputError(f"options['reset_mask'] must be a bool array of shape "
                                 f"({self.num_envs},) with a True, got {mask!r}")
            if not self._started and not mask.all():
                raise InputError("options['reset_mask']: the first reset starts every "
                                 "environment")
            index = np.flatnonzero(mask)
        tasks = self.cords.tasks_from_options(options, len(index), self.np_random,
                                              self.difficulty, self.success_threshold)
        self._begin(index, tasks)
        self._prev_done[index] = False
        self._started = True
        shapes = self.cords.shapes_numpy()
        obs = self.cords.observe(shapes)
        info, _, _ = self._step_info(shapes, None)
        info.update(self._masked(self._reset_info(tasks), index))
        return obs, info

    def _masked(self, info: dict[str, Any], index: np.ndarray) -> dict[str, Any]:
        """Per-environment ``info`` of the environments ``index``, spread to the batch with
        Gymnasium's ``_key`` masks."""
        out: dict[str, Any] = {}
        for key, value in info.items():
            full = (np.empty(self.num_envs, dtype=object) if value.dtype == object
                    else np.zeros(self.num_envs, dtype=value.dtype))
            full[index] = value
            mask = np.zeros(self.num_envs, dtype=bool)
            mask[index] = True
            out[key], out[f"_{key}"] = full, mask
        return out

    def step(self, actions: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray,
                                                 np.ndarray, np.ndarray, dict[str, Any]]:
        """Move every cord's held end(s) by ``clip(actions, -1, 1) * max_step`` (one model
        prediction each), and autoreset the environments whose episodes ended."""
        if not self._started:
            raise RuntimeError("step() needs reset() first")
        a = _check_actions(actions, self.action_space.shape)
        spread = self.cords.step(a, spread=self.uncertainty_penalty > 0)
        self.steps += 1
        restart = np.flatnonzero(self._prev_done)  # next-step autoreset
        tasks = None
        if len(restart):
            tasks = self._autoreset_tasks(len(restart))
            self._begin(restart, tasks)
        shapes = self.cords.shapes_numpy()
        info, reward, solved = self._step_info(shapes, spread)
        terminated = solved.copy()
        truncated = self.steps >= self.max_episode_steps
        obs = self.cords.observe(shapes)
        if tasks is not None:
            reward[restart] = 0.0
            terminated[restart] = truncated[restart] = False
            info.update(self._masked(self._reset_info(tasks), restart))
        done = terminated | truncated
        if self.autoreset_mode == AutoresetMode.SAME_STEP and done.any():
            obs, info = self._same_step_reset(np.flatnonzero(done), obs, info)
            done[:] = False
        self._prev_done = done
        return obs, reward, terminated, truncated, info

    def _same_step_reset(self, ended: np.ndarray, obs: dict[str, np.ndarray],
                         info: dict[str, Any]) -> tuple[dict[str, np.ndarray], dict]:
        final_obs = np.empty(self.num_envs, dtype=object)
        for i in ended:
            final_obs[i] = {k: v[i].copy() for k, v in obs.items()}
        final_info = {k: v.copy() for k, v in info.items()}
        tasks = self._autoreset_tasks(len(ended))
        self._begin(ended, tasks)
        shapes = self.cords.shapes_numpy()
        obs = self.cords.observe(shapes)
        fresh, _, _ = self._step_info(shapes, None)
        info = {**info, **{k: np.where(np.isin(np.arange(self.num_envs), ended), fresh[k],
                                       info[k]) for k in fresh}}
        info.update(self._masked(self._reset_info(tasks), ended))
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[ended] = True
        info.update({"final_obs": final_obs, "_final_obs": mask, "final_info": final_info,
                     "_final_info": mask})
        return obs, info

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One ``(H, W, 3)`` frame per environment (``render_mode="rgb_array"``)."""
        if self.render_mode is None:
            return self._render_one(np.zeros(0), np.zeros(0))
        shapes = self.cords.shapes_numpy()
        return tuple(self._render_one(s, g) for s, g in zip(shapes, self.cords.goals))


class SurrogateCordEnv(_SurrogateArgs, GoalReward, gym.Env[dict[str, np.ndarray], np.ndarray]):
    """One learned cord: a batch of one through the vector environment's step.

    Same arguments as :class:`SurrogateCordVectorEnv` but ``num_envs``,
    ``max_episode_steps`` (``gym.make`` adds its ``TimeLimit``) and ``autoreset_mode``; same
    differences from the pymunk environment. ``reset`` puts the episode's ``Task`` in
    ``info["task"]``, as the pymunk environment does.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 10}
    _batched: ClassVar[bool] = False

    def __init__(self, *, model: TransitionModel | str | None = None, device: str = "auto",
                 params: CordParams | None = None, max_step: float = DEFAULT_MAX_STEP,
                 reward_type: str = "dense", success_threshold: float = SUCCESS_THRESHOLD,
                 success_metric: str = "error", judge_at_rest: bool = True,
                 difficulty: int | tuple[int, ...] = 1, max_pegs: int = 0,
                 uncertainty_penalty: float = 0.0,
                 merge_runs: bool = True, render_mode: str | None = None) -> None:
        self._setup(1, model=model, device=device, params=params, max_step=max_step,
                    reward_type=reward_type, success_threshold=success_threshold,
                    success_metric=success_metric, judge_at_rest=judge_at_rest,
                    difficulty=difficulty, max_pegs=max_pegs,
                    uncertainty_penalty=uncertainty_penalty, merge_runs=merge_runs,
                    render_mode=render_mode)
        self.action_space, self.observation_space = goal_spaces(self.params.n_points,
                                                                len(self.cords.ends))
        self.task: Task | None = None
        self.goal: np.ndarray | None = None
        self._started = False

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start an episode; ``options`` as the pymunk environment's (no pegs)."""
        super().reset(seed=seed)
        tasks = self.cords.tasks_from_options(dict(options or {}), 1, self.np_random,
                                              self.difficulty, self.success_threshold)
        self.cords.start(np.arange(1), tasks.starts)
        self.cords.set_goals(np.arange(1), tasks.goals)
        self.goal = tasks.goals[0].copy()
        self._started = True
        obs, info = self._one(None)
        extra = self._reset_info(tasks)
        k = int(tasks.difficulty[0])
        if tasks.given is not None:
            self.task = tasks.given[0]
        else:
            self.task = Task(start=tasks.starts[0], goal=tasks.goals[0],
                             reference_actions=extra["reference_actions"][0], difficulty=k,
                             seed=-1, grasp=self.grasp, moves=tasks.moves[0, :k],
                             max_step=self.max_step) if k else None
        info.update({"params": self.params, "pegs": (), "task": self.task, "difficulty": k,
                     "task_seed": int(extra["task_seed"][0]),
                     "reference_actions": tuple(extra["reference_actions"][0]),
                     "moves": tuple(extra["moves"][0])})
        return obs, info

    def _one(self, spread: np.ndarray | None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        shapes = self.cords.shapes_numpy()
        obs = {k: v[0] for k, v in self.cords.observe(shapes).items()}
        info, reward, _ = self._step_info(shapes, spread)
        info = {k: (v[0].item() if isinstance(v[0], np.generic) else v[0])
                for k, v in info.items()}
        info["params"] = self.params
        self._reward = float(reward[0])
        return obs, info

    def step(self, action: np.ndarray
             ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Move the held end(s) by ``clip(action, -1, 1) * max_step`` (one model prediction)."""
        if not self._started:
            raise RuntimeError("step() needs reset() first")
        a = _check_actions(action, self.action_space.shape)
        spread = self.cords.step(a[None], spread=self.uncertainty_penalty > 0)
        obs, info = self._one(spread)
        return obs, self._reward, bool(info["is_success"]), False, info

    def settled_metrics(self) -> dict[str, Any]:
        """The errors of the shape at rest, as the pymunk environment's: the cord is always at
        rest here, so those of the current shape, with ``shape`` and ``at_rest`` (True)."""
        if not self._started:
            raise RuntimeError("settled_metrics() needs an episode: call reset() first")
        shape = self.cords.shapes_numpy()[0]
        metrics = goal_metrics(shape, self.cords.goals[0])
        return {**metrics, "shape": shape.copy(), "at_rest": True}

    def render(self) -> np.ndarray | None:
        """An ``(H, W, 3)`` frame of the cord and its goal (``render_mode="rgb_array"``)."""
        if self.render_mode is None or not self._started:
            return self._render_one(np.zeros(0), np.zeros(0)) if self.render_mode is None \
                else None
        return self._render_one(self.cords.shapes_numpy()[0], self.cords.goals[0])


class DLOEndpointSurrogateEnv(SurrogateCordEnv):
    """``dlo_env/DLOEndpointSurrogate-v0``: ``DLOEndpoint-v0`` on the learned cord."""

    grasp: ClassVar[str] = "head"


class DLODualEndpointSurrogateEnv(SurrogateCordEnv):
    """``dlo_env/DLODualEndpointSurrogate-v0``: ``DLODualEndpoint-v0`` on the learned cord."""

    grasp: ClassVar[str] = "both"


class DLOEndpointSurrogateVectorEnv(SurrogateCordVectorEnv):
    """``gym.make_vec("dlo_env/DLOEndpointSurrogate-v0", num_envs=N,
    vectorization_mode="vector_entry_point")``."""

    grasp: ClassVar[str] = "head"


class DLODualEndpointSurrogateVectorEnv(SurrogateCordVectorEnv):
    """``gym.make_vec("dlo_env/DLODualEndpointSurrogate-v0", num_envs=N,
    vectorization_mode="vector_entry_point")``."""

    grasp: ClassVar[str] = "both"
