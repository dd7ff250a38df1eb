"""Two designs of the transition model on the same data: shape space against latent space.

(a) shape space (what ships): the network maps the cord in the move frame to the displacement
    of every point.
(b) latent space: the shipped GAN's Encoder encodes the cord (in the same move frame), the
    network predicts the next latent from it, the move and the same rim vectors, and the frozen
    Generator decodes it. The loss is on the
    decoded points for both, so the comparison is of the representations, not of the losses.

Both train with the same settings, steps, seed and data; the held-out one-move error is printed
side by side. The latent design is bounded below by how well the GAN represents a shape (its
inversion error), which is the question this script answers.

    python benchmarks/transition_designs.py --data data/transitions-train.npz \\
        --heldout data/transitions-heldout.npz [--steps 4000] [--out runs/transition-designs]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import torch

from dlo_env.atomic import write_text_atomic
from dlo_env.dataset.transitions import load_transitions
from latent_model import ShapeModel
from latent_model.transition_metrics import report_lines, transition_report
from latent_model.transition_model import EnsembleMLP, TransitionModel, TransitionModelConfig
from latent_model.transition_training import TransitionTrainConfig, train_transition_model

#: The settings both designs train with: those of the comparison in docs/history.md
#: (the defaults when it was run; later defaults are the shape-space model's own tuning).
DESIGN_MODEL = TransitionModelConfig(rim_reach=0.15, rim_targets=1, mirror=False)
DESIGN_CHAIN_WEIGHT = 0.5


class LatentTransitionModel(TransitionModel):
    """Design (b): predict the next GAN latent of the cord in the move frame."""

    shape_model: ShapeModel | None = None  # set before construction (a frozen, shared GAN)

    def __init__(self, config: TransitionModelConfig | None = None,
                 device: str | torch.device = "auto", info: dict | None = None) -> None:
        gan = self.shape_model
        assert gan is not None, "set LatentTransitionModel.shape_model first"
        for p in list(gan.generator.parameters()) + list(gan.encoder.parameters()):
            p.requires_grad_(False)
        self.latent_dim = gan.latent_dim
        super().__init__(config, device, info)

    def networks(self, members: int, width: int | None = None,  # noqa: D102
                 design: str = "mlp") -> EnsembleMLP:
        c = self.config
        inputs = self.latent_dim + 2 * c.rim_inputs + 4  # latent, rim, move
        return EnsembleMLP(members, inputs, c.width if width is None else width, c.depth,
                           self.latent_dim)

    def predict_points(self, points, lead, other, both, rim, members_batch,  # noqa: D102
                       members=None, net=None, cord=None):
        net = self.net if net is None else net
        gan = self.shape_model
        c = self.config
        latent = gan.encode_torch(points)  # (E*B or B, L): shape latent and pose in the frame
        x = torch.cat([latent, rim.flatten(1), lead[:, None] / c.move_scale,
                       other / c.move_scale, both[:, None].to(points.dtype)], dim=1)
        out = (net(x.reshape(*members_batch, -1)) if members_batch
               else net(x, members))  # (E, B, L)
        e, b = out.shape[:2]
        nxt = latent.reshape(-1, b, self.latent_dim) + out
        return gan.decode_torch(nxt.reshape(e * b, -1)).reshape(e, b, c.n_points, 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default="data/transitions-train.npz")
    parser.add_argument("--heldout", default="data/transitions-heldout.npz")
    parser.add_argument("--steps", type=int, default=4000, help="training steps per design")
    parser.add_argument("--shape-model", default=None, help="GAN for (b) (default: shipped)")
    parser.add_argument("--out", default="runs/transition-designs")
    args = parser.parse_args()
    data, heldout = load_transitions(args.data), load_transitions(args.heldout)
    LatentTransitionModel.shape_model = ShapeModel.load_or_pretrained(args.shape_model, "cpu")
    tc = TransitionTrainConfig(steps=args.steps, eval_every=max(args.steps // 4, 1),
                               chain_weight=DESIGN_CHAIN_WEIGHT)
    results = {}
    for name, cls in (("shape space", TransitionModel), ("latent space", LatentTransitionModel)):
        out = Path(args.out) / name.replace(" ", "-")
        started = time.perf_counter()
        model = train_transition_model(data, out, tc, DESIGN_MODEL, resume=True, device="cpu",
                                       model_class=cls)
        minutes = (time.perf_counter() - started) / 60
        rows, rank = transition_report(model, heldout, max_moves=2)
        print(f"\n{name}: {args.steps} steps in {minutes:.1f} min")
        for line in report_lines(rows, rank):
            print("   " + line)
        results[name] = {"minutes": minutes, "rows": [r.__dict__ for r in rows], "rank": rank}
    print("\none move, held out (mean / within 1 cm)")
    for name, r in results.items():
        one = {row["group"]: row for row in r["rows"] if row["moves"] == 1}
        print(f"   {name:<13} " + "  ".join(
            f"{g} {one[g]['mean_cm']:.3f} cm / {100 * one[g]['within_1cm']:.1f} %"
            for g in ("head", "tail", "both")))
    write_text_atomic(Path(args.out) / "designs.json", json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
