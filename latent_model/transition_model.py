"""``TransitionModel``: the shape at rest after one straight move of the held end(s).

The network works in the frame attached to the move (:mod:`latent_model.move_frame`): its
input is the cord in that frame and the move's length (plus the other end's move when both are
held), its output the displacement of every point. The held ends' final positions are known
exactly and are set, not predicted. An ensemble of ``members`` networks, batched as one module,
gives a mean prediction and a spread that says how far to trust it. A model may also hold a
*mean network*: one network distilled from the ensemble's mean
(:mod:`latent_model.transition_training`, ``teacher``), which then makes ``predict``'s
prediction at the cost of one network; the ensemble still gives the spread.

Example:
    >>> tm = TransitionModel.load_or_pretrained()
    >>> nxt = tm.predict(shapes, "head", d)                  # (B, n, 2), (B, 2) -> (B, n, 2)
    >>> nxt, spread = tm.predict(shapes, "both", d4, return_std=True)
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass, replace
from importlib import resources
from numbers import Integral
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from dlo_env.cord import (
    LINK_RADIUS,
    PEG_GUARD,
    PEG_RADIUS,
    CordParams,
    check_pegs,
    peg_contact,
    reachable_targets,
)
from dlo_env.core.checks import non_negative, positive, positive_ints
from dlo_env.core.deprecation import renamed_argument
from dlo_env.dataset.transitions import PARAM_COLUMNS, same_cord
from dlo_env.designed_suites import LETTERS_CORD
from dlo_env.errors import InputError
from dlo_env.randomize import trained_ranges
from dlo_env.shapes import TABLE_HALF, unflatten
from dlo_env.tasks import DEFAULT_MAX_STEP
from latent_model.chain_network import EnsembleChainNet
from latent_model.checkpoint import load_checkpoint, save_atomic
from latent_model.config import config_from_dict
from latent_model.inextensible import make_inextensible
from latent_model.move_frame import (
    GRASP_CODES,
    MoveFrame,
    from_frame,
    handedness,
    into_frame,
    out_of_frame,
    rim_vectors,
    to_frame,
)
from latent_model.shape_model import resolve_device

#: Marks a file as a transition-model checkpoint.
FORMAT = "dlo-transition-model"
#: Bumped whenever the checkpoint layout changes incompatibly.
FORMAT_VERSION = 1
#: File name of the model in a training folder and in ``pretrained/``.
MODEL_FILE = "transition.pt"
#: The shipped model of several cords (``cord_inputs``), beside ``MODEL_FILE``.
CORDS_MODEL_FILE = "transition-cords.pt"
#: The shipped model that sees pegs (``peg_reach``), beside ``MODEL_FILE``.
PEGS_MODEL_FILE = "transition-pegs.pt"


#: Shipped models of several cords fine-tuned for one cord, each loaded instead of
#: ``CORDS_MODEL_FILE`` for its cord: file -> the cord (``CordParams`` fields; the others the
#: default cord's). The letters cord of ``shapes-letters`` lies in a corner of the ranges the
#: model of several cords trained on.
CORD_MODEL_FILES: dict[str, Mapping[str, float]] = {"transition-letters.pt": LETTERS_CORD}


def pretrained_file(cords: bool = False, pegs: bool = False,
                    cord: CordParams | None = None) -> str:
    """The name of a shipped model in ``pretrained/``: the default cord's on the empty table,
    the model of several cords (``cords``; for ``cord``, the one fine-tuned for it in
    :data:`CORD_MODEL_FILES` where there is one) or the one that sees pegs (``pegs``)."""
    if cords and pegs:
        raise InputError("no shipped transition model is both of several cords and of pegs: "
                         "give cords=True or pegs=True, or a model file")
    if cords and cord is not None:
        for name, fields in CORD_MODEL_FILES.items():
            if same_cord(cord, replace(CordParams(), **fields)):
                return name
    return CORDS_MODEL_FILE if cords else PEGS_MODEL_FILE if pegs else MODEL_FILE
#: Predictions per network call in ``predict`` (keeps activations in cache).
PREDICT_CHUNK = 4096
#: Config fields every file must state: files from before they existed are no longer read
#: (no shipped model is one); fields added since (``architecture``, ``cord_inputs``) default
#: to what such files behaved by.
REQUIRED_CONFIG = ("rim_targets", "mean_network", "mirror", "mean_by_grasp", "contact_reach")
#: Config fields retired with the only value any shipped model had: files still state them
#: (so older readers and ``REQUIRED_CONFIG`` read them), and a file with another value (both
#: handednesses, the leading end's rim alone, a mean network of another width than the
#: ensemble's) is refused; a file from before ``mean_width`` existed may omit it.
RETIRED_CONFIG = {"rim_targets": 2, "mirror": True, "mean_width": None}
#: The default cord: what a model of several cords predicts without ``params``.
DEFAULT_CORD = CordParams()
#: The fields of ``TransitionModelConfig`` that record the cord trained on, by the
#: ``CordParams`` field each holds (``PARAM_COLUMNS``, the cord's settings that data vary).
CORD_FIELDS = {f"cord_{k}": k for k in PARAM_COLUMNS}
#: The ``CORD_FIELDS`` added after files were first written (``cord_length`` is older): a file
#: states them only off the default cord, and one from before them is read by
#: :func:`recorded_cord`.
LATER_CORD_FIELDS = ("cord_bending_stiffness", "cord_friction", "cord_mass")
#: The held ends' targets whose rim (and peg) vectors the network sees: both (the other end's
#: target is its start when it is not held).
RIM_TARGETS = RETIRED_CONFIG["rim_targets"]


def check_config_keys(config: dict[str, Any], name: str, checkpoint: bool = False) -> None:
    """Raise a one-line ``ValueError`` when a saved config lacks a ``REQUIRED_CONFIG`` field
    (a file written before it existed) or has a retired field at another value than
    ``RETIRED_CONFIG``'s; ``checkpoint``: a training checkpoint's."""
    what, fix = (("training checkpoint", "give another --out or delete it") if checkpoint
                 else ("transition model file",
                       "train it again with dlo train transition"))
    missing = [k for k in REQUIRED_CONFIG if k not in config]
    if missing:
        raise InputError(f"{name}: a {what} from before {', '.join(missing)} existed, which "
                         f"this version no longer reads: {fix}")
    retired = [f"{k}={config[k]!r}" for k, v in RETIRED_CONFIG.items()
               if config.get(k, v) != v]
    if retired:
        raise InputError(f"{name}: a {what} with {', '.join(retired)}, which this version no "
                         f"longer supports: {fix}")


def current_config(config: dict[str, Any]) -> dict[str, Any]:
    """A saved config without its ``RETIRED_CONFIG`` fields (checked by
    :func:`check_config_keys`), as ``TransitionModelConfig`` takes it."""
    return {k: v for k, v in config.items() if k not in RETIRED_CONFIG}


def saved_config(config: TransitionModelConfig) -> dict[str, Any]:
    """``config`` as files store it: with the ``RETIRED_CONFIG`` fields, and without the peg
    fields of a model that does not see pegs and the cord fields of a model of the default
    cord (so earlier versions still read its file)."""
    saved = {**asdict(config), **RETIRED_CONFIG}
    if not config.peg_reach:
        for key in ("peg_reach", "peg_radius"):
            saved.pop(key)
    for key in LATER_CORD_FIELDS:
        if getattr(config, key) == getattr(DEFAULT_CORD, CORD_FIELDS[key]):
            saved.pop(key)
    return saved


def recorded_cord(config: dict[str, Any], info: dict[str, Any] | None) -> dict[str, Any]:
    """A saved ``config`` with the ``LATER_CORD_FIELDS`` it lacks (a file from before they
    existed, or of the default cord) filled in: a model of one cord gets its training data's
    cord, as its provenance records it (``info["data"]["cord"]``); a file that names none, and
    a model of several cords, keep the default cord's (the fields' defaults)."""
    data = (info or {}).get("data")
    cord = data.get("cord") if isinstance(data, dict) else None
    if config.get("cord_inputs") or not isinstance(cord, dict):
        return config
    return {**{key: cord[CORD_FIELDS[key]] for key in LATER_CORD_FIELDS
               if CORD_FIELDS[key] in cord}, **config}


def _required_grasp(grasp: str | None) -> str:
    """``grasp``, which is required (a default of None keeps ``displacement`` third)."""
    if grasp is None:
        raise InputError(f"grasp is required: one of {tuple(GRASP_CODES)}")
    return grasp


#: The default cord's ``PARAM_COLUMNS``: ``cord_features`` are log ratios to these.
DEFAULT_CORD_ROW = np.array([getattr(DEFAULT_CORD, k) for k in PARAM_COLUMNS], dtype=np.float64)


def cord_features(rows: np.ndarray) -> np.ndarray:
    """What a cord-conditioned network sees of cords ``(B, len(PARAM_COLUMNS))`` (length m,
    bending stiffness N m^2, friction, mass kg): the logarithm of each over the default
    cord's, float32 (0 for the default cord; a cord twice as stiff adds log 2)."""
    return np.log(np.asarray(rows, dtype=np.float64) / DEFAULT_CORD_ROW).astype(np.float32)


