"""latent-mpc: CEM over straight moves, every candidate scored by the learned transition model.

The planner ``planners.cem.CEMPolicy`` shared with physics-mpc (the cross-entropy method over
straight moves of the held end(s), warm-started from the previous plan), with the simulator
replaced by ``latent_model.TransitionModel``: all candidates of an iteration are rolled out in
one batched call, move after move, and scored by the error of the predicted final shape to the
goal (plus, optionally, the ensemble's spread). The first move is executed as ``split_move``
actions, followed by zero actions while the cord comes to rest, and the policy plans again
from the observed shape (closed loop) until the goal is reached.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dlo_env.core.checks import non_negative, non_negative_ints, positive, positive_ints
from dlo_env.errors import InputError
from planners.cem import LATER, CEMConfig, CEMPolicy
from planners.observation import CordObservation


@dataclass(frozen=True)
class LatentMPCConfig(CEMConfig):
    """CEM budget of latent-mpc (the model is cheap: many more samples than physics-mpc) and
    how it uses the model. The defaults were chosen on the train splits of linear-1 to
    linear-5 (``benchmarks/tune_planner.py``; the sweep is in docs/history.md): one network
    scores as well as five at a fifth of the cost, a horizon of 3 moves beats 2, and stopping
    once a plan is predicted within half the success threshold (1 cm of 2 cm) halves the time
    for the same success. A horizon of 5 moves while the cord is more than 6 cm from the goal
    (``far_moves``, one end held) was chosen on the train splits of shapes-curves, linear-2,
    -3, -5 and -8 at 1 and 0.5 cm: designed goals 20 -> 68 % and linear-8 78 -> 98 % at 1 cm,
    the others as before; with both ends held longer horizons lost (dual linear-3 93 -> 65 %),
    the both-ends predictions compounding their errors. Polishing a plan that the search
    leaves short of the goal by 20 gradient steps (``polish_steps``) was chosen on the train
    splits of shapes-curves, linear-3, -5 and -8 at 1 and 0.5 cm: dual shapes-curves 45 ->
    95 %, endpoint 65 -> 85 %, dual linear-3 at 0.5 cm 55 -> 100 %, none worse, at 1.1-4.9x
    the planning time.

    Attributes:
        members: Ensemble members that score the candidates (the first ones), or None: the
            model's mean network when it has one (the shipped model), else the ensemble's
            first network (all of them with ``spread_weight``), one network's cost either way.
            More members cost proportionally more; the spread needs at least two.
        spread_weight: Weight of the ensemble's spread of the final shape in the cost.
        settle_actions: Zero actions after each executed move, for the cord to come to rest
            (the model predicts shapes at rest).
        inextensible: Score with predictions moved onto rest-length segments
            (``TransitionModel.predict(inextensible=True)``, more accurate). Off: the setting
            the defaults were tuned and benchmarked with, before the projection existed.
        verify: The best plans (by the model) whose first move is simulated on the observed
            cord (the simulator, with the observed pegs) before one is executed: each is
            scored by the model's prediction of its other moves from the simulated shape.
            0: none, the model's best plan. The simulation counts in the planning time.
        verify_settle: Control periods simulated with the grippers still after a verified
            move.
        polish_steps: Where the search's best plan is not predicted within ``stop_fraction``
            of the threshold, Adam steps on it and ``polish_samples - 1`` plans around it
            through the differentiable model (``planners.gradient_search``, grad-mpc's
            descent); the polished plan is taken where the search's own scoring predicts it
            better. 0: none. Not with ``verify``, among observed pegs or with a model that
            sees pegs (the differentiable step models the empty table), nor with ``members``
            or ``spread_weight`` set (it descends the mean network alone).
        polish_samples: Plans descended together (the search's best and ones around it).
        polish_std: Standard deviation of the plans around the best, metres.
        polish_rate: Adam's step size, metres.
    """

    moves: int = 3
    samples: int = 256
    elites: int = 25
    iterations: int = 5
    init_std: float = 0.08
    focus: float = 2.0
    max_move: float = 0.35
    far_moves: int = 5
    far_error: float = 0.06
    far_grasps: tuple[str, ...] = ("head", "tail")
    stop_fraction: float = 0.5
    members: int | None = None
    spread_weight: float = 0.0
    settle_actions: int = 3
    inextensible: bool = False
    verify: int = field(default=0, metadata=LATER)
    verify_settle: int = field(default=2, metadata=LATER)
    polish_steps: int = 20
    polish_samples: int = 8
    polish_std: float = 0.01
    polish_rate: float = 0.01

    def __post_init__(self) -> None:
        super().__post_init__()
        non_negative(self, "spread_weight")
        non_negative_ints(self, "settle_actions", "verify", "verify_settle", "polish_steps")
        positive_ints(self, "polish_samples")
        positive(self, "polish_rate")
        non_negative(self, "polish_std")
        if self.members is not None:
            positive_ints(self, "members")
        if self.spread_weight > 0 and self.members == 1:
            raise InputError("LatentMPCConfig.spread_weight > 0 needs members >= 2 (the spread "
                             "of one member is zero), got members=1")


#: What latent-mpc changes where pegs are observed (``dlo_bench.build_agent`` and the
#: benchmark's pegs section): the straight plan to the goal's ends is scored in every
#: iteration. Chosen on the train splits of pegs-1/-2/-3 and route-2 at 1 cm, 50 tasks each
#: (``benchmarks/tune_planner.py``, docs/history.md): 184 against 181 of 200 tasks with one
#: end held, 168 against 154 with both; simulating the three best plans' first moves
#: (``verify=3``) gained nothing at about twice the time.
PEGS_SETTINGS: dict[str, Any] = {"offer_straight": True}


class LatentMPCPolicy(CEMPolicy):
    """CEM model-predictive control on the learned transition model.

    Args:
        model: A ``latent_model.TransitionModel`` (its cord and ``max_step`` must match the
            environment's).
        grasp: ``"head"`` for ``DLOEndpoint-v0``, ``"both"`` for ``DLODualEndpoint-v0``
            (``"tail"`` for a cord held at the tail).
        success_threshold: The environment's success threshold, metres (``for_env`` reads it):
            the policy holds still within it and stops planning at ``config.stop_fraction``
            of it.
        config: CEM budget.
        cord: The cord a model of several cords (``config.cord_inputs``) is told, its
            predictions made for it; None: the model's own cord (``for_env`` tells such a model
            the environment's cord).
    """

    def __init__(self, model: Any, grasp: str = "head", success_threshold: float = 0.02,
                 config: LatentMPCConfig | None = None, *,
                 success_metric: str = "error", cord: Any = None) -> None:
        self.model = model
        if cord is not None:
            cord = model.told(cord)
        #: The cord told to the model (``predict``'s ``params``), or None.
        self.cord = cord
        config = config if config is not None else LatentMPCConfig()
        total = model.config.members
        if config.members is not None and config.members > total:
            raise InputError(f"LatentMPCConfig.members must be <= the model's {total} members, "
                             f"got {config.members}")
        super().__init__(model.cord_params, grasp, model.config.max_step, success_threshold,
                         config, success_metric=success_metric)
        #: ``predict``'s ``members``: None runs the mean network, or the whole ensemble.
        self.members = config.members
        if config.members is None and getattr(model, "mean_net", None) is None:
            self.members = None if config.spread_weight > 0 else 1

    @classmethod
    def for_env(cls, env: object, config: LatentMPCConfig | None = None,
                model: Any = None) -> LatentMPCPolicy:
        """Build the policy for a ``dlo_env`` environment; refuses a mismatched model."""
        if model is None:
            from latent_model import TransitionModel

            model = TransitionModel.load_or_pretrained(device="cpu")
        base = getattr(env, "unwrapped", env)
        told = {"cord": base.params} if getattr(model.config, "cord_inputs", False) else {}
        policy = cls(model, grasp=base.grasp, success_threshold=base.success_threshold,
                     config=config, success_metric=base.success_metric, **told)
        policy.check_env(env)
        policy.peg_radius = base.peg_radius  # of the pegs it will observe
        policy.sim_params = base.params  # the cord its verification simulates
        return policy

    def check_env(self, env: object) -> None:
        """Raise ``ValueError`` unless the environment's cord, grasp and step fit the model."""
        base = getattr(env, "unwrapped", env)
        self.model.check_env_cord(base.params)
        if abs(base.max_step - self.max_step) > 1e-12:
            raise InputError(
                f"the transition model was trained with max_step={self.max_step} m, but the "
                f"environment has max_step={base.max_step} m")
        if base.grasp != self.grasp:
            raise InputError(f"the policy moves grasp {self.grasp!r} but the environment holds "
                             f"{base.grasp!r}")
        self._check_threshold(base)

    def reset(self) -> None:
        """Forget the plan and the pegs last observed (see ``CEMPolicy.reset``)."""
        super().reset()
        self._pegs: np.ndarray | None = None

    @property
    def keep(self) -> int:  # type: ignore[override]
        """The best plans ``_choose`` verifies (``config.verify``), at least one."""
        return max(1, self.config.verify)

    def _choose(self, shape: np.ndarray, goal: np.ndarray, plans: np.ndarray,
                errors: np.ndarray) -> tuple[np.ndarray, float]:
        """With ``config.verify``, the plan whose simulated first move, followed by its other
        moves as the model predicts them, ends nearest the goal; else the model's best."""
        if not self.config.verify:
            return super()._choose(shape, goal, plans, errors)
        from planners.physics_mpc import fitted_cord, simulate

        sim = getattr(self, "_sim", None)
        params = getattr(self, "sim_params", None) or self.cord or self.model.cord_params
        if sim is None:
            from dlo_env.cord import PEG_RADIUS, Cord

            sim = Cord(params, grasp=self.grasp,
                       peg_radius=getattr(self, "peg_radius", None) or PEG_RADIUS)
        pegs = self._pegs if self._pegs is not None else np.zeros((0, 2))
        if not np.array_equal(pegs, sim.pegs):
            sim.set_pegs(pegs)
        sim, start = fitted_cord(sim, params, shape)
        self._sim = sim
        shapes = np.stack([simulate(sim, start, plan[:1], self.ends, self.config.verify_settle)
                           for plan in plans])
        for k in range(1, plans.shape[1]):
            moves = plans[:, k].reshape(len(plans), -1)
            shapes = self._predict(shapes, moves, members=self.members,
                                   inextensible=self.config.inextensible)
        scores = np.asarray(self._distance(shapes, goal), dtype=np.float64)
        best = int(np.argmin(scores))
        return plans[best].copy(), float(scores[best])

    def _refine(self, shape: np.ndarray, goal: np.ndarray, plan: np.ndarray, error: float
                ) -> tuple[np.ndarray, float]:
        """With ``config.polish_steps``, ``plan`` polished by gradient steps through the
        differentiable model where the search's scoring predicts the result better."""
        from planners.gradient_search import descend

        cfg = self.config
        pegs = getattr(self, "_pegs", None)
        if (not cfg.polish_steps or cfg.verify or (pegs is not None and len(pegs))
                or getattr(self.model.config, "peg_reach", False)
                or cfg.members is not None or cfg.spread_weight > 0):
            return plan, error
        dynamics = self._differentiable_step()
        starts = plan + cfg.polish_std * self._rng.standard_normal(
            (cfg.polish_samples,) + plan.shape)
        starts[0] = plan
        polished, _, rollouts = descend(
            dynamics, shape, goal, starts, steps=cfg.polish_steps,
            learning_rate=cfg.polish_rate, max_move=cfg.max_move,
            stop_error=cfg.stop_fraction * self.success_threshold,
            direction_free=self.success_metric == "direction_free_error")
        score = float(self._score(shape, goal, polished[None])[0])
        self.stats.rollouts += rollouts + 1
        return (polished, score) if score < error else (plan, error)

    def _polish_cord(self) -> Any:
        """The cord the polish's differentiable step predicts: the told one (None: the
        model's own)."""
        return self.cord

    def _differentiable_step(self) -> Any:
        """``CordDynamics`` of the model, the held end(s) and ``_polish_cord()`` (kept while
        that cord stays the same)."""
        cord = self._polish_cord()
        cached = getattr(self, "_dynamics", None)
        if cached is None or cached[0] != cord:
            from latent_model.cord_dynamics import CordDynamics
            from latent_model.inextensible import ITERATIONS

            iterations = ITERATIONS if self.config.inextensible else 0
            cached = self._dynamics = (cord, CordDynamics(self.model, self.grasp, params=cord,
                                                          inextensible_iterations=iterations))
        return cached[1]

    def _act(self, obs: CordObservation) -> np.ndarray:
        """Plan with the pegs the observation shows (their stop rule on the grippers), then act
        as a CEM policy."""
        self._pegs = obs.pegs
        return super()._act(obs)

    def _score(self, shape: np.ndarray, goal: np.ndarray, candidates: np.ndarray) -> np.ndarray:
        cfg = self.config
        shapes = np.broadcast_to(shape, (len(candidates),) + shape.shape)
        spread = np.zeros(len(candidates))
        for k in range(candidates.shape[1]):
            moves = candidates[:, k].reshape(len(candidates), -1)
            if cfg.spread_weight > 0:
                shapes, spread = self._predict(shapes, moves, return_std=True,
                                               members=self.members,
                                               inextensible=cfg.inextensible)
            else:
                shapes = self._predict(shapes, moves, members=self.members,
                                       inextensible=cfg.inextensible)
        return self._distance(shapes, goal) + cfg.spread_weight * spread

    def _predict(self, shapes: np.ndarray, moves: np.ndarray, **kw: Any) -> Any:
        """The model's prediction of ``moves`` from ``shapes`` (for the told cord, else the
        model's own), the grippers stopping at the observed pegs."""
        if self.cord is not None and "params" not in kw:
            kw = {**kw, "params": self.cord}
        pegs = getattr(self, "_pegs", None)
        if pegs is not None and len(pegs):
            kw = {**kw, "pegs": pegs, "peg_radius": getattr(self, "peg_radius", None)}
        return self.model.predict(shapes, self.grasp, moves, **kw)

    def _execute(self, plan: np.ndarray) -> list[np.ndarray]:
        """The first move, then zero actions while the cord comes to rest."""
        zero = np.zeros(2 * len(self.ends), dtype=np.float32)
        return self._actions(plan[:1]) + [zero] * self.config.settle_actions
