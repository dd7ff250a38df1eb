"""A bad command line is refused before any work starts.

Every case below prints exactly one line on stderr, ``dlo COMMAND: error: ...`` naming the flag
and the value given, returns exit status 2 with no traceback, and writes nothing: no progress
bar, no training, no output folder. The values a flag takes are checked while the command line
is parsed (``dlo_cli.flags``); what depends on several flags is checked first thing in ``run``.
"""

from __future__ import annotations

import itertools

import pytest

from dlo_cli.main import main


def command_words(argv: list[str]) -> str:
    """The command and subcommand of a command line, as its errors name them."""
    return " ".join(itertools.takewhile(lambda word: not word.startswith("-"), argv))


NOPE_ENV = "dlo_env/Nope-v0"
ACCEPTED_ENVS = ("dlo_env/DLOEndpoint-v0", "dlo_env/DLODualEndpoint-v0")

#: (command line with OUT for the output folder, the flag the line names, other words it holds)
CASES = [
    # One name for the environment on every command; unknown ids name the ids accepted.
    ("evaluate --agent straight-line --env dlo_env/Nope-v0 --out OUT", "--env",
     (NOPE_ENV, *ACCEPTED_ENVS)),
    ("evaluate --agent straight-line --env Nope --out OUT", "--env", ("'Nope'", *ACCEPTED_ENVS)),
    ("evaluate --agent straight-line --env-id Nope --out OUT", "--env-id", ACCEPTED_ENVS),
    ("baseline --algo ppo --env dlo_env/Nope-v0 --out OUT", "--env", (NOPE_ENV, *ACCEPTED_ENVS)),
    ("baseline --algo ppo --env-id Nope --out OUT", "--env-id", ACCEPTED_ENVS),
    ("benchmark --env dlo_env/Nope-v0 --out OUT", "--env", (NOPE_ENV, *ACCEPTED_ENVS)),
    ("benchmark --env DLOEndpoint-v0 Nope --out OUT", "--env", ("'Nope'",)),
    ("export-minari --env dlo_env/Nope-v0 --root OUT", "--env", (NOPE_ENV, *ACCEPTED_ENVS)),
    ("evaluate --agent straight-line --env gymnasium:dlo_env/DLOEndpoint-v0 --out OUT", "--env",
     ("gymnasium:",)),
    # Seeds are integers from 0 to 2**32 - 1 everywhere.
    ("evaluate --agent straight-line --seed -5 --out OUT", "--seed", ("'-5'", "from 0")),
    ("evaluate --agent straight-line --seed 4294967296 --out OUT", "--seed", ("4294967296",)),
    ("baseline --algo ppo --seed -5 --out OUT", "--seed", ("'-5'",)),
    ("benchmark --seed -5 --out OUT", "--seed", ("'-5'",)),
    ("collect shapes --num-shapes 10 --seed -5 --out OUT/d.npz", "--seed", ("'-5'",)),
    ("train shape --data OUT/d.npz --seed -5 --out OUT", "--seed", ("'-5'",)),
    ("finetune --seed 1.5 --model OUT --shapes OUT/s.npz --out OUT", "--seed", ("'1.5'",)),
    # Difficulties are those of the tasks: 1 to dlo_env.tasks.MAX_DIFFICULTY.
    ("evaluate --agent straight-line --difficulty 11 --out OUT", "--difficulty",
     ("'11'", "from 1 to 10")),
    ("evaluate --agent straight-line --difficulty 1 0 --out OUT", "--difficulty", ("'0'",)),
    ("baseline --algo ppo --difficulty 7 --out OUT", "--difficulty", ("'7'", "from 1 to 5")),
    ("benchmark --difficulty 7 --out OUT", "--difficulty", ("'7'", "one of 1 2 3 4 5 8 10")),
    ("benchmark --threshold 0 --out OUT", "--threshold", ("'0'", "metres")),
    ("collect transitions --num-transitions 5 --randomize mass --out OUT.npz",
     "--randomize", ("'mass'", "NAME=LOW:HIGH")),
    ("collect transitions --num-transitions 5 --randomize mass=0.01:0.3 --out OUT.npz",
     "--randomize", ("within 0.05..0.5",)),
    ("benchmark --threshold 0.01 0.01 --out OUT", "--threshold", ("repeat",)),
    ("evaluate --agent straight-line --threshold -1 --out OUT", "--threshold",
     ("'-1'", "metres")),
    # A planning budget is a number of seconds > 0.
    ("evaluate --agent straight-line --max-seconds -1 --out OUT", "--max-seconds", ("'-1'",)),
    ("evaluate --agent straight-line --max-seconds 0 --out OUT", "--max-seconds", ("'0'",)),
    ("benchmark --max-seconds -1 --out OUT", "--max-seconds", ("'-1'",)),
    ("benchmark --max-seconds nan --out OUT", "--max-seconds", ("'nan'",)),
    # Episodes: at least 1, and no more than a suite's split holds.
    ("evaluate --agent straight-line --episodes 0 --out OUT", "--episodes", ("'0'",)),
    ("evaluate --agent straight-line --suite linear-1 --episodes 51 --out OUT", "--episodes",
     ("50", "51")),
    ("benchmark --episodes 0 --out OUT", "--episodes", ("'0'", "1 to 50")),
    ("benchmark --episodes 51 --out OUT", "--episodes", ("'51'", "1 to 50")),
    # Others found by trying.
    ("evaluate --agent teleport --out OUT", "--agent", ("'teleport'", "straight-line")),
    ("benchmark --agent teleport --out OUT", "--agent", ("'teleport'", "straight-line")),
    ("benchmark --agent sb3:runs/ppo --out OUT", "--agent", ("runs/ppo", "no such file")),
    ("evaluate --agent sb3:OUT/nope --out OUT", "--agent", ("nope", "dlo baseline")),
    ("evaluate --out OUT", "--agent", ("required",)),
    ("evaluate --agent straight-line --split nope --out OUT", "--split", ("'nope'", "test")),
    ("evaluate --agent straight-line --suite linear-9 --out OUT", "--suite",
     ("'linear-9'", "linear-1")),
    ("evaluate --agent latent-tree --model OUT/none.pt --out OUT", "--model", ("none.pt",)),
    ("evaluate --agent latent-mpc --transition-model OUT/none.pt --out OUT",
     "--transition-model", ("none.pt",)),
    ("benchmark --model OUT/none.pt --out OUT", "--model", ("none.pt",)),
    ("evaluate --agent straight-line --threads 0 --out OUT", "--threads", ("'0'",)),
    ("evaluate --agent straight-line --address auto --out OUT", "--address", ("--backend ray",)),
    ("evaluate --agent straight-line --bogus --out OUT", "--bogus", ("unrecognized",)),
    ("baseline --algo nope --out OUT", "--algo", ("'nope'", "sac-her")),
    ("baseline --algo ppo --timesteps 0 --out OUT", "--timesteps", ("'0'",)),
    ("baseline --algo ppo --set seed=-5 --out OUT", "--set seed", ("--seed",)),
    ("baseline --algo ppo --set learning_rte=0.1 --out OUT", "--set learning_rte",
     ("unknown key",)),
    ("baseline --algo ppo --set ppo_n_steps=abc --out OUT", "--set ppo_n_steps",
     ("an int >= 1", "'abc'")),
    ("baseline --algo ppo --set ppo_n_steps=-4 --out OUT", "--set ppo_n_steps", ("-4",)),
    ("baseline --algo ppo --set gamma=2 --out OUT", "--set gamma", ("(0, 1]",)),
    ("baseline --algo ppo --set net_arch=[0] --out OUT", "--set net_arch", ("layer sizes",)),
    ("export-minari --suite linear-9 --root OUT", "--suite", ("'linear-9'",)),
    ("export-minari --limit 0 --root OUT", "--limit", ("'0'",)),
    ("export-minari --no-demonstrations --root OUT", "--no-demonstrations", ("--transitions",)),
    ("collect shapes --num-shapes 10 --out OUT/d.txt", "--out", ("d.txt", ".npz")),
    # A flag of the other subcommand is not one of this one's.
    ("collect shapes --num-shapes 10 --num-transitions 5 --out OUT/d.npz", "--num-transitions",
     ("unrecognized arguments",)),
    ("collect shapes --num-shapes 10 --max-pegs 2 --out OUT/d.npz", "--max-pegs",
     ("unrecognized arguments",)),
    ("collect transitions --num-transitions 5 --record-every 5 --out OUT/d.npz",
     "--record-every", ("unrecognized arguments",)),
    ("collect transitions --num-transitions 5 --cosine-threshold 0.5 --out OUT/d.npz",
     "--cosine-threshold", ("unrecognized arguments",)),
    ("train shape --data OUT/d.npz --lr 0.1 --out OUT", "--lr", ("unrecognized arguments",)),
    ("train transition --data OUT/d.npz --gan-steps 5 --out OUT", "--gan-steps",
     ("unrecognized arguments",)),
    ("collect transitions --num-transitions 5 --max-pegs 17 --out OUT/d.npz",
     "--max-pegs", ("'17'", "from 0 to 16")),
    ("train transition --data OUT/d.npz --lr -1 --out OUT", "--lr", ("'-1'",)),
    ("finetune --model OUT/none --shapes OUT/s.npz --out OUT", "--model", ("none",)),
]