def peg_vectors(points: torch.Tensor, pegs: torch.Tensor, radius: float, reach: float
                ) -> torch.Tensor:
    """How close each world point ``(B, k, 2)`` is to the pegs ``(B, m, 2)``, as a vector
    ``(B, k, 2)``: each peg whose surface lies within ``reach`` adds its outward direction
    scaled by ``1 - distance / reach`` (a ``PEG_FAR`` slot adds nothing), so the vector is
    exactly zero farther than ``reach`` from every peg."""
    rel = points[:, :, None, :] - pegs[:, None, :, :]  # (B, k, m, 2)
    dist = rel.norm(dim=-1, keepdim=True).clamp_min(1e-9)
    near = torch.relu(1.0 - (dist - radius) / reach)
    return (near * rel / dist).sum(dim=2)


def padded_pegs(pegs: Any, count: int) -> np.ndarray:
    """``pegs`` as float32 ``(count, m, 2)`` rows: one ``(m, 2)`` for every row, or already
    ``(count, m, 2)`` (``PEG_FAR`` slots hold none); ``(count, 0, 2)`` for None."""
    if pegs is None:
        return np.zeros((count, 0, 2), dtype=np.float32)
    arr = np.asarray(pegs, dtype=np.float32)
    if arr.ndim == 2:
        arr = np.broadcast_to(check_pegs(arr, "pegs").astype(np.float32)[None],
                              (count,) + arr.shape)
    if arr.ndim != 3 or arr.shape[0] != count or arr.shape[2] != 2:
        raise InputError(f"pegs must have shape (m, 2) or ({count}, m, 2), got {np.shape(pegs)}")
    return np.array(arr, dtype=np.float32)  # a writable copy (torch takes it as it is)


#: The ensemble designs of ``TransitionModelConfig.architecture``.
ARCHITECTURES = ("mlp", "chain")


