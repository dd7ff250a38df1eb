"""A trained SB3 policy as what acting needs: ``policy.pt``, the weights of its actor alone.

An SB3 ``model.zip`` holds everything training needs: the critics (SAC's two and their
targets, PPO's value network) and every optimizer's moments. To act, a policy needs only its
actor: ``policy.pt`` holds those weights, a plain ``torch.save`` of tensors that
``torch.load(weights_only=True)`` reads. The model is rebuilt from its config (the folder's
``hyperparameters.json``) and the weights loaded into it; it acts exactly as the model it came
from. The shipped baselines are such folders; ``dlo baseline`` and ``train_bc`` write
``policy.pt`` beside ``model.zip``, and running an agent's training command again rebuilds the
full ``model.zip`` (``AgentSpec.train`` in :mod:`dlo_bench.agents` names the command).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from dlo_env.core.atomic import atomic_path
from dlo_env.errors import InputError

#: The file of a folder holding the acting weights.
POLICY_FILE = "policy.pt"
#: State-dict prefixes of an SB3 policy that only learning reads (critics, value networks).
LEARNING_ONLY = ("critic.", "critic_target.", "value_net.", "mlp_extractor.value_net.",
                 "vf_features_extractor.")


def weights_file(folder: str | os.PathLike) -> Path:
    """The file a baseline ``folder`` acts from: its ``model.zip`` (a run of ``dlo baseline``)
    or, where there is none, its ``policy.pt`` (a shipped folder)."""
    folder = Path(folder)
    return folder / "model.zip" if (folder / "model.zip").is_file() else folder / POLICY_FILE


def acting_weights(policy: Any) -> dict[str, Any]:
    """The entries of ``policy``'s state dict that acting reads, on the CPU."""
    return {k: v.detach().cpu().clone() for k, v in policy.state_dict().items()
            if not k.startswith(LEARNING_ONLY)}


def write_policy_file(model: Any, path: str | os.PathLike) -> Path:
    """Write the acting weights of SB3 ``model`` to ``path`` (atomically)."""
    import torch

    path = Path(path)
    with atomic_path(path) as tmp:
        torch.save(acting_weights(model.policy), tmp)
    return path


def load_policy_file(model: Any, path: str | os.PathLike) -> Any:
    """``model`` (an SB3 model built as the one ``path`` came from) with its acting weights
    read from ``path``; its critics keep their initial weights, which acting never reads.

    Raises:
        InputError: If ``path`` is not a weights file, or holds other weights than
            ``model``'s actor (another algorithm or network).
    """
    import torch

    try:
        state = torch.load(path, map_location=model.device, weights_only=True)
    except Exception as exc:  # torch raises many types for a file that is not its own
        raise InputError(f"{path} is not a policy weights file: {exc}") from None
    wanted = acting_weights(model.policy)
    shapes = {k: tuple(v.shape) for k, v in state.items()} if isinstance(state, dict) else {}
    if shapes != {k: tuple(v.shape) for k, v in wanted.items()}:
        raise InputError(f"{path} holds the weights of another policy than its "
                         "hyperparameters.json describes (other keys or shapes)")
    model.policy.load_state_dict(state, strict=False)
    model.policy.set_training_mode(False)
    return model
