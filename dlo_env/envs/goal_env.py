"""The goal-conditioned cord environment shared by the endpoint environments.

Follows Gymnasium-Robotics' ``GoalEnv`` convention (a Dict observation with ``observation``,
``achieved_goal`` and ``desired_goal``; ``compute_reward`` works on batches and ``step`` calls
it, so hindsight relabelling is exact) without depending on Gymnasium-Robotics. Subclasses only
choose the grasp and carry the documentation.
"""

from __future__ import annotations

import pickle
from dataclasses import replace
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from dlo_env.cord import (
    PEG_RADIUS,
    Cord,
    CordParams,
    Grasp,
    check_not_crossing,
    check_pegs,
)
from dlo_env.core.checks import all_finite
from dlo_env.envs.goal_api import (
    GoalReward,
    check_goal_args,
    check_task,
    goal_metrics,
    goal_spaces,
    option_difficulty,
)
from dlo_env.envs.step_info import StepInfo
from dlo_env.errors import InputError
from dlo_env.randomize import check_params, check_randomize, draw_params
from dlo_env.shapes import (
    SUCCESS_METRICS,
    at_segment_length,
    validate_shape,
)
from dlo_env.tasks import (
    DEFAULT_MAX_STEP,
    GRASP_ENDS,
    REST_CHECK_MARGIN,
    REST_SPEED,
    SUCCESS_THRESHOLD,
    Task,
    action_moves,
    at_rest,
    check_difficulty,
    make_task,
    random_start,
    wait_for_rest,
)

_OPTIONS = ("difficulty", "start", "goal", "task", "params", "pegs")


def _copy(cord: Cord) -> Cord:
    """A copy of ``cord`` that continues exactly as ``copy.deepcopy(cord)`` would (pymunk's own
    pickling of the space: bodies, contacts, no cached joint impulses), at under half its
    cost."""
    return pickle.loads(pickle.dumps(cord, pickle.HIGHEST_PROTOCOL))


