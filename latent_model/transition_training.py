"""Training the transition model: the one-move loss.

Each step takes a batch of single transitions; the loss is the mean per-point distance (the
project's ``error``). (A loss on rolled-out chains of 2-3 moves was retired: at equal time
more one-move steps did better, on chains too; docs/history.md.) The frame of the move makes
rigid-transform augmentation redundant: the model is exactly equivariant, mirror-equivariant
too. Checkpoints are
written atomically every ``eval_every`` steps; a run resumes from the last one. The learning
rate follows a cosine decay over ``steps``.

With a ``teacher`` (a trained model file) the run distils instead: the teacher's ensemble is
copied and frozen, and only a *mean network* is trained, starting from the ensemble's first
member, towards both the data and the ensemble's mean prediction. The result predicts at the
cost of one network and keeps the ensemble for the spread. With ``teacher_moves`` the mean
network also learns the ensemble's mean on moves the data never made: each training start
paired with the move of another transition of its grasp (made reachable from it), a denser
sample of what the ensemble knows than the data alone.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch

from dlo_env.core.atomic import atomic_path
from dlo_env.core.checks import non_negative, positive, positive_ints
from dlo_env.dataset.transitions import (
    GRASP_NAMES,
    PARAM_COLUMNS,
    TransitionDataset,
    split_transitions,
)
from dlo_env.errors import InputError
from dlo_env.randomize import near_test_cords
from latent_model.checkpoint import load_checkpoint, save_atomic
from latent_model.config import LR_SCHEDULES, config_from_dict
from latent_model.transition_model import (
    CORD_FIELDS,
    LATER_CORD_FIELDS,
    EnsembleMLP,
    TransitionModel,
    TransitionModelConfig,
    check_config_keys,
    cord_features,
    current_config,
    saved_config,
)

#: Marks a file as a transition-training checkpoint (resumable state).
CHECKPOINT_FORMAT = "dlo-transition-training"
#: File names inside the output folder.
CHECKPOINT_FILE = "transition-checkpoint.pt"
CURVE_FILE = "transition-training.csv"


@dataclass(frozen=True)
class TransitionTrainConfig:
    """How the transition model is trained; the defaults make the shipped model.

    Attributes:
        steps: Optimiser steps.
        batch_size: Single transitions per step.
        lr: Adam learning rate at the start.
        lr_schedule: ``"cosine"`` (decays to 0 over ``steps``) or ``"constant"``.
        validation_fraction: Share of the training episodes kept out to watch progress.
        eval_every: Steps between validation, checkpoint and a row of the training curve.
        seed: Seed of the initialisation, the split and the batches.
        init: Start from the weights of this transition model file (fine-tuning, e.g. after
            adding data); its architecture must be the one trained. A mean network it holds
            is not kept (it would not fit the tuned ensemble: distil again). None: random
            weights.
        teacher: Distil a mean network for this transition model file (its ensemble is
            copied unchanged; the architecture is the teacher's). None: train an ensemble.
        teacher_weight: Weight of the error to the teacher's mean against the error to the
            data, when distilling.
        teacher_moves: When distilling, this many extra inputs per training transition: its
            start with the move of another transition of the same grasp, labelled by the
            teacher's mean alone (no simulation). They take this share of every batch,
            ``teacher_moves / (teacher_moves + 1)`` (the batch size is unchanged). 0: the
            data's moves only.
        miss_weight: Extra weight of the one-move error beyond ``miss_margin``: the loss adds
            ``miss_weight * mean(max(0, error - miss_margin))`` over the batch's transitions,
            so moves predicted worse than the margin count ``1 + miss_weight`` times (0: none).
        miss_margin: Per-transition error (mean over points, metres) above which a move counts
            as a miss for ``miss_weight``.
    """

    steps: int = 96_000
    batch_size: int = 512
    lr: float = 1e-3
    lr_schedule: str = "cosine"
    validation_fraction: float = 0.05
    eval_every: int = 4000
    seed: int = 0
    init: str | None = None
    teacher: str | None = None
    teacher_weight: float = 1.0
    teacher_moves: int = 0
    miss_weight: float = 0.0
    miss_margin: float = 0.005

    def __post_init__(self) -> None:
        positive_ints(self, "steps", "batch_size", "eval_every")
        non_negative(self, "teacher_weight", "miss_weight", "miss_margin")
        if not (isinstance(self.teacher_moves, int) and self.teacher_moves >= 0):
            raise InputError("TransitionTrainConfig.teacher_moves must be an int >= 0, "
                             f"got {self.teacher_moves!r}")
        if self.teacher_moves and not self.teacher:
            raise InputError("TransitionTrainConfig.teacher_moves: moves labelled by a teacher "
                             "need one (teacher, --teacher)")
        if self.init and self.teacher:
            raise InputError("TransitionTrainConfig: give init (fine-tune the ensemble) or "
                             "teacher (distil a mean network), not both")
        positive(self, "lr")
        if self.lr_schedule not in LR_SCHEDULES:
            raise InputError(f"TransitionTrainConfig.lr_schedule must be one of {LR_SCHEDULES}, "
                             f"got {self.lr_schedule!r}")
        if not 0.0 < self.validation_fraction < 1.0:
            raise InputError("TransitionTrainConfig.validation_fraction must be in (0, 1), "
                             f"got {self.validation_fraction!r}")


@dataclass
class TransitionTensors:
    """Transitions as tensors the model takes: moves already made reachable."""

    start: torch.Tensor  # (T, n, 2)
    next: torch.Tensor  # (T, n, 2)
    grasp: torch.Tensor  # (T,) int64
    moves: torch.Tensor  # (T, 2, 2)
    episode: np.ndarray
    step: np.ndarray
    cord: torch.Tensor | None = None  # (T, 4) cord_features, for a model with cord_inputs
    pegs: torch.Tensor | None = None  # (T, m, 2) peg centres (PEG_FAR: none), with peg_reach

    def rows(self, name: str, idx: Any) -> torch.Tensor | None:
        """``cord`` or ``pegs`` of the transitions ``idx`` (None when the model reads none)."""
        value = getattr(self, name)
        return None if value is None else value[idx]


def _cords(model: TransitionModel, params: np.ndarray) -> torch.Tensor | None:
    """The ``cord_features`` of transitions' cords, for a model that sees them (else None)."""
    if not model.config.cord_inputs:
        return None
    return torch.from_numpy(cord_features(params)).to(model.device)


def _pegs(model: TransitionModel, data: TransitionDataset, idx: Any) -> torch.Tensor | None:
    """The pegs of transitions ``idx``, for a model that sees them (else None)."""
    if not model.config.peg_reach:
        return None
    return torch.from_numpy(data.peg_rows(idx)).to(model.device)


def _reachable(model: TransitionModel, data: TransitionDataset, starts: np.ndarray,
               idx: np.ndarray, name: str, moves_of: np.ndarray) -> np.ndarray:
    """Reachable moves of ``starts`` with the commanded moves of transitions ``moves_of``, on
    the cords and among the pegs of transitions ``idx`` (a model of one cord: its own)."""
    params = data.params[idx] if model.config.cord_inputs else None
    pegs = data.peg_rows(idx) if data.pegs.shape[1] else None
    return model.reachable_moves(starts, name, data.end_displacement(moves_of), params=params,
                                 pegs=pegs, peg_radius=model.config.peg_radius)


def as_tensors(model: TransitionModel, data: TransitionDataset) -> TransitionTensors:
    """The dataset's transitions with every commanded move turned into the reachable one."""
    moves = np.zeros((len(data), 2, 2), dtype=np.float32)
    for code, name in enumerate(GRASP_NAMES):
        idx = np.flatnonzero(data.grasp == code)
        if len(idx):
            moves[idx] = _reachable(model, data, data.start[idx], idx, name, idx)
    dev = model.device
    return TransitionTensors(
        start=torch.from_numpy(data.start).to(dev), next=torch.from_numpy(data.next).to(dev),
        grasp=torch.from_numpy(data.grasp.astype(np.int64)).to(dev),
        moves=torch.from_numpy(moves).to(dev), episode=data.episode, step=data.step,
        cord=_cords(model, data.params), pegs=_pegs(model, data, slice(None)))


def paired_moves(model: TransitionModel, data: TransitionDataset, copies: int, seed: int
                 ) -> TransitionTensors:
    """``copies`` inputs per transition of ``data`` that the data never made: its start with
    the commanded move of a random other transition of the same grasp, made reachable from
    that start. Their ``next`` is left zero (distillation labels them with the teacher)."""
    rng = np.random.default_rng(seed)
    order = np.concatenate([np.flatnonzero(data.grasp == code)
                            for code in range(len(GRASP_NAMES))])
    starts = np.concatenate([data.start[order]] * copies)
    grasp = np.concatenate([data.grasp[order]] * copies).astype(np.int64)
    moves = np.zeros((len(starts), 2, 2), dtype=np.float32)
    lo = 0
    for _ in range(copies):
        for code, name in enumerate(GRASP_NAMES):
            idx = np.flatnonzero(data.grasp == code)
            part = slice(lo, lo + len(idx))
            lo += len(idx)
            if len(idx):
                moves[part] = _reachable(model, data, starts[part], idx, name,
                                         rng.permutation(idx))
    dev = model.device
    return TransitionTensors(
        start=torch.from_numpy(starts).to(dev), next=torch.zeros(starts.shape, device=dev),
        grasp=torch.from_numpy(grasp).to(dev), moves=torch.from_numpy(moves).to(dev),
        episode=np.full(len(starts), -1), step=np.zeros(len(starts), dtype=np.int64),
        cord=_cords(model, np.concatenate([data.params[order]] * copies)),
        pegs=None if not model.config.peg_reach else torch.cat(
            [_pegs(model, data, order)] * copies))


def chain_starts(episode: np.ndarray, step: np.ndarray, moves: int) -> np.ndarray:
    """Indices ``i`` where transitions ``i .. i + moves - 1`` follow each other on one cord."""
    if moves < 1 or len(episode) < moves:
        return np.zeros(0, dtype=np.int64)
    last = len(episode) - moves + 1
    ok = np.ones(last, dtype=bool)
    for k in range(1, moves):
        ok &= (episode[k:k + last] == episode[:last]) & (step[k:k + last] == step[:last] + k)
    return np.flatnonzero(ok)


def point_error(pred: torch.Tensor, true: torch.Tensor) -> torch.Tensor:
    """Mean per-point distance over the last two dims: ``(..., n, 2)`` -> ``(...)``."""
    return ((pred - true).square().sum(dim=-1) + 1e-12).sqrt().mean(dim=-1)


def one_move_loss(errors: torch.Tensor, tc: TransitionTrainConfig) -> torch.Tensor:
    """The one-move loss from per-transition errors (metres): their mean, plus ``miss_weight``
    times the mean of what each error has beyond ``miss_margin``."""
    loss = errors.mean()
    if tc.miss_weight:
        loss = loss + tc.miss_weight * (errors - tc.miss_margin).clamp_min(0.0).mean()
    return loss


def _curve_row(path: Path, row: dict[str, Any]) -> None:
    new = not path.is_file()
    with path.open("a", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(row))
        if new:
            writer.writeheader()
        writer.writerow(row)


@torch.no_grad()
def validation_error(model: TransitionModel, data: TransitionTensors, limit: int = 4096,
                     net: EnsembleMLP | None = None) -> float:
    """Mean one-move error of the ensemble's (``net``'s) mean on (at most ``limit``)
    transitions, metres."""
    pred = mean_predictions(model, data, net, limit)
    return float(point_error(pred, data.next[:len(pred)]).mean())


@torch.no_grad()
def mean_predictions(model: TransitionModel, data: TransitionTensors,
                     net: EnsembleMLP | None = None, limit: int | None = None,
                     chunk: int = 4096) -> torch.Tensor:
    """The mean prediction of the ensemble (``net``) for the first ``limit`` (None: every)
    transitions, ``(T, n, 2)``: validation, and distillation's targets."""
    count = len(data.grasp) if limit is None else min(limit, len(data.grasp))
    parts = []
    for lo in range(0, count, chunk):
        part = slice(lo, min(lo + chunk, count))
        parts.append(model(data.start[part], data.grasp[part], data.moves[part], net=net,
                           cord=data.rows("cord", part), pegs=data.rows("pegs", part)
                           ).mean(dim=0))
    return torch.cat(parts)


def fingerprint(net: EnsembleMLP) -> str:
    """A short SHA-256 of a network's weights: which ensemble a mean network was distilled
    from, whatever file it came in."""
    digest = hashlib.sha256()
    for value in net.state_dict().values():
        digest.update(value.detach().float().cpu().numpy().tobytes())
    return digest.hexdigest()[:16]


def _distil_from(teacher_path: str, mc: TransitionModelConfig
                 ) -> tuple[TransitionModel, TransitionModelConfig]:
    # The teacher, checked against the data's cord; the student's config is the teacher's.
    teacher = TransitionModel.load(teacher_path, device="cpu")
    tcfg = teacher.config
    for field in ("n_points", *CORD_FIELDS, "max_step"):
        if getattr(tcfg, field) != getattr(mc, field):
            raise InputError(f"teacher {teacher_path!r} was trained for {field}="
                             f"{getattr(tcfg, field)!r}, the data has {getattr(mc, field)!r}")
    return teacher, replace(tcfg, mean_network=True, mean_by_grasp=mc.mean_by_grasp)


def _output_folder(out: str | os.PathLike[str], resume: bool) -> tuple[Path, Path]:
    """The output folder (made) and its checkpoint's path; a checkpoint there needs
    ``resume``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    checkpoint = out / CHECKPOINT_FILE
    if checkpoint.exists() and not resume:
        raise InputError(f"out {str(out)!r} holds a training checkpoint; pass resume=True "
                         "(--resume) to continue it, or choose another folder")
    return out, checkpoint


def _training_data(data: TransitionDataset, tc: TransitionTrainConfig,
                   mc: TransitionModelConfig
                   ) -> tuple[TransitionDataset, TransitionModelConfig, np.ndarray]:
    """The transitions a run trains on, the architecture fitted to them (their points, cord
    length, action size and pegs) and which transitions were left out (near the test cords)."""
    # A model of one cord learns the cord its data's metadata names; a cord-conditioned one
    # (cord_inputs) the cords of every transition, its own being the default cord's length.
    conditioned = mc.cord_inputs or bool(
        tc.teacher and TransitionModel.load(tc.teacher, device="cpu").config.cord_inputs)
    cord = {} if conditioned else asdict(data.one_cord("data"))
    # A model of several cords never trains on the cords near the held-out test cords.
    left_out = near_test_cords(data.params, PARAM_COLUMNS) if conditioned \
        else np.zeros(len(data), dtype=bool)
    if left_out.all():
        raise InputError("data holds only cords near the held-out test cords "
                         "(dlo_env.randomize.TEST_CORDS): nothing to train on")
    if left_out.any():
        data = data.subset(~left_out)
    mc = TransitionModelConfig(**{**asdict(mc), "n_points": int(data.start.shape[1]),
                                  **{key: float(cord.get(name, getattr(mc, key)))
                                     for key, name in CORD_FIELDS.items()},
                                  "max_step": float(data.metadata.get("collect", {}).get(
                                      "max_step", mc.max_step))})
    if mc.mean_network and not tc.teacher:
        raise InputError("model_config.mean_network: a mean network is made by distilling a "
                         "trained ensemble (TransitionTrainConfig.teacher, --teacher), not "
                         "trained with it")
    collected = data.metadata.get("collect", {})
    if mc.peg_reach and "peg_radius" in collected:  # the pegs the data went around
        mc = replace(mc, peg_radius=float(collected["peg_radius"]))
    return data, mc, left_out


def _check_pegs(data: TransitionDataset, mc: TransitionModelConfig) -> None:
    """Transitions around pegs need a model that sees them."""
    if len(data) and data.peg_count.any() and not mc.peg_reach:
        raise InputError("data holds transitions around pegs (collected with max_pegs); a "
                         "model without peg_reach (--peg-reach) does not see pegs: give it one, "
                         "or use data of an empty table")


def _start_from_teacher(model: TransitionModel, teacher: TransitionModel,
                        mc: TransitionModelConfig) -> EnsembleMLP:
    """Copy the teacher's ensemble into ``model`` and freeze it; returns the mean network,
    what the run trains."""
    model.net.load_state_dict(teacher.net.state_dict())
    model.net.requires_grad_(False)
    trained = model.mean_net
    # Start from the ensemble's first member (the MLP student of a chain ensemble starts
    # from its own random weights).
    first = model.net.first(1) if mc.architecture == "mlp" else None
    with torch.no_grad():
        for mine, theirs in zip(trained.parameters(),
                                [] if first is None else first.parameters()):
            mine.copy_(theirs)
    return trained


def _grown_network(start: TransitionModel, mc: TransitionModelConfig, init: str
                   ) -> EnsembleMLP:
    """``start``'s ensemble with the inputs ``mc`` adds (their weights zero), checked to be
    of the architecture and cord ``mc`` describes otherwise."""
    # A network without contact vectors is a fine start for one with them, one of the
    # default cord for one of several cords, and one of the empty table for one that
    # sees pegs (the new inputs' weights start at zero: it first predicts as before,
    # every cord as the default and every peg as absent); one of another stiffness, friction
    # or mass for one of the data's cord.
    seen = replace(start.config, mean_network=False, mean_by_grasp=False,
                   **{key: getattr(mc, key) for key in LATER_CORD_FIELDS})
    grow_contact = not seen.contact_reach and mc.contact_reach
    grow_cord = not seen.cord_inputs and mc.cord_inputs
    grow_pegs = not seen.peg_reach and mc.peg_reach
    grown = replace(seen, contact_reach=mc.contact_reach if grow_contact
                    else seen.contact_reach, cord_inputs=seen.cord_inputs or grow_cord,
                    peg_reach=mc.peg_reach if grow_pegs else seen.peg_reach,
                    peg_radius=mc.peg_radius if grow_pegs else seen.peg_radius)
    differ = [f"{k}={v!r} (this run {getattr(mc, k)!r})" for k, v in asdict(grown).items()
              if getattr(mc, k) != v]
    if differ:
        raise InputError(f"init {init!r} is a model of another architecture or cord: "
                         f"{', '.join(differ)}")
    net = start.net
    if grow_contact:
        after = replace(seen, contact_reach=mc.contact_reach)
        net = net.with_inputs(seen.contact_at, after.inputs - seen.inputs)
        seen = after
    if grow_pegs:  # the peg vectors come after the rim's (and contact's)
        after = replace(seen, peg_reach=mc.peg_reach, peg_radius=mc.peg_radius)
        net = net.with_inputs(seen.peg_at, 2 * after.peg_inputs)
        seen = after
    if grow_cord:  # the cord's features come before the move's four inputs
        net = net.with_inputs(seen.inputs - 4, mc.cord_features)
    return net


def _start_from_init(model: TransitionModel, init: str, mc: TransitionModelConfig
                     ) -> dict[str, Any]:
    """Load the ensemble of the model file ``init`` into ``model``; returns what fine-tuning
    started from: its weights' fingerprint and its own provenance."""
    start = TransitionModel.load(init, device="cpu")
    model.net.load_state_dict(_grown_network(start, mc, init).state_dict())
    return {"fingerprint": fingerprint(start.net), "info": start.info}


@dataclass
class _Run:
    """One training run: its model, the networks it trains, the optimiser and its provenance.

    Attributes:
        trained: The networks the optimiser moves (the ensemble, or the mean network).
        net: The networks the losses run (None: the ensemble).
        teacher: The distilled teacher (None: an ensemble is trained).
        teacher_ensemble: The fingerprint of the teacher's ensemble (None: no teacher).
        init_record: What fine-tuning started from (None: random weights or a teacher).
        step: Optimiser steps done.
    """

    model: TransitionModel
    trained: EnsembleMLP
    net: EnsembleMLP | None
    optimiser: torch.optim.Optimizer
    teacher: TransitionModel | None
    teacher_ensemble: str | None
    init_record: dict[str, Any] | None
    step: int = 0

    @property
    def init_fingerprint(self) -> str | None:
        """The fingerprint of the model fine-tuning started from (else what it has: None)."""
        return self.init_record and self.init_record["fingerprint"]


def _start_run(model_class: type[TransitionModel], mc: TransitionModelConfig,
               tc: TransitionTrainConfig, device: str | torch.device,
               teacher: TransitionModel | None) -> _Run:
    """The seeded model, started from the teacher's ensemble, a model file or random
    weights, and the optimiser of what it trains."""
    torch.manual_seed(tc.seed)
    model = model_class(mc, device=device)
    trained, init_record = model.net, None
    if teacher is not None:  # the ensemble is the teacher's, frozen; the mean network learns
        trained = _start_from_teacher(model, teacher, mc)
    elif tc.init:
        init_record = _start_from_init(model, tc.init, mc)
    return _Run(model=model, trained=trained, net=None if teacher is None else trained,
                optimiser=torch.optim.Adam(trained.parameters(), lr=tc.lr), teacher=teacher,
                teacher_ensemble=None if teacher is None else fingerprint(model.net),
                init_record=init_record)


def _resume(run: _Run, checkpoint: Path, tc: TransitionTrainConfig,
            mc: TransitionModelConfig) -> None:
    """Continue ``run`` from ``checkpoint``, written by a run of the same settings, teacher
    and start."""
    saved = load_checkpoint(checkpoint, str(checkpoint), kind=CHECKPOINT_FORMAT, version=1)
    check_config_keys(saved["model_config"], str(checkpoint), checkpoint=True)
    saved_mc = config_from_dict(TransitionModelConfig, current_config(saved["model_config"]),
                                "model_config")
    saved_tc = config_from_json(saved["train_config"])
    if saved_tc != tc or saved_mc != mc:
        differ = [f"{k}={a!r} (now {b!r})" for old, new in ((saved_tc, tc), (saved_mc, mc))
                  for (k, a), b in zip(asdict(old).items(), asdict(new).values()) if a != b]
        raise InputError(f"resume: {checkpoint} was written with other settings: "
                         f"{', '.join(differ)}; use the same settings or another --out")
    if saved.get("teacher_ensemble", run.teacher_ensemble) != run.teacher_ensemble:
        raise InputError(f"resume: {checkpoint} distils another ensemble than teacher "
                         f"{tc.teacher!r} holds now; use that teacher or another --out")
    if saved.get("init_fingerprint", run.init_fingerprint) != run.init_fingerprint:
        raise InputError(f"resume: {checkpoint} fine-tunes another model than init "
                         f"{tc.init!r} holds now; use that model or another --out")
    run.trained.load_state_dict(saved["net"])
    run.optimiser.load_state_dict(saved["optimiser"])
    run.step = int(saved["step"])


@dataclass
class _Batch:
    """One training batch: the data's transitions ``idx`` first, then the teacher's moves."""

    idx: torch.Tensor
    start: torch.Tensor
    grasp: torch.Tensor
    moves: torch.Tensor
    target: torch.Tensor | None  # the teacher's mean prediction (None: not distilling)
    cord: torch.Tensor | None
    pegs: torch.Tensor | None


@dataclass
class _Batches:
    """Where a run's batches come from: the training transitions (with the teacher's mean
    predictions of them, when distilling), the teacher's moves that fill each batch, and the
    seeded stream that draws them.

    Attributes:
        real: Transitions of the data per batch (the rest are the teacher's moves).
    """

    train: TransitionTensors
    targets: torch.Tensor | None
    extra: TransitionTensors | None
    extra_targets: torch.Tensor | None
    real: int
    size: int
    gen: torch.Generator

    @classmethod
    def of(cls, run: _Run, train: TransitionTensors, train_data: TransitionDataset,
           tc: TransitionTrainConfig) -> _Batches:
        """The batches of ``run`` (its teacher's targets computed once), drawn by a stream
        seeded with ``tc.seed`` and the step the run starts at."""
        distil = run.teacher is not None
        targets = mean_predictions(run.model, train) if distil else None
        extra = extra_targets = None
        real = tc.batch_size
        if distil and tc.teacher_moves:
            extra = paired_moves(run.model, train_data, tc.teacher_moves, seed=tc.seed)
            extra_targets = mean_predictions(run.model, extra)
            real = max(1, round(tc.batch_size / (tc.teacher_moves + 1)))
        gen = torch.Generator(device="cpu").manual_seed(tc.seed * 1_000_003 + run.step)
        return cls(train, targets, extra, extra_targets, real, tc.batch_size, gen)

    def draw(self, device: torch.device) -> _Batch:
        """The next batch, on ``device``."""
        tr = self.train
        idx = torch.randint(len(tr.grasp), (self.real,), generator=self.gen).to(device)
        start, grasp, moves = tr.start[idx], tr.grasp[idx], tr.moves[idx]
        target = None if self.targets is None else self.targets[idx]
        cord, pegs = tr.rows("cord", idx), tr.rows("pegs", idx)
        extra = self.extra
        if extra is not None and self.real < self.size:  # the teacher's moves fill the batch
            pick = torch.randint(len(extra.grasp), (self.size - self.real,),
                                 generator=self.gen).to(device)
            start, grasp, moves, target = (torch.cat([a, b[pick]]) for a, b in (
                (start, extra.start), (grasp, extra.grasp), (moves, extra.moves),
                (target, self.extra_targets)))
            if cord is not None:
                cord = torch.cat([cord, extra.cord[pick]])
            if pegs is not None:
                pegs = torch.cat([pegs, extra.pegs[pick]])
        return _Batch(idx, start, grasp, moves, target, cord, pegs)


def _train_step(run: _Run, batches: _Batches, tc: TransitionTrainConfig) -> dict[str, float]:
    """One optimiser step on the next batch; returns its one-move loss (and, distilling, its
    error to the teacher's mean)."""
    batch = batches.draw(run.model.device)
    pred = run.model(batch.start, batch.grasp, batch.moves, net=run.net, cord=batch.cord,
                     pegs=batch.pegs)
    errors = point_error(pred[:, :batches.real], batches.train.next[batch.idx][None])
    loss_one = errors.mean()
    loss = one_move_loss(errors, tc)
    loss_teacher = torch.zeros(())
    if batch.target is not None:
        loss_teacher = point_error(pred, batch.target[None]).mean()
        loss = loss + tc.teacher_weight * loss_teacher
    run.optimiser.zero_grad(set_to_none=True)
    loss.backward()
    run.optimiser.step()
    run.step += 1
    stats = {"loss": float(loss_one.detach())}
    if batches.targets is not None:
        stats["teacher"] = float(loss_teacher.detach())
    return stats


def _lr_factor(tc: TransitionTrainConfig, step: int) -> float:
    """The learning rate's share of ``tc.lr`` at ``step``."""
    fraction = step / tc.steps
    return 0.5 * (1 + math.cos(math.pi * fraction)) if tc.lr_schedule == "cosine" else 1.0


def _record(run: _Run, validation: TransitionTensors, stats: dict[str, float], lr: float,
            started: float, out: Path, tc: TransitionTrainConfig,
            mc: TransitionModelConfig) -> None:
    """Validate (into ``stats``), add a row to the training curve (seconds since
    ``started``) and write the checkpoint."""
    run.model.eval()
    stats["validation_cm"] = 100 * validation_error(run.model, validation, net=run.net)
    run.model.train()
    _curve_row(out / CURVE_FILE, {"step": run.step, "lr": lr, **stats,
                                  "seconds": round(time.perf_counter() - started, 1)})
    save_atomic({"format": CHECKPOINT_FORMAT, "format_version": 1, "step": run.step,
                 "train_config": asdict(tc), "model_config": saved_config(mc),
                 "net": run.trained.state_dict(), "optimiser": run.optimiser.state_dict(),
                 "teacher_ensemble": run.teacher_ensemble,
                 "init_fingerprint": run.init_fingerprint},
                out / CHECKPOINT_FILE)


def _run_info(data: TransitionDataset, train: TransitionDataset, tc: TransitionTrainConfig,
              left_out: np.ndarray) -> dict[str, Any]:
    """The provenance of a run: its data, settings and sample cost."""
    return {"data": data.metadata.get("collect", {}), "files": data.metadata.get("files"),
            "sources": data.metadata.get("sources"),
            "train_config": asdict(tc),
            "transitions": len(train), "data_transitions": len(data),
            "test_cords_left_out": int(left_out.sum()),
            "env_steps": data.env_steps()}


def _finish(run: _Run, info: dict[str, Any], validation: TransitionTensors, out: Path
            ) -> TransitionModel:
    """Record the trained model's provenance and final validation error; save it to ``out``."""
    model, teacher = run.model, run.teacher
    model.eval()
    model.info = {**info, "steps": run.step,
                  "validation_cm": 100 * validation_error(model, validation, net=run.net)}
    if teacher is not None:  # the ensemble's own provenance, as its training recorded it
        model.info["ensemble"] = (teacher.info.get("ensemble", teacher.info)
                                  if teacher.config.mean_network else teacher.info)
        model.info["teacher_ensemble"] = run.teacher_ensemble
    if run.init_record is not None:
        model.info["init_model"] = run.init_record
    model.save(out)
    with atomic_path(out / "transition-info.json") as tmp:
        tmp.write_text(json.dumps(model.info, indent=1, sort_keys=True))
    return model


def train_transition_model(
    data: TransitionDataset,
    out: str | os.PathLike[str],
    config: TransitionTrainConfig | None = None,
    model_config: TransitionModelConfig | None = None,
    *,
    resume: bool = False,
    device: str | torch.device = "auto",
    progress: Callable[[int, dict[str, float]], None] | None = None,
    model_class: type[TransitionModel] = TransitionModel,
) -> TransitionModel:
    """Train a transition model on ``data``; writes ``transition.pt`` and the curve to ``out``.

    Args:
        data: Training transitions (a share of episodes is held out for validation).
        out: Output folder (checkpoint, training curve CSV, final model).
        config: Training settings.
        model_config: Architecture (the cord's points and length are taken from ``data``).
        resume: Continue from ``out``'s checkpoint (same settings required).
        device: ``"auto"``, ``"cpu"``, ``"cuda"``...
        progress: Called as ``progress(steps_done, stats)`` after every step.
        model_class: The design to train (a ``TransitionModel`` subclass, for comparisons).

    Returns:
        The trained model (also saved as ``out/transition.pt``).
    """
    tc = config if config is not None else TransitionTrainConfig()
    out, checkpoint = _output_folder(out, resume)
    data, mc, left_out = _training_data(
        data, tc, model_config if model_config is not None else TransitionModelConfig())
    teacher = None
    if tc.teacher:
        teacher, mc = _distil_from(tc.teacher, mc)
    _check_pegs(data, mc)
    run = _start_run(model_class, mc, tc, device, teacher)
    if resume and checkpoint.is_file():
        _resume(run, checkpoint, tc, mc)
    train, validation = split_transitions(data, tc.validation_fraction, seed=tc.seed)
    tr, va = as_tensors(run.model, train), as_tensors(run.model, validation)
    batches = _Batches.of(run, tr, train, tc)
    info = _run_info(data, train, tc, left_out)
    started = time.perf_counter()
    run.model.train()
    while run.step < tc.steps:
        factor = _lr_factor(tc, run.step)
        for group in run.optimiser.param_groups:
            group["lr"] = tc.lr * factor
        stats = _train_step(run, batches, tc)
        if run.step % tc.eval_every == 0 or run.step == tc.steps:
            _record(run, va, stats, tc.lr * factor, started, out, tc, mc)
        if progress is not None:
            progress(run.step, stats)
    return _finish(run, info, va, out)


#: Training settings retired (the chain loss, off in every shipped model: ``chain_weight``
#: 0); a record with another ``chain_weight`` is refused.
RETIRED_TRAIN = {"chain_batch": 128, "chain_moves": 3, "chain_weight": 0.0}


def config_from_json(values: dict[str, Any]) -> TransitionTrainConfig:
    """A training config from JSON values (unknown keys are an error naming them; retired
    ones must have had no effect)."""
    if values.get("chain_weight", 0.0) != 0.0:
        raise InputError(f"train_config has chain_weight={values['chain_weight']!r}: the chain "
                         "loss is retired")
    return config_from_dict(TransitionTrainConfig,
                            {k: v for k, v in values.items() if k not in RETIRED_TRAIN},
                            "train_config")
