"""Specification: the validators of latent_model raise ``dlo_env.errors.InputError``."""

from __future__ import annotations

import pytest

from dlo_env.errors import InputError, MissingFileError
from latent_model.checkpoint import load_checkpoint
from latent_model.config import ModelConfig
from latent_model.dataset import load_labelled_shapes
from latent_model.transition_model import TransitionModelConfig
from latent_model.transition_training import TransitionTrainConfig


@pytest.mark.parametrize("build", [
    lambda: ModelConfig(n_points=2),
    lambda: ModelConfig(output="angles", representation="world"),
    lambda: TransitionModelConfig(mean_by_grasp=True),
    lambda: TransitionTrainConfig(teacher_moves=4),
])
def test_a_model_or_training_config_check_raises_an_input_error(build):
    with pytest.raises(InputError):
        build()


def test_a_missing_or_foreign_file_raises_an_input_error_naming_its_argument(tmp_path):
    with pytest.raises(MissingFileError, match="--data: no dataset file"):
        load_labelled_shapes(tmp_path / "nope.npz", name="--data")
    with pytest.raises(MissingFileError, match="--model: no checkpoint file"):
        load_checkpoint(tmp_path / "nope.pt", name="--model")
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    with pytest.raises(InputError, match="--model: .*not a readable torch checkpoint"):
        load_checkpoint(bad, name="--model")