class CordGoalEnv(GoalReward, gym.Env[dict[str, np.ndarray], np.ndarray]):
    """Move the grasped end(s) of a cord on a table until its shape matches a goal shape.

    See :class:`dlo_env.envs.endpoint.DLOEndpointEnv` for the full documentation.

    Args:
        params: Cord parameters (the default cord if None): every episode's cord unless
            ``randomize`` or ``options["params"]`` says otherwise.
        max_step: Gripper displacement of an action of 1.0 on one axis, metres.
        reward_type: ``"dense"`` (``-error``) or ``"sparse"`` (0 within the threshold, moving
            or not, else -1).
        success_threshold: Success when ``error(cord, goal)`` is at most this, metres.
        success_metric: ``"error"`` (default) or ``"direction_free_error"`` (a designed goal
            whose ends may swap): what success and the reward measure.
        judge_at_rest: Judge success on the cord at rest (default): a step succeeds when the
            cord, if the grippers stopped now, comes to rest within ``success_threshold``; the
            step then lets it come to rest. False: the earlier rule, the moving cord within
            ``success_threshold``.
        difficulty: Straight moves between start and goal when ``reset`` draws a task (1-10).
        randomize: Cord parameter -> ``(low, high)``: each episode's cord is ``params`` with
            these drawn from the environment's ``np_random`` (``dlo_env.randomize``).
        max_pegs: Most pegs on the table (0, the default: none, and the observation of an
            empty table). A drawn task places 0 to ``max_pegs`` pegs near its start, and the
            observation holds ``max_pegs`` peg slots (centres, then a mask).
        peg_radius: Radius of every peg, metres.
        peg_friction: Friction coefficient between the cord and the pegs: every episode's cord
            with ``CordParams.peg_friction`` set, also one of ``options["params"]`` (None:
            each cord's own, 0 for the default cord: frictionless pegs).
        render_mode: ``None``, ``"rgb_array"`` or ``"human"``.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human", "rgb_array"], "render_fps": 10}
    #: The ends the grippers hold; subclasses choose.
    grasp: ClassVar[Grasp] = "head"

    def __init__(
        self,
        *,
        params: CordParams | None = None,
        max_step: float = DEFAULT_MAX_STEP,
        reward_type: str = "dense",
        success_threshold: float = SUCCESS_THRESHOLD,
        success_metric: str = "error",
        judge_at_rest: bool = True,
        difficulty: int = 1,
        randomize: dict[str, tuple[float, float]] | None = None,
        max_pegs: int = 0,
        peg_radius: float = PEG_RADIUS,
        peg_friction: float | None = None,
        render_mode: str | None = None,
    ) -> None:
        check_goal_args(params=params, max_step=max_step, reward_type=reward_type,
                        success_threshold=success_threshold, success_metric=success_metric,
                        judge_at_rest=judge_at_rest, max_pegs=max_pegs, render_mode=render_mode,
                        render_modes=self.metadata["render_modes"])
        self.params = params if params is not None else CordParams()
        #: The pegs' friction the environment was made with (None: each cord's own).
        self._peg_friction = peg_friction
        if peg_friction is not None:
            self.params = replace(self.params, peg_friction=peg_friction)
        self.max_step = float(max_step)
        self.reward_type = reward_type
        self.success_threshold = float(success_threshold)
        self.judge_at_rest = bool(judge_at_rest)
        self.success_metric = success_metric
        self._distance = SUCCESS_METRICS[success_metric]
        self.difficulty = check_difficulty(difficulty)
        #: Cord parameter -> (low, high) drawn every episode (empty: always ``params``).
        self.randomize = check_randomize(randomize) if randomize is not None else {}
        self.render_mode = render_mode

        self.max_pegs = int(max_pegs)
        self.cord = Cord(self.params, grasp=self.grasp, peg_radius=peg_radius)
        self.peg_radius = self.cord.peg_radius
        self._ends = GRASP_ENDS[self.grasp]
        self._pegs_obs = np.zeros(3 * self.max_pegs, dtype=np.float32)
        self.action_space, self.observation_space = goal_spaces(
            self.params.n_points, len(self._ends), self.max_pegs)
        #: The current task (``None`` when the goal was given without reference moves).
        self.task: Task | None = None
        self.goal: np.ndarray | None = None
        self._goal_flat: np.ndarray | None = None
        self._renderer = None

    # ----------------------------------------------------------------- gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start an episode; see the class documentation for ``options``."""
        super().reset(seed=seed)
        start, goal, task, params, pegs = self._episode(dict(options or {}))
        if params != self.cord.params:
            self.cord = Cord(params, grasp=self.grasp, peg_radius=self.peg_radius)
        self.task = task
        self.goal = goal
        self._goal_flat = goal.reshape(-1)
        self.cord.set_pegs(pegs)
        self._pegs_obs[:] = 0.0
        self._pegs_obs[: 2 * len(pegs)] = pegs.reshape(-1)
        self._pegs_obs[2 * self.max_pegs: 2 * self.max_pegs + len(pegs)] = 1.0
        self.cord.reset(start)
        shape, speed = self.cord.shape_and_speed()
        obs, info = self._observe(shape, speed,
                                  self._distance(shape, self._goal_flat.reshape(-1, 2)))
        info["settle_actions"] = 0
        info["params"] = self.cord.params
        info["pegs"] = tuple(np.array(pegs, dtype=np.float32))  # copies: the task keeps its own
        # Tuples, not (T, dim) arrays: their length varies per episode, and Gymnasium's vector
        # envs stack equal-shape arrays but keep other objects as they are.
        info["task"] = task
        info["difficulty"] = task.difficulty if task is not None else 0
        info["task_seed"] = task.seed if task is not None else -1
        info["reference_actions"] = tuple(task.reference_actions) if task is not None else ()
        info["moves"] = tuple(task.moves) if task is not None else ()
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(
        self, action: np.ndarray
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Move the held end(s) by ``clip(action, -1, 1) * max_step`` metres (one ``Cord.move``).

        With ``judge_at_rest`` (the default), a step whose cord would come to rest within
        ``success_threshold`` if the grippers stopped now also waits until it is at rest
        (``info["settle_actions"]`` zero actions, at most ``MAX_SETTLE_ACTIONS``) and ends the
        episode solved: the returned shape is the one at rest.

        Raises:
            ValueError: If ``action`` has the wrong shape or is not finite.
        """
        a = np.asarray(action, dtype=np.float64)  # clipped before float32: 1e39 is finite
        if a.shape != self.action_space.shape:
            raise InputError(f"action must have shape {self.action_space.shape}, got {a.shape}")
        if not all_finite(a):
            raise InputError(f"action must be finite, got {a.tolist()}")
        # minimum/maximum: np.clip's arithmetic on finite values, without its call overhead.
        clipped = np.minimum(np.maximum(a, -1.0), 1.0).astype(np.float32)
        # ``apply_action``'s move, read out from the move's own last read of the bodies; that
        # read-out and one distance to the goal serve the judging and the observation (a
        # settled cord is read again).
        shape, speed = self.cord.move_and_read(
            **action_moves(self.cord.grasp, clipped, self.max_step))
        distance = self._distance(shape, self._goal_flat.reshape(-1, 2))
        settle = self._settle_if_solved(shape, speed, distance) if self.judge_at_rest else 0
        if settle:
            shape, speed = self.cord.shape_and_speed()
            distance = self._distance(shape, self._goal_flat.reshape(-1, 2))
        obs, info = self._observe(shape, speed, distance)
        info["settle_actions"] = settle
        info["params"] = self.cord.params
        reward = float(self.compute_reward(obs["achieved_goal"], obs["desired_goal"], info))
        if self.render_mode == "human":
            self.render()
        return obs, reward, bool(info["is_success"]), False, info

    def _settle_if_solved(self, shape: np.ndarray, speed: float, distance: float) -> int:
        """Zero actions until the cord is at rest, when it would come to rest within the
        threshold; the number taken (0 when it is at rest already or would rest outside).

        ``distance`` is the success metric of ``shape``, the cord's shape moving at ``speed``.
        A copy judges first, so a cord that would not rest within the threshold goes on
        undisturbed; the cord itself then takes the zero actions, exactly as an agent sending
        them would (a copy continues close to, not bitwise like, the original).
        """
        if speed < REST_SPEED or distance > self.success_threshold + REST_CHECK_MARGIN:
            return 0
        goal = self._goal_flat.reshape(-1, 2)
        trial = _copy(self.cord)
        wait_for_rest(trial, self.max_step)
        if not (at_rest(trial) and self._distance(trial.shape, goal) <= self.success_threshold):
            return 0
        return wait_for_rest(self.cord, self.max_step)

    def settled_metrics(self) -> dict[str, float]:
        """The error metrics of the shape the cord comes to rest in if the grippers stop now.

        Simulates a copy of the cord (zero actions until it is at rest, at most
        ``MAX_SETTLE_ACTIONS``); the episode goes on unchanged. ``evaluate`` records it after an
        episode's last step.

        Returns:
            ``error``, ``max_error``, ``direction_free_error`` and ``bead_share`` of the shape
            at rest, ``shape`` (float32 ``(n, 2)``, the shape itself) and ``at_rest`` (False
            when the cord still moves after the zero actions).
        """
        if self.cord.space is None or self._goal_flat is None:
            raise RuntimeError("settled_metrics() needs an episode: call reset() first")
        cord = self.cord if at_rest(self.cord) else _copy(self.cord)
        if cord is not self.cord:
            wait_for_rest(cord, self.max_step)
        shape = cord.shape
        metrics = goal_metrics(shape, self._goal_flat.reshape(-1, 2))
        metrics["shape"] = np.asarray(shape, dtype=np.float32).copy()
        metrics["at_rest"] = at_rest(cord)
        return metrics

    def _observe(self, shape: np.ndarray, speed: float, distance: float
                 ) -> tuple[dict[str, np.ndarray], StepInfo]:
        # ``shape`` and ``speed``: the cord's ``shape_and_speed()``; ``distance``: the success
        # metric of ``shape``. The errors in ``info`` are computed when read.
        flat = shape.reshape(-1)
        n2 = flat.shape[0]
        size = n2 + 2 * len(self._ends)
        observation = np.empty(size + len(self._pegs_obs), dtype=np.float32)
        observation[:n2] = flat
        for i, end in enumerate(self._ends):
            observation[n2 + 2 * i : n2 + 2 * i + 2] = self.cord.grippers[end].position
        observation[size:] = self._pegs_obs
        goal = self._goal_flat
        resting = speed < REST_SPEED
        solved = distance <= self.success_threshold
        # ``shape`` is copied: ``achieved_goal`` is a view of it, which the caller may change.
        kept = shape.copy()
        info = StepInfo({"is_success": solved and (resting or not self.judge_at_rest),
                         "at_rest": resting},
                        lambda: goal_metrics(kept, goal.reshape(-1, 2)))
        obs = {"observation": observation, "achieved_goal": flat, "desired_goal": goal.copy()}
        return obs, info

    # ----------------------------------------------------------------- options
    def _shape_option(self, options: dict, name: str, p: CordParams,
                      pegs: np.ndarray) -> np.ndarray:
        """``options[name]`` checked as the cord it gives: the start as ``Cord.reset`` lays it
        out (``at_segment_length``), the goal as given."""
        shape = validate_shape(options[name], n_points=p.n_points, length=p.length, name=name)
        cord = at_segment_length(shape, p.segment) if name == "start" else shape
        if self.grasp == "both":
            span = float(np.linalg.norm(cord[-1] - cord[0]))
            if span >= p.max_span * p.length:
                raise InputError(
                    f"{name} must have its head and tail closer than max_span * length = "
                    f"{p.max_span * p.length:.3f} m when both ends are held, got {span:.3f} m"
                )
        check_not_crossing(cord, pegs, self.peg_radius, f"options['{name}']")
        return shape

    def _episode_params(self, options: dict) -> CordParams:
        """The episode's cord: ``options["params"]``, a draw (only when randomising), or the
        environment's. A given task, start or goal keeps its own length."""
        if "params" in options:
            params = check_params(options.pop("params"), self.params)
            # the environment's pegs keep their friction when a task brings its cord
            return (params if self._peg_friction is None
                    else replace(params, peg_friction=self._peg_friction))
        if not self.randomize:
            return self.params
        params = draw_params(self.params, self.randomize, self.np_random)
        given = [options[k] for k in ("task", "start", "goal") if k in options]
        if "length" in self.randomize and given:
            shape = given[0].start if isinstance(given[0], Task) else given[0]
            try:
                points = np.asarray(shape, dtype=np.float64).reshape(-1, 2)
                length = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
                params = replace(params, length=length)
            except (TypeError, ValueError):
                pass  # the shape's own check says what is wrong with it
        return params

    @property
    def pegs(self) -> np.ndarray:
        """``(k, 2)`` centres of this episode's pegs, metres (``(0, 2)``: none)."""
        return self.cord.pegs.astype(np.float32)

    def _pegs_option(self, options: dict) -> np.ndarray | None:
        if "pegs" not in options:
            return None
        pegs = check_pegs(options["pegs"], "options['pegs']",
                          radius=self.peg_radius).astype(np.float32)
        if len(pegs) > self.max_pegs:
            raise InputError(f"options['pegs'] holds {len(pegs)} pegs, more than this "
                             f"environment observes: make it with gym.make(id, max_pegs="
                             f"{len(pegs)}) (max_pegs={self.max_pegs})")
        return pegs

    def _episode(self, options: dict
                 ) -> tuple[np.ndarray, np.ndarray, Task | None, CordParams, np.ndarray]:
        difficulty = option_difficulty(options, _OPTIONS, self.difficulty)
        # The episode's cord first, then its task; the env's cord changes only once every
        # option has passed (a refused reset leaves the environment as it was).
        p = self._episode_params(options)
        pegs = self._pegs_option(options)
        if "task" in options:
            task = self._check_task(options["task"], p)
            return task.start, task.goal, task, p, task.pegs
        given = pegs if pegs is not None else np.zeros((0, 2), dtype=np.float32)
        start, goal = (self._shape_option(options, name, p, given) if name in options else None
                       for name in ("start", "goal"))
        if goal is not None and start is not None:
            return start, goal, None, p, given
        seed = int(self.np_random.integers(2**31 - 1))
        if goal is not None:  # a start clear of the pegs
            cord = Cord(p, grasp=self.grasp, pegs=given, peg_radius=self.peg_radius)
            return random_start(seed, self.grasp, cord=cord), goal, None, p, given
        # A drawn task: the pegs given, or 0 to max_pegs drawn near its start.
        count = int(self.np_random.integers(self.max_pegs + 1)) if self.max_pegs else None
        task = make_task(seed, difficulty, self.grasp, params=p, max_step=self.max_step,
                         start=start, min_error=self.success_threshold,
                         pegs=pegs if pegs is not None else count, peg_radius=self.peg_radius)
        return task.start, task.goal, task, p, task.pegs

    def _check_task(self, task: object, p: CordParams) -> Task:
        task = check_task(task, self.grasp, self.max_step)
        if len(task.pegs) > self.max_pegs:
            raise InputError(f"options['task'] has {len(task.pegs)} pegs, more than this "
                             f"environment observes: make it with gym.make(id, max_pegs="
                             f"{len(task.pegs)}) (max_pegs={self.max_pegs})")
        if len(task.pegs) and task.peg_radius != self.peg_radius:
            raise InputError(f"options['task'] was made with peg_radius {task.peg_radius}, "
                             f"this environment uses {self.peg_radius}")
        check_pegs(task.pegs, "options['task'].pegs", radius=self.peg_radius)
        for name in ("start", "goal"):
            validate_shape(getattr(task, name), n_points=p.n_points, length=p.length,
                           name=f"options['task'].{name}")
        return task

    # ----------------------------------------------------------------- rendering
    def render(self) -> np.ndarray | None:
        """Draw the table, the goal (ghost), the cord and the grippers.

        Returns:
            An ``(H, W, 3)`` uint8 image in ``"rgb_array"`` mode, else None.
        """
        if self.render_mode is None:
            gym.logger.warn(
                "render() was called without a render_mode; pass render_mode='rgb_array' or "
                "'human' to the constructor (gym.make(..., render_mode='rgb_array'))."
            )
            return None
        if self._renderer is None:
            from dlo_env.rendering import CordRenderer

            self._renderer = CordRenderer(self.render_mode, fps=round(1.0 / self.cord.params.dt))
        grippers = [self.cord.grippers[e].position for e in self._ends] if self.cord.space else []
        shape = self.cord.shape if self.cord.space is not None else None
        return self._renderer.draw(shape, self.goal, grippers, pegs=self.cord.pegs,
                                   peg_radius=self.peg_radius)

    def close(self) -> None:
        """Close the render window, if any; safe to call more than once."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # ----------------------------------------------------------------- pickling
    def __getstate__(self) -> dict[str, Any]:
        # The cord pickles its pymunk space (see Cord.__getstate__); a window does not pickle.
        state = self.__dict__.copy()
        state["_renderer"] = None
        return state
