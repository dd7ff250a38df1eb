"""Errors a user can act on: one line on stderr naming what to fix, exit status 2, no traceback.

``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import subprocess
import sys

import numpy as np
import pytest

from dlo_cli.errors import EXTRAS
from dlo_cli.main import main


def _one_line_error(capsys, code: int) -> str:
    assert code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_a_missing_data_file_is_one_line(tmp_path, capsys):
    line = _one_line_error(capsys, main(["train", "shape", "--data", str(tmp_path / "nope.npz"),
                                         "--out", str(tmp_path / "run")]))
    assert line.startswith("dlo train shape: error:") and "nope.npz" in line


def test_a_corrupt_data_file_is_one_line_that_says_so(tmp_path, capsys):
    bad = tmp_path / "corrupt.npz"
    bad.write_bytes(b"this is not an npz archive")
    line = _one_line_error(capsys, main(["train", "shape", "--data", str(bad), "--out",
                                         str(tmp_path / "run")]))
    assert "not a readable .npz file" in line and "pickled" not in line


def test_an_unknown_suite_is_one_line_naming_the_suites(tmp_path, capsys):
    line = _one_line_error(capsys, main(["evaluate", "--agent", "straight-line", "--suite",
                                         "linear-9", "--out", str(tmp_path)]))
    assert "linear-9" in line and "linear-1" in line


def test_an_unknown_agent_is_one_line_naming_the_agents(tmp_path, capsys):
    line = _one_line_error(capsys, main(["evaluate", "--agent", "teleport", "--out",
                                         str(tmp_path)]))
    assert "teleport" in line and "straight-line" in line


def test_an_agent_in_an_environment_it_does_not_act_in_is_one_line(tmp_path, capsys,
                                                                   monkeypatch):
    # Every registered agent acts in both environments; one that does not is refused.
    from dataclasses import replace

    from dlo_bench import agents

    spec = replace(agents.AGENTS["straight-line"], environments=("dlo_env/DLOEndpoint-v0",))
    monkeypatch.setitem(agents.AGENTS, "straight-line", spec)
    line = _one_line_error(capsys, main(["evaluate", "--agent", "straight-line", "--env",
                                         "dlo_env/DLODualEndpoint-v0", "--out", str(tmp_path)]))
    assert "--agent straight-line acts in dlo_env/DLOEndpoint-v0" in line and "--env" in line


def test_a_shape_model_for_another_cord_is_one_line(tmp_path, capsys):
    from latent_model import ShapeModel
    from latent_model.config import ModelConfig
    from latent_model.normalisation import Normalisation

    ShapeModel(ModelConfig(n_points=12), Normalisation(), device="cpu").save(tmp_path / "m.pt")
    line = _one_line_error(capsys, main(["evaluate", "--agent", "latent-tree", "--model",
                                         str(tmp_path / "m.pt"), "--out", str(tmp_path)]))
    assert "n_points=12" in line and "n_points=20" in line


def test_a_missing_optional_dependency_names_the_extra_that_installs_it(monkeypatch, capsys):
    def run(args):
        raise ModuleNotFoundError("No module named 'stable_baselines3'", name="stable_baselines3")

    monkeypatch.setattr("dlo_cli.baseline.run", run)
    line = _one_line_error(capsys, main(["baseline", "--algo", "ppo"]))
    assert 'pip install "dlo[rl]"' in line and 'pip install -e ".[rl]"' in line


def test_every_optional_dependency_maps_to_an_extra_of_the_package():
    from pathlib import Path

    tomllib = pytest.importorskip("tomllib")  # Python 3.11+

    pyproject = tomllib.loads((Path(__file__).parents[2] / "pyproject.toml").read_text())
    assert set(EXTRAS.values()) <= set(pyproject["project"]["optional-dependencies"])


def test_debug_shows_the_traceback_instead(tmp_path):
    with pytest.raises(FileNotFoundError):
        main(["--debug", "train", "shape", "--data", str(tmp_path / "nope.npz"), "--out",
              str(tmp_path)])
    with pytest.raises(FileNotFoundError):
        main(["train", "shape", "--debug", "--data", str(tmp_path / "nope.npz"), "--out",
              str(tmp_path)])


def test_version_prints_the_package_version(capsys):
    from importlib import metadata

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"dlo {metadata.version('dlo')}"


def test_every_flag_of_every_command_has_help(capsys):
    from dlo_cli.main import build_parser

    def check(parser, words):
        for action in parser._actions:  # noqa: SLF001 (argparse has no API to list them)
            if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
                for name, sub in action.choices.items():
                    check(sub, f"{words} {name}")
            else:
                assert action.help, f"{words} {action.option_strings} has no help"

    check(build_parser(), "dlo")


def test_collect_runs_on_the_core_install_without_tqdm_torch_or_matplotlib(tmp_path):
    out = tmp_path / "d.npz"
    blocked = "; ".join(f"sys.modules[{m!r}] = None" for m in ("tqdm", "torch", "matplotlib"))
    code = (f"import sys; {blocked}; from dlo_cli.main import main; "
            f"sys.exit(main(['collect', 'shapes', '--num-shapes', '30', '--out', {str(out)!r}]))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    with np.load(out, allow_pickle=False) as data:
        assert data["shapes"].shape == (30, 20, 2)


@pytest.mark.parametrize("subcommand, flags", [
    ("shape --stage gan", ["--teacher", "model.pt"]),
    ("shape", ["--lr", "1e-3"]),
    ("shape --stage encoder", ["--peg-reach", "0.1"]),
    ("transition", ["--gan-steps", "5"]),
    ("transition", ["--minutes", "3"]),
    ("transition", ["--report-size", "9"]),
    ("shape", ["--miss-weight", "0"]),
    ("transition", ["--minutes", "0"]),
    ("shape --stage gan", ["--contact-reach", "0.03"]),
    ("shape", ["--mean-by-grasp"]),
    ("transition", ["--stage", "gan"]),
])
def test_a_flag_of_the_other_training_is_one_line_naming_it(subcommand, flags, tmp_path,
                                                            capsys):
    line = _one_line_error(capsys, main(["train", *subcommand.split(), "--data",
                                         str(tmp_path / "x.npz"), "--out", str(tmp_path / "r"),
                                         *flags]))
    name = subcommand.split()[0]
    assert line == f"dlo train {name}: error: unrecognized arguments: {' '.join(flags)}"
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("flag", ["--miss-weight", "--miss-margin", "--teacher-weight",
                                  "--contact-reach"])
@pytest.mark.parametrize("value", ["-1", "inf", "nan"])
def test_a_loss_weight_that_is_negative_or_not_finite_is_refused_before_any_data_loads(
        flag, value, tmp_path, capsys):
    line = _one_line_error(capsys, main(["train", "transition", "--data",
                                         str(tmp_path / "x.npz"), "--out", str(tmp_path / "r"),
                                         flag, value]))
    assert line == (f"dlo train transition: error: argument {flag}: expected a number >= 0, "
                    f"got '{value}'")
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("error", [ValueError("operands could not be broadcast together"),
                                   IndexError("index 20 is out of bounds for axis 0"),
                                   OSError(5, "Input/output error", "/elsewhere/cache.bin")])
def test_an_internal_error_keeps_its_traceback(error, tmp_path, monkeypatch):
    # A library bug (here a numpy-like error deep in collection) is not a user error: it
    # propagates, so the interpreter prints its traceback and exits with status 1.
    def collect(*args, **kwargs):
        raise error

    monkeypatch.setattr("dlo_env.dataset.collect.collect", collect)
    with pytest.raises(type(error), match=str(error.args[-1])):
        main(["collect", "shapes", "--num-shapes", "5", "--out", str(tmp_path / "d.npz")])


def test_an_internal_error_prints_its_traceback_and_exits_1(tmp_path):
    code = ("import sys, dlo_env.dataset.collect as c\n"
            "def collect(*args, **kwargs):\n"
            "    raise ValueError('operands could not be broadcast together')\n"
            "c.collect = collect\n"
            "from dlo_cli.main import main\n"
            f"sys.exit(main(['collect', 'shapes', '--num-shapes', '5', '--out', "
            f"{str(tmp_path / 'd.npz')!r}]))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 1
    assert "Traceback (most recent call last)" in done.stderr
    assert "ValueError: operands could not be broadcast together" in done.stderr


def test_an_input_error_from_a_library_is_one_line_naming_the_flag_of_its_field(tmp_path, capsys):
    line = _one_line_error(capsys, main(["collect", "shapes", "--num-shapes", "5",
                                         "--grasp-weights", "0", "0", "3",
                                         "--out", str(tmp_path / "d.npz")]))
    assert line.startswith("dlo collect shapes: error: argument --grasp-weights: grasp_weights "
                           "must be 3 non-negative weights")


def test_the_machine_refusing_a_path_the_command_line_names_is_one_line(tmp_path, capsys,
                                                                         monkeypatch):
    out = tmp_path / "d.npz"

    def collect(*args, **kwargs):
        raise PermissionError(13, "Permission denied", str(out))

    monkeypatch.setattr("dlo_env.dataset.collect.collect", collect)
    line = _one_line_error(capsys, main(["collect", "shapes", "--num-shapes", "5", "--out",
                                         str(out)]))
    assert line == f"dlo collect shapes: error: {out}: Permission denied"
