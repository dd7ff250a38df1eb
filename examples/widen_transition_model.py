"""Widen a transition model's ensemble without changing what it predicts, to fine-tune it wider.

Every hidden layer gets new units with random incoming weights and zero outgoing weights, so
the widened networks compute exactly what the old ones did; ``dlo train --stage transition
--init OUT --width WIDTH`` then fine-tunes all units. A mean network the file holds is not kept
(distil again). The widening probe of docs/history.md:

    python examples/widen_transition_model.py --model runs/s/finetune5/transition.pt \\
        --width 384 --out runs/widened.pt
    dlo train --stage transition --init runs/widened.pt --width 384 --steps 20000 \\
        --lr 0.0005 --data ... --out runs/wide
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import torch

from dlo_cli.flags import positive_int
from latent_model.transition_model import TransitionModel


def widen(model: TransitionModel, width: int, seed: int = 0) -> TransitionModel:
    """A copy of ``model``'s ensemble with ``width`` hidden units per layer, same predictions."""
    if width < model.config.width:
        raise ValueError(f"width must be at least the model's {model.config.width}, got {width}")
    config = replace(model.config, width=width, mean_network=False, mean_by_grasp=False,
                     mean_width=None)
    wide = TransitionModel(config, device="cpu", info=dict(model.info))
    wide.net = model.net.widened(width, seed).cpu()
    return wide.eval()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True, help="transition model file to widen")
    parser.add_argument("--width", type=positive_int, required=True, help="new hidden units")
    parser.add_argument("--out", required=True, help="file to write (float32 weights)")
    args = parser.parse_args()
    model = TransitionModel.load(args.model, device="cpu")
    wide = widen(model, args.width)
    # A check on random cords of the model's own points and length.
    n, segment = model.config.n_points, model.config.cord_length / (model.config.n_points - 1)
    links = torch.nn.functional.normalize(torch.randn(64, n - 1, 2), dim=-1) * segment
    shapes = torch.cat([torch.zeros(64, 1, 2), torch.cumsum(links, 1)], 1)
    grasp, moves = torch.randint(0, 3, (64,)), 0.1 * torch.randn(64, 2, 2)
    with torch.no_grad():
        gap = (model(shapes, grasp, moves, net=model.net)
               - wide(shapes, grasp, moves, net=wide.net)).abs().max()
    print(f"wrote {wide.save(args.out, half=False)}: width {model.config.width} -> "
          f"{args.width}, largest change of a prediction {float(gap):.1e} m")


if __name__ == "__main__":
    main()
