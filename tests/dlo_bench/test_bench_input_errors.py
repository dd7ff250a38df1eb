"""Specification: the validators of dlo_bench raise ``dlo_env.errors.InputError``, naming the
config field they are about."""

from __future__ import annotations

import pytest

from dlo_bench.agents import agent_spec
from dlo_bench.benchmark import BenchmarkConfig
from dlo_env.errors import InputError, MissingFileError


@pytest.mark.parametrize("build, fields", [
    (lambda: BenchmarkConfig(thresholds=(0.01, 0.01)), ("thresholds",)),
    (lambda: BenchmarkConfig(episodes=0), ("episodes",)),
    (lambda: BenchmarkConfig(envs=("dlo_env/Nope-v0",)),
     ("envs", "designed_envs", "cord_envs", "peg_envs")),
    (lambda: agent_spec("teleport"), ()),
])
def test_a_benchmark_check_raises_an_input_error_naming_its_fields(build, fields):
    with pytest.raises(InputError) as info:
        build()
    assert info.value.fields == fields


def test_a_baseline_config_check_names_its_field():
    pytest.importorskip("stable_baselines3")
    from dlo_bench.baselines import BaselineConfig

    with pytest.raises(InputError) as info:
        BaselineConfig(gamma=2.0)
    assert info.value.fields == ("gamma",)


def test_a_missing_sb3_model_is_a_missing_file_error(tmp_path):
    pytest.importorskip("stable_baselines3")
    from dlo_bench.sb3_models import find_sb3

    with pytest.raises(MissingFileError):
        find_sb3(tmp_path / "nope")


def test_an_environment_without_default_difficulties_is_refused_not_given_1_2_3(monkeypatch):
    """The linear cells of an environment come from DEFAULT_DIFFICULTIES; one registered
    without an entry there is refused in one line (it silently ran linear-1..3 before)."""
    import dlo_bench.benchmark.config as config_module

    monkeypatch.setitem(config_module.ENVIRONMENTS, "dlo_env/Other-v0", None)
    with pytest.raises(InputError, match="no default difficulties"):
        BenchmarkConfig(envs=("dlo_env/Other-v0",))
    assert BenchmarkConfig(envs=("dlo_env/Other-v0",), difficulties=(1,)).cells()[0][:2] == (
        "dlo_env/Other-v0", "linear-1")