@pytest.mark.parametrize("line, flag, words", CASES, ids=[c[0].replace(" OUT", "")
                                                        for c in CASES])
def test_a_bad_input_is_one_line_naming_the_flag_before_any_work(line, flag, words, tmp_path,
                                                                  capsys):
    out = tmp_path / "out"
    argv = line.replace("OUT", str(out)).split()
    code = main(argv)
    captured = capsys.readouterr()
    lines = [text for text in captured.err.splitlines() if text.strip()]
    assert code == 2, captured.err
    assert len(lines) == 1, captured.err
    assert "Traceback" not in captured.err
    assert lines[0].startswith(f"dlo {command_words(argv)}: error: "), lines[0]
    assert flag in lines[0]
    for word in words:
        assert word in lines[0], lines[0]
    assert captured.out == ""
    assert not out.exists()



#: Commands with an output folder (FILE is an existing file) or file, refused before any work.
BAD_OUTS = [
    ("evaluate --agent straight-line --episodes 1 --out FILE", "--out must be a folder, got"),
    ("evaluate --agent straight-line --episodes 1 --out FILE/sub", "this user can write"),
    ("demo --episodes 1 --out FILE", "--out must be a folder, got"),
    ("benchmark --quick --allow-dirty --out FILE/sub", "this user can write"),
    ("reference --limit 1 --out FILE", "--out must be a folder, got"),
    ("baseline --algo ppo --timesteps 8 --out FILE", "--out must be a folder, got"),
    ("collect shapes --num-shapes 10 --out FILE/d.npz", "a file in a folder this user can write"),
    ("collect transitions --num-transitions 5 --out FILE/d.npz",
     "a file in a folder this user can write"),
]


