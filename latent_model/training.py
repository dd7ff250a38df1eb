"""Training of the GAN and the Encoder, with held-out evaluation, logs, checkpoints and resume.

One ``Trainer`` owns the networks, their optimisers and the data in network units. ``train``
is the function ``dlo train`` calls: it resumes from ``OUT/checkpoint.pt`` when present,
trains each stage within its budget, evaluates on the held-out split every ``eval_every``
steps (CSV row + PNG of the curves), checkpoints atomically, and exports ``OUT/model.pt``.
"""

from __future__ import annotations

import csv
import math
import os
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch

import latent_model.losses as losses
import latent_model.metrics as metrics
import latent_model.pose as pose
from dlo_env.core.atomic import atomic_path
from dlo_env.errors import InputError
from dlo_env.shapes import TABLE_HALF
from latent_model.checkpoint import FORMAT, FORMAT_VERSION, load_checkpoint, save_atomic
from latent_model.config import ModelConfig, TrainConfig, config_from_dict
from latent_model.dataset import evaluation_subsets
from latent_model.networks import Discriminator, Encoder, Generator
from latent_model.normalisation import CANONICAL_SCALE, Normalisation
from latent_model.shape_model import ShapeModel, resolve_device

STAGES = ("gan", "encoder", "all")
CHECKPOINT_FILE = "checkpoint.pt"
METRICS_CSV = "metrics.csv"
METRICS_PNG = "metrics.png"
CSV_FIELDS = (
    "stage", "step", "train_minutes", "cov", "mmd", "nna", "spacing_cv", "length",
    "inversion_encoder", "inversion_refined", "loss_d", "loss_g", "loss_e", "eval_seconds",
)


def normalisation_for(config: ModelConfig) -> Normalisation:
    """The fixed map from metres to network units of a representation.

    World: the table's half-side is one unit, so tanh covers the table. Canonical: every point
    of a cord lies within half its length of the centroid (the mean distance to the other
    points is at most the mean arc length to them), so ``0.525 * length`` per unit fits every
    possible shape with 5 % headroom; no data-dependent fit that new shapes could exceed.
    """
    if config.representation == "canonical":
        return Normalisation(0.0, 0.0, CANONICAL_SCALE * config.cord_length)
    return Normalisation(0.0, 0.0, TABLE_HALF)


def network_shapes(shapes: torch.Tensor, config: ModelConfig) -> torch.Tensor:
    """World shapes ``(N, n, 2)`` as the generator must produce them, in network units."""
    norm = normalisation_for(config)
    if config.representation == "canonical":
        return norm.to_network(pose.canonicalise(shapes))
    return norm.to_network(shapes)


@dataclass
class Progress:
    """Counters that make a run resumable."""

    gan_step: int = 0
    encoder_step: int = 0
    gan_seconds: float = 0.0
    encoder_seconds: float = 0.0
    total_seconds: float = 0.0  # all training, including Encoder runs that were redone
    encoder_for_gan_step: int = -1  # the GAN step the Encoder was trained against
    best_score: float = -math.inf  # COV - 1-NNA of the best GAN evaluation (validation subset)
    best_step: int = -1  # its GAN step; the GAN stage ends by restoring it
    rows: list[dict[str, Any]] = field(default_factory=list)


