"""The agent registry: one table maps an agent's name to its builder, defaults and environments.

``build_agent(name, env, **options)`` makes the policy called ``name`` for ``env``; every
command, the benchmark and the examples build agents through it, so a name means the same agent
everywhere. ``sb3:PATH`` loads any folder written by ``dlo baseline``. Adding an agent is one
entry in ``AGENTS``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from dlo_bench.paths import shipped_baseline
from dlo_bench.policy_file import weights_file
from dlo_env.errors import InputError, MissingFileError
from planners.interfaces import Policy, ShapeSurrogate
from planners.policy import DEFAULT_REPLAN_EVERY

ENDPOINT = "dlo_env/DLOEndpoint-v0"
DUAL_ENDPOINT = "dlo_env/DLODualEndpoint-v0"
#: Prefix of an agent name that loads a ``dlo baseline`` folder: ``sb3:PATH``.
SB3_PREFIX = "sb3:"


@dataclass(frozen=True)
class AgentOptions:
    """What a builder may be told; fields an agent does not use are ignored by it.

    Attributes:
        model: Shape model of the latent-tree agents: a loaded model, a file or folder, or None
            for the shipped one.
        transition_model: Transition model of latent-mpc and latent-tree-kino: a loaded
            ``TransitionModel``, a file or folder, or None for the shipped one.
        baseline: Folder of a ``dlo baseline`` run for the RL agents (None: the shipped one).
        seed: Seed of the planner's sampling.
        replan_every: Steps between the checks of ``latent-tree-closed``.
        max_seconds: Time budget of one latent-tree plan, seconds (None: ``TreeConfig``'s).
        device: Torch device of the RL agents.
    """

    model: ShapeSurrogate | str | Path | None = None
    transition_model: Any = None
    baseline: str | Path | None = None
    seed: int = 0
    replan_every: int = DEFAULT_REPLAN_EVERY
    max_seconds: float | None = None
    device: str = "cpu"


@dataclass(frozen=True)
class AgentSpec:
    """One registered agent.

    Attributes:
        name: The agent's name on the command line and in tables.
        summary: One line saying what it is.
        build: ``build(env, options) -> policy``.
        environments: Environment ids it acts in.
        extra: The ``pip install "dlo[EXTRA]"`` it needs beyond the core ("" for none).
        shape_model: Whether it plans on a shape model (``options.model``).
        transition_model: Whether it plans on a transition model (``options.transition_model``).
        cords: Whether it is an agent of cords that differ: its transition model is by default
            the shipped model of several cords, and the benchmark runs it in its ``cords``
            section only (the cord suites, ``dlo_env.cord_suites``).
        told_cord: Whether, in an environment made on another cord than the default one (a
            designed suite's own cord, ``gym.make(..., params=...)``), it plans on the shipped
            model of several cords told that cord (:func:`uses_cords_model`).
        train: How its trained model or policy is made, for messages about a missing one
            (``{env}``: the environment id).
        no_pegs: Why it cannot act where pegs are observed ("": it can).
        network: Whether it acts by a distilled network (``planners.distilled``): the file or
            folder ``options.baseline``, or the shipped one for the environment
            (``dlo_bench/pretrained/<name>[-dual-endpoint]/distilled.pt``).
        defaults: ``AgentOptions`` fields this agent sets differently.
    """

    name: str
    summary: str
    build: Callable[[Any, AgentOptions], Policy]
    environments: tuple[str, ...] = (ENDPOINT,)
    extra: str = ""
    shape_model: bool = False
    transition_model: bool = False
    cords: bool = False
    told_cord: bool = False
    train: str = ""
    no_pegs: str = ""
    network: bool = False
    defaults: Mapping[str, Any] = field(default_factory=dict)


def _max_step(env: Any) -> float:
    return float(env.unwrapped.max_step)


def observes_pegs(env: Any) -> bool:
    """Whether ``env`` observes pegs (``max_pegs > 0``): its RL agents are those trained
    there (``dlo baseline --max-pegs``)."""
    return int(getattr(env.unwrapped, "max_pegs", 0)) > 0


def told_cord(spec: AgentSpec, env: Any) -> Any:
    """The cord agent ``spec`` is told in ``env``: the environment's ``params`` (not an
    episode's ``options["params"]``) where it is not the default cord and the agent is told
    it (``told_cord``), else None."""
    from dlo_env.cord import CordParams
    from dlo_env.dataset.transitions import same_cord

    params = env.unwrapped.params
    return params if spec.told_cord and not same_cord(params, CordParams()) else None


def uses_cords_model(spec: AgentSpec, env: Any) -> bool:
    """Whether agent ``spec`` plans on a model of several cords in ``env``: an agent of
    cords that differ, or one told the environment's cord (:func:`told_cord`)."""
    return spec.cords or told_cord(spec, env) is not None


def train_command(spec: AgentSpec, env: Any) -> str:
    """How the trained model of ``spec`` for ``env`` is made: its ``train`` text for the
    environment, with ``--max-pegs N`` where pegs are observed."""
    command = spec.train.format(env=env.unwrapped.spec.id)
    return command + (f" --max-pegs {env.unwrapped.max_pegs}" if observes_pegs(env) else "")


def _loaded_or_file(model: Any, loaded: type, load: Callable[[Any], Any], what: str,
                    train: str) -> Any:
    """``model`` itself when it is a ``loaded`` instance, else ``load(model)``; a missing file
    raises ``FileNotFoundError`` saying "no WHAT" and how to make one."""
    if isinstance(model, loaded):
        return model
    try:
        return load(model)
    except FileNotFoundError as exc:
        raise MissingFileError(f"no {what}: {exc} (train one with `{train}`)") from exc


def load_shape_model(model: ShapeSurrogate | str | Path | None) -> ShapeSurrogate:
    """``model`` itself when it is loaded, else ``ShapeModel.load_or_pretrained(model)``.

    Raises:
        FileNotFoundError: Saying "no shape model" and where, when the file is missing.
    """
    def load(path: Any) -> ShapeSurrogate:
        from latent_model import ShapeModel  # torch only when a file must be read

        return ShapeModel.load_or_pretrained(path, device="cpu")

    return _loaded_or_file(model, ShapeSurrogate, load, "shape model", "dlo train")


def load_transition_model(model: Any, cords: bool = False, pegs: bool = False,
                          cord: Any = None) -> Any:
    """``model`` itself when it is loaded, else ``TransitionModel.load_or_pretrained(model,
    cords=cords, pegs=pegs, cord=cord)`` (when ``model`` is None, ``cords``: the shipped model
    of several cords, or the one fine-tuned for ``cord``; ``pegs``: the shipped model that sees
    pegs).

    Raises:
        FileNotFoundError: Saying "no transition model" and where, when the file is missing.
    """
    from latent_model import TransitionModel

    return _loaded_or_file(model, TransitionModel,
                           lambda m: TransitionModel.load_or_pretrained(
                               m, device="cpu", cords=cords, pegs=pegs, cord=cord),
                           "transition model", "dlo train transition"
                           + (" --cord-inputs" if cords else " --peg-reach" if pegs else ""))


def model_files(name: str, env: Any, model: Any = None, transition_model: Any = None,
                baseline: str | Path | None = None) -> list[str]:
    """The model files agent ``name`` plans or acts with in ``env``: its shape model
    (``model``, a path or None for the shipped one), its transition model
    (``transition_model``; None: the shipped one it loads there, the model that sees pegs where
    pegs are observed) and a trained policy's weights (``weights_file`` of its ``sb3:`` folder
    or of the shipped one for the environment) or distilled network (``baseline``, or the
    shipped one), for the provenance of its results. A model passed already loaded is named by
    its type."""
    from dlo_bench.paths import shape_model_file, transition_model_file

    spec = agent_spec(name)
    cords = uses_cords_model(spec, env)
    files = []
    if spec.extra == "rl":  # the folder _sb3 and _bc load
        folder = Path(spec.defaults.get("baseline") or shipped_baseline(
            name, env.unwrapped.spec.id, pegs=observes_pegs(env)))
        files.append(str(folder if folder.suffix == ".zip" else weights_file(folder)))
    if spec.network:
        files.append(str(_network_file(spec, env, baseline or spec.defaults.get("baseline"))))
    for wanted, given, file in (
            (spec.shape_model, model, shape_model_file),
            (spec.transition_model, transition_model,
             lambda p: transition_model_file(p, cords=cords,
                                             pegs=observes_pegs(env) and not cords,
                                             cord=told_cord(spec, env)))):
        if wanted:
            files.append(str(file(given)) if given is None or isinstance(given, (str, Path))
                         else f"<{type(given).__name__} passed in>")
    return files


def _goal_for(config: Any, env: Any) -> Any:
    """``config`` (a ``TreeConfig``) for ``env``: its grasp (the end(s) the environment holds),
    and its ``goal_threshold`` scaled to the environment's success threshold (the defaults
    were tuned at the default threshold, 2 cm)."""
    from dataclasses import replace as with_fields

    from dlo_env.tasks import SUCCESS_THRESHOLD

    scale = float(env.unwrapped.success_threshold) / SUCCESS_THRESHOLD
    return with_fields(config, goal_threshold=config.goal_threshold * scale,
                       grasp=env.unwrapped.grasp)


def _latent_tree(closed: bool) -> Callable[[Any, AgentOptions], Policy]:
    def build(env: Any, options: AgentOptions) -> Policy:
        from planners.latent_tree import LatentTreePlanner, TreeConfig
        from planners.policy import PlannerPolicy

        model = load_shape_model(options.model)
        budget = {} if options.max_seconds is None else {"max_seconds": options.max_seconds}
        planner = LatentTreePlanner(model, _goal_for(TreeConfig(), env), seed=options.seed,
                                    **budget)
        policy = PlannerPolicy(model, planner, max_step=_max_step(env),
                               replan_every=options.replan_every if closed else None)
        policy.check_env(env)
        return policy

    return build


def _latent_tree_kino(env: Any, options: AgentOptions) -> Policy:
    from dataclasses import replace as with_fields

    from planners.latent_tree import KINO_CONFIG, LatentTreePlanner
    from planners.policy import PlannerPolicy

    model = load_shape_model(options.model)
    config = _goal_for(KINO_CONFIG, env)
    if options.max_seconds is not None:
        config = with_fields(config, max_seconds=options.max_seconds)
    transition = planner_model("latent-tree-kino", env, options)
    told = {"cord": env.unwrapped.params} if getattr(transition.config, "cord_inputs", False) \
        else {}
    planner = LatentTreePlanner(model, config, seed=options.seed, transition_model=transition,
                                **told)
    policy = PlannerPolicy(model, planner, max_step=_max_step(env), moves_per_plan=1,
                           partial_plans=True)
    policy.check_env(env)
    return policy


def _straight_line(env: Any, options: AgentOptions) -> Policy:
    from planners.straight_line import StraightLinePolicy

    return StraightLinePolicy(max_step=_max_step(env), grasp=env.unwrapped.grasp)


def _physics_mpc(env: Any, options: AgentOptions) -> Policy:
    from planners.physics_mpc import PhysicsMPCConfig, PhysicsMPCPolicy

    return PhysicsMPCPolicy.for_env(env, PhysicsMPCConfig(seed=options.seed))


def planner_model(name: str, env: Any, options: AgentOptions) -> Any:
    """The transition model agent ``name`` plans on in ``env``: ``options.transition_model``,
    else the shipped one for the cord it is told (:func:`told_cord`) or the pegs it sees."""
    spec = AGENTS[name]
    cords = uses_cords_model(spec, env)
    return load_transition_model(options.transition_model, cords=cords,
                                 pegs=observes_pegs(env) and not cords,
                                 cord=told_cord(spec, env))


def _latent_mpc(env: Any, options: AgentOptions) -> Policy:
    from planners.latent_mpc import PEGS_SETTINGS, LatentMPCConfig, LatentMPCPolicy

    among_pegs = PEGS_SETTINGS if observes_pegs(env) else {}
    return LatentMPCPolicy.for_env(env, LatentMPCConfig(seed=options.seed, **among_pegs),
                                   model=planner_model("latent-mpc", env, options))


def _grad_mpc(env: Any, options: AgentOptions) -> Policy:
    from planners.grad_mpc import GradMPCConfig, GradMPCPolicy

    return GradMPCPolicy.for_env(env, GradMPCConfig(seed=options.seed),
                                 model=planner_model("grad-mpc", env, options))


def _surrogate_sb3(algo: str, title: str, flags: str) -> AgentSpec:
    """The agent ``ALGO-surrogate``: SB3's ``algo`` trained in the surrogate environment on
    difficulties 1-5, episodes ending at 1 cm, with ``dlo baseline`` ``flags``."""
    name = f"{algo}-surrogate"
    return AgentSpec(name, f"{title} trained in the surrogate environment (the learned cord), "
                     "no pymunk step", _sb3(algo, name),
                     environments=(ENDPOINT, DUAL_ENDPOINT), extra="rl",
                     train=f"dlo baseline --algo {algo} --surrogate --difficulty 1 2 3 4 5 "
                           f"--success-threshold 0.01 {flags} --env {{env}}",
                     no_pegs="it trained in the surrogate, which models the empty table")


def _network_file(spec: AgentSpec, env: Any, given: str | Path | None) -> Path:
    """The distilled network agent ``spec`` acts by in ``env``: ``given`` (a file, or a folder
    holding ``distilled.pt``) or the shipped one for the environment."""
    from dlo_bench.distillation import NETWORK_FILE

    path = Path(given) if given is not None else shipped_baseline(spec.name,
                                                                   env.unwrapped.spec.id)
    return path / NETWORK_FILE if path.is_dir() or given is None else path


def _distilled(env: Any, options: AgentOptions) -> Policy:
    from planners.distilled import DistilledPolicy, MoveNetwork

    spec = AGENTS["latent-mpc-distilled"]
    path = _network_file(spec, env, options.baseline)
    if not path.is_file():
        raise MissingFileError(f"no network of {spec.name} for {env.unwrapped.spec.id} at "
                               f"{path}: make one with `{train_command(spec, env)}`")
    return DistilledPolicy.for_env(env, MoveNetwork.load(path))


def _latent_mpc_adaptive(env: Any, options: AgentOptions) -> Policy:
    from planners.adaptive_mpc import AdaptiveLatentMPCPolicy
    from planners.latent_mpc import LatentMPCConfig

    return AdaptiveLatentMPCPolicy.for_env(
        env, LatentMPCConfig(seed=options.seed),
        model=load_transition_model(options.transition_model, cords=True))


def _physics_mpc_true_cord(env: Any, options: AgentOptions) -> Policy:
    from planners.physics_mpc import PhysicsMPCConfig, TrueCordPhysicsMPCPolicy

    return TrueCordPhysicsMPCPolicy(env, PhysicsMPCConfig(seed=options.seed))


def _sb3(algo: str, shipped: str = "", cords: str = "") -> Callable[[Any, AgentOptions], Policy]:
    """The builder of an SB3 agent ``algo``; ``shipped``: its shipped folder's name when it
    is not ``algo`` (``sac-her-cords``); ``cords``: the cords its model must have trained on
    (``BaselineConfig.cords``; "" any)."""
    def build(env: Any, options: AgentOptions) -> Policy:
        from dlo_bench.baselines import load_baseline

        folder = options.baseline
        if not algo and folder is not None:  # sb3:PATH: any SB3 model
            from dlo_bench.sb3_models import find_sb3, load_sb3

            return load_sb3(find_sb3(folder), env, device=options.device)
        if folder is None:
            env_id, pegs = env.unwrapped.spec.id, observes_pegs(env)
            folder = shipped_baseline(shipped or algo, env_id, pegs=pegs)
            if not folder.is_dir():
                where = f" where {env.unwrapped.max_pegs} pegs are observed" if pegs else ""
                raise MissingFileError(
                    f"no {shipped or algo} trained{where} in {env_id} is shipped ({folder.name}/):"
                    f" train one with `{train_command(AGENTS[shipped or algo], env)}` and run "
                    "it as agent sb3:FOLDER")
        return load_baseline(folder, device=options.device, algo=algo, cords=cords)

    return build


def _bc(env: Any, options: AgentOptions) -> Policy:
    from dlo_bench.behaviour_cloning import load_bc

    env_id = env.unwrapped.spec.id
    folder = (options.baseline if options.baseline is not None
              else shipped_baseline("bc", env_id))
    return load_bc(folder, device=options.device, env_id=env_id)


def observation_shape(env: Any) -> tuple[int, ...]:
    """The shape of ``env``'s ``"observation"`` entry.

    Raises:
        ValueError: One line when ``env`` does not observe the goal-conditioned Dict (a
            ``FlattenObservation`` wrapper, say): the agents read its entries.
    """
    space = env.observation_space
    if "observation" not in getattr(space, "spaces", {}):
        raise InputError("env must observe the dlo_env Dict (observation, achieved_goal, "
                         f"desired_goal), got {space}: build the agent on, and give it the "
                         "observations of, the environment without a flattening wrapper")
    return space["observation"].shape


def _check_observation(name: str, policy: Any, env: Any) -> None:
    """Refuse, in one line, a trained policy whose observation is not the environment's (one
    trained on an empty table, in an environment with pegs, say)."""
    space = getattr(policy, "observation_space", None)
    spaces = getattr(space, "spaces", None)
    if not spaces or "observation" not in spaces:
        return
    want = observation_shape(env)
    got = spaces["observation"].shape
    if got != want:
        pegs = getattr(env.unwrapped, "max_pegs", 0)
        slots, rest = divmod(got[0] - want[0], 3) if len(got) == len(want) == 1 else (0, 1)
        where = (f"act where max_pegs={pegs + slots} (a peg suite), or "
                 if not rest and pegs + slots > 0 else "")
        raise InputError(f"agent {name!r} was trained on observations of shape {got}, but this "
                         f"environment observes {want} (max_pegs={pegs}: 3 numbers per peg "
                         f"slot): {where}train one there (dlo baseline "
                         f"{f'--max-pegs {pegs}' if pegs else 'without --max-pegs'})")


#: Every agent by name, in the benchmark's table order.
AGENTS: dict[str, AgentSpec] = {spec.name: spec for spec in (
    AgentSpec("straight-line", "moves the held end(s) straight to the goal's (reference)",
              _straight_line, environments=(ENDPOINT, DUAL_ENDPOINT)),
    AgentSpec("latent-tree", "the paper's latent tree, planned once (open loop)",
              _latent_tree(closed=False), environments=(ENDPOINT, DUAL_ENDPOINT), extra="model",
              shape_model=True),
    AgentSpec("latent-tree-closed", "the latent tree, checked and replanned every few steps",
              _latent_tree(closed=True), environments=(ENDPOINT, DUAL_ENDPOINT), extra="model",
              shape_model=True),
    AgentSpec("latent-tree-kino", "the latent tree with straight-move edges predicted by the "
              "transition model, one move per plan (closed loop)", _latent_tree_kino,
              environments=(ENDPOINT, DUAL_ENDPOINT), extra="model", shape_model=True,
              transition_model=True, told_cord=True),
    AgentSpec("physics-mpc", "CEM over straight moves with the simulator as the model",
              _physics_mpc, environments=(ENDPOINT, DUAL_ENDPOINT)),
    AgentSpec("latent-mpc", "CEM over straight moves scored by the learned transition model",
              _latent_mpc, environments=(ENDPOINT, DUAL_ENDPOINT), extra="model",
              transition_model=True, told_cord=True),
    AgentSpec("grad-mpc", "straight-move plans descended by gradient steps through the "
              "differentiable transition model", _grad_mpc,
              environments=(ENDPOINT, DUAL_ENDPOINT), extra="model", transition_model=True,
              told_cord=True,
              no_pegs="its differentiable step (CordDynamics) models the empty table"),
    AgentSpec("latent-mpc-distilled", "a network distilled from latent-mpc by DAgger in the "
              "surrogate: one network call per plan, no search", _distilled,
              environments=(ENDPOINT, DUAL_ENDPOINT), extra="model", network=True,
              train="dlo distil --env {env}",
              no_pegs="it was distilled in the surrogate, which models the empty table"),
    AgentSpec("ppo", "the shipped PPO baseline (Stable-Baselines3)", _sb3("ppo"),
              environments=(ENDPOINT, DUAL_ENDPOINT), extra="rl",
              train="dlo baseline --algo ppo --env {env}"),
    AgentSpec("sac-her", "the shipped SAC + HER baseline (Stable-Baselines3)", _sb3("sac-her"),
              environments=(ENDPOINT, DUAL_ENDPOINT), extra="rl",
              train="dlo baseline --algo sac-her --env {env}"),
    _surrogate_sb3("ppo", "PPO", "--n-envs 256 --timesteps 5000000 --set ppo_n_steps=64 "
                   "ppo_batch_size=2048 ppo_epochs=5"),
    _surrogate_sb3("sac-her", "SAC + HER", "--n-envs 64 --timesteps 1000000 --set "
                   "sac_learning_starts=10000 sac_gradient_steps=8"),
    AgentSpec("bc", "behaviour cloning of the oracle demonstrations (Minari datasets)", _bc,
              environments=(ENDPOINT, DUAL_ENDPOINT), extra="rl",
              train="dlo_bench.behaviour_cloning.train_bc for {env}",
              no_pegs="its demonstrations (the oracle's Minari datasets) have no pegs"),
    AgentSpec("latent-mpc-adaptive", "latent-mpc on the model of several cords, fitting the "
              "cord to the episode's moves after each one", _latent_mpc_adaptive,
              environments=(ENDPOINT, DUAL_ENDPOINT), extra="model", transition_model=True,
              cords=True),
    AgentSpec("physics-mpc-true-cord", "physics-mpc told each episode's cord (the oracle of "
              "unknown cords)", _physics_mpc_true_cord, environments=(ENDPOINT, DUAL_ENDPOINT),
              cords=True),
    AgentSpec("sac-her-cords", "SAC + HER trained on randomised cords (Stable-Baselines3)",
              _sb3("sac-her", "sac-her-cords", cords="train"),
              environments=(ENDPOINT, DUAL_ENDPOINT), extra="rl", cords=True,
              train="dlo baseline --algo sac-her --cords train --env {env}"),
)}


def agent_names() -> tuple[str, ...]:
    """Registered names and the ``sb3:PATH`` form, for help texts and error messages."""
    return (*AGENTS, f"{SB3_PREFIX}PATH")


def agent_spec(name: str) -> AgentSpec:
    """The spec of ``name``; ``sb3:PATH`` gives an RL agent loading that folder.

    Raises:
        ValueError: For an unknown name.
    """
    if name in AGENTS:
        return AGENTS[name]
    if name.startswith(SB3_PREFIX) and len(name) > len(SB3_PREFIX):
        folder = name[len(SB3_PREFIX):]
        return AgentSpec(name, f"the baseline in {folder}", _sb3(""), extra="rl",
                         defaults={"baseline": folder}, environments=_trained_in(folder))
    raise InputError(f"agent name must be one of {', '.join(agent_names())}, got {name!r}")


def _trained_in(folder: str) -> tuple[str, ...]:
    """The environment the SB3 model in ``folder`` was trained in, when its folder says
    (``dlo_bench.sb3_models.find_sb3``); both when unknown or unreadable (loading it says
    why, and a model of the other environment's spaces is refused then)."""
    from dlo_bench.sb3_models import find_sb3

    try:
        env_id = find_sb3(folder).env_id
    except (OSError, ValueError, KeyError, TypeError, ImportError):
        env_id = None
    return (env_id,) if env_id in (ENDPOINT, DUAL_ENDPOINT) else (ENDPOINT, DUAL_ENDPOINT)


def build_agent(name: str, env: Any, **options: Any) -> Policy:
    """The policy called ``name``, matched to ``env`` (its cord, grasp and ``max_step``).

    Args:
        name: A key of ``AGENTS``, or ``sb3:PATH`` with a folder written by ``dlo baseline``.
        env: The environment the agent will act in (wrapped or not), or its id (an
            environment made with ``gym.make(env)``, its defaults, and closed again). An
            agent of a pymunk environment acts in its surrogate twin too
            (``dlo_env.SURROGATE_OF``: the same spaces and options).
        **options: ``AgentOptions`` fields (``model``, ``transition_model``, ``baseline``,
            ``seed``, ``replan_every``, ``max_seconds``, ``device``); None keeps the default.

    Returns:
        A policy with SB3's ``predict``.

    Raises:
        ValueError: For an unknown name or option, an environment the agent does not act in,
            or a model that does not fit the environment.
        FileNotFoundError: When a model or baseline file is missing.
    """
    if isinstance(env, str):
        if name == "physics-mpc-true-cord":
            raise InputError("physics-mpc-true-cord reads the cord of the environment it acts "
                             "in: give it that environment, not its id")
        import gymnasium as gym

        import dlo_env  # noqa: F401  (registers the environments)

        with gym.make(env) as made:
            return build_agent(name, made, **options)
    if not hasattr(env, "unwrapped") or not hasattr(env, "observation_space"):
        raise InputError(f"env must be a dlo_env environment or its id, got {type(env).__name__}")
    spec = agent_spec(name)
    known = {f.name for f in fields(AgentOptions)}
    unknown = sorted(set(options) - known)
    if unknown:
        raise InputError(f"build_agent options must be some of {sorted(known)}, got {unknown}")
    env_id = getattr(env.unwrapped.spec, "id", None)
    from dlo_env import SURROGATE_OF

    twin = {v: k for k, v in SURROGATE_OF.items()}.get(env_id, env_id)  # same spaces, options
    if env_id is not None and twin not in spec.environments:
        raise InputError(f"agent {name!r} acts in {', '.join(spec.environments)}, "
                         f"got environment {env_id!r}")
    size = math.prod(observation_shape(env))
    if spec.no_pegs and observes_pegs(env):
        raise InputError(f"agent {name!r} does not act where pegs are observed: {spec.no_pegs}")
    given = {k: v for k, v in options.items() if v is not None}  # None: the default
    policy = spec.build(env, replace(AgentOptions(), **{**spec.defaults, **given}))
    _check_observation(name, policy, env)
    from planners.episodic_policy import EpisodicPolicy

    if isinstance(policy, EpisodicPolicy):  # aim as the environment scores, in it alone
        policy.success_metric = getattr(env.unwrapped, "success_metric", "error")
        pegs = getattr(env.unwrapped, "max_pegs", 0)
        policy.built_for = (f"{env_id or type(env.unwrapped).__name__} with max_pegs={pegs}",
                            size)
    return policy
