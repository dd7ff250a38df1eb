"""Additional training (paper section VI-C): teach the model shapes it cannot represent yet.

For every shape the model cannot invert within 1 cm, the cord simulator makes slightly deformed
variants of it (reset to the shape, small random straight moves of one end, shapes recorded
along each move). The GAN and then the Encoder continue training on those variants mixed with
the original data. The report compares inversion success on the shapes, and the held-out
metrics, before and after.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dlo_env.cord import Cord
from dlo_env.errors import InputError
from dlo_env.shapes import is_cord_like, validate_shape
from latent_model.config import TrainConfig
from latent_model.evaluation import QualityReport, quality_report
from latent_model.shape_model import ShapeModel
from latent_model.training import Trainer


@dataclass(frozen=True)
class FinetuneConfig:
    """Settings of additional training.

    Attributes:
        variants_per_shape: Simulated moves per unrepresented shape.
        max_move: Longest end displacement of a variant move, metres.
        record_every: Physics substeps between recorded shapes along a move.
        new_fraction: Share of the variants in the mixed training data.
        gan_steps: Generator steps of additional GAN training (200: enough to represent the
            new shapes without moving the generator far from the step training kept;
            docs/shape_model.md has the measurement).
        encoder_steps: Encoder steps afterwards.
        train: Optimisation settings (the model's training defaults).
    """

    variants_per_shape: int = 16
    max_move: float = 0.05
    record_every: int = 5
    new_fraction: float = 0.25
    gan_steps: int = 200
    encoder_steps: int = 1500
    train: TrainConfig = TrainConfig()

    def __post_init__(self) -> None:
        if self.variants_per_shape < 1 or self.record_every < 1:
            raise InputError("variants_per_shape and record_every must be >= 1")
        if not 0.0 < self.new_fraction < 1.0:
            raise InputError(f"new_fraction must be in (0, 1), got {self.new_fraction!r}")
        if not self.max_move > 0:
            raise InputError(f"max_move must be > 0, got {self.max_move!r}")


def deformed_variants(
    shapes: np.ndarray, model: ShapeModel, config: FinetuneConfig, seed: int
) -> np.ndarray:
    """Simulated shapes near each of ``shapes`` ``(B, n, 2)``: the shape itself plus its variants.

    Each variant resets the cord to the shape, grasps the head or the tail at random and moves
    it straight by a random displacement of up to ``max_move``; the cord-like shapes recorded
    along the move are kept.

    Raises:
        ValueError: If a shape is not a valid cord of the model's length and number of points.
    """
    rng = np.random.default_rng(seed)
    params = model.cord_params
    cord = Cord(params, grasp="head")
    out = []
    for i, shape in enumerate(shapes):
        shape = validate_shape(shape, n_points=params.n_points, length=params.length,
                               name=f"shapes[{i}]")
        out.append(shape[None])
        for _ in range(config.variants_per_shape):
            cord.reset(shape)
            cord.set_grasp("head" if rng.random() < 0.5 else "tail")
            angle = rng.uniform(-np.pi, np.pi)
            direction = np.array([np.cos(angle), np.sin(angle)])
            move = rng.uniform(0.2, 1.0) * config.max_move * direction
            recorded = cord.move(head=move, tail=move, record_every=config.record_every)
            out.append(recorded[is_cord_like(recorded)])
    return np.concatenate(out).astype(np.float32)


@dataclass(frozen=True)
class FinetuneReport:
    """What additional training changed.

    Attributes:
        n_shapes: Shapes given.
        n_unrepresented: Of those, not represented before (the ones variants were made of).
        n_variants: Simulated variant shapes trained on.
        success_before, success_after: Inversion success on all given shapes (refined).
        encoder_success_before, encoder_success_after: The same with the Encoder alone.
        heldout_before, heldout_after: Held-out quality reports (None without held-out data).
    """

    n_shapes: int
    n_unrepresented: int
    n_variants: int
    success_before: float
    success_after: float
    encoder_success_before: float
    encoder_success_after: float
    heldout_before: QualityReport | None
    heldout_after: QualityReport | None

    def format(self) -> str:
        """Plain-text summary."""
        lines = [
            f"shapes: {self.n_shapes}, not represented before: {self.n_unrepresented}, "
            f"simulated variants: {self.n_variants}",
            f"inversion success on the shapes: {self.success_before:.3f} -> "
            f"{self.success_after:.3f}"
            f" (encoder only {self.encoder_success_before:.3f} -> "
            f"{self.encoder_success_after:.3f})",
        ]
        if self.heldout_before is not None and self.heldout_after is not None:
            b, a = self.heldout_before, self.heldout_after
            lines.append("held-out metrics before -> after:")
            for name in ("cov", "mmd", "nna", "spacing_cv", "length_error", "inversion",
                         "foreign_inversion"):
                if name == "mmd":  # metres, printed in cm as `dlo train` prints it
                    lines.append(f"  {'mmd (cm)':<18} {100 * b.mmd:.4f} -> {100 * a.mmd:.4f}")
                    continue
                lines.append(f"  {name:<18} {getattr(b, name):.4f} -> {getattr(a, name):.4f}")
        return "\n".join(lines)


def _success(model: ShapeModel, shapes: np.ndarray, refine: bool, seed: int) -> float:
    if len(shapes) == 0:
        return 1.0
    return float(np.mean(model.invert(shapes, refine=refine, seed=seed)[2]))


def finetune(
    model: ShapeModel,
    shapes: np.ndarray,
    train_shapes: np.ndarray,
    heldout_shapes: np.ndarray | None = None,
    config: FinetuneConfig | None = None,
    *,
    seed: int = 0,
    report_size: int = 1000,
    progress_bar: bool = True,
) -> tuple[ShapeModel, FinetuneReport]:
    """Additional training of ``model`` on shapes it cannot represent.

    Args:
        model: The model to improve (needs its Discriminator; models saved by training have it).
        shapes: Shapes the model should represent, ``(B, n, 2)`` world metres.
        train_shapes: The original training data, ``(N, n, 2)``.
        heldout_shapes: Held-out shapes to check that quality did not degrade (optional).
        config: Settings.
        seed: Seeds the variants and the training.
        report_size: Held-out reference and inversion shapes of each quality report.
        progress_bar: Show tqdm bars.

    Returns:
        The new model (the given one is left unchanged) and the report.
    """
    from dlo_env.core.progress import progress_bar as bar_of

    config = config or FinetuneConfig()
    if model.discriminator is None:
        raise InputError("model has no discriminator saved; additional training needs one")
    shapes = np.asarray(shapes, dtype=np.float32)
    if shapes.ndim == 2:
        shapes = shapes[None]
    model._shapes_in(shapes, name="shapes")  # same checks and messages as the model's methods
    _, _, ok = model.invert(shapes, seed=seed)
    hard = shapes[~ok]
    report_kw = {"n_reference": report_size, "n_inversion": report_size, "seed": seed}
    use_heldout = heldout_shapes is not None and len(heldout_shapes) >= 2 * report_size
    before = quality_report(model, heldout_shapes, **report_kw) if use_heldout else None
    enc_before = _success(model, shapes, refine=False, seed=seed)
    variants = deformed_variants(hard, model, config, seed) if len(hard) else shapes[:0]

    new_model = model
    if len(variants):
        train_shapes = np.asarray(train_shapes, dtype=np.float32)
        copies = int(np.ceil(config.new_fraction / (1 - config.new_fraction)
                             * len(train_shapes) / len(variants)))
        mixed = np.concatenate([train_shapes, np.tile(variants, (copies, 1, 1))])
        tc = config.train
        trainer = Trainer(mixed, heldout_shapes if heldout_shapes is not None else variants,
                          model.config, tc, model.device, seed)
        state = model.state()
        trainer.norm = model.normalisation
        for name in ("generator", "discriminator", "encoder"):
            getattr(trainer, name).load_state_dict(state[name])
        for name, steps, step_fn in (("gan", config.gan_steps, trainer.gan_step),
                                     ("encoder", config.encoder_steps, trainer.encoder_step)):
            bar = bar_of(steps, f"finetune {name}", "step", enabled=progress_bar)
            for i in range(steps):
                trainer.set_lr_fraction(i / steps)  # FinetuneConfig.train's schedule
                step_fn()
                bar.update(1)
            bar.close()
        info = dict(model.info, finetuned_on=len(hard), finetune_variants=len(variants),
                    finetune_config=repr(replace(config)))
        new_model = trainer.model(info)
        for net in (new_model.generator, new_model.encoder, new_model.discriminator):
            net.eval()
    after = quality_report(new_model, heldout_shapes, **report_kw) if use_heldout else None
    report = FinetuneReport(
        n_shapes=len(shapes), n_unrepresented=len(hard), n_variants=len(variants),
        success_before=float(np.mean(ok)) if len(ok) else 1.0,
        success_after=_success(new_model, shapes, refine=True, seed=seed),
        encoder_success_before=enc_before,
        encoder_success_after=_success(new_model, shapes, refine=False, seed=seed),
        heldout_before=before, heldout_after=after,
    )
    return new_model, report