class Trainer:
    """Networks, optimisers and data of one training run.

    Args:
        train_shapes: ``(N, n, 2)`` world metres.
        heldout_shapes: ``(M, n, 2)`` world metres, used only for evaluation.
        model_config: Architecture.
        train_config: Optimisation settings.
        device: ``"auto"``, ``"cpu"``, ``"cuda"``...
        seed: Seeds the networks' initialisation and every random draw of the run.
    """

    def __init__(
        self,
        train_shapes: np.ndarray,
        heldout_shapes: np.ndarray,
        model_config: ModelConfig,
        train_config: TrainConfig,
        device: str | torch.device = "auto",
        seed: int = 0,
    ) -> None:
        self.mc, self.tc = model_config, train_config
        self.device = resolve_device(device)
        self.seed = seed
        if self.tc.threads > 0 and self.device.type == "cpu":
            torch.set_num_threads(self.tc.threads)
        torch.manual_seed(seed)
        shapes = torch.as_tensor(np.asarray(train_shapes, dtype=np.float32))
        self.norm = normalisation_for(model_config)
        x = network_shapes(shapes, model_config)
        self.data = x.to(self.device)  # (N, n, 2) network units
        self.rest = float(metrics.segment_lengths(x).mean())  # d_r, network units
        # Fixed random subsets (seed 0 whatever the run's seed, so runs compare on equal terms).
        heldout = np.asarray(heldout_shapes, dtype=np.float32)
        n_reference = min(train_config.eval_reference, len(heldout) * 5 // 6)
        n_inversion = min(train_config.eval_inversion, len(heldout) - n_reference)
        # The validation subsets come from the END of the seed-0 permutation, the final
        # report's subsets (``quality_report``, seed 0) from its start: with a large held-out
        # file, choosing the best GAN step never sees the shapes it is reported on.
        rest = len(heldout) - n_reference - n_inversion
        _, reference, targets = evaluation_subsets(
            heldout, (rest, n_reference, n_inversion), seed=0)
        self.eval_reference, self.eval_targets = torch.from_numpy(reference), targets
        self.generator = Generator(model_config).to(self.device)
        self.discriminator = Discriminator(model_config).to(self.device)
        self.encoder = Encoder(model_config).to(self.device)
        betas = (train_config.beta1, 0.999)
        self.opt_g = torch.optim.Adam(self.generator.parameters(), train_config.lr_generator, betas)
        self.opt_d = torch.optim.Adam(
            self.discriminator.parameters(), train_config.lr_discriminator, betas
        )
        self.opt_e = torch.optim.Adam(self.encoder.parameters(), train_config.lr_encoder, betas)
        self.rng = torch.Generator(device=self.device).manual_seed(seed)
        self.progress = Progress()
        self.best_state: dict[str, Any] | None = None  # networks at progress.best_step
        self.last = {"loss_d": math.nan, "loss_g": math.nan, "loss_e": math.nan}

    # ---------------------------------------------------------- learning rate
    def set_lr_fraction(self, fraction: float) -> None:
        """Set every learning rate for a stage that is ``fraction`` (0..1) through its budget."""
        tc = self.tc
        factor = 1.0
        if tc.lr_schedule == "cosine":
            factor = 0.5 * (1 + math.cos(math.pi * min(max(fraction, 0.0), 1.0)))
        for opt, base in ((self.opt_g, tc.lr_generator), (self.opt_d, tc.lr_discriminator),
                          (self.opt_e, tc.lr_encoder)):
            for group in opt.param_groups:
                group["lr"] = base * factor

    # ---------------------------------------------------------------- batches
    def _real(self, size: int) -> torch.Tensor:
        idx = torch.randint(len(self.data), (size,), generator=self.rng, device=self.device)
        return self.data[idx]  # (B, n, 2)

    def _latent(self, size: int) -> torch.Tensor:
        u = torch.rand(size, self.mc.latent_dim, generator=self.rng, device=self.device)
        return u * 2 - 1  # (B, k) uniform on [-1, 1]

    # ------------------------------------------------------------------ steps
    def gan_step(self) -> tuple[float, float]:
        """``d_steps`` discriminator updates, then one generator update; returns the losses."""
        tc = self.tc
        for _ in range(tc.d_steps):
            real = self._real(tc.batch_size)
            with torch.no_grad():
                fake = self.generator(self._latent(tc.batch_size))
            loss_d = losses.discriminator_loss(self.discriminator(real), self.discriminator(fake))
            self.opt_d.zero_grad(set_to_none=True)
            loss_d.backward()
            self.opt_d.step()
        fake = self.generator(self._latent(tc.batch_size))
        adversarial = losses.generator_adversarial_loss(self.discriminator(fake))
        spacing = losses.spacing_loss(fake, self.rest)
        loss_g = (1 - tc.spacing_weight) * adversarial + tc.spacing_weight * spacing
        self.opt_g.zero_grad(set_to_none=True)
        if tc.reconstruction_weight > 0:
            real = self._real(tc.batch_size)
            z = self.encoder(real)
            loss_e = tc.reconstruction_weight * losses.reconstruction_loss(real, self.generator(z))
            if tc.prior_weight > 0:
                loss_e = loss_e + tc.prior_weight * losses.sliced_wasserstein(
                    z, self._latent(tc.batch_size), generator=self.rng)
            loss_g = loss_g + loss_e
            self.opt_e.zero_grad(set_to_none=True)
            self.last["loss_e"] = loss_e.item()
        loss_g.backward()
        self.opt_g.step()
        if tc.reconstruction_weight > 0:
            self.opt_e.step()
        self.progress.gan_step += 1
        self.last.update(loss_d=loss_d.item(), loss_g=loss_g.item())
        return self.last["loss_d"], self.last["loss_g"]

    def encoder_step(self) -> float:
        """One Encoder update on ``||x - G(E(x))||^2`` with the generator frozen."""
        x = self._real(self.tc.encoder_batch_size)
        for p in self.generator.parameters():
            p.requires_grad_(False)
        loss = losses.reconstruction_loss(x, self.generator(self.encoder(x)))
        for p in self.generator.parameters():
            p.requires_grad_(True)
        self.opt_e.zero_grad(set_to_none=True)
        loss.backward()
        self.opt_e.step()
        self.progress.encoder_step += 1
        self.last["loss_e"] = loss.item()
        return loss.item()

    # ------------------------------------------------------------- evaluation
    def model(self, info: dict[str, Any] | None = None) -> ShapeModel:
        """A ``ShapeModel`` sharing this run's networks."""
        return ShapeModel(self.mc, self.norm, self.generator, self.encoder, self.discriminator,
                          self.device, info)

    def evaluate(self) -> dict[str, float]:
        """Metrics on the held-out split: set quality of samples, inversion success."""
        start = time.perf_counter()
        model = self.model()
        reference, targets = self.eval_reference, self.eval_targets
        seed = self.seed + 1_000_003  # evaluation draws never disturb the training stream
        generated = torch.from_numpy(model.sample(5 * len(reference), seed=seed))
        quality = metrics.set_quality(generated, reference, self.mc.cord_length)
        _, err_e, _ = model.invert(targets, refine=False)
        _, err_r, _ = model.invert(targets, seed=seed)
        for net in (self.generator, self.encoder, self.discriminator):
            net.train()
        return {
            "cov": quality.cov, "mmd": quality.mmd, "nna": quality.nna,
            "spacing_cv": quality.spacing_cv, "length": quality.length,
            "inversion_encoder": metrics.success_rate(torch.as_tensor(err_e)),
            "inversion_refined": metrics.success_rate(torch.as_tensor(err_r)),
            "eval_seconds": time.perf_counter() - start,
        }

    # ------------------------------------------------------------ checkpoints
    def state(self, data_info: dict[str, Any]) -> dict[str, Any]:
        """Everything needed to resume: networks, optimisers, counters, random state."""
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "kind": "training",
            "model_config": asdict(self.mc),
            "train_config": asdict(self.tc),
            "normalisation": asdict(self.norm),
            "seed": self.seed,
            "generator": self.generator.state_dict(),
            "discriminator": self.discriminator.state_dict(),
            "encoder": self.encoder.state_dict(),
            "opt_g": self.opt_g.state_dict(),
            "opt_d": self.opt_d.state_dict(),
            "opt_e": self.opt_e.state_dict(),
            "rng": self.rng.get_state(),
            "progress": asdict(self.progress),
            "best": self.best_state,
            "data": data_info,
        }

    def load_state(self, data: dict[str, Any]) -> None:
        """Continue from a checkpoint written by ``state`` (same configs required)."""
        for key, current in (("model_config", asdict(self.mc)), ("train_config", asdict(self.tc))):
            saved = dict(data[key])
            if key == "train_config":  # runs from before lr_schedule existed used a constant rate
                saved.setdefault("lr_schedule", "constant")
            if saved != current:
                raise InputError(
                    f"the checkpoint was written with a different {key}: {saved} "
                    f"(now {current}); use another --out folder or the same settings"
                )
        self.norm = config_from_dict(Normalisation, data["normalisation"], "normalisation")
        for name in ("generator", "discriminator", "encoder"):
            getattr(self, name).load_state_dict(data[name])
        for name in ("opt_g", "opt_d", "opt_e"):
            getattr(self, name).load_state_dict(data[name])
        self.rng.set_state(data["rng"])
        self.progress = Progress(**data["progress"])
        self.best_state = data.get("best")

    def networks_state(self) -> dict[str, Any]:
        """Copies of the three networks' state dicts."""
        return {name: {k: v.detach().clone() for k, v in getattr(self, name).state_dict().items()}
                for name in ("generator", "discriminator", "encoder")}


