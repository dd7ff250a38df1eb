"""Progress output: a bar on a terminal, ten lines in a piped log, nothing when disabled."""

from __future__ import annotations

from dlo_env.core.progress import progress_bar


def test_piped_output_gets_a_line_per_tenth_not_a_redrawn_bar(capsys):
    bar = progress_bar(200, "training", "step")  # pytest's captured stderr is no terminal
    for _ in range(200):
        bar.update(1)
    bar.close()
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 10 and "\r" not in "".join(lines)
    assert lines[-1].startswith("training: 200/200 steps")


def test_a_resumed_bar_prints_only_the_tenths_still_ahead(capsys):
    bar = progress_bar(100, "training", "step", initial=50)
    for _ in range(50):
        bar.update(1)
    assert len(capsys.readouterr().err.strip().splitlines()) == 5


def test_a_disabled_bar_prints_nothing_but_its_messages(capsys):
    bar = progress_bar(10, "demo", "run", enabled=False)
    bar.update(10)
    bar.write("step 10: 5 steps/s")
    out = capsys.readouterr()
    assert out.err == "" and out.out == "step 10: 5 steps/s\n"
