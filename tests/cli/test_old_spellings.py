"""Specification: the 0.2.0 spellings ``dlo collect [--kind K]`` and ``dlo train [--stage S]``
still work until 0.3.0, as ``dlo collect shapes|transitions`` and ``dlo train
shape|transition``, with a one-line notice on stderr that names the new spelling."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from dlo_cli.main import main
from dlo_cli.old_spellings import REMOVED_IN, new_spelling

SUBCOMMANDS = {"collect": ["shapes", "transitions"], "train": ["shape", "transition"]}


@pytest.mark.parametrize("old, new, was", [
    ("collect --num-shapes 5 --out d.npz", "collect shapes --num-shapes 5 --out d.npz",
     "dlo collect without a subcommand"),
    ("collect --kind shapes --num-shapes 5", "collect shapes --num-shapes 5",
     "dlo collect --kind shapes"),
    ("collect --num-transitions 5 --kind transitions", "collect transitions --num-transitions 5",
     "dlo collect --kind transitions"),
    ("collect --kind=transitions --num-transitions 5", "collect transitions --num-transitions 5",
     "dlo collect --kind transitions"),
    ("--debug train --data d.npz", "--debug train shape --data d.npz",
     "dlo train without a subcommand"),
    ("train --stage gan --data d.npz", "train shape --stage gan --data d.npz",
     "dlo train without a subcommand"),
    ("train --data d.npz --stage transition --lr 1", "train transition --data d.npz --lr 1",
     "dlo train --stage transition"),
])
def test_an_old_spelling_becomes_the_new_one_with_a_notice(old, new, was):
    argv, notice = new_spelling(old.split(), SUBCOMMANDS)
    assert argv == new.split()
    command, subcommand = new.removeprefix("--debug ").split()[:2]
    assert notice == (f"dlo: `{was}` is deprecated and {REMOVED_IN} removes it: use "
                      f"`dlo {command} {subcommand}`")


@pytest.mark.parametrize("line", ["collect shapes --num-shapes 5", "train transition --data x",
                                  "collect --help", "train", "evaluate --agent straight-line",
                                  "--version"])
def test_a_new_spelling_or_a_help_request_is_left_as_it_is(line):
    assert new_spelling(line.split(), SUBCOMMANDS) == (line.split(), None)


def test_the_old_collect_spelling_makes_the_same_file_after_one_notice(tmp_path, capsys):
    assert main(["collect", "--num-shapes", "20", "--out", str(tmp_path / "old.npz")]) == 0
    err = capsys.readouterr().err
    assert ("dlo: `dlo collect without a subcommand` is deprecated and 0.3.0 removes it: use "
            "`dlo collect shapes`") in err.splitlines()
    assert main(["collect", "shapes", "--num-shapes", "20", "--out",
                 str(tmp_path / "new.npz")]) == 0
    assert "deprecated" not in capsys.readouterr().err
    with np.load(tmp_path / "old.npz") as old, np.load(tmp_path / "new.npz") as new:
        np.testing.assert_array_equal(old["shapes"], new["shapes"])


def test_an_old_spelling_with_a_bad_flag_prints_the_notice_then_the_error(tmp_path, capsys):
    assert main(["train", "--stage", "transition", "--data", str(tmp_path / "d.npz"), "--out",
                 str(tmp_path / "r"), "--lr", "-1"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert lines == ["dlo: `dlo train --stage transition` is deprecated and 0.3.0 removes it: "
                     "use `dlo train transition`",
                     "dlo train transition: error: argument --lr: expected a number > 0, got "
                     "'-1'"]


def test_the_readme_and_docs_use_the_new_spellings():
    root = Path(__file__).resolve().parents[2]
    pages = [root / "README.md", *sorted((root / "docs").glob("*.md"))]
    commands = re.compile(r"`(dlo [^`]*)`|^(dlo .*)$", re.M)
    old = []
    for page in pages:
        if page.name == "history.md":  # a record of the commands as they were run then
            continue
        text = re.sub(r"## Old spellings\n.*?(?=\n## |\Z)", "", page.read_text(), flags=re.S)
        for match in commands.finditer(text):
            words = (match.group(1) or match.group(2)).split()[1:]
            if new_spelling(words, SUBCOMMANDS)[1] is not None:
                old.append(f"{page.name}: {match.group(0)}")
    assert not old, old
