"""Configurations of the surrogate: networks (``ModelConfig``) and training (``TrainConfig``).

Defaults are the paper's (latent 5, n 20, alpha 0.5, five discriminator steps per generator
step, Adam 2e-4 with beta1 0.5) except where a measured improvement is documented next to the
field and on the shape model's page, docs/shape_model.md.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from dlo_env.core.checks import positive_ints
from dlo_env.errors import InputError

REPRESENTATIONS = ("canonical", "world")
OUTPUTS = ("points", "angles")
LR_SCHEDULES = ("cosine", "constant")


@dataclass(frozen=True)
class ModelConfig:
    """Architecture of the Generator, Discriminator and Encoder.

    Attributes:
        n_points: Points of the chain the networks produce.
        cord_length: Rest length of the cord the data came from, metres.
        latent_dim: Dimension of the generator's shape latent ``z ~ U[-1, 1]^latent_dim``.
        representation: ``"world"`` is the paper's: the generator outputs world coordinates, so
            ``z`` also has to encode where the cord lies and how it is turned. ``"canonical"``
            (default, measured better, docs/shape_model.md): the generator outputs the shape in its
            canonical frame (centroid at the origin, arc-length regression direction along +x)
            and the pose is applied analytically; the full latent is then
            ``[z, centre_x, centre_y, cos(angle), sin(angle)]``.
        output: ``"angles"`` (default for the canonical representation, which it needs): the
            last layer gives the ``n - 2`` turning angles between consecutive segments
            (``pi * tanh``) and the chain is built from segments of exactly the rest length,
            then moved into its canonical frame; inextensibility holds by construction
            (spacing CV 0, exact length, spacing loss 0) and the network learns only the
            bending. ``"points"`` (default for ``"world"``) is the paper's tanh layer of
            ``2 n`` coordinates kept near the rest spacing by the spacing loss. Measured in
            docs/shape_model.md.
        width: Hidden units of every fully connected layer.
        depth: Hidden layers of each network.
        leaky_slope: Negative slope of the LeakyReLU activations.
        encoder_spectral_norm: Whether the Encoder keeps the Discriminator's spectral norm.
    """

    n_points: int = 20
    cord_length: float = 1.0
    latent_dim: int = 5
    representation: str = "canonical"
    output: str | None = None
    width: int = 256
    depth: int = 3
    leaky_slope: float = 0.2
    encoder_spectral_norm: bool = False

    def __post_init__(self) -> None:
        if self.representation not in REPRESENTATIONS:
            raise InputError(
                f"representation must be one of {REPRESENTATIONS}, got {self.representation!r}"
            )
        if self.output is None:  # the best measured output for the representation
            object.__setattr__(
                self, "output", "angles" if self.representation == "canonical" else "points")
        if self.output not in OUTPUTS:
            raise InputError(f"output must be one of {OUTPUTS}, got {self.output!r}")
        if self.output == "angles" and self.representation != "canonical":
            raise InputError("output='angles' needs representation='canonical' (the pose is "
                             f"applied analytically), got representation={self.representation!r}")
        for name in ("n_points", "latent_dim", "width", "depth"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise InputError(f"ModelConfig.{name} must be a positive int, got {value!r}")
        if self.n_points < 3:
            raise InputError(f"ModelConfig.n_points must be >= 3, got {self.n_points!r}")
        if not self.cord_length > 0:
            raise InputError(f"ModelConfig.cord_length must be > 0, got {self.cord_length!r}")

    @property
    def pose_dim(self) -> int:
        """Extra latent dimensions that carry the pose (0 for the world representation)."""
        return 4 if self.representation == "canonical" else 0

    @property
    def full_latent_dim(self) -> int:
        """Dimension of the latent that ``ShapeModel.encode`` returns."""
        return self.latent_dim + self.pose_dim


@dataclass(frozen=True)
class TrainConfig:
    """How the GAN and the Encoder are trained.

    Attributes:
        batch_size: Shapes per step (the paper used 6000 on a GPU; 256 with 2 D-steps and
            lr 5e-4 learns faster per CPU-minute than 1024 with 5 D-steps and lr 2e-4: the
            recipes' table in docs/shape_model.md).
        lr_generator: Adam learning rate of the Generator (paper 2e-4).
        lr_discriminator: Adam learning rate of the Discriminator (paper 2e-4).
        beta1: Adam beta1 (beta2 is 0.999).
        d_steps: Discriminator updates per Generator update (paper 5).
        spacing_weight: The paper's alpha: the generator minimises
            ``alpha * L_spacing + (1 - alpha) * L_adversarial``.
        lr_encoder: Adam learning rate of the Encoder.
        encoder_batch_size: Shapes per Encoder step.
        encoder_fraction: Share of the time budget given to the Encoder when ``stage="all"``.
        reconstruction_weight: Weight of ``||x - G(E(x))||^2`` on real shapes, trained jointly
            into the Generator and the Encoder at every generator step (0 = the paper, where the
            Encoder is trained only after the GAN). It ties every training shape to a latent,
            so the generator cannot drop modes (docs/shape_model.md has the measurement).
        prior_weight: Weight of the sliced Wasserstein distance between the Encoder's latents
            of real shapes and ``U[-1, 1]^k`` (only with ``reconstruction_weight > 0``).
        lr_schedule: ``"cosine"``: every learning rate follows half a cosine from its value to 0
            over its stage's budget (steps or minutes); the later part of a run swings less
            (a small effect, docs/shape_model.md). The GAN stage still keeps its best evaluation.
            ``"constant"``: the paper. Extending a finished run's budget restarts the
            decay part-way (at the old budget's share of the new one).
        eval_every: Generator steps between evaluations on the held-out split.
        eval_reference: Held-out shapes used by the evaluation during training.
        eval_inversion: Held-out shapes inverted by the evaluation during training.
        checkpoint_every_seconds: Wall time between checkpoints.
        threads: Torch CPU threads (0 = leave torch's default).
    """

    batch_size: int = 256
    lr_generator: float = 5e-4
    lr_discriminator: float = 5e-4
    beta1: float = 0.5
    d_steps: int = 2
    spacing_weight: float = 0.5
    lr_encoder: float = 1e-3
    encoder_batch_size: int = 1024
    encoder_fraction: float = 0.1
    reconstruction_weight: float = 100.0
    prior_weight: float = 5.0
    lr_schedule: str = "cosine"
    eval_every: int = 500
    eval_reference: int = 1000
    eval_inversion: int = 200
    checkpoint_every_seconds: float = 60.0
    threads: int = 2

    def __post_init__(self) -> None:
        positive_ints(self, "batch_size", "d_steps", "encoder_batch_size", "eval_every")
        if not 0.0 <= self.spacing_weight <= 1.0:
            raise InputError(
                f"TrainConfig.spacing_weight must be in [0, 1], got {self.spacing_weight!r}"
            )
        if self.lr_schedule not in LR_SCHEDULES:
            raise InputError(f"TrainConfig.lr_schedule must be one of {LR_SCHEDULES}, "
                             f"got {self.lr_schedule!r}")
        if not 0.0 <= self.encoder_fraction < 1.0:
            raise InputError(
                f"TrainConfig.encoder_fraction must be in [0, 1), got {self.encoder_fraction!r}"
            )


#: The paper's recipe (world-free canonical frame kept; ``--paper`` in ``dlo train``).
PAPER_MODEL = ModelConfig(output="points")
PAPER_TRAIN = TrainConfig(batch_size=1024, lr_generator=2e-4, lr_discriminator=2e-4, d_steps=5,
                          encoder_fraction=0.25, reconstruction_weight=0.0, prior_weight=0.0,
                          lr_schedule="constant")


def config_from_dict(cls: type, values: dict[str, Any], name: str = "config") -> Any:
    """Build a config dataclass from a (checkpoint) dict, rejecting unknown keys clearly."""
    known = {f.name for f in fields(cls)}
    unknown = sorted(set(values) - known)
    if unknown:
        raise InputError(
            f"{name} has unknown fields {unknown}; expected a subset of {sorted(known)}"
        )
    return cls(**values)
