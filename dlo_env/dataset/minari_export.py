"""Minari datasets of the project's data: the suites' oracle demonstrations, transition data.

:func:`export_demonstrations` runs the ``reference_actions`` of a suite's train tasks through
the environment and stores each task as one Minari episode (Dict observations, actions,
rewards, terminations, truncations, and ``is_success``/``error``/``max_error`` infos), with the
environment's spec recorded, so ``minari.load_dataset(id).recover_environment()`` makes the
environment again in any process (the spec names its entry point). Episode ``i`` is the
``i``-th train task of the suite; it ends on success, as the environment does.

:func:`export_transitions` turns a ``dlo collect transitions`` file into one dataset
per environment: the head-held episodes for ``DLOEndpoint-v0``, the two-handed ones for
``DLODualEndpoint-v0`` (tail-held episodes have no environment and are left out). A step is one
straight move: the recorded spec wraps the environment in
:class:`dlo_env.straight_moves.StraightMoves`, whose action is the displacement of the held
end(s) in metres. Each episode is replayed in that environment from its recorded start, with
the shape after its last move as the goal (and its pegs, in an environment observing as many
peg slots as the file has), so the dataset holds the environment's own observations, rewards
and infos; the replayed shapes of every environment are checked against the file's before any
dataset is written.

Datasets are written with Minari's own ``create_dataset_from_buffers`` into Minari's dataset
root (``$MINARI_DATASETS_PATH`` or ``~/.minari/datasets``) or the ``root`` given. Ids:
``dlo/endpoint/linear-1-oracle-v0``, ``dlo/dual-endpoint/linear-2-oracle-v0``, ...,
``dlo/endpoint/transitions-v0``.

Needs the ``minari`` extra (``minari`` with ``h5py``).
"""

from __future__ import annotations

import contextlib
import os
import re
import warnings
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from dlo_env.cord import MAX_PEGS, PEG_RADIUS, CordParams
from dlo_env.dataset.transitions import GRASP_NAMES, load_transitions
from dlo_env.envs import ENVIRONMENTS
from dlo_env.errors import InputError
from dlo_env.shapes import error
from dlo_env.straight_moves import StraightMoves
from dlo_env.tasks import SUITES, load_suite, suite_max_steps

#: Namespace of every exported dataset.
NAMESPACE = "dlo"
#: The infos recorded at every step.
INFO_KEYS = ("is_success", "error", "max_error")
#: Largest ``error`` (metres) between a replayed transition and the file's that is accepted.
REPLAY_TOLERANCE = 1e-3
#: What a transition dataset's ``name`` may hold (it becomes part of a Minari id).
NAME_PATTERN = re.compile(r"[A-Za-z0-9_]+(-[A-Za-z0-9_]+)*")


@dataclass(frozen=True)
class ExportedDataset:
    """One dataset written.

    Attributes:
        dataset_id: Its Minari id.
        episodes: Episodes in it.
        steps: Steps (actions) in it.
        solved: Episodes that end solved.
        replay_error: Largest ``error`` between a replayed shape and the recorded one, metres
            (transition data; 0 for demonstrations, which are recorded as they are run).
    """

    dataset_id: str
    episodes: int
    steps: int
    solved: int
    replay_error: float = 0.0


def demonstrations_id(env_id: str, suite: str, version: int = 0) -> str:
    """Minari id of the oracle demonstrations of ``suite`` in ``env_id``."""
    if env_id not in ENVIRONMENTS:
        raise InputError(f"env_id must be one of {tuple(ENVIRONMENTS)}, got {env_id!r}")
    if suite not in SUITES:
        raise InputError(f"suite must be one of {tuple(SUITES)}, got {suite!r}")
    return f"{NAMESPACE}/{ENVIRONMENTS[env_id][1]}/{suite}-oracle-v{version}"


@contextlib.contextmanager
def minari_root(root: str | os.PathLike[str] | None) -> Iterator[None]:
    """Within the block, Minari reads and writes datasets under ``root`` (None: its default).

    Minari takes its root only from ``$MINARI_DATASETS_PATH``; the variable is restored after.
    """
    if root is None:
        yield
        return
    old = os.environ.get("MINARI_DATASETS_PATH")
    # Absolute: Minari joins a relative root onto itself when it writes the episodes.
    os.environ["MINARI_DATASETS_PATH"] = os.path.abspath(root)
    try:
        yield
    finally:
        if old is None:
            del os.environ["MINARI_DATASETS_PATH"]
        else:
            os.environ["MINARI_DATASETS_PATH"] = old


