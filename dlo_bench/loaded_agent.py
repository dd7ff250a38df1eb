"""An agent loaded for the benchmark: the policy :func:`dlo_bench.agents.build_agent` makes
from the benchmark's models and baselines, with the data it was trained on (its sample cost) and
its files, or why it cannot act (:class:`LoadedAgent`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dlo_bench.agents import (
    SB3_PREFIX,
    agent_spec,
    build_agent,
    load_transition_model,
    model_files,
    observes_pegs,
    told_cord,
    train_command,
    uses_cords_model,
)
from dlo_bench.paths import baseline_folder_name, shipped_baseline
from dlo_bench.policy_file import weights_file
from planners.cem import settings_repr
from planners.interfaces import Policy, ShapeSurrogate

if TYPE_CHECKING:
    from dlo_bench.benchmark.config import BenchmarkConfig


@dataclass(frozen=True)
class LoadedAgent:
    """An agent ready to run, or the reason it cannot.

    Attributes:
        name: Agent name.
        policy: The policy, or None when ``missing`` says why not.
        missing: Why the agent has no policy (empty when it has one).
        training_env_steps: Environment steps of the data its model or policy was trained on
            (None: not trained on environment steps; ``sample_cost`` says what instead).
        sample_cost: What it was trained on, in words.
        models: The files of its models (none for model-free planners).
        settings: Its planner's settings (``repr`` of its config), part of the resume key.
        applicable: False when the agent cannot act there at all (``missing`` says why): its
            cells read "n/a", not "missing".
    """

    name: str
    policy: Policy | None
    missing: str = ""
    training_env_steps: int | None = None
    sample_cost: str = ""
    models: tuple[str, ...] = ()
    settings: str = ""
    applicable: bool = True


def policy_settings(policy: Any) -> str:
    """The settings of a planner (``repr`` of its config, and of its tree's), "" without any:
    a change of an agent's defaults makes its saved cells stale (``planners.cem.LATER``
    fields at their defaults are left out)."""
    parts = [settings_repr(getattr(policy, "config", ""))]
    planner = getattr(policy, "planner", None)
    if planner is not None:
        parts.append(settings_repr(getattr(planner, "config", "")))
    for name in ("replan_every", "moves_per_plan", "partial_plans"):
        if hasattr(policy, name):
            parts.append(f"{name}={getattr(policy, name)!r}")
    return "; ".join(p for p in parts if p and p != "''")


def _baseline_folder(name: str, config: BenchmarkConfig, env_id: str,
                     pegs: bool = False) -> Path:
    """Where the RL agent ``name`` for ``env_id`` is read: ``ppo/`` for ``DLOEndpoint-v0``,
    ``ppo-dual-endpoint/`` for ``DLODualEndpoint-v0``, ``ppo-pegs/`` where pegs are observed
    (in ``config.baselines`` or shipped)."""
    if config.baselines:
        return Path(config.baselines) / baseline_folder_name(name, env_id, pegs)
    return shipped_baseline(name, env_id, pegs)


def _steps(count: int) -> str:
    """``1.12M``, ``301k``, ``256``."""
    if count >= 1e6:
        return f"{count / 1e6:.2f}M"
    return f"{count / 1e3:.0f}k" if count >= 1e4 else f"{count:,}"


def load_agent(name: str, config: BenchmarkConfig, env: Any,
               shape_model: ShapeSurrogate | None = None) -> LoadedAgent:
    """Build the agent called ``name`` for ``env``, or say why it is missing.

    Args:
        name: A key of ``AGENTS``.
        config: The benchmark (baselines folder, models, replanning, time budget, seed).
        env: The environment (for its id, the cord and ``max_step``).
        shape_model: The loaded shape model for the latent-tree agents (None: missing).
    """
    spec = agent_spec(name)
    env_id = env.unwrapped.spec.id
    if env_id not in spec.environments:
        return LoadedAgent(name, None, missing=f"acts only in {', '.join(spec.environments)}")
    pegs = observes_pegs(env)
    if pegs and spec.no_pegs:
        return LoadedAgent(name, None, missing=f"does not act among pegs: {spec.no_pegs}",
                           applicable=False)
    if name.startswith(SB3_PREFIX):
        return _load_sb3_agent(name, env)
    if spec.extra == "rl":
        from dlo_bench.baselines import read_baseline_metadata

        folder = _baseline_folder(name, config, env_id, pegs)
        try:
            meta = read_baseline_metadata(folder)
            policy = build_agent(name, env, baseline=folder)
        except FileNotFoundError:
            return LoadedAgent(name, None, missing=(
                f"no trained model for {env_id}{' with pegs' if pegs else ''} in "
                f"{baseline_folder_name(name, env_id, pegs)}/ (train one with "
                f"`{train_command(spec, env)}`)"))
        except ValueError as exc:
            return LoadedAgent(name, None, missing=f"no usable model for {env_id}: "
                                                   f"{exc}".splitlines()[0])
        steps = int(meta.get("real_env_steps", meta["trained_timesteps"]))
        surrogate = int(meta.get("surrogate_steps", 0))
        # bc trains offline on the oracle's demonstrations
        cost = f"{_steps(steps)} {'demonstration' if name == 'bc' else 'env'} steps"
        if surrogate:  # trained in the learned cord: both kinds of step, apart
            cost += f" + {_steps(surrogate)} surrogate steps"
        return LoadedAgent(name, policy, training_env_steps=steps, sample_cost=cost,
                           models=(str(weights_file(folder)),))
    options: dict[str, Any] = {"seed": config.seed}
    costs, steps = [], None
    cords = uses_cords_model(spec, env)
    path = (config.cords_transition_model if cords
            else config.pegs_transition_model if pegs else config.transition_model)
    if spec.shape_model:
        if shape_model is None:
            return LoadedAgent(name, None, missing="no shape model (pass --model, or ship "
                                                   "latent_model/pretrained/model.pt)")
        options.update(model=shape_model, replan_every=config.replan_every,
                       max_seconds=config.max_seconds)
        shapes = getattr(shape_model, "info", {}).get("n_train")
        costs.append(f"{_steps(shapes)} simulated shapes" if shapes else "simulated shapes")
    if spec.transition_model:
        try:
            transition = load_transition_model(path, cords=cords, pegs=pegs and not cords,
                                               cord=told_cord(spec, env))
        except (FileNotFoundError, ValueError) as exc:
            return LoadedAgent(name, None, missing=str(exc).splitlines()[0])
        options.update(transition_model=transition)
        steps, moves = training_data(transition.info)
        costs.insert(0, "unknown (the model does not record its data)" if not steps
                     else f"{_steps(steps)} env steps" + (f" ({_steps(moves)} moves)" if moves
                                                           else ""))
    if spec.network:  # a distilled network: the baselines folder's, or the shipped one
        options.update(baseline=_baseline_folder(name, config, env_id))
    try:
        policy = build_agent(name, env, **options)
    except ValueError as exc:  # e.g. a model made for another cord
        return LoadedAgent(name, None, missing=str(exc).splitlines()[0])
    if spec.network:
        steps, cost = policy.training_cost()
        costs.append(cost)
    return LoadedAgent(name, policy, training_env_steps=steps,
                       sample_cost=" + ".join(costs) or "none (no learned model)",
                       models=tuple(model_files(name, env, config.model, path,
                                                      options.get("baseline"))),
                       settings=policy_settings(policy))


def _load_sb3_agent(name: str, env: Any) -> LoadedAgent:
    """An ``sb3:PATH`` agent for ``env``, its sample cost from its folder (else unknown), or
    why it cannot act there (a model of other spaces)."""
    from dlo_bench.sb3_models import find_sb3

    source = find_sb3(name[len(SB3_PREFIX):])
    try:
        policy = build_agent(name, env)
    except ValueError as exc:
        return LoadedAgent(name, None, missing=str(exc).splitlines()[0], applicable=False)
    except ImportError as exc:  # a TQC model without sb3_contrib, say
        return LoadedAgent(name, None, missing=str(exc).splitlines()[0])
    meta = {}
    if source.kind == "dlo baseline":
        from dlo_bench.baselines import read_baseline_metadata

        meta = read_baseline_metadata(source.model_file)
    steps = meta.get("real_env_steps", meta.get("trained_timesteps"))
    surrogate = int(meta.get("surrogate_steps", 0))
    cost = "unknown (the folder does not record it)" if steps is None else (
        f"{_steps(int(steps))} env steps" + (f" + {_steps(surrogate)} surrogate steps"
                                             if surrogate else ""))
    return LoadedAgent(name, policy, training_env_steps=None if steps is None else int(steps),
                       sample_cost=cost, models=(str(source.model_file),))


def training_data(info: dict[str, Any]) -> tuple[int | None, int | None]:
    """The environment steps and moves a transition model was trained on, counting the models
    it came from (``info["init_model"]``, fine-tuned from, and ``info["ensemble"]``, distilled
    from; recursively): each file once (by digest), a model's recorded steps and moves shared
    out over its files by their sizes. A model that records no files adds nothing (its files
    cannot be told apart from its descendants'); the result is never below what the model
    itself records. ``(None, None)`` when the model does not record its data."""
    steps, moves = info.get("env_steps"), info.get("data_transitions")
    if steps is None:
        return steps, moves
    seen: set[str] = set()
    total_steps, total_moves = 0.0, 0.0
    todo: list[dict[str, Any]] = [info]
    while todo:
        level = todo.pop(0)
        sources = level.get("sources") or []
        made = sum(int(src.get("transitions", 0)) for src in sources)
        fresh = sum(int(src.get("transitions", 0)) for src in sources
                    if str(src.get("digest")) not in seen)
        if made:
            share = fresh / made
            total_steps += (level.get("env_steps") or 0) * share
            total_moves += (level.get("data_transitions") or fresh) * share
        seen.update(str(src.get("digest")) for src in sources)
        parents = [(level.get("init_model") or {}).get("info"), level.get("ensemble")]
        todo += [p for p in parents if isinstance(p, dict)]
    return (max(int(round(total_steps)), int(steps)),
            max(int(round(total_moves)), int(moves or 0)) if moves is not None or total_moves
            else None)


def load_shape_model(path: str | None) -> tuple[ShapeSurrogate | None, str]:
    """The shape model at ``path`` (None: the shipped one), or None and why it is missing."""
    from dlo_bench.agents import load_shape_model as load

    try:
        return load(path), ""
    except (FileNotFoundError, ValueError) as exc:
        return None, str(exc).splitlines()[0]
