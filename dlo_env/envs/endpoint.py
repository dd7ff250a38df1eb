"""``dlo_env/DLOEndpoint-v0``: one gripper holds the head of the cord."""

from __future__ import annotations

from typing import ClassVar

from dlo_env.cord import Grasp
from dlo_env.envs.goal_env import CordGoalEnv


class DLOEndpointEnv(CordGoalEnv):
    """
    ## Description

    A cord (1 m, 20 points, default `CordParams`) lies on a 2 m x 2 m table, seen from above.
    A gripper holds its **head** (point 0) and moves it in straight steps; table friction and
    the cord's bending stiffness decide how the rest follows. The goal is a cord shape made
    from the start by `difficulty` random straight head moves in the same simulator, so every
    goal is reachable. Difficulty 1 is the experiment of *Generating Shape Transitions of
    Deformable Linear Objects Using GANs* (one straight endpoint displacement); because friction
    makes the result depend on the path, higher difficulties need planning.

    ## Action Space

    `Box(-1, 1, (2,), float32)`: the head gripper's displacement in units of `max_step`
    (default 0.02 m). Finite out-of-range actions are clipped to [-1, 1]; NaN or infinite
    actions raise `ValueError`. One step is one `Cord.move`: the gripper moves in a straight line
    at most `max_speed` (0.2 m/s), i.e. one control period (0.1 s) when the displacement is at
    most 0.02 m, two for a full diagonal action.

    | Num | Action                       | Min | Max |
    |-----|------------------------------|-----|-----|
    | 0   | head dx / `max_step`         | -1  | 1   |
    | 1   | head dy / `max_step`         | -1  | 1   |

    ## Observation Space

    A `Dict` of float32 arrays in metres, each a `Box(-1, 1)` (the table):

    | Key             | Shape   | Content                                             |
    |-----------------|---------|-----------------------------------------------------|
    | `observation`   | `(42,)` | points (x, y), head first; then head gripper (x, y) |
    |                 | `+3 max_pegs` | with pegs: `max_pegs` centres (x, y), then a mask |
    | `achieved_goal` | `(40,)` | the current shape, flat (x0, y0, x1, y1, ...)       |
    | `desired_goal`  | `(40,)` | the goal shape, flat                                |

    ## Rewards

    `error` is the mean over points of the distance between the cord and the goal (metres).
    Dense (default): `-error`. Sparse (`reward_type="sparse"`): 0 when `error` is within the
    threshold (moving or not: success also needs the cord at rest), else -1.
    `env.unwrapped.compute_reward(achieved_goal, desired_goal, info)` gives the same numbers for
    any batch of goals (the step reward is computed by it), ready for hindsight relabelling.

    ## Success

    Judged on the cord at rest. A step succeeds when the cord, if the gripper stopped now, would
    come to rest with `error <= success_threshold` (default 0.02 m, 2 % of the cord length); the
    step then waits until it is at rest (`info["settle_actions"]` zero actions, at most 10), so
    the observation of a solved step is the cord at rest. A cord that only passes through the
    goal does not count. An agent never has to stop on its own, and may send zero actions (each
    waits one control period). `judge_at_rest=False` restores the earlier rule: the moving cord
    within the threshold.

    `info` always holds `is_success` (bool), `at_rest` (every point slower than 1 mm/s),
    `settle_actions`, `params` (the episode's `CordParams`), and the errors of the returned
    shape: `error`, `max_error` (largest per-point distance), `direction_free_error` (the
    smaller of the errors to the goal and to the reversed goal) and `bead_share` (share of
    points within 1.75 cm of the goal polyline), metres, computed when first read.
    `env.unwrapped.settled_metrics()` gives the same errors for the shape the cord would come to
    rest in now, without changing the episode.

    ## Starting State

    A random smooth cord-like shape (`random_cord_shape`) settled in the simulator with the
    head held (a rest state). The goal is the shape after `difficulty` straight head moves of
    random direction and length U(5, 30) cm (targets at least 0.1 m inside the table edge),
    each split into equal actions of at most `max_step`, followed by zero actions until the
    cord is at rest. Goals are always more than `success_threshold` away from the start.

    ## Reset Options

    | Option       | Value                  | Effect                                      |
    |--------------|------------------------|---------------------------------------------|
    | `difficulty` | int 1-10               | straight moves from start to goal           |
    | `start`      | `(20, 2)` or `(40,)`   | start there (not settled); goal made from it |
    | `goal`       | `(20, 2)` or `(40,)`   | this goal; random start; no reference moves |
    | `task`       | `dlo_env.tasks.Task`   | its start and goal (combines with `params`)  |
    | `params`     | `dlo_env.CordParams`   | this episode's cord (same `n_points`)       |
    | `pegs`       | `(k, 2)`, k <= max_pegs | these pegs instead of drawn ones           |

    `difficulty` applies to this episode only (the constructor sets the default). A given
    `start` is used as is, its segments re-projected to rest length from the head (shifted back
    onto the table where that makes it poke over the rim).

    Shapes are validated: wrong size, non-finite, off the table or a segment more than 5 % from
    rest length raise `ValueError` naming the option, as do unknown options.

    The reset `info` also holds `reference_actions` (`(T, 2)` float32: replayed through `step`
    from the reset state they solve the task on the cord that made it, within
    `dlo_env.tasks.difficulty_max_steps(difficulty)` steps: more than the registered 100
    above difficulty 5, so pass that as `gym.make(..., max_episode_steps=...)`; with
    `judge_at_rest=False` they reach the goal exactly, bitwise), `moves` (`(difficulty, 2)`
    displacements, metres), `difficulty` and `task_seed` (0 and -1 when the goal was given),
    and `pegs` (the centres of the episode's pegs, a tuple; empty without pegs).

    ## Pegs

    `max_pegs > 0` puts round pegs of `peg_radius` on the table: a drawn task places 0 to
    `max_pegs` near its start, the cord collides with them, a gripper stops where it would
    touch one, and no point ever lies inside one (docs/environments.md#pegs).

    ## Episode End

    Termination on success. Truncation after 100 steps (the registered `max_episode_steps`).

    ## Arguments

    ```python
    import gymnasium as gym
    import dlo_env

    env = gym.make(
        "dlo_env/DLOEndpoint-v0",
        params=None,             # dlo_env.CordParams; None = the default cord
        max_step=0.02,           # metres per unit action
        reward_type="dense",     # or "sparse"
        success_threshold=0.02,  # metres
        success_metric="error",  # or "direction_free_error" (ends may swap)
        judge_at_rest=True,      # success judged on the cord at rest
        difficulty=1,            # default number of straight moves, 1-10
        randomize=None,          # e.g. {"bending_stiffness": (0.003, 0.03)}: a cord per episode
        max_pegs=0,              # most pegs on the table (0: none, and the observation above)
        peg_radius=0.02,         # metres
        peg_friction=None,       # cord-peg friction (None: params' own, 0: frictionless pegs)
        render_mode=None,        # or "rgb_array", "human"
    )
    ```

    ## Version History

    * v0: Initial release. Since dlo 0.2 (2026-11) success is judged at rest;
      `judge_at_rest=False` gives the first rule.
    """

    grasp: ClassVar[Grasp] = "head"