@dataclass(frozen=True)
class TransitionModelConfig:
    """Architecture of the transition model and the setting it was trained for.

    Attributes:
        n_points: Points of the cord.
        cord_length, cord_bending_stiffness, cord_friction, cord_mass: The cord trained on
            (``CordParams``' ``length`` in metres, ``bending_stiffness`` in N m^2,
            ``friction``, ``mass`` in kg); its other settings are the default cord's. A model
            of several cords (``cord_inputs``) has the default cord's, which ``predict``
            takes when no ``params`` are given. Files from before the last three existed
            are read as of their training data's cord (:func:`recorded_cord`).
        max_step: The environments' ``max_step`` the moves were carried out with, metres.
        members: Networks in the ensemble.
        width: Hidden units per layer.
        depth: Hidden layers.
        move_scale: Move lengths are divided by this in the input, metres.
        output_scale: The network's outputs are point displacements in units of this, metres.
        rim_reach: Points (and the held ends' targets) closer than this to the table's edge
            tell the network where the rim is, metres; farther, the model is exactly
            equivariant.
        contact_reach: The points and the targets also get a second rim vector of this
            reach, metres (0: none): a sharp one that tells a point touching a wall (the
            cord rests ``LINK_RADIUS`` from the edge) from one a few centimetres away, where
            the ``rim_reach`` vector barely changes.
        mean_network: The model also holds one network distilled from the ensemble's mean,
            which makes ``predict``'s prediction (the ensemble gives the spread).
        mean_by_grasp: The mean network is two networks of this size, one for moves of one
            end and one for moves of both ends (``GraspRoutedMLP``): twice the weights, each
            prediction still at the cost of one network. Needs ``mean_network``.
        cord_inputs: The networks also see the cord (``cord_features``: the logarithm of
            each of ``PARAM_COLUMNS`` over the default cord's), so one model predicts cords
            that differ; ``predict(params=...)`` says which. Off: a model of one cord.
        architecture: The ensemble's design: ``"mlp"`` (``EnsembleMLP``, the whole chain as
            one vector) or ``"chain"`` (``latent_model.chain_network.EnsembleChainNet``:
            weights shared along the chain, ``width`` channels, ``depth`` residual blocks). The
            mean network is always an MLP: the fast student of either ensemble.
        peg_reach: The points and the held ends' targets also get a peg vector (0: none, a
            model of the empty table): each peg whose surface lies within this of them adds
            its outward direction scaled by ``1 - distance / peg_reach``, so far from every
            peg the vector is exactly zero, as on the empty table. The chain network reads
            them as one more vector per point, like the rim's.
        peg_radius: Radius of the pegs the model was trained with, metres.
    """

    n_points: int = 20
    cord_length: float = 1.0
    max_step: float = DEFAULT_MAX_STEP
    members: int = 5
    width: int = 256
    depth: int = 3
    move_scale: float = 0.35
    output_scale: float = 0.1
    rim_reach: float = 0.35
    contact_reach: float = 0.0
    mean_network: bool = False
    mean_by_grasp: bool = False
    architecture: str = "mlp"
    cord_inputs: bool = False
    peg_reach: float = 0.0
    peg_radius: float = PEG_RADIUS
    cord_bending_stiffness: float = DEFAULT_CORD.bending_stiffness
    cord_friction: float = DEFAULT_CORD.friction
    cord_mass: float = DEFAULT_CORD.mass

    def __post_init__(self) -> None:
        positive_ints(self, "n_points", "members", "width", "depth")
        positive(self, "cord_mass")
        non_negative(self, "cord_friction", "cord_bending_stiffness")
        non_negative(self, "peg_reach")
        positive(self, "peg_radius")
        if not math.isfinite(self.peg_reach):
            raise InputError(f"TransitionModelConfig.peg_reach must be finite, got "
                             f"{self.peg_reach!r}")
        if self.architecture not in ARCHITECTURES:
            raise InputError(f"TransitionModelConfig.architecture must be one of "
                             f"{ARCHITECTURES}, got {self.architecture!r}")
        positive(self, "cord_length", "max_step", "move_scale", "output_scale", "rim_reach")
        non_negative(self, "contact_reach")
        if not math.isfinite(self.contact_reach):
            raise InputError(f"TransitionModelConfig.contact_reach must be finite, got "
                             f"{self.contact_reach!r}")
        if self.mean_by_grasp and not self.mean_network:
            raise InputError("TransitionModelConfig.mean_by_grasp needs mean_network=True "
                             "(it splits the mean network by grasp)")

    @property
    def cord(self) -> dict[str, Any]:
        """The cord trained on as ``CordParams`` fields: ``n_points`` and ``CORD_FIELDS``."""
        return {"n_points": self.n_points,
                **{value: getattr(self, key) for key, value in CORD_FIELDS.items()}}

    @property
    def rim_inputs(self) -> int:
        """Rim vectors the network sees: one per point and target, two with ``contact_reach``."""
        return (self.n_points + RIM_TARGETS) * (2 if self.contact_reach else 1)

    @property
    def contact_at(self) -> int:
        """Where the contact vectors' inputs start (or would): after the points', segments'
        and rim vectors', before the move's four (``TransitionModel.features``)."""
        n = self.n_points
        return 2 * n + 2 * (n - 1) + 2 * (n + RIM_TARGETS)

    @property
    def peg_inputs(self) -> int:
        """Peg vectors the network sees: one per point and target with ``peg_reach``."""
        return self.n_points + RIM_TARGETS if self.peg_reach else 0

    @property
    def peg_at(self) -> int:
        """Where the peg vectors' inputs start (or would): after the rim's and contact's."""
        return self.contact_at + 2 * (self.rim_inputs - self.n_points - RIM_TARGETS)

    @property
    def inputs(self) -> int:
        """Network inputs: the cord's points and segment directions in the frame, the rim near
        each point and near the held ends' targets (and their contact vectors), the pegs near
        them (``peg_reach``), the cord's parameters (``cord_inputs``), the lead length, the
        other move, both."""
        return self.peg_at + 2 * self.peg_inputs + self.cord_features + 4

    @property
    def cord_features(self) -> int:
        """Inputs that describe the cord: ``len(PARAM_COLUMNS)`` with ``cord_inputs``, else 0."""
        return len(PARAM_COLUMNS) if self.cord_inputs else 0


class EnsembleMLP(nn.Module):
    """``members`` independent MLPs evaluated as one batched network (SiLU activations).

    Args:
        members: Networks.
        inputs: Input features.
        width: Hidden units.
        depth: Hidden layers.
        outputs: Output features.
    """

    def __init__(self, members: int, inputs: int, width: int, depth: int, outputs: int) -> None:
        super().__init__()
        dims = [inputs] + [width] * depth + [outputs]
        self.weights = nn.ParameterList()
        self.biases = nn.ParameterList()
        for i, (a, b) in enumerate(zip(dims[:-1], dims[1:])):
            bound = 1.0 / math.sqrt(a)
            if i == len(dims) - 2:
                bound *= 0.1  # start near "nothing moves but the held ends"
            self.weights.append(nn.Parameter(torch.empty(members, a, b).uniform_(-bound, bound)))
            self.biases.append(nn.Parameter(torch.zeros(members, 1, b)))

    @property
    def members(self) -> int:
        """Networks in the ensemble."""
        return self.weights[0].shape[0]

    def _layers(self, h: torch.Tensor, nets: slice) -> torch.Tensor:
        # The networks ``nets`` on their inputs h (k, B, inputs) -> (k, B, outputs).
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases)):
            h = torch.baddbmm(b[nets], h, w[nets])
            if i < last:
                h = nn.functional.silu(h)
        return h

    def with_inputs(self, at: int, count: int) -> EnsembleMLP:
        """A copy that takes ``count`` more inputs, inserted before input ``at``, and computes
        what this one does whatever they hold (their first-layer weights are zero)."""
        inputs = self.weights[0].shape[1]
        if not (0 <= at <= inputs and count >= 0):
            raise InputError(f"at must be in 0..{inputs} and count >= 0, got {at}, {count}")
        w = self.weights[0].detach()
        grown = EnsembleMLP(self.members, inputs + count, w.shape[-1], len(self.weights) - 1,
                            self.weights[-1].shape[-1]).to(w.device)
        with torch.no_grad():
            for mine, theirs in zip(grown.parameters(), self.parameters()):
                if mine.shape == theirs.shape:
                    mine.copy_(theirs)
            grown.weights[0].copy_(torch.cat([w[:, :at], w.new_zeros(w.shape[0], count, w.shape[2]),
                                              w[:, at:]], dim=1))
        return grown

    def first(self, members: int) -> EnsembleMLP:
        """A copy of the first ``members`` networks alone."""
        w = self.weights[0]
        out = EnsembleMLP(members, w.shape[1], w.shape[2], len(self.weights) - 1,
                          self.weights[-1].shape[-1]).to(w.device)
        with torch.no_grad():
            for mine, theirs in zip(out.parameters(), self.parameters()):
                mine.copy_(theirs[:members])
        return out

    def member(self, x: torch.Tensor, index: int) -> torch.Tensor:
        """Network ``index`` alone: ``(B, inputs)`` -> ``(B, outputs)``."""
        return self._layers(x[None], slice(index, index + 1))[0]

    def forward(self, x: torch.Tensor, members: int | None = None) -> torch.Tensor:
        """``(B, inputs)`` or ``(members, B, inputs)`` -> ``(members, B, outputs)``; with
        ``members`` (``x`` shared, 2-D) only the first ``members`` networks run."""
        k = self.members if members is None else members
        return self._layers(x.expand(k, *x.shape) if x.dim() == 2 else x, slice(0, k))


