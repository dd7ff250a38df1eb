"""Specification: collection on Ray gives the arrays of the local backend for the same seed, and
a chunk whose worker is killed is made again, once, without loss."""

from __future__ import annotations

import os
import sys
import tempfile
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from dlo_env.core.ray_backend import RayBackend
from dlo_env.dataset.chunks import ChunkJob, chunk_plan, run_chunks
from dlo_env.dataset.collect import CollectConfig, collect
from dlo_env.dataset.remote_chunks import (
    CHUNK_FOLDER_PREFIX,
    LOCK_FILE,
    remove_orphan_chunk_folders,
)
from dlo_env.dataset.transitions import TransitionCollectConfig, collect_transitions

ray = pytest.importorskip("ray", reason='needs the ray extra: pip install -e ".[ray]"')


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray runtime with 2 CPUs, started by the test and shut down after it."""
    from ray import cloudpickle  # Ray's own copy, the one that pickles its tasks

    # Ray's workers cannot import this test module by name: send its functions by value.
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    ray.init(num_cpus=2, include_dashboard=False, logging_level="warning")
    yield
    ray.shutdown()
    cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


@pytest.mark.slow
def test_transitions_on_ray_equal_the_local_ones(local_ray, tmp_path):
    config = TransitionCollectConfig(seed=5, chunk_size=10)
    local = collect_transitions(tmp_path / "local.npz", 35, config)
    on_ray = collect_transitions(tmp_path / "ray.npz", 35, config, backend=RayBackend())
    for name, array in local.arrays().items():
        np.testing.assert_array_equal(on_ray.arrays()[name], array, err_msg=name)


@pytest.mark.slow
def test_shapes_on_ray_equal_the_local_ones(local_ray, tmp_path):
    config = CollectConfig(seed=2, chunk_size=40)
    local = collect(tmp_path / "local.npz", 100, config)
    on_ray = collect(tmp_path / "ray.npz", 100, config, backend=RayBackend())
    np.testing.assert_array_equal(on_ray.shapes, local.shapes)


def write_numbers_dying_once(marks: str, index: int, size: int, path: Path, progress) -> None:
    """A chunk writer whose worker process dies the first time it makes chunk 1."""
    marker = Path(marks) / f"attempt-{index}"
    attempts = len(list(Path(marks).glob(f"attempt-{index}*")))
    marker.with_name(f"attempt-{index}-{attempts}").touch()
    if index == 1 and attempts == 0:
        os._exit(1)  # as a worker killed by the system: no exception, no cleanup
    np.savez(path, numbers=np.arange(index * 100, index * 100 + size))


def chunk_folders() -> set[Path]:
    return set(Path(tempfile.gettempdir()).glob(f"{CHUNK_FOLDER_PREFIX}*"))


def numbers_in(path: Path) -> int:
    with np.load(path) as data:
        return len(data["numbers"])


@pytest.mark.slow
def test_a_killed_worker_chunk_is_made_again_once_and_nothing_is_lost(local_ray, tmp_path):
    marks = tmp_path / "marks"
    marks.mkdir()
    job = ChunkJob(kind="numbers", format_version=1, settings={},
                   write=partial(write_numbers_dying_once, str(marks)), size_of=numbers_in)
    plan = chunk_plan(30, 10)
    before = chunk_folders()
    done = []
    parts, reused, _ = run_chunks(job, tmp_path / "out.npz", plan, workers=1,
                                  progress=lambda n, _: done.append(n),
                                  backend=RayBackend(max_retries=2))
    chunks = sorted(p.name for p in parts.glob("chunk-*.npz"))
    assert chunks == ["chunk-000000.npz", "chunk-000001.npz", "chunk-000002.npz"]
    with np.load(parts / "chunk-000001.npz") as data:
        np.testing.assert_array_equal(data["numbers"], np.arange(100, 110))
    assert sorted(p.name for p in marks.iterdir()) == [
        "attempt-0-0", "attempt-1-0", "attempt-1-1", "attempt-2-0"]  # chunk 1 ran twice
    assert done == [10, 10, 10] and reused == 0  # each chunk counted once
    # the killed worker could not remove its chunk folder; the next task did
    assert chunk_folders() <= before


def test_only_the_chunk_folders_whose_lock_no_process_holds_are_removed(tmp_path):
    import fcntl

    orphan, live, young = (tmp_path / f"{CHUNK_FOLDER_PREFIX}{name}" for name in
                           ("orphan", "live", "young"))
    for folder in (orphan, live, young):
        folder.mkdir()
    (orphan / LOCK_FILE).touch()
    (orphan / ".chunk-000001.npz.tmp.npz").write_bytes(b"half")
    (live / LOCK_FILE).touch()
    with open(live / LOCK_FILE) as held:  # a task at work holds its lock
        fcntl.flock(held, fcntl.LOCK_EX)
        assert remove_orphan_chunk_folders(tmp_path) == [orphan]
    # a folder without a lock file (being made) stays until it is old
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([live.name, young.name])


def test_ray_backend_settings_are_checked_naming_the_argument():
    with pytest.raises(ValueError, match="max_retries must be"):
        RayBackend(max_retries=-1)
    with pytest.raises(ValueError, match="num_cpus must be"):
        RayBackend(num_cpus=0)