# ------------------------------------------------------------------- logging
def write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    """Rewrite the metrics CSV atomically from all rows."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=CSV_FIELDS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def plot_curves(
    rows: list[dict[str, Any]], path: Path, floors: dict[str, float] | None = None
) -> None:
    """Redraw the PNG of the metric curves against training minutes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [("cov", "COV", 1), ("mmd", "MMD (cm)", 100), ("nna", "1-NNA", 1),
              ("spacing_cv", "spacing CV", 1), ("length", "length (m)", 1),
              ("inversion_refined", "inversion success", 1)]
    floors = floors or {}
    fig, axes = plt.subplots(2, 3, figsize=(12, 6.5))
    best = [r for r in rows if r["stage"] == "gan-best"]  # a copy of an earlier evaluation
    rows = [r for r in rows if r["stage"] != "gan-best"]
    minutes = [r["train_minutes"] for r in rows]
    for ax, (key, label, factor) in zip(axes.flat, panels):
        ax.plot(minutes, [r[key] * factor for r in rows], marker=".")
        ax.plot([r["train_minutes"] for r in best], [r[key] * factor for r in best], "*",
                color="C3", markersize=11, label="kept GAN step" if key == "cov" else None)
        if key == "cov" and best:
            ax.legend(fontsize=8)
        if key == "inversion_refined":
            encoder_only = [r["inversion_encoder"] for r in rows]
            ax.plot(minutes, encoder_only, marker=".", label="encoder only")
            ax.plot([], [], color="C0", label="refined")
            ax.legend(fontsize=8)
        if key in floors:
            ax.axhline(floors[key] * factor, color="k", lw=0.8, ls="--")
        ax.set_title(label)
        ax.set_xlabel("training minutes")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=80)
    plt.close(fig)


