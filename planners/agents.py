"""Agents by name, as ``dlo evaluate`` and the benchmark build them for an environment."""

from __future__ import annotations

from typing import Any

#: Names ``build_agent`` knows; ``sb3:PATH`` loads a Stable-Baselines3 baseline folder.
AGENT_NAMES = ("latent-tree", "latent-tree-closed", "straight-line", "physics-mpc", "sb3:PATH")
#: Environment steps between replans of ``latent-tree-closed``.
DEFAULT_REPLAN_EVERY = 10


def build_agent(
    name: str,
    env: Any,
    *,
    model: Any = None,
    seed: int = 0,
    replan_every: int = DEFAULT_REPLAN_EVERY,
    tree_overrides: dict[str, Any] | None = None,
) -> Any:
    """The policy called ``name``, matched to ``env`` (its cord and ``max_step``).

    Args:
        name: One of ``AGENT_NAMES`` (``sb3:PATH`` with the folder written by ``dlo baseline``).
        env: The environment the agent will act in (wrapped or not).
        model: The shape model of the latent-tree agents (default: the shipped pretrained one).
        seed: Seed of the planner's sampling.
        replan_every: Steps between replans of ``latent-tree-closed``.
        tree_overrides: ``TreeConfig`` fields for the latent-tree agents.

    Returns:
        An object with SB3's ``predict`` (and ``reset`` for the planners).

    Raises:
        ValueError: For an unknown name, an ``sb3:`` folder without a baseline, or a model that
            does not fit the environment.
    """
    base = getattr(env, "unwrapped", env)
    max_step = float(getattr(base, "max_step", 0.02))
    if name in ("latent-tree", "latent-tree-closed"):
        from planners.latent_tree import LatentTreePlanner
        from planners.policy import PlannerPolicy

        if model is None:
            from latent_model import ShapeModel

            model = ShapeModel.load_pretrained(device="cpu")
        planner = LatentTreePlanner(model, seed=seed, **(tree_overrides or {}))
        policy = PlannerPolicy(
            model, planner, replan_every=replan_every if name == "latent-tree-closed" else None,
            max_step=max_step,
        )
        policy.check_env(env)
        return policy
    if name == "straight-line":
        from planners.straight_line import StraightLinePolicy

        return StraightLinePolicy(max_step=max_step)
    if name == "physics-mpc":
        from planners.physics_mpc import PhysicsMPCConfig, PhysicsMPCPolicy

        return PhysicsMPCPolicy.for_env(env, PhysicsMPCConfig(seed=seed))
    if name.startswith("sb3:") and len(name) > 4:
        from planners.rl_baseline import load_baseline

        try:
            return load_baseline(name[4:], device="cpu")
        except FileNotFoundError as exc:  # a ValueError: callers report bad agent names alike
            raise ValueError(str(exc)) from exc
    raise ValueError(f"agent name must be one of {AGENT_NAMES}, got {name!r}")
