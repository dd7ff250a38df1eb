"""``ShapeModel``: the trained surrogate behind one numpy-in, numpy-out interface in metres."""

from __future__ import annotations

import os
from contextlib import contextmanager
from dataclasses import asdict
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import torch

import latent_model.pose as pose
from dlo_env.cord import CordParams
from dlo_env.errors import InputError
from dlo_env.shapes import TABLE_HALF, unflatten
from latent_model.checkpoint import FORMAT, FORMAT_VERSION, load_checkpoint, save_atomic
from latent_model.config import ModelConfig, config_from_dict
from latent_model.inversion import refine_latents
from latent_model.metrics import REPRESENTED, error
from latent_model.networks import Discriminator, Encoder, Generator
from latent_model.normalisation import Normalisation

#: File name of the model inside a training output folder and inside ``pretrained/``.
MODEL_FILE = "model.pt"
#: Latents decoded per batch by ``decode`` (hidden activations stay in the CPU cache).
DECODE_CHUNK = 2048


def resolve_device(device: str | torch.device = "auto") -> torch.device:
    """``"auto"`` is CUDA when available, else CPU; anything else is passed to ``torch.device``."""
    if isinstance(device, str) and device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        return torch.device(device)
    except (RuntimeError, TypeError) as exc:
        raise InputError(
            f"device must be 'auto', 'cpu', 'cuda' or 'cuda:N', got {device!r}"
        ) from exc


@contextmanager
def _frozen(module: torch.nn.Module):
    """Turn off parameter gradients for the duration (latent refinement needs none)."""
    saved = [p.requires_grad for p in module.parameters()]
    for p in module.parameters():
        p.requires_grad_(False)
    try:
        yield module
    finally:
        for p, flag in zip(module.parameters(), saved):
            p.requires_grad_(flag)