#: The floors of the shipped model (drawn as dashed lines on the PNG).
FLOORS = {"cov": 0.85, "mmd": 0.015, "nna": 0.75, "spacing_cv": 0.05, "inversion_refined": 0.95}


# --------------------------------------------------------------------- train
@dataclass(frozen=True)
class _StageBudget:
    """What one stage of ``train`` may spend: ``steps`` (a step count), or else ``seconds``
    of training."""

    name: str
    steps: int | None
    seconds: float

    @property
    def by_steps(self) -> bool:
        return self.steps is not None

    @property
    def total(self) -> int:
        """The budget in the progress bar's unit (steps or seconds)."""
        return self.steps if self.steps is not None else round(self.seconds)

    def steps_done(self, prog: Progress) -> int:
        return getattr(prog, f"{self.name}_step")

    def seconds_done(self, prog: Progress) -> float:
        return getattr(prog, f"{self.name}_seconds")

    def done(self, prog: Progress) -> int:
        """What the stage has spent, in the progress bar's unit."""
        return self.steps_done(prog) if self.by_steps else round(self.seconds_done(prog))

    def spent(self, prog: Progress) -> bool:
        if self.steps is not None:
            return self.steps_done(prog) >= self.steps
        return self.seconds_done(prog) >= self.seconds

    def fraction(self, prog: Progress) -> float:
        """How far through its budget the stage is (the learning-rate schedule's clock)."""
        if self.steps is not None:
            return self.steps_done(prog) / self.steps
        return self.seconds_done(prog) / max(self.seconds, 1e-9)


