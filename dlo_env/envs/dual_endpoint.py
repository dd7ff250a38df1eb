"""``dlo_env/DLODualEndpoint-v0``: two grippers hold the head and the tail of the cord."""

from __future__ import annotations

from typing import ClassVar

from dlo_env.cord import Grasp
from dlo_env.envs.goal_env import CordGoalEnv


class DLODualEndpointEnv(CordGoalEnv):
    """
    ## Description

    The cord of `DLOEndpoint-v0` with a gripper on **each end**: the head (point 0) and the
    tail (point 19) move at the same time, each in a straight line per step. Holding both ends
    reaches goals one gripper cannot (e.g. translating the whole cord), but the grippers stay at
    most `max_span * length` (0.9 m) apart: an action that would separate them further is
    shortened symmetrically, so a cord is never pulled taut.

    ## Action Space

    `Box(-1, 1, (4,), float32)` in units of `max_step` (default 0.02 m). Finite out-of-range
    actions are clipped to [-1, 1]; NaN or infinite actions raise `ValueError`. One step is one
    `Cord.move` of both grippers, lasting as many control periods (0.1 s) as the longer of
    the two displacements needs at `max_speed` (0.2 m/s).

    | Num | Action                 | Min | Max |
    |-----|------------------------|-----|-----|
    | 0   | head dx / `max_step`   | -1  | 1   |
    | 1   | head dy / `max_step`   | -1  | 1   |
    | 2   | tail dx / `max_step`   | -1  | 1   |
    | 3   | tail dy / `max_step`   | -1  | 1   |

    ## Observation Space

    A `Dict` of float32 arrays in metres, each a `Box(-1, 1)` (the table):

    | Key             | Shape   | Content                                             |
    |-----------------|---------|-----------------------------------------------------|
    | `observation`   | `(44,)` | points (x, y), head first; head, tail gripper (x, y) |
    |                 | `+3 max_pegs` | with pegs: `max_pegs` centres (x, y), then a mask |
    | `achieved_goal` | `(40,)` | the current shape, flat                             |
    | `desired_goal`  | `(40,)` | the goal shape, flat                                |

    ## Rewards and Success

    As in `DLOEndpoint-v0`: dense `-error` (default) or sparse 0 / -1; success when the cord
    comes to rest with `error <= success_threshold` (0.02 m), judged at rest; `info` holds the
    same keys; `compute_reward` is batched.

    ## Starting State

    A random cord-like shape whose head and tail are less than `max_span * length - 0.02 m`
    apart, settled with both ends held. The goal is the shape after `difficulty` moves, each a
    straight displacement of random direction and length U(5, 30) cm for the head and,
    independently, for the tail (both targets at least 0.1 m inside the table edge and closer
    than the span limit), split into equal actions, followed by zero actions until the cord is at
    rest.

    ## Reset Options

    As in `DLOEndpoint-v0` (`difficulty`, `start`, `goal`, `task`, `params`, `pegs`; pegs as
    there, `max_pegs` and `peg_radius` too); a `start` or `goal` whose
    head-tail distance is not below `max_span * length` raises `ValueError`, and a task must have
    `grasp="both"`. The reset `info` holds `reference_actions` `(T, 4)` (they solve the task
    within `difficulty_max_steps(difficulty)` steps; bitwise replay with `judge_at_rest=False`),
    `moves` `(difficulty, 4)`, `difficulty` and `task_seed`.

    ## Episode End

    Termination on success. Truncation after 100 steps (the registered `max_episode_steps`).

    ## Arguments

    ```python
    env = gym.make(
        "dlo_env/DLODualEndpoint-v0",
        params=None, max_step=0.02, reward_type="dense", success_threshold=0.02,
        judge_at_rest=True, difficulty=1, render_mode=None,
    )
    ```

    ## Version History

    * v0: Initial release. Since dlo 0.2 (2026-11) success is judged at rest;
      `judge_at_rest=False` gives the first rule.
    """

    grasp: ClassVar[Grasp] = "both"
