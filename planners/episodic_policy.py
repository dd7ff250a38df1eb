"""Episodes and batches for every planner policy: one mechanism, in one base class.

A planner keeps state across steps (a plan being executed, a warm start, a goal's latent).
Stable-Baselines3's loop tells a policy where an episode starts (``episode_start``), but a plain
loop does not::

    obs, info = env.reset()
    while True:
        action, _ = policy.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = env.step(action)
        ...

so a planner must notice a new episode itself. :class:`EpisodicPolicy` resets the policy
before acting when

- ``episode_start`` is true for its environment (SB3's signal), or
- the goal changed (every ``reset`` of a task draws a new goal), or
- a held gripper moved farther than one action can move it (:func:`gripper_reach`): the cord
  was reset, even to the same goal.

Only an episode with the last one's goal whose gripper starts within ``gripper_reach`` of where
it stopped looks like a continuation; pass ``episode_start`` (or call ``reset()``) there. An
observation without the grippers (only ``achieved_goal`` and ``desired_goal``) is checked by the
goal and by the cord jumping farther than :data:`JUMP_ERROR` (mean point distance) in one step.

A vector env (``gym.make_vec``, SB3's ``VecEnv``) passes a batch with one row per environment.
The policy then keeps one copy of its episode state per environment (:attr:`env_policies`; the
models and planners are shared, not copied) and plans for each environment in turn, one at a
time: the actions come back as a ``(B, action_dim)`` batch. The copies are shallow, so a
subclass's ``reset()`` must create anew every attribute an episode changes; everything else
(models, planners, configs, scratch simulators used within one call) is shared.
"""

from __future__ import annotations

import copy
import functools
import math
from dataclasses import replace
from typing import Any

import numpy as np

from dlo_env.cord import CordParams
from dlo_env.errors import InputError
from dlo_env.shapes import error
from planners.interfaces import Observation
from planners.observation import CordObservation, read_observation, split_batch

#: Goals whose coordinates differ by at most this are one goal, metres (float32 rounding).
GOAL_TOLERANCE = 1e-6
#: Slack on the farthest one action moves a gripper, metres (float32 rounding).
GRIPPER_SLACK = 1e-5
#: Without gripper positions: a cord whose mean point distance to the last observation exceeds
#: this was reset, metres. Random full-speed steps move it at most about 9 cm with both ends
#: held (``tests/planners/test_episodes.py`` checks the bound); a reset to another start
#: moves it 15 cm or more.
JUMP_ERROR = 0.12


def gripper_reach(max_step: float, params: CordParams | None = None) -> float:
    """The farthest one action can move a held gripper, metres: the rule of ``Cord.move``.

    An action moves each gripper by at most ``max_step`` per axis. Its target is clipped to
    the table less ``rim_margin`` (after a reset a gripper may sit up to ``rim_margin`` outside
    that square, so one step can pull it in by as much), and with both ends held a pair
    farther apart than ``max_span * length`` is pulled towards its middle, by at most the
    half of what the two moves added to the gap. Together: ``2 * sqrt(2) * (max_step +
    rim_margin)``.
    """
    rim = params.rim_margin if params is not None else CordParams.rim_margin  # the default's
    return 2.0 * math.sqrt(2.0) * (max_step + rim) + GRIPPER_SLACK


def _starts(episode_start: Any, size: int) -> np.ndarray:
    """``episode_start`` as ``size`` booleans (None: all false; one value: for every row)."""
    if episode_start is None:
        return np.zeros(size, dtype=bool)
    starts = np.asarray(episode_start, dtype=bool).reshape(-1)
    if starts.size == 1:
        return np.repeat(starts, size)
    if starts.size != size:
        raise InputError(f"episode_start must hold one flag per environment ({size}), got "
                         f"{starts.size}")
    return starts


