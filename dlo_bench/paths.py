"""Where the harness reads shipped models and writes its outputs.

Shipped files are found relative to the package, never the current folder, so an installed copy
finds them too. Commands write under ``runs/<command>`` (ignored by git) unless told otherwise;
nothing overwrites a tracked file by default.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path
from typing import Any

from dlo_env.errors import InputError

#: Folder every command writes under unless ``--out`` says otherwise (git-ignored).
RUNS_DIR = Path("runs")
#: Folder of the shipped Stable-Baselines3 baselines, one ``dlo baseline`` folder per agent.
PRETRAINED_BASELINES = Path(str(resources.files("dlo_bench") / "pretrained"))


def default_out(command: str) -> Path:
    """The output folder of ``dlo <command>`` when no ``--out`` is given: ``runs/<command>``."""
    return RUNS_DIR / command


def baseline_folder_name(name: str, env_id: str = "dlo_env/DLOEndpoint-v0",
                         pegs: bool = False) -> str:
    """The folder of an RL agent for an environment in a baselines folder: ``ppo`` for
    ``DLOEndpoint-v0``, ``ppo-dual-endpoint`` for ``DLODualEndpoint-v0``; with ``pegs`` (an
    environment that observes pegs, ``dlo baseline --max-pegs``) ``ppo-pegs``,
    ``ppo-pegs-dual-endpoint``."""
    from dlo_env.envs import ENVIRONMENTS

    if env_id not in ENVIRONMENTS:
        raise InputError(f"env_id must be one of {tuple(ENVIRONMENTS)}, got {env_id!r}")
    name = f"{name}-pegs" if pegs else name
    return name if env_id == "dlo_env/DLOEndpoint-v0" else f"{name}-{ENVIRONMENTS[env_id][1]}"


def shipped_baseline(name: str, env_id: str = "dlo_env/DLOEndpoint-v0",
                     pegs: bool = False) -> Path:
    """The folder of the shipped baseline ``name`` (``ppo``, ``sac-her``, ``bc``) for
    ``env_id`` (``pegs``: the one trained where pegs are observed)."""
    return PRETRAINED_BASELINES / baseline_folder_name(name, env_id, pegs)


def shape_model_file(path: str | os.PathLike | None) -> Path:
    """The file of a shape model: ``path`` (a file, or a folder holding ``model.pt``), or the
    shipped ``latent_model/pretrained/model.pt`` when None or empty."""
    from latent_model.shape_model import MODEL_FILE

    if not path:
        return Path(str(resources.files("latent_model") / "pretrained" / MODEL_FILE))
    p = Path(path)
    return p / MODEL_FILE if p.is_dir() else p


def transition_model_file(path: str | os.PathLike | None, cords: bool = False,
                          pegs: bool = False, cord: Any = None) -> Path:
    """The file of a transition model: ``path`` (a file, or a folder holding
    ``transition.pt``), or when None the shipped ``latent_model/pretrained/transition.pt``
    (``transition-cords.pt`` with ``cords``: the model of several cords, or the one fine-tuned
    for ``cord``; ``transition-pegs.pt`` with ``pegs``: the model that sees pegs)."""
    from latent_model.transition_model import MODEL_FILE, pretrained_file

    if not path:
        name = pretrained_file(cords, pegs, cord)
        return Path(str(resources.files("latent_model") / "pretrained" / name))
    p = Path(path)
    return p / MODEL_FILE if p.is_dir() else p
