"""How far each designed goal moves when the cord relaxes in it, by bending stiffness.

    python benchmarks/goal_relaxation.py

``dlo_env.goals`` lays the cord in a drawing and lets it come to rest; a drawing whose rest
shape lies more than ``goals.MAX_CHANGE`` (3 cm, mean point distance) from it is refused. This
prints that distance for every letter and curve family (default parameters, centred, the head
held) on cords of several bending stiffnesses: which designed goals a cord can rest in.
"""

from __future__ import annotations

import argparse

from dlo_env import goals
from dlo_env.cord import CordParams
from dlo_env.shapes import error

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stiffness", type=float, nargs="+", default=[0.001, 0.003, 0.01],
                        help="bending stiffnesses, N m^2 (the default cord: 0.01)")
    args = parser.parse_args()
    makers = {**{f"letter {k}": (lambda k=k, **kw: goals.letter(k, **kw)) for k in goals.LETTERS},
              **goals.CURVES}
    print("cm the rest shape lies from the drawing (* refused: over "
          f"{100 * goals.MAX_CHANGE:.0f} cm)")
    print(f"{'goal':<12}" + "".join(f"{s:>10g}" for s in args.stiffness))
    for name, make in makers.items():
        cells = []
        for stiffness in args.stiffness:
            params = CordParams(bending_stiffness=stiffness)
            change = float(error(make(params=params, max_change=10.0),
                                 make(params=params, relax=False)))
            cells.append(f"{100 * change:>9.1f}{'*' if change > goals.MAX_CHANGE else ' '}")
        print(f"{name:<12}" + "".join(cells), flush=True)
