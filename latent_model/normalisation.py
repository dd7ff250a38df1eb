"""Normalisation between metres and the networks' tanh range; it is saved in every checkpoint."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from dlo_env.errors import InputError

#: Cord lengths per network unit of the canonical representation (see ``normalisation_for``).
CANONICAL_SCALE = 0.525


@dataclass(frozen=True)
class Normalisation:
    """An isotropic affine map ``network = (metres - offset) / scale``.

    One scale for both axes keeps distances meaningful in network units, which the
    point-spacing loss relies on.

    Attributes:
        offset_x: Metres subtracted from x.
        offset_y: Metres subtracted from y.
        scale: Metres per network unit.
    """

    offset_x: float = 0.0
    offset_y: float = 0.0
    scale: float = 1.0

    def __post_init__(self) -> None:
        if not self.scale > 0:
            raise InputError(f"Normalisation.scale must be > 0, got {self.scale!r}")

    def _offset(self, like: torch.Tensor) -> torch.Tensor:
        return torch.tensor([self.offset_x, self.offset_y], dtype=like.dtype, device=like.device)

    def to_network(self, metres: torch.Tensor) -> torch.Tensor:
        """Shapes in metres ``(..., 2)`` to network units."""
        return (metres - self._offset(metres)) / self.scale

    def to_metres(self, network: torch.Tensor) -> torch.Tensor:
        """Shapes in network units ``(..., 2)`` to metres."""
        return network * self.scale + self._offset(network)