class GraspRoutedMLP(nn.Module):
    """One network to its callers, two inside: rows of moves of one end go to the first,
    rows of moves of both ends to the second (``TransitionModel.features`` ends with that
    flag). Each row costs one network; the two do not share capacity.

    Args:
        routes: The two networks (the model's design: ``TransitionModel.networks(2)``).
    """

    def __init__(self, routes: EnsembleMLP) -> None:
        super().__init__()
        if routes.members != 2:
            raise InputError(f"routes must be 2 networks, got {routes.members}")
        self.routes = routes
        self.outputs = routes.weights[-1].shape[-1]

    @property
    def members(self) -> int:
        """It predicts as one network."""
        return 1

    def forward(self, x: torch.Tensor, members: int | None = None) -> torch.Tensor:
        """``(B, inputs)`` or ``(1, B, inputs)`` -> ``(1, B, outputs)``."""
        if x.dim() == 3:
            if x.shape[0] != 1:
                raise InputError(f"a grasp-routed mean network is one network, got inputs for "
                                 f"{x.shape[0]}")
            x = x[0]
        both = x[:, -1] > 0.5
        if not both.any():
            return self.routes.member(x, 0)[None]
        if both.all():
            return self.routes.member(x, 1)[None]
        rows = [torch.nonzero(~both).squeeze(1), torch.nonzero(both).squeeze(1)]
        out = x.new_zeros(len(x), self.outputs)
        for route, idx in enumerate(rows):
            out = out.index_put((idx,), self.routes.member(x[idx], route))
        return out[None]