def test_a_baseline_never_replaces_a_finished_run(tmp_path, capsys):
    (tmp_path / "model.zip").write_text("the user's model")
    for resume in ([], ["--resume"]):
        code = main(["baseline", "--algo", "ppo", "--timesteps", "8", "--out", str(tmp_path),
                     *resume])
        captured = capsys.readouterr()
        assert code == 2 and captured.out == ""
        assert "--out" in captured.err and "holds a finished run (model.zip)" in captured.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.zip"]


@pytest.mark.parametrize("line, words", BAD_OUTS, ids=[c[0] for c in BAD_OUTS])
def test_an_output_that_cannot_be_written_is_refused_before_any_work(line, words, tmp_path,
                                                                     capsys):
    file = tmp_path / "file.txt"
    file.write_text("the user's file")
    argv = line.replace("FILE", str(file)).split()
    code = main(argv)
    captured = capsys.readouterr()
    lines = [text for text in captured.err.splitlines() if text.strip()]
    assert code == 2, captured.err
    assert lines == [lines[0]] and lines[0].startswith(
        f"dlo {command_words(argv)}: error: --out "), lines
    assert words in lines[0] and str(file) in lines[0], lines[0]
    assert captured.out == ""  # no work started: nothing printed
    assert file.read_text() == "the user's file"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt"]
