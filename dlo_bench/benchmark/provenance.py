"""What made a benchmark cell: the code, the run and the machine.

Every cell records the git commit of the code (:func:`code_version`, ``+dirty`` with
uncommitted changes to tracked files), the run (one invocation, :func:`new_run_id`) that timed
it, so the report compares planning times only between cells of one run, and the machine
(:func:`machine_label`).
"""

from __future__ import annotations

import os
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

#: What a cell records of the run that made it: the code's commit, the run, the machine.
RUN_FACTS = ("commit", "run", "machine")


def machine_label() -> str:
    """This machine in a few words, recorded with every cell it times: the processor's model
    (``/proc/cpuinfo`` where there is one) and the CPUs, ``Intel(R) Xeon(R) ... x 2 CPUs``."""
    import platform

    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model or platform.processor() or platform.machine()} x {os.cpu_count()} CPUs"


#: The folder holding the code's packages: a git checkout's root when run from a clone.
CODE_ROOT = Path(__file__).resolve().parents[2]


def code_path(path: str | os.PathLike[str]) -> str:
    """``path`` relative to ``CODE_ROOT`` when it lies below it (a shipped model), else
    absolute: how a cell records a model file, the same on every machine and in every clone."""
    full = Path(path).resolve()
    try:
        return full.relative_to(CODE_ROOT).as_posix()
    except ValueError:
        return str(full)


def model_label(path: str | os.PathLike[str]) -> str:
    """A model path as a cell records it (:func:`code_path`), leaving a label such as
    ``"<TransitionModel passed in>"`` (a model given loaded, not by its file) as it is."""
    return str(path) if str(path).startswith("<") else code_path(path)


def recorded_path(path: str) -> str:
    """A recorded model path in today's form: one recorded relative is relative to
    ``CODE_ROOT`` already (not to the current folder); an absolute one below ``CODE_ROOT`` (a
    cell from before paths were relative) becomes relative; a label stays."""
    return path if path.startswith("<") else code_path(code_file(path))


def code_file(path: str | os.PathLike[str]) -> Path:
    """The file a cell's recorded model path names: below ``CODE_ROOT`` when relative."""
    return Path(path) if Path(path).is_absolute() else CODE_ROOT / path


@dataclass(frozen=True)
class CodeState:
    """The git checkout the code runs from.

    Attributes:
        root: The checkout's root.
        commit: The short commit of ``HEAD``.
        changed: Tracked files with uncommitted changes (staged or not), relative to ``root``;
            untracked files (``runs/``, ``data/``) do not count.
    """

    root: Path
    commit: str
    changed: tuple[str, ...]

    @property
    def version(self) -> str:
        """The commit, ``+dirty`` with uncommitted changes to tracked files."""
        return self.commit + ("+dirty" if self.changed else "")


def code_state(root: str | os.PathLike | None = None) -> CodeState | None:
    """The git checkout whose root is ``root`` (None: :data:`CODE_ROOT`), or None when it is not
    the root of one (an installed package; a package inside some other repository's tree)."""
    folder = Path(root).resolve() if root is not None else CODE_ROOT

    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=folder, check=True, capture_output=True,
                              text=True, timeout=30).stdout

    try:
        if Path(git("rev-parse", "--show-toplevel").strip()).resolve() != folder:
            return None
        commit = git("rev-parse", "--short", "HEAD").strip()
        status = git("status", "--porcelain", "--untracked-files=no", "-z")
    except (OSError, subprocess.SubprocessError):  # no git, not a checkout, no commit yet
        return None
    # -z: "XY PATH\0", a rename adds "ORIGINAL\0"; paths are not quoted.
    entries = status.split("\0")
    changed, k = [], 0
    while k < len(entries):
        entry = entries[k]
        if entry:
            changed.append(entry[3:])
            if entry[0] in "RC":
                k += 1
        k += 1
    return CodeState(folder, commit, tuple(changed))


def code_version() -> str:
    """``git`` commit of the code (``+dirty`` with uncommitted changes to tracked files), ""
    outside a checkout of its own."""
    state = code_state()
    return state.version if state is not None else ""


def new_run_id() -> str:
    """A new run's id: its UTC start time and a random suffix (``20261125T055614Z-3f2a``)."""
    import secrets

    return time.strftime("%Y%m%dT%H%M%SZ", time.gmtime()) + "-" + secrets.token_hex(2)
