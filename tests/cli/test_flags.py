"""The flags read the same on every command: one name for the environment, one seed, one
difficulty range, one default of episodes for quick looks, and every default stated once."""

from __future__ import annotations

import argparse
import re

import pytest

from dlo_cli.flags import DEFAULT_EPISODES, HelpFormatter, env_id_type
from dlo_cli.main import build_parser, main

ENDPOINT = "dlo_env/DLOEndpoint-v0"
DUAL = "dlo_env/DLODualEndpoint-v0"


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    return parser._subparsers._group_actions[0].choices  # noqa: SLF001 (argparse has no API)


def _parse(*argv: str) -> argparse.Namespace:
    return build_parser().parse_args(list(argv))


@pytest.mark.parametrize("given", [DUAL, "DLODualEndpoint-v0", f"dlo_env:{DUAL}"])
def test_env_takes_the_full_id_the_bare_name_and_the_module_qualified_id(given):
    assert _parse("evaluate", "--agent", "straight-line", "--env", given).env_id == DUAL
    assert _parse("baseline", "--algo", "ppo", "--env", given).env_id == DUAL
    assert _parse("benchmark", "--env", given, ENDPOINT).env == [DUAL, ENDPOINT]
    assert _parse("export-minari", "--env", given).env == [DUAL]


def test_env_id_is_a_hidden_deprecated_alias_of_env(capsys):
    assert _parse("evaluate", "--agent", "straight-line", "--env-id",
                  "DLODualEndpoint-v0").env_id == DUAL
    assert _parse("baseline", "--algo", "ppo", "--env-id", DUAL).env_id == DUAL
    for name in ("evaluate", "baseline"):
        text = _commands()[name].format_help()
        assert "--env ENV_ID" in text and "--env-id" not in text


def test_env_id_type_names_the_value_and_every_accepted_id():
    with pytest.raises(argparse.ArgumentTypeError) as error:
        env_id_type((ENDPOINT, DUAL))("Nope")
    assert "'Nope'" in str(error.value) and ENDPOINT in str(error.value) and DUAL in str(
        error.value)


def test_quick_commands_share_one_default_of_episodes_and_the_benchmark_says_why_it_differs():
    assert DEFAULT_EPISODES == 10
    assert _parse("evaluate", "--agent", "straight-line").episodes == DEFAULT_EPISODES
    benchmark = _commands()["benchmark"].format_help()
    assert "50 tasks per" in re.sub(r"\s+", " ", benchmark)


def test_every_flag_states_its_default_at_most_once():
    for name, sub in _commands().items():
        formatter = HelpFormatter(prog=f"dlo {name}")
        for action in sub._actions:
            if not action.help or action.help == argparse.SUPPRESS:
                continue
            text = formatter._expand_help(action)  # noqa: SLF001 (the text --help prints)
            said = len(re.findall(r"default|None:", text, flags=re.IGNORECASE))
            assert said <= 1, f"dlo {name} {action.option_strings}: {text}"
            assert "(default: None)" not in text and "(default: False)" not in text


def test_lists_in_defaults_read_as_on_the_command_line():
    text = re.sub(r"\s+", " ", _commands()["baseline"].format_help())
    assert "(default: 1 2 3)" in text and "[1, 2, 3]" not in text


def test_the_top_level_help_says_train_also_trains_the_transition_model(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--help"])
    assert stop.value.code == 0
    text = re.sub(r"\s+", " ", capsys.readouterr().out)
    assert "train the shape model (GAN + encoder) on shapes or the transition model" in text
    with pytest.raises(SystemExit):
        main(["train", "--help"])
    text = re.sub(r"\s+", " ", capsys.readouterr().out)
    assert "shape the shape model (GAN + encoder) on shapes" in text
    assert "transition the transition model on transitions" in text


def test_repeated_set_flags_add_up():
    args = _parse("baseline", "--algo", "ppo", "--set", "ppo_n_steps=32", "gamma=0.9",
                  "--set", "ppo_batch_size=32")
    assert args.set == ["ppo_n_steps=32", "gamma=0.9", "ppo_batch_size=32"]


def test_device_takes_what_this_machine_has(capsys):
    import torch

    assert _parse("baseline", "--algo", "ppo", "--device", "cpu").device == "cpu"
    for command in (["train", "shape", "--data", "d.npz"], ["finetune"],
                    ["baseline", "--algo", "ppo"]):
        assert main([*command, "--device", "tpu"]) == 2
        err = capsys.readouterr().err
        assert "--device: expected auto, cpu, cuda, cuda:N or mps, got 'tpu'" in err
        if not torch.cuda.is_available():
            assert main([*command, "--device", "cuda"]) == 2
            assert "this PyTorch sees no CUDA device" in capsys.readouterr().err
