"""Specification: every validator of dlo_env raises ``dlo_env.errors.InputError``.

It is a ``ValueError`` (so ``except ValueError`` keeps working), names the field a config check
is about (``fields``, which the ``dlo`` command turns into its flag), and a missing file is a
``MissingFileError``, which is also a ``FileNotFoundError``.
"""

from __future__ import annotations

import pickle

import gymnasium as gym
import pytest

import dlo_env
from dlo_env.cord import CordParams
from dlo_env.dataset.collect import CollectConfig
from dlo_env.dataset.shape_file import load_shapes
from dlo_env.dataset.transitions import TransitionCollectConfig, load_transitions
from dlo_env.errors import InputError, MissingFileError


def test_input_error_is_a_value_error_exported_by_the_package():
    assert issubclass(InputError, ValueError)
    assert dlo_env.InputError is InputError
    assert issubclass(MissingFileError, InputError)
    assert issubclass(MissingFileError, FileNotFoundError)


def test_input_error_keeps_its_fields_through_pickling():
    error = pickle.loads(pickle.dumps(InputError("a must be > 0, got 0", field=("a", "b"))))
    assert str(error) == "a must be > 0, got 0" and error.fields == ("a", "b")
    assert InputError("no field").fields == ()


@pytest.mark.parametrize("build, fields", [
    (lambda: CordParams(length=0.0), ("length",)),
    (lambda: CordParams(n_points=2), ()),
    (lambda: CollectConfig(grasp_weights=(0.0, 0.0, 1.0)), ("grasp_weights",)),
    (lambda: CollectConfig(cosine_threshold=2.0), ("cosine_threshold",)),
    (lambda: TransitionCollectConfig(randomize={"mass": (0.01, 0.3)}), ("randomize",)),
    (lambda: TransitionCollectConfig(rim_fraction=0.8), ("push_fraction", "rim_fraction")),
    (lambda: TransitionCollectConfig(test_cords=True, randomize={"mass": (0.1, 0.2)}),
     ("test_cords", "randomize")),
])
def test_a_config_check_raises_an_input_error_naming_its_fields(build, fields):
    with pytest.raises(InputError) as info:
        build()
    assert info.value.fields == fields


def test_environment_arguments_and_options_raise_input_errors():
    with pytest.raises(InputError, match="max_step"):
        gym.make("dlo_env/DLOEndpoint-v0", max_step=-1.0)
    with gym.make("dlo_env/DLOEndpoint-v0") as env:
        with pytest.raises(InputError, match="unknown keys"):
            env.reset(seed=0, options={"bogus": 1})
        with pytest.raises(InputError, match="difficulty"):
            env.reset(seed=0, options={"difficulty": 0})


def test_a_missing_or_corrupt_dataset_file_raises_an_input_error(tmp_path):
    with pytest.raises(MissingFileError, match="dlo collect shapes"):
        load_shapes(tmp_path / "nope.npz")
    with pytest.raises(MissingFileError, match="dlo collect transitions"):
        load_transitions(tmp_path / "nope.npz")
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not an archive")
    with pytest.raises(InputError, match="bad.npz"):
        load_shapes(bad)
