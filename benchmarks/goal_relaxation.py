"""How far each designed goal moves when the cord relaxes in it, by bending stiffness.

    python benchmarks/goal_relaxation.py

``dlo_env.goals`` lays the cord in a drawing and lets it come to rest; a drawing whose rest
shape lies more than ``goals.MAX_CHANGE`` (3 cm, mean point distance) from it is refused. This
prints that distance for every letter and curve family (default parameters, centred, the head
held) on cords of several bending stiffnesses and on the cord of ``shapes-letters``
(``dlo_env.designed_suites.LETTERS_CORD``): which designed goals a cord can rest in.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from dlo_env import goals
from dlo_env.cord import CordParams
from dlo_env.designed_suites import LETTERS_CORD
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
    cords = {f"{s:g}": CordParams(bending_stiffness=s) for s in args.stiffness}
    cords["letters"] = replace(CordParams(), **LETTERS_CORD)
    print(f"{'goal':<12}" + "".join(f"{name:>10}" for name in cords))
    for name, make in makers.items():
        cells = []
        for params in cords.values():
            change = float(error(make(params=params, max_change=10.0),
                                 make(params=params, relax=False)))
            cells.append(f"{100 * change:>9.1f}{'*' if change > goals.MAX_CHANGE else ' '}")
        print(f"{name:<12}" + "".join(cells), flush=True)