def _stage_budgets(stage: str, minutes: float, encoder_fraction: float,
                   gan_steps: int | None, encoder_steps: int | None) -> list[_StageBudget]:
    """The stages ``stage`` runs, in order, with their budgets."""
    encoder_share = encoder_fraction if stage == "all" else (1.0 if stage == "encoder" else 0.0)
    seconds = {"gan": (1 - encoder_share) * minutes * 60, "encoder": encoder_share * minutes * 60}
    steps = {"gan": gan_steps, "encoder": encoder_steps}
    names = {"gan": ["gan"], "encoder": ["encoder"], "all": ["gan", "encoder"]}[stage]
    return [_StageBudget(name, steps[name], seconds[name]) for name in names]


@dataclass
class _Run:
    """A ``train`` call's trainer, output folder and provenance: its evaluations, logs and
    checkpoints."""

    trainer: Trainer
    out: Path
    info: dict[str, Any]

    def model(self) -> ShapeModel:
        """The run's model, with its provenance and last evaluation."""
        prog = self.trainer.progress
        last = prog.rows[-1] if prog.rows else None
        return self.trainer.model(dict(self.info, gan_step=prog.gan_step,
                                       encoder_step=prog.encoder_step, last_metrics=last))

    def save(self) -> None:
        """Write the checkpoint and ``model.pt``."""
        save_atomic(self.trainer.state(self.info), self.out / CHECKPOINT_FILE)
        self.model().save(self.out / "model.pt")

    def write_logs(self) -> None:
        """Rewrite the metrics CSV and PNG."""
        rows = self.trainer.progress.rows
        write_csv(rows, self.out / METRICS_CSV)
        plot_curves(rows, self.out / METRICS_PNG, FLOORS)

    def log_eval(self, name: str) -> dict[str, Any]:
        """Evaluate after stage ``name``'s current step, keep the best GAN step so far, log
        the row; returns it."""
        trainer, prog = self.trainer, self.trainer.progress
        row = {"stage": name, "step": getattr(prog, f"{name}_step"),
               "train_minutes": prog.total_seconds / 60}
        row.update(trainer.evaluate())
        row.update(trainer.last)
        if name == "gan" and row["cov"] - row["nna"] > prog.best_score:
            prog.best_score, prog.best_step = row["cov"] - row["nna"], prog.gan_step
            trainer.best_state = trainer.networks_state()
        prog.rows.append(row)
        self.write_logs()
        return row

    def keep_best_gan(self) -> None:
        """Go back to the best GAN step (its row logged again as ``gan-best``)."""
        trainer, prog = self.trainer, self.trainer.progress
        for net in ("generator", "discriminator", "encoder"):
            getattr(trainer, net).load_state_dict(trainer.best_state[net])
        best_row = next(r for r in prog.rows
                        if r["stage"] == "gan" and r["step"] == prog.best_step)
        prog.rows.append(dict(best_row, stage="gan-best"))
        self.write_logs()


