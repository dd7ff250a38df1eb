"""What the planners need from a model and what they offer a harness, as ``typing.Protocol``s.

A planner plans on a :class:`ShapeSurrogate` (``latent_model.ShapeModel`` is one; so is any toy
model with the same four members). Every agent is a :class:`Policy`, the interface of
Stable-Baselines3 models, so one harness drives planners and RL models alike. An agent that
plans is also a :class:`PlanningPolicy`: the harness resets it at every episode start and asks
it for its :class:`EpisodeStats`, never for its internals. A tree planner's result is a
:class:`Plan`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from dlo_env.core.deprecation import renamed_field


@renamed_field("end", "grasp")
@dataclass(frozen=True)
class Plan:
    """A planned shape transition: the decoded path and the end's straight moves.

    The manipulated end moves in straight lines between the positions it has at the path's
    nodes; every planned shape has the end position (waypoint) at which it is predicted. With
    both ends held (``grasp="both"``) every end array gains an ends axis (head first) and both
    ends move at once, each in a straight line.

    Attributes:
        shapes: ``(T, n, 2)`` decoded shapes along the path, metres (``shapes[0]`` decodes the
            inverted start).
        latents: ``(T, d)`` their latents.
        waypoints: ``(T, 2)`` position of the manipulated end for each shape (``(T, 2, 2)``
            with both ends), metres; on the
            straight line of its edge, anchored at the real start (and, on success, real goal)
            end position.
        nodes: ``(K,)`` indices into ``shapes`` of the path's nodes (first 0, last T-1): the
            corners of the end's path.
        success: Whether the path reaches the goal (within ``goal_threshold``).
        stats: What the search did: ``nodes``, ``decoder_calls``, ``seconds``, ``iterations``,
            inversion errors, rejection counts per check, ``direct`` (one straight move).
        grasp: The manipulated end(s): ``"head"``, ``"tail"`` or ``"both"``.
    """

    shapes: np.ndarray
    latents: np.ndarray
    waypoints: np.ndarray
    nodes: np.ndarray
    success: bool
    stats: dict[str, Any] = field(default_factory=dict)
    grasp: str = "head"

    @property
    def corners(self) -> np.ndarray:
        """``(K, 2)`` end positions at the nodes (``(K, 2, 2)`` with both ends): the end moves
        straight from one to the next."""
        return self.waypoints[self.nodes]

    @property
    def moves(self) -> np.ndarray:
        """``(K - 1, 2)`` straight displacements of the end (``(K - 1, 2, 2)`` with both),
        metres."""
        return np.diff(self.corners, axis=0)

    @property
    def path_length(self) -> float:
        """Total distance the end travels (both ends: summed), metres."""
        return float(np.linalg.norm(self.moves, axis=-1).sum())


#: A ``dlo_env`` goal observation: ``observation``, ``achieved_goal``, ``desired_goal`` arrays.
Observation = dict[str, np.ndarray]


@runtime_checkable
class ShapeSurrogate(Protocol):
    """A generative shape model the latent planners can plan on.

    Attributes:
        n_points: Points of the decoded shapes.
        latent_dim: Dimension of the latents.
    """

    n_points: int
    latent_dim: int

    def decode(self, latents: Any) -> Any:
        """Shapes ``(B, n, 2)`` (numpy or torch) of latents ``(B, d)``."""

    def invert(self, shapes: Any) -> tuple[Any, Any, Any]:
        """Latents ``(B, d)``, reconstruction errors ``(B,)`` in metres, verified flags ``(B,)``."""


@runtime_checkable
class Policy(Protocol):
    """Anything that acts in a ``dlo_env`` environment: SB3's ``predict`` signature."""

    def predict(
        self,
        observation: Observation,
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """The next action (and the recurrent state, passed through by the planners)."""


@dataclass(frozen=True)
class EpisodeStats:
    """What a planning policy reports about the episode under way.

    Attributes:
        plans: Planning calls so far.
        failures: Plans that did not reach the goal.
        seconds: Time spent planning (inversions included), seconds.
        goal_inversion_error: ``error`` of the decoded goal inversion, metres (NaN if the
            policy does not invert the goal).
        first_plan: The plan made from the episode's start, if the policy makes latent plans
            (its transition fidelity is measured against the simulator).
        latest_plan: The plan being executed now (drawn as ghosts in episode GIFs).
    """

    plans: int = 0
    failures: int = 0
    seconds: float = 0.0
    goal_inversion_error: float = math.nan
    first_plan: Plan | None = None
    latest_plan: Plan | None = None


@runtime_checkable
class PlanningPolicy(Policy, Protocol):
    """A policy that plans: reset per episode, reports its statistics, checks its environment."""

    def reset(self) -> None:
        """Forget the episode under way."""

    def episode_stats(self) -> EpisodeStats:
        """Statistics of the episode under way."""

    def check_env(self, env: Any) -> None:
        """Raise ``ValueError`` when the policy was not made for ``env`` (cord, step, grasp)."""
