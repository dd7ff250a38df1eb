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
from dlo_env.randomize import near_test_cords
from latent_model.checkpoint import load_checkpoint, save_atomic
from latent_model.config import LR_SCHEDULES, config_from_dict
from latent_model.transition_model import (
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
            raise ValueError("TransitionTrainConfig.teacher_moves must be an int >= 0, "
                             f"got {self.teacher_moves!r}")
        if self.teacher_moves and not self.teacher:
            raise ValueError("TransitionTrainConfig.teacher_moves: moves labelled by a teacher "
                             "need one (teacher, --teacher)")
        if self.init and self.teacher:
            raise ValueError("TransitionTrainConfig: give init (fine-tune the ensemble) or "
                             "teacher (distil a mean network), not both")
        positive(self, "lr")
        if self.lr_schedule not in LR_SCHEDULES:
            raise ValueError(f"TransitionTrainConfig.lr_schedule must be one of {LR_SCHEDULES}, "
                             f"got {self.lr_schedule!r}")
        if not 0.0 < self.validation_fraction < 1.0:
            raise ValueError("TransitionTrainConfig.validation_fraction must be in (0, 1), "
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
    for field in ("n_points", "cord_length", "max_step"):
        if getattr(tcfg, field) != getattr(mc, field):
            raise ValueError(f"teacher {teacher_path!r} was trained for {field}="
                             f"{getattr(tcfg, field)!r}, the data has {getattr(mc, field)!r}")
    return teacher, replace(tcfg, mean_network=True, mean_by_grasp=mc.mean_by_grasp)


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
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    checkpoint = out / CHECKPOINT_FILE
    if checkpoint.exists() and not resume:
        raise ValueError(f"out {str(out)!r} holds a training checkpoint; pass resume=True "
                         "(--resume) to continue it, or choose another folder")
    mc = model_config if model_config is not None else TransitionModelConfig()
    # A model of one cord learns the cord its data's metadata names; a cord-conditioned one
    # (cord_inputs) the cords of every transition, its own being the default cord's length.
    conditioned = mc.cord_inputs or bool(
        tc.teacher and TransitionModel.load(tc.teacher, device="cpu").config.cord_inputs)
    cord = {} if conditioned else asdict(data.one_cord("data"))
    # A model of several cords never trains on the cords near the held-out test cords.
    left_out = near_test_cords(data.params, PARAM_COLUMNS) if conditioned \
        else np.zeros(len(data), dtype=bool)
    if left_out.all():
        raise ValueError("data holds only cords near the held-out test cords "
                         "(dlo_env.randomize.TEST_CORDS): nothing to train on")
    if left_out.any():
        data = data.subset(~left_out)
    mc = TransitionModelConfig(**{**asdict(mc), "n_points": int(data.start.shape[1]),
                                  "cord_length": float(cord.get("length", mc.cord_length)),
                                  "max_step": float(data.metadata.get("collect", {}).get(
                                      "max_step", mc.max_step))})
    if mc.mean_network and not tc.teacher:
        raise ValueError("model_config.mean_network: a mean network is made by distilling a "
                         "trained ensemble (TransitionTrainConfig.teacher, --teacher), not "
                         "trained with it")
    collected = data.metadata.get("collect", {})
    if mc.peg_reach and "peg_radius" in collected:  # the pegs the data went around
        mc = replace(mc, peg_radius=float(collected["peg_radius"]))
    teacher = init_record = None
    if tc.teacher:
        teacher, mc = _distil_from(tc.teacher, mc)
    if len(data) and data.peg_count.any() and not mc.peg_reach:
        raise ValueError("data holds transitions around pegs (collected with max_pegs); a "
                         "model without peg_reach (--peg-reach) does not see pegs: give it one, "
                         "or use data of an empty table")
    torch.manual_seed(tc.seed)
    model = model_class(mc, device=device)
    trained = model.net
    if teacher is not None:  # the ensemble is the teacher's, frozen; the mean network learns
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
    elif tc.init:
        start = TransitionModel.load(tc.init, device="cpu")
        # A network without contact vectors is a fine start for one with them, one of the
        # default cord for one of several cords, and one of the empty table for one that
        # sees pegs (the new inputs' weights start at zero: it first predicts as before,
        # every cord as the default and every peg as absent).
        seen = replace(start.config, mean_network=False, mean_by_grasp=False)
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
            raise ValueError(f"init {tc.init!r} is a model of another architecture or cord: "
                             f"{', '.join(differ)}")
        first_net = start.net
        if grow_contact:
            after = replace(seen, contact_reach=mc.contact_reach)
            first_net = first_net.with_inputs(seen.contact_at, after.inputs - seen.inputs)
            seen = after
        if grow_pegs:  # the peg vectors come after the rim's (and contact's)
            after = replace(seen, peg_reach=mc.peg_reach, peg_radius=mc.peg_radius)
            first_net = first_net.with_inputs(seen.peg_at, 2 * after.peg_inputs)
            seen = after
        if grow_cord:  # the cord's features come before the move's four inputs
            first_net = first_net.with_inputs(seen.inputs - 4, mc.cord_features)
        model.net.load_state_dict(first_net.state_dict())
        # What fine-tuning started from: its weights' fingerprint and its own provenance.
        init_record = {"fingerprint": fingerprint(start.net), "info": start.info}
    net = None if teacher is None else trained  # what the losses run
    teacher_ensemble = None if teacher is None else fingerprint(model.net)
    optimiser = torch.optim.Adam(trained.parameters(), lr=tc.lr)
    step = 0
    if resume and checkpoint.is_file():
        saved = load_checkpoint(checkpoint, str(checkpoint), kind=CHECKPOINT_FORMAT, version=1)
        check_config_keys(saved["model_config"], str(checkpoint), checkpoint=True)
        saved_mc = config_from_dict(TransitionModelConfig, current_config(saved["model_config"]),
                                    "model_config")
        saved_tc = config_from_json(saved["train_config"])
        if saved_tc != tc or saved_mc != mc:
            differ = [f"{k}={a!r} (now {b!r})" for old, new in ((saved_tc, tc), (saved_mc, mc))
                      for (k, a), b in zip(asdict(old).items(), asdict(new).values()) if a != b]
            raise ValueError(f"resume: {checkpoint} was written with other settings: "
                             f"{', '.join(differ)}; use the same settings or another --out")
        if saved.get("teacher_ensemble", teacher_ensemble) != teacher_ensemble:
            raise ValueError(f"resume: {checkpoint} distils another ensemble than teacher "
                             f"{tc.teacher!r} holds now; use that teacher or another --out")
        started_from = init_record and init_record["fingerprint"]
        if saved.get("init_fingerprint", started_from) != started_from:
            raise ValueError(f"resume: {checkpoint} fine-tunes another model than init "
                             f"{tc.init!r} holds now; use that model or another --out")
        trained.load_state_dict(saved["net"])
        optimiser.load_state_dict(saved["optimiser"])
        step = int(saved["step"])
    train, validation = split_transitions(data, tc.validation_fraction, seed=tc.seed)
    tr, va = as_tensors(model, train), as_tensors(model, validation)
    targets = mean_predictions(model, tr) if teacher is not None else None
    extra = extra_targets = None
    real = tc.batch_size
    if teacher is not None and tc.teacher_moves:
        extra = paired_moves(model, train, tc.teacher_moves, seed=tc.seed)
        extra_targets = mean_predictions(model, extra)
        real = max(1, round(tc.batch_size / (tc.teacher_moves + 1)))
    gen = torch.Generator(device="cpu").manual_seed(tc.seed * 1_000_003 + step)
    info = {"data": data.metadata.get("collect", {}), "files": data.metadata.get("files"),
            "sources": data.metadata.get("sources"),
            "train_config": asdict(tc),
            "transitions": len(train), "data_transitions": len(data),
            "test_cords_left_out": int(left_out.sum()),
            "env_steps": data.env_steps()}
    started = time.perf_counter()
    model.train()
    while step < tc.steps:
        fraction = step / tc.steps
        factor = 0.5 * (1 + math.cos(math.pi * fraction)) if tc.lr_schedule == "cosine" else 1.0
        for group in optimiser.param_groups:
            group["lr"] = tc.lr * factor
        idx = torch.randint(len(tr.grasp), (real,), generator=gen).to(model.device)
        start, grasp, moves, target = tr.start[idx], tr.grasp[idx], tr.moves[idx], None
        cord, pegs = tr.rows("cord", idx), tr.rows("pegs", idx)
        if targets is not None:
            target = targets[idx]
        if extra is not None and real < tc.batch_size:  # the teacher's moves fill the batch
            pick = torch.randint(len(extra.grasp), (tc.batch_size - real,),
                                 generator=gen).to(model.device)
            start, grasp, moves, target = (torch.cat([a, b[pick]]) for a, b in (
                (start, extra.start), (grasp, extra.grasp), (moves, extra.moves),
                (target, extra_targets)))
            if cord is not None:
                cord = torch.cat([cord, extra.cord[pick]])
            if pegs is not None:
                pegs = torch.cat([pegs, extra.pegs[pick]])
        pred = model(start, grasp, moves, net=net, cord=cord, pegs=pegs)
        errors = point_error(pred[:, :real], tr.next[idx][None])
        loss_one = errors.mean()
        loss = one_move_loss(errors, tc)
        loss_teacher = torch.zeros(())
        if target is not None:
            loss_teacher = point_error(pred, target[None]).mean()
            loss = loss + tc.teacher_weight * loss_teacher
        optimiser.zero_grad(set_to_none=True)
        loss.backward()
        optimiser.step()
        step += 1
        stats = {"loss": float(loss_one.detach())}
        if targets is not None:
            stats["teacher"] = float(loss_teacher.detach())
        if step % tc.eval_every == 0 or step == tc.steps:
            model.eval()
            stats["validation_cm"] = 100 * validation_error(model, va, net=net)
            model.train()
            _curve_row(out / CURVE_FILE, {"step": step, "lr": tc.lr * factor, **stats,
                                          "seconds": round(time.perf_counter() - started, 1)})
            save_atomic({"format": CHECKPOINT_FORMAT, "format_version": 1, "step": step,
                         "train_config": asdict(tc), "model_config": saved_config(mc),
                         "net": trained.state_dict(), "optimiser": optimiser.state_dict(),
                         "teacher_ensemble": teacher_ensemble,
                         "init_fingerprint": init_record and init_record["fingerprint"]},
                        checkpoint)
        if progress is not None:
            progress(step, stats)
    model.eval()
    model.info = {**info, "steps": step,
                  "validation_cm": 100 * validation_error(model, va, net=net)}
    if teacher is not None:  # the ensemble's own provenance, as its training recorded it
        model.info["ensemble"] = (teacher.info.get("ensemble", teacher.info)
                                  if teacher.config.mean_network else teacher.info)
        model.info["teacher_ensemble"] = teacher_ensemble
    if init_record is not None:
        model.info["init_model"] = init_record
    model.save(out)
    with atomic_path(out / "transition-info.json") as tmp:
        tmp.write_text(json.dumps(model.info, indent=1, sort_keys=True))
    return model


#: Training settings retired (the chain loss, off in every shipped model: ``chain_weight``
#: 0); a record with another ``chain_weight`` is refused.
RETIRED_TRAIN = {"chain_batch": 128, "chain_moves": 3, "chain_weight": 0.0}


def config_from_json(values: dict[str, Any]) -> TransitionTrainConfig:
    """A training config from JSON values (unknown keys are an error naming them; retired
    ones must have had no effect)."""
    if values.get("chain_weight", 0.0) != 0.0:
        raise ValueError(f"train_config has chain_weight={values['chain_weight']!r}: the chain "
                         "loss is retired")
    return config_from_dict(TransitionTrainConfig,
                            {k: v for k, v in values.items() if k not in RETIRED_TRAIN},
                            "train_config")
