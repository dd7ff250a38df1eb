"""Where the harness reads shipped models and writes its outputs.

Shipped files are found relative to the package, never the current folder, so an installed copy
finds them too. Commands write under ``runs/<command>`` (ignored by git) unless told otherwise;
nothing overwrites a tracked file by default.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

#: Folder every command writes under unless ``--out`` says otherwise (git-ignored).
RUNS_DIR = Path("runs")
#: Folder of the shipped Stable-Baselines3 baselines, one ``dlo baseline`` folder per agent.
PRETRAINED_BASELINES = Path(str(resources.files("dlo_bench") / "pretrained"))


def default_out(command: str) -> Path:
    """The output folder of ``dlo <command>`` when no ``--out`` is given: ``runs/<command>``."""
    return RUNS_DIR / command


def shipped_baseline(name: str) -> Path:
    """The folder of the shipped baseline ``name`` (``ppo``, ``sac-her``)."""
    return PRETRAINED_BASELINES / name


def shape_model_file(path: str | os.PathLike | None) -> Path:
    """The file of a shape model: ``path`` (a file, or a folder holding ``model.pt``), or the
    shipped ``latent_model/pretrained/model.pt`` when None or empty."""
    from latent_model.shape_model import MODEL_FILE

    if not path:
        return Path(str(resources.files("latent_model") / "pretrained" / MODEL_FILE))
    p = Path(path)
    return p / MODEL_FILE if p.is_dir() else p