class TransitionModel(nn.Module):
    """The learned transition model of the cord; numpy in and out in ``predict``.

    Args:
        config: Architecture and setting.
        device: ``"auto"`` (CUDA if available), ``"cpu"``, ``"cuda"``...
        info: Free-form provenance saved with the model (data, training, metrics).
    """

    def __init__(self, config: TransitionModelConfig | None = None,
                 device: str | torch.device = "auto", info: dict[str, Any] | None = None) -> None:
        super().__init__()
        self.config = config if config is not None else TransitionModelConfig()
        c = self.config
        self.net = self.networks(c.members, design=c.architecture)
        self.mean_net: EnsembleMLP | GraspRoutedMLP | None = None
        if c.mean_network:
            self.mean_net = (GraspRoutedMLP(self.networks(2)) if c.mean_by_grasp
                             else self.networks(1))
        self.device = resolve_device(device)
        self.info = dict(info or {})
        self.to(self.device)

    # ------------------------------------------------------------- facts
    @property
    def cord_params(self) -> CordParams:
        """The cord this model was trained on (``TransitionModelConfig.cord``): that of its
        ``predict`` without ``params``."""
        return CordParams(**self.config.cord)

    def told(self, cord: CordParams) -> CordParams:
        """``cord`` as this model of several cords is told it (``predict``'s ``params``): its
        ``PARAM_COLUMNS`` on the model's own cord, since the model predicts nothing else of a
        cord (such as its friction with pegs).

        Raises:
            InputError: For a model of one cord, another type than ``CordParams``, or a cord
                outside the model's ranges (:meth:`check_env_cord`).
        """
        if not self.config.cord_inputs:
            raise InputError("cord is told to a transition model of several cords "
                             "(TransitionModelConfig.cord_inputs); this model predicts one cord")
        if not isinstance(cord, CordParams):
            raise InputError(f"cord must be a CordParams or None, got {type(cord).__name__}")
        self.check_env_cord(cord)
        return replace(self.cord_params, **{k: getattr(cord, k) for k in PARAM_COLUMNS})

    def check_env_cord(self, params: CordParams) -> None:
        """Raise a one-line ``ValueError`` unless this model predicts an environment's cord
        ``params``: its points, and for a model of one cord (without ``cord_inputs``) its
        length, stiffness, friction and mass too; a model of several cords takes a cord inside
        the ranges its moves were drawn from (:func:`trained_ranges`; its length when none
        is recorded)."""
        own = self.cord_params
        ranges = trained_ranges(getattr(self, "info", None) or {}) if self.config.cord_inputs \
            else {}
        outside = [f"{k}={getattr(params, k)!r} outside {low!r}..{high!r}"
                   for k, (low, high) in ranges.items()
                   if not low * (1 - 1e-9) <= getattr(params, k) <= high * (1 + 1e-9)]
        if outside:
            raise InputError(f"the transition model was trained on cords of other parameters "
                             f"than the environment's: {', '.join(outside)}: train a model "
                             "on ranges that hold this cord (dlo collect transitions "
                             "--randomize)")
        length_known = "length" in ranges
        if params.n_points != own.n_points or (
                not length_known and params.length != own.length):
            raise InputError(
                f"the transition model was trained for a cord of {own.n_points} points "
                f"and {own.length} m, but the environment's cord has {params.n_points} "
                f"points and {params.length} m: train a model for this cord")
        if self.config.cord_inputs:  # it is told the cord
            return
        differ = [f"{k}={getattr(own, k)!r} where the environment's cord has "
                  f"{getattr(params, k)!r}" for k in PARAM_COLUMNS
                  if not math.isclose(getattr(params, k), getattr(own, k), rel_tol=1e-9)]
        if differ:
            raise InputError(f"the transition model was trained for one cord, with "
                             f"{', '.join(differ)}: train a model for this cord, or one of "
                             "several cords (--cord-inputs)")

    # ------------------------------------------------------------- torch core
    def networks(self, members: int, design: str = "mlp") -> EnsembleMLP | EnsembleChainNet:
        """``members`` new networks (the ensemble, or one: the mean network) of ``design``
        (``ARCHITECTURES``), of the config's width (hidden units or channels)."""
        c = self.config
        width = c.width
        if design == "chain":
            # Rim, contact and peg vectors share one layout: a vector per point and target.
            blocks = (c.rim_inputs + c.peg_inputs) // (c.n_points + RIM_TARGETS)
            return EnsembleChainNet(members, c.n_points, RIM_TARGETS, blocks, width, c.depth,
                                    extra_globals=c.cord_features)
        return EnsembleMLP(members, c.inputs, width, c.depth, 2 * c.n_points)

    def features(self, points: torch.Tensor, lead: torch.Tensor, other: torch.Tensor,
                 both: torch.Tensor, rim: torch.Tensor, cord: torch.Tensor | None = None
                 ) -> torch.Tensor:
        """Network input ``(B, inputs)`` from a batch described in the move frames; ``cord``
        ``(B, len(PARAM_COLUMNS))`` is the cords' ``cord_features`` (None: the default cord's),
        read only with ``config.cord_inputs``."""
        c = self.config  # the both-ends flag comes last: GraspRoutedMLP routes by it
        seg = points[:, 1:] - points[:, :-1]
        seg = seg / seg.norm(dim=-1, keepdim=True).clamp_min(1e-9)
        parts = [points.flatten(1) / c.cord_length, seg.flatten(1), rim.flatten(1)]
        if c.cord_inputs:
            parts.append(points.new_zeros(len(points), c.cord_features) if cord is None
                         else cord.to(points.dtype))
        return torch.cat([*parts, lead[:, None] / c.move_scale, other / c.move_scale,
                          both[:, None].to(points.dtype)], dim=1)

    def in_frame(self, shapes: torch.Tensor, grasp: torch.Tensor, moves: torch.Tensor,
                 members: int | None = None, net: EnsembleMLP | None = None,
                 cord: torch.Tensor | None = None, pegs: torch.Tensor | None = None
                 ) -> tuple[torch.Tensor, MoveFrame]:
        """Every member's prediction in the move frames, ``(members, B, n, 2)``, and the frames.

        ``shapes`` is ``(B, n, 2)`` (one frame per move, shared by the members) or
        ``(members, B, n, 2)`` (one start per member; frames then cover ``members * B``).
        ``members`` runs only the first networks (shared frames only). ``net`` is the
        networks to run (None: the ensemble; ``self.mean_net`` for the mean network). The
        networks (``predict_points``) get the mirrored inputs of cords on the right of the
        move's line and their outputs are mirrored back here. ``cord``
        is ``(B, len(PARAM_COLUMNS))`` ``cord_features`` (None: the default cord); ``pegs``
        ``(B, m, 2)`` world peg centres (None: none), read only with ``config.peg_reach``.
        """
        net = self.net if net is None else net
        e, n = net.members, self.config.n_points
        per_member = shapes.dim() == 4
        if per_member and members is not None:
            raise InputError("members applies to shapes shared by the members (B, n, 2), not to "
                             "one start per member")
        if per_member:
            b = shapes.shape[1]
            grasp, moves, shapes = grasp.repeat(e), moves.repeat(e, 1, 1), shapes.reshape(-1, n, 2)
            cord = None if cord is None else cord.repeat(e, 1)
            pegs = None if pegs is None else pegs.repeat(e, 1, 1)
        else:
            b = shapes.shape[0]
        points, lead, other, frame = to_frame(shapes, grasp, moves)
        both = grasp == GRASP_CODES["both"]
        c = self.config
        target = frame.origin + torch.stack([frame.cos, frame.sin], dim=-1) * lead[:, None]
        # The other end's target too: its start plus its move.
        far_end = torch.where(frame.reversed[:, None], shapes[:, 0], shapes[:, -1])
        target = torch.stack([target, far_end + out_of_frame(other[:, None], frame)[:, 0]],
                             dim=1)
        reaches = (c.rim_reach, c.contact_reach) if c.contact_reach else (c.rim_reach,)
        rim = torch.cat([v for reach in reaches for v in (
            into_frame(rim_vectors(shapes, TABLE_HALF, reach), frame),
            into_frame(rim_vectors(target, TABLE_HALF, reach), frame, reorder=False))],
            dim=1)  # (B, rim_inputs, 2)
        if c.peg_reach:  # then the pegs near the points and the targets (none: zeros)
            near = [torch.zeros_like(shapes), torch.zeros_like(target)] if pegs is None else [
                peg_vectors(x, pegs.to(shapes.dtype), c.peg_radius, c.peg_reach)
                for x in (shapes, target)]
            rim = torch.cat([rim, into_frame(near[0], frame),
                             into_frame(near[1], frame, reorder=False)], dim=1)
        # One handedness: cords on the right of the move's line are seen mirrored (the
        # physics has none, so the networks learn one instead of two).
        flip = handedness(points)
        moved = self.predict_points(points * flip[:, None], lead, other * flip, both,
                                    rim * flip[:, None], (e, b) if per_member else None,
                                    members, net, cord)
        moved = moved * flip.reshape(-1, b, 1, 2)
        if per_member:
            points, lead, other, both = (t.reshape(e, b, *t.shape[1:])
                                         for t in (points, lead, other, both))
        return self._pin_ends(moved, points, lead, other, both), frame

    def predict_points(self, points: torch.Tensor, lead: torch.Tensor, other: torch.Tensor,
                       both: torch.Tensor, rim: torch.Tensor,
                       members_batch: tuple[int, int] | None, members: int | None = None,
                       net: EnsembleMLP | None = None, cord: torch.Tensor | None = None
                       ) -> torch.Tensor:
        """The members' points in the move frames, ``(members, B, n, 2)``, before the held
        ends are pinned: the one place where a model design differs. Every input is a cord on
        the left of its move's line (``in_frame`` mirrors).

        Args:
            points: ``(B, n, 2)`` the cords in the move frames (flat over members and batch
                when ``members_batch`` is given, else shared by the members, as are the next
                three).
            lead: ``(B,)`` the length of the leading end's move.
            other: ``(B, 2)`` the other end's move in the frame (zero unless both are held).
            both: ``(B,)`` whether both ends are held.
            rim: ``(B, config.rim_inputs + config.peg_inputs, 2)`` rim vectors of the points
                and the targets (then, with ``contact_reach``, their contact vectors, and with
                ``peg_reach`` their peg vectors).
            members_batch: ``(members, B)`` when every member has its own input.
            members: Run only the first ``members`` networks (inputs shared).
            net: The networks to run (None: the ensemble).
            cord: The cords' ``cord_features``, one row per input (None: the default cord).
        """
        n = self.config.n_points
        net = self.net if net is None else net
        x = self.features(points, lead, other, both, rim, cord)
        out = (net(x.reshape(*members_batch, -1)) if members_batch
               else net(x, members))  # (E, B, 2n)
        e, b = out.shape[:2]
        return points.reshape(-1, b, n, 2) + self.config.output_scale * out.reshape(e, b, n, 2)

    def forward(self, shapes: torch.Tensor, grasp: torch.Tensor, moves: torch.Tensor,
                net: EnsembleMLP | None = None, cord: torch.Tensor | None = None,
                pegs: torch.Tensor | None = None) -> torch.Tensor:
        """Every member's prediction, world ``(members, B, n, 2)``; differentiable.

        Args:
            shapes: ``(B, n, 2)`` world shapes at rest, or ``(members, B, n, 2)``: one per
                member (a member's own previous prediction, when rolling out a chain).
            grasp: ``(B,)`` int64 grasp codes (0 head, 1 tail, 2 both).
            moves: ``(B, 2, 2)`` reachable displacement of [head, tail] (zero if not held).
            net: The networks to run (None: the ensemble; ``self.mean_net``: one member).
            cord: ``(B, len(PARAM_COLUMNS))`` ``cord_features`` of each move's cord (None: the
                default cord; read only with ``config.cord_inputs``).
            pegs: ``(B, m, 2)`` world centres of each move's pegs, ``PEG_FAR`` in empty slots
                (None: none; read only with ``config.peg_reach``).
        """
        moved, frame = self.in_frame(shapes, grasp, moves, net=net, cord=cord, pegs=pegs)
        e, b, n = moved.shape[:3]
        if shapes.dim() == 3:  # one frame per move: repeat it for the members
            frame = MoveFrame(frame.origin.repeat(e, 1), frame.cos.repeat(e),
                              frame.sin.repeat(e), frame.reversed.repeat(e))
        return from_frame(moved.reshape(e * b, n, 2), frame).reshape(e, b, n, 2)

    @staticmethod
    def _pin_ends(moved: torch.Tensor, points: torch.Tensor, lead: torch.Tensor,
                  other: torch.Tensor, both: torch.Tensor) -> torch.Tensor:
        # The grippers put the held ends exactly where they were sent: set, do not predict.
        # moved (E, B, n, 2); points (B or E, ...), lead (..,), other (.., 2), both (..,).
        first = torch.stack([lead, torch.zeros_like(lead)], dim=-1).expand(moved.shape[0], -1, -1)
        last = torch.where(both[..., None], points[..., -1, :] + other, moved[..., -1, :])
        return torch.cat([first[:, :, None], moved[:, :, 1:-1], last[:, :, None]], dim=2)

    # ------------------------------------------------------------- numpy API
    def cord_rows(self, params: Any, count: int) -> np.ndarray:
        """``(count, len(PARAM_COLUMNS))`` float64 cords of a batch: ``params`` None (this
        model's cord), a ``CordParams``, or rows of ``PARAM_COLUMNS`` values (one row for the
        batch, or one per shape). A model without ``cord_inputs`` takes only its own cord."""
        own = np.array([getattr(self.cord_params, k) for k in PARAM_COLUMNS], dtype=np.float64)
        if params is None:
            return np.tile(own, (count, 1))
        if isinstance(params, CordParams):
            # Only the PARAM_COLUMNS differ between the cords a model knows; the rest (points,
            # rim margin, span...) is the model's.
            other = [k for k, v in asdict(params).items() if k not in PARAM_COLUMNS
                     and k != "length" and v != getattr(self.cord_params, k)]
            if other:
                raise InputError(f"params may differ from the model's cord only in "
                                 f"{PARAM_COLUMNS}, got other {', '.join(other)}")
            rows = np.array([getattr(params, k) for k in PARAM_COLUMNS], dtype=np.float64)
        else:
            try:
                rows = np.asarray(params, dtype=np.float64)
            except (TypeError, ValueError):
                raise InputError(f"params must be None, a CordParams, or rows of "
                                 f"{PARAM_COLUMNS}, got {type(params).__name__}") from None
        cols = len(PARAM_COLUMNS)
        if rows.ndim == 1:
            rows = np.tile(rows, (count, 1)) if rows.shape == (cols,) else rows[None]
        if rows.shape != (count, cols) or not (np.isfinite(rows).all() and (rows > 0).all()):
            raise InputError(f"params must be None, a CordParams, or positive finite rows of "
                             f"{PARAM_COLUMNS}, shape ({cols},) or ({count}, {cols}), got "
                             f"shape {np.shape(params)}")
        if not self.config.cord_inputs and not np.allclose(rows, own, rtol=1e-5):
            raise InputError("params: this model was trained for one cord "
                             f"({dict(zip(PARAM_COLUMNS, own.tolist()))}) and does not see "
                             "others (TransitionModelConfig.cord_inputs); give None")
        return rows

    def _lengths(self, rows: np.ndarray) -> list[tuple[np.ndarray, CordParams]]:
        """The distinct cord lengths of ``rows``: ``(indices, CordParams)``, this model's cord
        of that length (the length is all the clipping rule reads of a cord)."""
        lengths = rows[:, PARAM_COLUMNS.index("length")]
        unique, which = np.unique(lengths, return_inverse=True)
        base = self.cord_params
        return [(np.flatnonzero(which.reshape(-1) == i),
                 base if length == base.length else replace(base, length=float(length)))
                for i, length in enumerate(unique)]

    @renamed_argument("end", "grasp")
    def reachable_moves(self, shapes: np.ndarray, grasp: str | None = None,
                        displacement: np.ndarray | None = None, *,
                        params: Any = None, pegs: np.ndarray | None = None,
                        peg_radius: float | None = None) -> np.ndarray:
        """``(B, 2, 2)`` displacement of [head, tail] the grippers really make, zero for an end
        not held: the move carried out as ``split_move`` actions, each clipped by the rule of
        ``Cord.move`` (targets on the table, both ends within the span of the cord, ``params``
        as in ``predict``; with ``pegs``, ``(m, 2)`` centres or ``(B, m, 2)`` each shape's own,
        a move stops where a gripper would touch one). ``end`` is the deprecated name of
        ``grasp``; ``peg_radius`` None: ``config.peg_radius``)."""
        grasp = _required_grasp(grasp)
        if displacement is None:
            raise InputError("displacement is required")
        pegs = None if pegs is None else padded_pegs(pegs, len(shapes)).astype(np.float64)
        peg_radius = self.config.peg_radius if peg_radius is None else float(peg_radius)
        if params is not None and grasp == "both":  # only the span, of two ends, is the cord's
            moves = np.zeros((len(shapes), 2, 2), dtype=np.float32)
            disp = np.asarray(displacement).reshape(len(shapes), -1)
            for idx, cord in self._lengths(self.cord_rows(params, len(shapes))):
                moves[idx] = self._reachable(shapes[idx], grasp, disp[idx], cord,
                                             None if pegs is None else pegs[idx], peg_radius)
            return moves
        return self._reachable(shapes, grasp, displacement, self.cord_params, pegs, peg_radius)

    def _reachable(self, shapes: np.ndarray, grasp: str, displacement: np.ndarray,
                   params: CordParams, pegs: np.ndarray | None = None,
                   peg_radius: float = PEG_RADIUS) -> np.ndarray:
        ends = {"head": [0], "tail": [-1], "both": [0, -1]}[grasp]
        start = shapes[:, ends].astype(np.float64)  # (B, k, 2)
        d = displacement.reshape(len(shapes), len(ends), 2).astype(np.float64)
        pos = start + d
        # Both rules are convex: the box, and (both ends) a gap between two ends moving in
        # straight lines, which is largest at the path's start or end. So a move whose start
        # and end obey the rule is never clipped on the way; only the others are walked.
        walk = (reachable_targets(start, params) != start).any(axis=(1, 2))
        clip = reachable_targets(pos, params)  # once: this runs for every planned move
        clipped = (clip != pos).any(axis=(1, 2))
        has_pegs = pegs is not None and pegs.size > 0
        if len(ends) == 1:
            # One end: the rule only clips to a box, and clipping after every step of a
            # straight path is clipping its end point, when the start is inside the box
            # (among pegs a clipped path slides along the edge: walked).
            pos = clip
            if has_pegs:
                walk |= clipped
        else:
            walk |= clipped
        if has_pegs:  # a path that meets a peg stops there: walked too
            walk |= peg_contact(start, d, pegs, peg_radius + LINK_RADIUS + PEG_GUARD) < 1.0
        if walk.any():  # step by step, as the environment's actions go
            longest = np.linalg.norm(d[walk], axis=-1).max(axis=-1, initial=0.0)
            actions = np.maximum(1, np.ceil(longest / self.config.max_step - 1e-9)).astype(int)
            step = d[walk] / actions[:, None, None]
            path = start[walk]
            rows = pegs[walk] if has_pegs and pegs.ndim == 3 else pegs
            rule = ({"starts": None, "pegs": rows, "peg_radius": peg_radius} if has_pegs
                    else {})
            for j in range(int(actions.max(initial=0))):
                going = j < actions
                if has_pegs:
                    rule["starts"] = path[going]
                    rule["pegs"] = rows[going] if rows.ndim == 3 else rows
                path[going] = reachable_targets(path[going] + step[going], params, **rule)
            pos[walk] = path
        moves = np.zeros((len(shapes), 2, 2), dtype=np.float32)
        if grasp == "both":
            moves[:] = pos - start
        else:
            moves[:, 0 if grasp == "head" else 1] = (pos - start)[:, 0]
        return moves

    def _inputs(self, shapes: Any, grasp: Any, displacement: Any
                ) -> tuple[np.ndarray, np.ndarray, bool]:
        if grasp not in GRASP_CODES:
            raise InputError(f"grasp must be one of {tuple(GRASP_CODES)}, got {grasp!r}")
        n = self.config.n_points
        # flat shapes, as observations hold them, too
        try:
            arr = np.ascontiguousarray(unflatten(shapes, n, dtype=np.float32))
        except (TypeError, ValueError) as exc:
            raise InputError(f"shapes must be numbers of shape ({n}, 2), ({2 * n},), (B, {n}, 2) "
                             f"or (B, {2 * n}): {exc}") from None
        single = arr.ndim == 2
        arr = arr[None] if single else arr
        if arr.ndim != 3 or arr.shape[1:] != (n, 2):
            raise InputError(f"shapes must have shape ({n}, 2), ({2 * n},), (B, {n}, 2) or "
                             f"(B, {2 * n}), got {np.shape(shapes)}")
        width = 4 if grasp == "both" else 2
        try:
            d = np.ascontiguousarray(displacement, dtype=np.float32)
        except (TypeError, ValueError) as exc:
            raise InputError(f"displacement must be numbers of shape ({width},) or "
                             f"(B, {width}): {exc}") from None
        d = d[None] if d.ndim == 1 else d
        if d.shape != (len(arr), width):
            want = f"({width},) or ({len(arr)}, {width})" if not single else f"({width},)"
            raise InputError(f"displacement must have shape {want} for grasp={grasp!r} "
                             f"and {len(arr)} shape(s), got {np.shape(displacement)}")
        if not (np.isfinite(arr).all() and np.isfinite(d).all()):
            raise InputError("shapes and displacement must be finite, got NaN or infinite values")
        return arr, d, single

    @renamed_argument("end", "grasp")
    @torch.no_grad()
    def predict(self, shapes: Any, grasp: str | None = None, displacement: Any = None,
                params: Any = None, return_std: bool = False, members: int | None = None,
                inextensible: bool = True, *,
                pegs: np.ndarray | None = None, peg_radius: float | None = None
                ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """The shape at rest after one straight move of the held end(s).

        Args:
            shapes: ``(n, 2)`` or ``(B, n, 2)`` world shapes at rest, metres; flat ``(2n,)``
                or ``(B, 2n)`` (as observations hold them) too.
            grasp: The held end(s) that move: ``"head"``, ``"tail"`` or ``"both"``
                (``end`` is its deprecated name).
            displacement: ``(2,)``/``(B, 2)`` for one end; ``(4,)``/``(B, 4)`` (head dx, dy,
                then tail dx, dy) for both. Targets off the table are clipped as the
                simulator clips them.
            params: The cord: None (the cord the model was trained for, the default cord for
                a model of several), a ``CordParams``, or ``PARAM_COLUMNS`` values, one row
                ``(4,)`` for every shape or ``(B, 4)``. A model of one cord
                (``config.cord_inputs`` off) takes only None or its own cord.
            return_std: Also return the ensemble's spread.
            members: Use only the first ``members`` networks of the ensemble for the mean and
                the spread (None: the model's prediction, below). Their share of the time
                falls by ``self.config.members / members``, a little less accurate; the spread
                needs two.
            inextensible: Move the mean onto a nearby shape whose segments have the
                cord's rest length, the held ends kept (:mod:`latent_model.inextensible`):
                more accurate (the simulator's links are rigid), at a small fixed cost per
                call that planners making many small calls may skip.

        Returns:
            float32 ``(B, n, 2)`` (``(n, 2)`` for one shape), on the table: the mean network's
            prediction when the model has one (``config.mean_network``) and ``members`` is
            None, else the mean of the ensemble's (first ``members``) networks; with
            ``return_std`` also ``(B,)`` (``()``) the members' spread: the mean over points of
            each point's standard deviation (metres).
            pegs, peg_radius: ``(m, 2)`` centres of pegs on the table (or ``(B, m, 2)``, each
                shape's own, ``PEG_FAR`` in empty slots) and their radius: a move stops where a
                gripper would touch one, as in the simulator (``reachable_moves``). A model
                with ``config.peg_reach`` also sees them; one without does not predict the
                cord's contact with them. ``peg_radius`` None: ``config.peg_radius``.
        """
        grasp = _required_grasp(grasp)
        if displacement is None:
            raise InputError("displacement is required: (2,)/(B, 2) for one end, (4,)/(B, 4) "
                             "for both")
        arr, d, single = self._inputs(shapes, grasp, displacement)
        members = self._members_argument(members, return_std)
        rows = (self.cord_rows(params, len(arr)) if params is not None or self.config.cord_inputs
                else None)
        moves = self.reachable_moves(arr, grasp, d, params=rows, pegs=pegs,
                                     peg_radius=peg_radius)
        mean, spread = self._mean_and_spread(arr, grasp, moves, rows, pegs, members, return_std)
        if inextensible and len(mean):
            held = (np.full(len(mean), grasp != "tail"), np.full(len(mean), grasp != "head"))
            length = (self.config.cord_length if rows is None
                      else rows[:, PARAM_COLUMNS.index("length")])
            mean = make_inextensible(mean, length / (self.config.n_points - 1), *held)
        still = np.abs(moves).sum(axis=(1, 2)) == 0  # nothing moves: the cord stays at rest
        mean[still] = arr[still]
        spread[still] = 0.0
        mean = np.clip(mean, -TABLE_HALF, TABLE_HALF).astype(np.float32)
        spread = spread.astype(np.float32)
        if single:
            mean, spread = mean[0], spread[0]
        return (mean, spread) if return_std else mean

    def _members_argument(self, members: Any, return_std: bool) -> int | None:
        """``predict``'s ``members``, checked: None or an int in 1..members (two for the
        spread)."""
        total = self.config.members
        if members is not None and not (isinstance(members, Integral) and not isinstance(
                members, bool) and 1 <= members <= total):
            raise InputError(f"members must be an int in 1..{total} or None, got {members!r}")
        if members is not None:
            members = int(members)
        if return_std and (members == 1 or (members is None and total == 1)):
            raise InputError("return_std needs members >= 2 (one network has no spread), "
                             f"got members={members or total}")
        return members

    @torch.no_grad()
    def _mean_and_spread(self, arr: np.ndarray, grasp: str, moves: np.ndarray,
                         rows: np.ndarray | None, pegs: Any, members: int | None,
                         return_std: bool) -> tuple[np.ndarray, np.ndarray]:
        """The raw mean prediction ``(B, n, 2)`` of shapes ``arr`` under reachable ``moves``,
        in chunks, and the members' spread ``(B,)`` (zeros without ``return_std``): the mean
        network's prediction when the model has one and ``members`` is None, else the mean
        of the ensemble's (first ``members``) networks."""
        use_mean_net = members is None and self.mean_net is not None
        seen_pegs = (torch.from_numpy(padded_pegs(pegs, len(arr))).to(self.device)
                     if self.config.peg_reach and pegs is not None else None)
        cord = (None if rows is None or not self.config.cord_inputs
                else torch.from_numpy(cord_features(rows)).to(self.device))
        codes = torch.full((len(arr),), GRASP_CODES[grasp], dtype=torch.int64)
        means, spreads = [], []
        for lo in range(0, len(arr), PREDICT_CHUNK):
            part = slice(lo, lo + PREDICT_CHUNK)
            batch = (torch.from_numpy(arr[part]).to(self.device), codes[part].to(self.device),
                     torch.from_numpy(moves[part]).to(self.device))
            mine = None if cord is None else cord[part]
            near = None if seen_pegs is None else seen_pegs[part]
            if use_mean_net:
                moved, frame = self.in_frame(*batch, net=self.mean_net, cord=mine, pegs=near)
            if not use_mean_net or return_std:
                ensemble, frame = self.in_frame(*batch, members, cord=mine, pegs=near)
                if not use_mean_net:
                    moved = ensemble
                if return_std:  # in the frame: the spread does not depend on its angle
                    var = ensemble.var(dim=0, unbiased=False).sum(dim=-1)  # (b, n)
                    spreads.append(var.sqrt().mean(dim=-1))
            means.append(from_frame(moved.mean(dim=0), frame))
        if not return_std:
            spreads = [torch.zeros(len(arr))]
        mean = torch.cat(means).cpu().numpy() if means else np.zeros((0,) + arr.shape[1:])
        spread = torch.cat(spreads).cpu().numpy() if spreads else np.zeros(0)
        return mean, spread

    # ------------------------------------------------------------- persistence
    def state(self, half: bool = True) -> dict[str, Any]:
        """The checkpoint dict; weights in float16 when ``half`` (the shipped file's size)."""
        def weights(net: nn.Module) -> dict[str, torch.Tensor]:
            return {k: (v.half() if half else v).cpu() for k, v in net.state_dict().items()}

        state = {"format": FORMAT, "format_version": FORMAT_VERSION,
                 "config": saved_config(self.config), "net": weights(self.net),
                 "info": self.info}
        if self.mean_net is not None:
            state["mean_net"] = weights(self.mean_net)
        return state

    def save(self, path: str | os.PathLike, half: bool = True) -> Path:
        """Write the model to ``path`` (a file, or a folder that gets ``transition.pt``)."""
        path = Path(path)
        if path.is_dir():
            path = path / MODEL_FILE
        return save_atomic(self.state(half), path)

    @classmethod
    def from_state(cls, data: dict[str, Any], device: str | torch.device = "auto",
                   name: str = "path") -> TransitionModel:
        """Rebuild a model from a checkpoint dict (as written by ``save``)."""
        if isinstance(data.get("config"), dict):
            check_config_keys(data["config"], name)
        try:
            config = config_from_dict(TransitionModelConfig, recorded_cord(
                current_config(data["config"]), data.get("info")), "config")
            model = cls(config, device="cpu", info=data.get("info"))
            model.net.load_state_dict({k: v.float() for k, v in data["net"].items()})
            if model.mean_net is not None:
                model.mean_net.load_state_dict({k: v.float()
                                                for k, v in data["mean_net"].items()})
        except (KeyError, TypeError, RuntimeError, ValueError) as exc:
            detail = " ".join(str(exc).split())  # torch's messages span several lines
            raise InputError(f"{name}: the checkpoint's contents do not fit a TransitionModel: "
                             f"{detail}") from exc
        model.device = resolve_device(device)
        return model.to(model.device).eval()

    @classmethod
    def load(cls, path: str | os.PathLike, device: str | torch.device = "auto"
             ) -> TransitionModel:
        """Load a model written by ``save`` (a file, or a folder holding ``transition.pt``).

        Raises:
            FileNotFoundError: No such file.
            ValueError: The file is corrupt, not a transition model, or of another version.
        """
        path = Path(path)
        if path.is_dir():
            path = path / MODEL_FILE
        data = load_checkpoint(path, str(path), kind=FORMAT, version=FORMAT_VERSION)
        return cls.from_state(data, device, name=str(path))

    @classmethod
    def load_pretrained(cls, device: str | torch.device = "auto", *,
                        cords: bool = False, pegs: bool = False,
                        cord: CordParams | None = None) -> TransitionModel:
        """The shipped model for the default cord (``latent_model/pretrained/transition.pt``),
        with ``cords`` the shipped model of several cords (``transition-cords.pt``,
        ``predict(params=...)``; with ``cord``, the one fine-tuned for that cord where one
        ships, :data:`CORD_MODEL_FILES`), with ``pegs`` the one that sees pegs
        (``transition-pegs.pt``, ``predict(pegs=...)``)."""
        name = pretrained_file(cords, pegs, cord)
        with resources.as_file(resources.files("latent_model") / "pretrained" / name) as p:
            return cls.load(p, device)

    @classmethod
    def load_or_pretrained(cls, path: str | os.PathLike | None = None,
                           device: str | torch.device = "auto", *,
                           cords: bool = False, pegs: bool = False,
                           cord: CordParams | None = None) -> TransitionModel:
        """``load(path)`` when a path is given (not ``None`` or ""), else
        ``load_pretrained(cords=cords, pegs=pegs, cord=cord)``.

        The one call for code whose model argument defaults to the shipped model (a CLI flag,
        an agent option): ``load_pretrained()`` always loads the shipped file, ``load(path)``
        always the given one.
        """
        return cls.load(path, device) if path else cls.load_pretrained(device, cords=cords,
                                                                       pegs=pegs, cord=cord)

    def extra_repr(self) -> str:
        c = self.config
        return (f"members={c.members}, width={c.width}, depth={c.depth}, "
                f"mean_network={c.mean_network}, mean_by_grasp={c.mean_by_grasp}, "
                f"contact_reach={c.contact_reach}, "
                f"n_points={c.n_points}, device={self.device}")