def _stack(items: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    return {k: np.stack([item[k] for item in items]) for k in items[0]}


def record_episode(env: gym.Env, options: dict[str, Any], actions: np.ndarray,
                   stop_on_success: bool = True) -> Any:
    """Reset ``env`` with ``options`` and run ``actions``; a Minari ``EpisodeBuffer`` of it.

    The episode stops on truncation, and on success when ``stop_on_success``.
    """
    from minari.data_collector import EpisodeBuffer

    obs, info = env.reset(options=options)
    observations, infos = [obs], [info]
    rewards, terminations, truncations, taken = [], [], [], []
    for action in actions:
        obs, reward, terminated, truncated, info = env.step(action)
        observations.append(obs)
        infos.append(info)
        taken.append(np.asarray(action, dtype=np.float32))
        rewards.append(float(reward))
        terminations.append(bool(terminated))
        truncations.append(bool(truncated))
        if truncated or (terminated and stop_on_success):
            break
    return EpisodeBuffer(
        observations=_stack(observations),
        actions=np.stack(taken),
        rewards=rewards,
        terminations=terminations,
        truncations=truncations,
        infos={k: np.array([i[k] for i in infos]) for k in INFO_KEYS},
    )


def export_demonstrations(
    env_id: str,
    suite: str,
    *,
    root: str | os.PathLike[str] | None = None,
    limit: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> ExportedDataset:
    """Write the oracle demonstrations of ``suite``'s train split in ``env_id`` as a dataset.

    Args:
        env_id: ``"dlo_env/DLOEndpoint-v0"`` or ``"dlo_env/DLODualEndpoint-v0"``.
        suite: A named suite (``dlo_env.tasks.SUITES``); its episodes last
            ``suite_max_steps(suite)`` steps.
        root: Minari dataset root (None: Minari's own).
        limit: Only the first ``limit`` train tasks (all 200 if None).
        progress: ``progress(done, 0)`` after every episode.

    Raises:
        ValueError: For a bad argument, or when the dataset already exists (Minari never
            overwrites one: delete it with ``minari delete ID``).
    """
    dataset_id = demonstrations_id(env_id, suite)
    check_absent([dataset_id], root)
    grasp = ENVIRONMENTS[env_id][0]
    tasks = load_suite(suite, "train", grasp=grasp, limit=limit)
    env = gym.make(env_id, max_episode_steps=suite_max_steps(suite))
    buffers = []
    for task in tasks:
        buffers.append(record_episode(env, {"task": task}, task.reference_actions))
        if progress is not None:
            progress(1, 0)
    spec = env.spec  # with this suite's episode length
    env.close()
    description = (f"Oracle demonstrations: the reference_actions of the {len(tasks)} train "
                   f"tasks of suite {suite} (dlo_env.tasks.load_suite), episode i being task i; "
                   "an episode ends on success.")
    _write(dataset_id, buffers, spec, "oracle", description, root)
    return _summary(dataset_id, buffers)


def _summary(dataset_id: str, buffers: list[Any], replay_error: float = 0.0) -> ExportedDataset:
    return ExportedDataset(dataset_id, len(buffers), sum(len(b.rewards) for b in buffers),
                           sum(bool(b.infos["is_success"][-1]) for b in buffers), replay_error)


def _write(dataset_id: str, buffers: list[Any], spec: gym.envs.registration.EnvSpec,
           algorithm: str, description: str, root: str | os.PathLike[str] | None) -> None:
    import minari

    check_absent([dataset_id], root)
    with minari_root(root):
        with warnings.catch_warnings():
            # The project has no contact address or code link to record; Minari asks for them.
            warnings.filterwarnings("ignore", message="`author_email` is set to None")
            warnings.filterwarnings("ignore", message="`code_permalink` is set to None")
            minari.create_dataset_from_buffers(
                dataset_id, buffers, env=spec, eval_env=spec, algorithm_name=algorithm,
                author="dlo", description=description, requirements=["dlo"],
                data_format="hdf5")


def check_absent(dataset_ids: Iterable[str], root: str | os.PathLike[str] | None) -> None:
    """Raise ``ValueError`` naming the first of ``dataset_ids`` that ``root`` (None: Minari's
    own) already holds: Minari never overwrites a dataset, so an export checks before it
    records."""
    import minari

    with minari_root(root):
        existing = set(minari.list_local_datasets())
    for dataset_id in dataset_ids:
        if dataset_id in existing:
            raise InputError(f"dataset {dataset_id!r} already exists; delete it (`minari delete "
                             f"{dataset_id}`) or choose another root")


def check_name(name: object) -> str:
    """``name`` if it can be a dataset name inside a Minari id, else a one-line ``ValueError``."""
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name) or re.search(
            r"-v\d+$", name):
        raise InputError("name must be letters, digits, '_' and inner '-' (not ending in "
                         f"-vN: Minari adds the version), got {name!r}")
    return name


def transitions_id(env_id: str, name: str = "transitions", version: int = 0) -> str:
    """Minari id of the transition data of ``env_id`` exported under ``name``."""
    if env_id not in ENVIRONMENTS:
        raise InputError(f"env_id must be one of {tuple(ENVIRONMENTS)}, got {env_id!r}")
    return f"{NAMESPACE}/{ENVIRONMENTS[env_id][1]}/{check_name(name)}-v{version}"


def transitions_ids(path: str | os.PathLike[str], name: str = "transitions") -> list[str]:
    """The ids ``export_transitions(path, name=name)`` writes, one per environment with
    episodes in the file.

    Raises:
        ValueError: For a bad file (see ``export_transitions``) or name.
    """
    return list(_held_environments(_default_cord_transitions(path), name))


def _held_environments(data: Any, name: str) -> dict[str, str]:
    """``{dataset id: env id}`` of the environments with episodes in the transitions ``data``."""
    return {transitions_id(env_id, name): env_id for env_id, (grasp, _) in ENVIRONMENTS.items()
            if (data.grasp == GRASP_NAMES.index(grasp)).any()}


def _default_cord_transitions(path: str | os.PathLike[str]) -> Any:
    """The transition file at ``path``, refused unless collected on the default cord."""
    data = load_transitions(path)
    if len(data) and (data.params != data.params[0]).any():
        raise InputError(f"path {str(path)!r} holds transitions of several cords (collected "
                         "with --randomize); only default-cord transitions are exported")
    if data.one_cord(f"path {str(path)!r}") != CordParams():
        raise InputError(f"path {str(path)!r} was collected on another cord than the "
                         "environments' default; only default-cord transitions are exported")
    if data.pegs.shape[1] > MAX_PEGS:
        raise InputError(f"path {str(path)!r} has {data.pegs.shape[1]} peg slots, more than an "
                         f"environment observes ({MAX_PEGS})")
    return data


def export_transitions(
    path: str | os.PathLike[str],
    *,
    name: str = "transitions",
    root: str | os.PathLike[str] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[ExportedDataset]:
    """Write the head-held and the two-handed episodes of a transition file as datasets.

    Args:
        path: A file written by ``dlo collect transitions``.
        name: Dataset name inside the ids (``dlo/endpoint/NAME-v0``).
        root: Minari dataset root (None: Minari's own).
        progress: ``progress(moves, 0)`` after every episode.

    Returns:
        One entry per environment that has episodes in the file.

    Raises:
        ValueError: For a bad file, an existing dataset, or a replay that does not reproduce
            the file (another cord or simulator version): one line naming the largest error.
    """
    data = _default_cord_transitions(path)
    held = _held_environments(data, name)
    check_absent(held, root)
    slots = int(data.pegs.shape[1])  # peg slots: the environments observe as many
    peg_radius = float(data.metadata.get("collect", {}).get("peg_radius", PEG_RADIUS))
    pegs_kwargs = {"max_pegs": slots, "peg_radius": peg_radius} if slots else {}
    replayed = []  # every environment's episodes are replayed and checked before any is written
    for dataset_id, env_id in held.items():
        grasp = ENVIRONMENTS[env_id][0]
        mine = data.subset(data.grasp == GRASP_NAMES.index(grasp))
        moves = int(np.bincount(mine.episode).max())
        env = StraightMoves(gym.make(env_id, max_episode_steps=100 * moves, **pegs_kwargs))
        buffers, worst = [], 0.0
        for episode in np.unique(mine.episode):
            rows = np.flatnonzero(mine.episode == episode)
            rows = rows[np.argsort(mine.step[rows])]
            displacement = mine.displacement[rows].reshape(len(rows), 4)
            actions = displacement if grasp == "both" else displacement[:, :2]
            options = {"start": mine.start[rows[0]], "goal": mine.next[rows[-1]]}
            if slots:  # an episode's pegs stand through all its moves
                options["pegs"] = mine.peg_list(rows[0])
            buffer = record_episode(env, options, actions, stop_on_success=False)
            shapes = buffer.observations["achieved_goal"][1:].reshape(mine.next[rows].shape)
            worst = max(worst, float(np.max(error(shapes, mine.next[rows]))))
            buffers.append(buffer)
            if progress is not None:
                progress(len(rows), 0)
        env_spec = env.spec
        env.close()
        if worst > REPLAY_TOLERANCE:
            raise InputError(f"path {str(path)!r}: replaying its {grasp} moves gives shapes up "
                             f"to {worst:.4f} m from the recorded ones (tolerance "
                             f"{REPLAY_TOLERANCE} m): collected with another simulator version?")
        replayed.append((dataset_id, grasp, buffers, env_spec, worst))
    written = []
    for dataset_id, grasp, buffers, env_spec, worst in replayed:
        among = f", among up to {slots} pegs (each episode's in its reset options)" if slots else ""
        description = (f"Transition data of {Path(path).name} ({grasp} held{among}): one "
                       "episode per collected episode, one step per straight move "
                       "(StraightMoves wrapper: action = displacement of the held end(s), "
                       "metres), goal = the shape after the last move; termination flags as the "
                       "environment reports.")
        _write(dataset_id, buffers, env_spec, "dlo collect transitions", description,
               root)
        written.append(_summary(dataset_id, buffers, worst))
    return written