class ShapeModel:
    """The GAN surrogate of the cord: decode latents to shapes, invert shapes to latents.

    Every method takes and returns numpy arrays in world metres. The latent has
    ``latent_dim`` dimensions: for the canonical representation (the default) the generator's
    shape latent ``z`` in ``[-1, 1]^config.latent_dim`` followed by the pose
    ``[centre_x, centre_y, cos(angle), sin(angle)]``; for the paper's world representation
    just ``z``. Straight lines in latent space are meaningful for both (the angle wraps).

    Args:
        config: Architecture of the networks.
        normalisation: Map between metres and the generator's output range.
        generator: Trained ``Generator`` (a fresh one if None).
        encoder: Trained ``Encoder`` (a fresh one if None).
        discriminator: Kept so additional training can continue the GAN (optional).
        device: ``"auto"`` (CUDA if available), ``"cpu"``, ``"cuda"``...
        info: Free-form provenance saved with the model (data file, seed, step, metrics).

    Example:
        >>> model = ShapeModel.load_pretrained()
        >>> z, err, ok = model.invert(shapes)   # shapes (B, 20, 2) metres
        >>> model.decode(z)                     # (B, 20, 2), each within 1 cm where ok
    """

    def __init__(
        self,
        config: ModelConfig,
        normalisation: Normalisation,
        generator: Generator | None = None,
        encoder: Encoder | None = None,
        discriminator: Discriminator | None = None,
        device: str | torch.device = "auto",
        info: dict[str, Any] | None = None,
    ) -> None:
        self.config = config
        self.normalisation = normalisation
        self.device = resolve_device(device)
        self.generator = (generator or Generator(config)).to(self.device).eval()
        self.encoder = (encoder or Encoder(config)).to(self.device).eval()
        self.discriminator = discriminator.to(self.device).eval() if discriminator else None
        self.info = dict(info or {})

    # ------------------------------------------------------------------ facts
    @property
    def latent_dim(self) -> int:
        """Dimension of the full latent that ``encode`` returns and ``decode`` takes."""
        return self.config.full_latent_dim

    @property
    def n_points(self) -> int:
        """Points per shape."""
        return self.config.n_points

    @property
    def cord_length(self) -> float:
        """Rest length of the modelled cord, metres."""
        return self.config.cord_length

    @property
    def cord_params(self) -> CordParams:
        """The default ``CordParams`` with this model's number of points and length."""
        return CordParams(n_points=self.config.n_points, length=self.config.cord_length)

    @property
    def latent_low(self) -> np.ndarray:
        """Lower bound of every latent coordinate the model was trained on, ``(latent_dim,)``."""
        return -self.latent_high

    @property
    def latent_high(self) -> np.ndarray:
        """Upper bound of every latent coordinate: 1 (the table half-side for the centre)."""
        return np.ones(self.latent_dim, dtype=np.float32)

    # ------------------------------------------------------------- conversion
    def _shapes_in(self, shapes: Any, name: str = "shapes") -> tuple[torch.Tensor, bool]:
        n = self.config.n_points
        arr = unflatten(shapes, n, dtype=np.float32)  # flat shapes, as observations hold them
        single = arr.ndim == 2
        if single:
            arr = arr[None]
        if arr.ndim != 3 or arr.shape[1:] != (n, 2):
            raise InputError(
                f"{name} must have shape ({n}, 2), ({2 * n},), (B, {n}, 2) or (B, {2 * n}), "
                f"got {np.shape(shapes)}"
            )
        if not np.isfinite(arr).all():
            raise InputError(f"{name} must be finite, got NaN or infinite coordinates")
        return torch.from_numpy(arr).to(self.device), single

    def _latents_in(self, z: Any, name: str = "z") -> tuple[torch.Tensor, bool]:
        arr = np.asarray(z, dtype=np.float32)
        single = arr.ndim == 1
        if single:
            arr = arr[None]
        if arr.ndim != 2 or arr.shape[1] != self.latent_dim:
            raise InputError(
                f"{name} must have shape ({self.latent_dim},) or (B, {self.latent_dim}), "
                f"got {np.shape(z)}"
            )
        if not np.isfinite(arr).all():
            raise InputError(f"{name} must be finite, got NaN or infinite values")
        return torch.from_numpy(arr).to(self.device), single

    @staticmethod
    def _out(t: torch.Tensor, single: bool) -> np.ndarray:
        arr = t.detach().cpu().numpy()
        return arr[0] if single else arr

    # ---------------------------------------------------------- torch core
    def decode_torch(self, latent: torch.Tensor) -> torch.Tensor:
        """Differentiable decoding, latents ``(B, latent_dim)`` to world shapes ``(B, n, 2)``."""
        k = self.config.latent_dim
        shapes = self.normalisation.to_metres(self.generator(latent[:, :k]))  # (B, n, 2)
        if self.config.representation == "canonical":
            centre, angle = pose.latent_to_pose(latent[:, k:])
            shapes = pose.to_world(shapes, centre, angle)
        return shapes

    def encode_torch(self, shapes: torch.Tensor) -> torch.Tensor:
        """The Encoder's latents ``(B, latent_dim)`` for world shapes ``(B, n, 2)``."""
        if self.config.representation == "canonical":
            centre, angle = pose.canonical_pose(shapes)
            canonical = pose.to_canonical(shapes, centre, angle)
            z = self.encoder(self.normalisation.to_network(canonical))
            return torch.cat([z, pose.pose_to_latent(centre, angle)], dim=-1)
        return self.encoder(self.normalisation.to_network(shapes))

    # ------------------------------------------------------------ public API
    @torch.no_grad()
    def decode(self, z: Any) -> np.ndarray:
        """Shapes (metres) of latents ``(latent_dim,)`` or ``(B, latent_dim)``: (n, 2), (B, n, 2)"""
        latent, single = self._latents_in(z)
        # Chunks keep the hidden activations in cache: ~20 % faster than one big batch on CPU.
        out = torch.cat([self.decode_torch(part) for part in latent.split(DECODE_CHUNK)])
        return self._out(out, single)

    @torch.no_grad()
    def encode(self, shapes: Any) -> np.ndarray:
        """The Encoder's latent of each shape (the paper's one-shot inversion, unverified)."""
        x, single = self._shapes_in(shapes)
        return self._out(self.encode_torch(x), single)

    @torch.no_grad()
    def sample_latent(self, n: int, seed: int | None = None) -> np.ndarray:
        """Random latents ``(n, latent_dim)`` whose shapes lie on the table.

        ``z`` is uniform on ``[-1, 1]^k``; for the canonical representation the angle is
        uniform and the centre uniform over the places where the decoded shape fits on the
        table with a 5 cm margin (like ``dlo_env.shapes.random_cord_shape``).
        """
        if not isinstance(n, (int, np.integer)) or n < 0:
            raise InputError(f"n must be a non-negative int, got {n!r}")
        gen = torch.Generator().manual_seed(int(seed) if seed is not None else
                                            int(np.random.SeedSequence().entropy % 2**63))
        k = self.config.latent_dim
        z = (torch.rand(n, k, generator=gen) * 2 - 1).to(self.device)
        if self.config.representation != "canonical":
            return z.cpu().numpy()
        angle = ((torch.rand(n, generator=gen) * 2 - 1) * torch.pi).to(self.device)
        turned = pose.to_world(
            self.normalisation.to_metres(self.generator(z)), torch.zeros(n, 2, device=self.device),
            angle,
        )
        half = TABLE_HALF - 0.05
        lo = -half - turned.min(dim=1).values  # (n, 2) smallest centre that keeps it on the table
        hi = half - turned.max(dim=1).values
        u = torch.rand(n, 2, generator=gen).to(self.device)
        centre = torch.where(lo <= hi, lo + u * (hi - lo), 0.5 * (lo + hi))
        return torch.cat([z, pose.pose_to_latent(centre, angle)], dim=-1).cpu().numpy()

    def sample(self, n: int, seed: int | None = None) -> np.ndarray:
        """``n`` random shapes ``(n, n_points, 2)`` in world metres (``decode(sample_latent)``)."""
        return self.decode(self.sample_latent(n, seed))

    def invert(
        self,
        shapes: Any,
        *,
        refine: bool = True,
        restarts: int = 4,
        steps: int = 150,
        lr: float = 0.03,
        threshold: float = REPRESENTED,
        tolerance: float = 0.002,
        seed: int = 0,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Verified inversion: the latent of each shape, its error and whether it is represented.

        The Encoder gives the first guess (the paper's method; ``refine=False`` stops there).
        Then that guess and ``restarts - 1`` random latents per shape are refined together by
        Adam on the decoded mean per-point error, and the best is kept.

        Args:
            shapes: ``(n, 2)`` or ``(B, n, 2)`` world metres.
            refine: Refine the Encoder's latent by gradient descent.
            restarts: Starting latents per shape, the Encoder's included.
            steps: Adam steps of the refinement.
            lr: Adam learning rate.
            threshold: A shape is represented when ``error(decode(z), shape) <= threshold``, m.
            tolerance: Refinement stops once every shape is matched this closely, metres
                (0 runs all ``steps``); the best latent seen is returned either way.
            seed: Seed of the random restarts.

        Returns:
            ``z`` ``(B, latent_dim)``, ``err`` ``(B,)`` metres, ``ok`` ``(B,)`` bool (unbatched
            for a single shape).

        The refinement needs autograd: it works under ``torch.no_grad()`` but not under
        ``torch.inference_mode()``.
        """
        if restarts < 1 or steps < 0:
            raise InputError(f"restarts must be >= 1 and steps >= 0, got {restarts}, {steps}")
        x, single = self._shapes_in(shapes)
        with torch.no_grad():
            guess = self.encode_torch(x)  # (B, L)
            err = error(self.decode_torch(guess), x)
        latent = guess
        if refine and steps > 0 and x.shape[0] > 0:
            gen = torch.Generator().manual_seed(seed)
            k = self.config.latent_dim
            starts = guess[:, None].repeat(1, restarts, 1)  # (B, R, L)
            randoms = torch.rand(x.shape[0], restarts - 1, k, generator=gen) * 2 - 1
            starts[:, 1:, :k] = randoms.to(self.device)
            low = torch.full((self.latent_dim,), -float("inf"), device=self.device)
            low[:k] = -1.0
            with _frozen(self.generator):
                latent, err = refine_latents(
                    self.decode_torch, x, starts, low, -low, steps=steps, lr=lr,
                    tolerance=tolerance,
                )
        ok = err <= threshold
        return self._out(latent, single), self._out(err, single), self._out(ok, single)

    # ------------------------------------------------------------ persistence
    def state(self) -> dict[str, Any]:
        """The checkpoint dict: format, configs, normalisation, state dicts, provenance."""
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "model_config": asdict(self.config),
            "normalisation": asdict(self.normalisation),
            "generator": self.generator.state_dict(),
            "encoder": self.encoder.state_dict(),
            "discriminator": (
                self.discriminator.state_dict() if self.discriminator is not None else None
            ),
            "info": self.info,
        }

    def save(self, path: str | os.PathLike) -> Path:
        """Write the model to ``path`` (a file, or a folder that gets ``model.pt``) atomically."""
        path = Path(path)
        if path.is_dir():
            path = path / MODEL_FILE
        return save_atomic(self.state(), path)

    @classmethod
    def from_state(cls, data: dict[str, Any], device: str | torch.device = "auto",
                   name: str = "path") -> ShapeModel:
        """Rebuild a model from a checkpoint dict (as written by ``save``)."""
        try:
            # Checkpoints written before ``output`` existed all had the paper's point output.
            config = config_from_dict(ModelConfig, {"output": "points", **data["model_config"]},
                                      "model_config")
            norm = config_from_dict(Normalisation, data["normalisation"], "normalisation")
            generator, encoder = Generator(config), Encoder(config)
            generator.load_state_dict(data["generator"])
            encoder.load_state_dict(data["encoder"])
            discriminator = None
            if data.get("discriminator") is not None:
                discriminator = Discriminator(config)
                discriminator.load_state_dict(data["discriminator"])
        except (KeyError, TypeError, RuntimeError, ValueError) as exc:
            raise InputError(
                f"{name}: the checkpoint's contents do not fit a ShapeModel: {exc}"
            ) from exc
        return cls(config, norm, generator, encoder, discriminator, device, data.get("info"))

    @classmethod
    def load(cls, path: str | os.PathLike, device: str | torch.device = "auto",
             name: str = "path") -> ShapeModel:
        """Load a model written by ``save`` (a file, or a folder holding ``model.pt``).

        Raises:
            FileNotFoundError: If there is no such file.
            ValueError: Naming ``name`` (the argument or flag that gave ``path``) if the file
                is corrupt, not a shape model, or of another format version.
        """
        path = Path(path)
        if path.is_dir():
            path = path / MODEL_FILE
        return cls.from_state(load_checkpoint(path, name), device, name=str(path))

    @classmethod
    def load_pretrained(cls, device: str | torch.device = "auto") -> ShapeModel:
        """The shipped model for the default cord (``latent_model/pretrained/model.pt``)."""
        with resources.as_file(resources.files("latent_model") / "pretrained" / MODEL_FILE) as p:
            return cls.load(p, device)

    @classmethod
    def load_or_pretrained(
        cls, path: str | os.PathLike | None = None, device: str | torch.device = "auto"
    ) -> ShapeModel:
        """``load(path)`` when a path is given (not ``None`` or ""), else ``load_pretrained()``.

        The one call for code whose model argument defaults to the shipped model (a CLI flag,
        an agent option): ``load_pretrained()`` always loads the shipped file, ``load(path)``
        always the given one.
        """
        return cls.load(path, device) if path else cls.load_pretrained(device)

    def __repr__(self) -> str:
        c = self.config
        return (f"ShapeModel(representation={c.representation!r}, latent_dim={self.latent_dim}, "
                f"n_points={c.n_points}, width={c.width}, depth={c.depth}, device={self.device})")