def _train_steps(run: _Run, budget: _StageBudget, progress_bar: bool) -> None:
    """Steps of one stage until its budget is spent: evaluations every ``eval_every`` steps,
    checkpoints every ``checkpoint_every_seconds``."""
    from dlo_env.core.progress import progress_bar as bar_of

    trainer, prog, tc = run.trainer, run.trainer.progress, run.trainer.tc
    step_fn = trainer.gan_step if budget.name == "gan" else trainer.encoder_step
    seconds_attr = f"{budget.name}_seconds"
    bar = bar_of(budget.total, budget.name, "step" if budget.by_steps else "s",
                 enabled=progress_bar)
    bar.update(budget.done(prog))
    last_save = time.perf_counter()
    while not budget.spent(prog):
        trainer.set_lr_fraction(budget.fraction(prog))
        t0 = time.perf_counter()
        step_fn()
        dt = time.perf_counter() - t0
        setattr(prog, seconds_attr, getattr(prog, seconds_attr) + dt)
        prog.total_seconds += dt
        bar.update(1 if budget.by_steps else 0)
        if not budget.by_steps:
            bar.n = min(budget.total, round(getattr(prog, seconds_attr)))
            bar.refresh()
        if budget.steps_done(prog) % tc.eval_every == 0:
            r = run.log_eval(budget.name)
            bar.set_postfix(cov=f"{r['cov']:.2f}", mmd=f"{100 * r['mmd']:.2f}cm",
                            inv=f"{r['inversion_refined']:.2f}", refresh=False)
        if time.perf_counter() - last_save > tc.checkpoint_every_seconds:
            run.save()
            last_save = time.perf_counter()
    bar.close()


def _train_stage(run: _Run, budget: _StageBudget, progress_bar: bool) -> None:
    """One stage within its budget, evaluated at its last step; the GAN stage ends at its
    best step. Checkpoints at the end."""
    trainer, prog, name = run.trainer, run.trainer.progress, budget.name
    if name == "encoder" and prog.encoder_for_gan_step != prog.gan_step:
        # The generator changed since the Encoder was trained: train it again (warm start).
        prog.encoder_step, prog.encoder_seconds = 0, 0.0
        prog.encoder_for_gan_step = prog.gan_step
    _train_steps(run, budget, progress_bar)
    if not prog.rows or prog.rows[-1]["stage"] != name or \
            prog.rows[-1]["step"] != budget.steps_done(prog):
        run.log_eval(name)
    if name == "gan" and trainer.best_state is not None and prog.best_step != prog.gan_step:
        # GAN quality oscillates from evaluation to evaluation: keep the best one (chosen
        # on the validation subsets) and go on from there.
        run.keep_best_gan()
    run.save()


def train(
    train_shapes: np.ndarray,
    heldout_shapes: np.ndarray,
    out_dir: str | os.PathLike,
    model_config: ModelConfig | None = None,
    train_config: TrainConfig | None = None,
    *,
    stage: str = "all",
    minutes: float = 30.0,
    gan_steps: int | None = None,
    encoder_steps: int | None = None,
    device: str | torch.device = "auto",
    seed: int = 0,
    data_info: dict[str, Any] | None = None,
    progress_bar: bool = True,
) -> ShapeModel:
    """Train (or resume training of) a ``ShapeModel``; write logs, checkpoints and ``model.pt``.

    The budget of a run is ``minutes`` of training wall time in total, evaluations excluded,
    across resumes. With ``stage="all"`` the GAN gets ``1 - encoder_fraction`` of it and the
    Encoder the rest; ``stage="encoder"`` trains only the Encoder of an existing run.
    ``gan_steps``/``encoder_steps`` replace the time budget of their stage by a step count
    (bit-reproducible runs on the same machine and torch build).

    Returns:
        The trained model (also saved to ``out_dir/model.pt``).
    """

    if stage not in STAGES:
        raise InputError(f"stage must be one of {STAGES}, got {stage!r}")
    if not minutes > 0:
        raise InputError(f"minutes must be > 0, got {minutes!r}")
    mc, tc = model_config or ModelConfig(), train_config or TrainConfig()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ckpt_path = out / CHECKPOINT_FILE
    if stage == "encoder" and not ckpt_path.exists():
        raise InputError(
            f"stage 'encoder' needs a trained GAN: no {CHECKPOINT_FILE} in {str(out)!r}"
        )
    trainer = Trainer(train_shapes, heldout_shapes, mc, tc, device, seed)
    if ckpt_path.exists():
        trainer.load_state(load_checkpoint(ckpt_path, name="checkpoint"))
    run = _Run(trainer, out, dict(data_info or {}, seed=seed))
    for budget in _stage_budgets(stage, minutes, tc.encoder_fraction, gan_steps, encoder_steps):
        _train_stage(run, budget, progress_bar)
    return run.model()