class EpisodicPolicy:
    """Base of the planner policies: SB3's ``predict`` with episodes noticed and batches split.

    A subclass sets ``max_step`` (metres per unit action), implements ``reset()`` (forget the
    episode) and ``_act(obs) -> action`` for one environment's :class:`CordObservation`, and
    may set ``n_points`` (the cord its model was made for; otherwise the observation's).

    The copies a batch makes are shallow: ``reset()`` must create anew every attribute that an
    episode changes.
    """

    max_step: float
    n_points: int | None = None
    #: The cord's parameters where the policy knows them (``gripper_reach`` uses its rim).
    params: CordParams | None = None
    #: The environment's ``success_metric``. With ``"direction_free_error"`` (a drawn goal
    #: does not say which end is the head) the policy aims at the goal in the order nearer
    #: the cord at the episode's first step, for the whole episode; ``build_agent`` and the
    #: CEM planners' ``for_env`` set it from the environment (set it yourself otherwise).
    success_metric: str = "error"
    #: The environment the policy was built for: its id and the size of its
    #: ``observation["observation"]`` (``build_agent`` sets them). An observation of another
    #: size (the other environment, another number of peg slots) is refused in one line.
    built_for: tuple[str, int] | None = None
    #: Whether ``predict`` takes a batch of several environments (one plan per row); a
    #: policy tied to one environment says False (``planners.PerEnvPolicy`` then serves a
    #: vector env).
    plans_batches: bool = True

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A subclass's ``reset()`` also forgets the goal order chosen for the episode."""
        super().__init_subclass__(**kwargs)
        own = cls.__dict__.get("reset")
        if own is None or getattr(own, "_forgets_goal_order", False):
            return

        @functools.wraps(own)
        def reset(self: EpisodicPolicy, *args: Any, **kw: Any) -> Any:
            self._reversed_goal = None
            return own(self, *args, **kw)

        reset._forgets_goal_order = True  # type: ignore[attr-defined]
        cls.reset = reset  # type: ignore[method-assign]

    @property
    def env_policies(self) -> list[EpisodicPolicy]:
        """The copies that hold each environment's episode after a batch of B > 1 (their
        ``episode_stats()`` report it), in the batch's order; empty before any batch."""
        return getattr(self, "_env_policies", [])

    # ------------------------------------------------------------------ to override
    def reset(self) -> None:
        """Forget the episode under way."""
        raise NotImplementedError

    def _act(self, obs: CordObservation) -> np.ndarray:
        """The next action for one environment's observation, ``(action_dim,)`` float32."""
        raise NotImplementedError

    # ------------------------------------------------------------------ episodes
    def _new_episode(self, obs: CordObservation) -> bool:
        """Whether ``obs`` cannot follow the last observation seen in the same episode."""
        last: CordObservation | None = getattr(self, "_last_seen", None)
        if last is None or last.shape.shape != obs.shape.shape:
            return last is not None
        if float(np.abs(obs.goal - last.goal).max()) > GOAL_TOLERANCE:
            return True
        if len(obs.grippers) and obs.grippers.shape == last.grippers.shape:
            reach = gripper_reach(self.max_step, self.params)
            return bool((np.linalg.norm(obs.grippers - last.grippers, axis=1) > reach).any())
        return float(error(obs.shape, last.shape)) > JUMP_ERROR

    def _step(self, observation: Observation, start: bool) -> np.ndarray:
        """One environment's action: reset first when its episode is new."""
        if self.built_for is not None and "observation" in observation:
            env_id, size = self.built_for
            got = np.asarray(observation["observation"]).size
            if got != size:
                raise InputError(
                    f"observation['observation'] has {got} numbers, but this policy was built "
                    f"for {env_id}, which observes {size}: build the agent with the "
                    "environment it acts in (a suite's: gym.make(id, "
                    "**dlo_bench.evaluation.task_env_kwargs(suite=...)))")
        n = self.n_points
        if n is None:
            n = np.asarray(observation["achieved_goal"]).reshape(-1).size // 2
        obs = read_observation(observation, n)
        if start or self._new_episode(obs):
            self.reset()
        self._last_seen = obs
        if self.success_metric == "direction_free_error":
            if getattr(self, "_reversed_goal", None) is None:
                self._reversed_goal = bool(error(obs.shape, obs.goal[::-1])
                                           < error(obs.shape, obs.goal))
            if self._reversed_goal:
                obs = replace(obs, goal=np.ascontiguousarray(obs.goal[::-1]))
        return np.clip(np.asarray(self._act(obs), dtype=np.float32), -1.0, 1.0)

    def _copies(self, size: int) -> list[EpisodicPolicy]:
        """``size`` policies sharing this one's models, each with its own episode state."""
        copies = self.env_policies
        if len(copies) != size:
            copies = []
            for _ in range(size):
                twin = copy.copy(self)  # shallow: models, planners and configs are shared
                twin._env_policies = []
                twin._last_seen = None
                twin._reversed_goal = None
                twin.reset()
                copies.append(twin)
            self._env_policies = copies
        return copies

    # ------------------------------------------------------------------ SB3 interface
    def predict(
        self,
        observation: Observation,
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """The next action(s), SB3's signature.

        Args:
            observation: A ``dlo_env`` goal observation (Dict of flat arrays), or a batch of
                them with a leading axis (SB3, ``gym.make_vec``).
            state: Passed through (the policy keeps its own episode state).
            episode_start: Optional, one flag per environment: true resets that environment's
                episode first (as SB3 passes). Without it a new episode is noticed by its goal
                or by the cord jumping (see the module's docstring).
            deterministic: Ignored (a plan is a function of the observation and the seed).

        Returns:
            ``(action, state)``: float32 ``(action_dim,)`` for an unbatched observation,
            ``(B, action_dim)`` for a batch of B.
        """
        rows, batched = split_batch(observation)
        starts = _starts(episode_start, len(rows))
        if len(rows) == 1:
            action = self._step(rows[0], bool(starts[0]))
            return (action[None] if batched else action), state
        actions = [twin._step(row, bool(start))
                   for twin, row, start in zip(self._copies(len(rows)), rows, starts)]
        return np.stack(actions), state
