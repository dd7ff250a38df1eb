"""The capstan effect of pegs with friction: the force a gripper needs against a load, by wrap.

    python benchmarks/peg_capstan.py [--friction 0 0.15 0.3] [--load 1.0]

A cord lies wrapped round one peg by an angle: its head held by the gripper on one side, its
tail pulled away with a constant force (the load) on the other, the table frictionless
(``CordParams.friction`` 0), so only the peg holds. The gripper then moves slowly along the
cord's lead, and the cord slides round the peg: towards the peg (lowering the load) the gripper
holds ``load * exp(-mu * angle)`` by the capstan equation, away from it (hoisting)
``load * exp(mu * angle)``, where ``mu`` is ``CordParams.peg_friction``. The cord's links are
straight, so a wrap is a polygon round the peg: each link that wraps turns the cord by a fixed
angle (92 degrees for the default cord and a 2 cm peg, 51 for a 5 cm peg), up to a half turn
here (the cord does not collide with itself). This prints the gripper's mean force over the
slide, over the load, against the capstan equation's, for the default cord round the default
peg and round a 5 cm one.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np

from dlo_env.cord import LINK_RADIUS, PEG_RADIUS, Cord, CordParams

#: Gripper speed of the slide, m/s, and its length, metres.
SPEED, SLIDE = 0.02, 0.06
#: Seconds the load pulls before the slide (the cord comes taut round the peg).
TAUT = 1.0


def wrapped_shape(params: CordParams, links: int, radius: float, lead: int) -> np.ndarray:
    """``(n, 2)``: ``lead`` links from the head to the peg at the origin, ``links`` links
    round it (each a chord tangent to the peg), the rest away from it; consecutive points one
    segment apart."""
    s = params.segment
    touch = radius + LINK_RADIUS + 5e-4  # a link's centre line this far from the peg's centre
    turn = 2.0 * math.atan(s / (2.0 * touch))  # the cord turns by this at each wrapped joint
    ring = touch / math.cos(turn / 2.0)  # the wrapped joints lie on this circle
    corners = [ring * np.array([math.cos(math.pi / 2 - i * turn), math.sin(math.pi / 2 - i * turn)])
               for i in range(links + 1)]  # clockwise from the top
    first_dir = np.array([1.0, 0.0]) if links == 0 else (corners[1] - corners[0]) / s
    last_dir = first_dir if links == 0 else (corners[-1] - corners[-2]) / s
    head = [corners[0] - k * s * first_dir for k in range(lead, 0, -1)]
    tail_count = params.n_points - lead - len(corners)
    tail = [corners[-1] + k * s * last_dir for k in range(1, tail_count + 1)]
    return np.array(head + corners + tail, dtype=np.float64)


def slide_force(params: CordParams, links: int, load: float, towards: bool,
                radius: float = PEG_RADIUS) -> tuple[float, float]:
    """The wrap angle (radians) and the gripper's mean force over the slide, newtons."""
    lead = params.n_points // 2 - links // 2
    shape = wrapped_shape(params, links, radius, lead)
    cord = Cord(params, grasp="head", pegs=np.zeros((1, 2)), peg_radius=radius)
    cord.reset(shape.astype(np.float32))
    direction = (shape[-1] - shape[-2]) / params.segment
    lead_dir = (shape[1] - shape[0]) / params.segment
    headings = np.unwrap(np.arctan2(*np.diff(shape, axis=0)[:, ::-1].T))
    angle = float(abs(headings[-1] - headings[0]))  # the cord's total turn round the peg
    tail = cord.segments[-1]
    half = 0.5 * params.segment
    h = params.dt / params.substeps
    force = tuple(float(f) for f in load * direction)

    def step() -> None:
        tail.apply_force_at_world_point(force, tail.local_to_world((half, 0.0)))
        cord.space.step(h)

    for _ in range(int(TAUT / h)):
        step()
    gripper = cord.grippers["head"]
    gripper.velocity = tuple(float(v) for v in (1 if towards else -1) * SPEED * lead_dir)
    forces = []
    for _ in range(int(SLIDE / SPEED / h)):
        step()
        forces.append(cord.gripper_forces()["head"])
    return angle, float(np.mean(forces[len(forces) // 4:]))  # after the start of the slide


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--friction", type=float, nargs="+", default=[0.0, 0.15, 0.3],
                        help="peg friction coefficients (CordParams.peg_friction)")
    parser.add_argument("--load", type=float, default=1.0, help="the tail's load, newtons")
    args = parser.parse_args()
    if args.load <= 0 or any(m < 0 for m in args.friction):
        parser.error("--load must be > 0 and --friction >= 0")
    for radius, wraps in ((PEG_RADIUS, range(1, 4)), (0.05, range(1, 6))):
        print(f"\ndefault cord, peg radius {radius} m, load {args.load:g} N, table "
              "frictionless; gripper force / load (capstan equation's)")
        print("| peg friction | wrapped links | wrap (deg) | lowering | hoisting |")
        print("|---|---|---|---|---|")
        for mu in args.friction:
            params = replace(CordParams(), friction=0.0, peg_friction=mu)
            for links in wraps:
                angle, low = slide_force(params, links, args.load, True, radius)
                _, high = slide_force(params, links, args.load, False, radius)
                print(f"| {mu:g} | {links} | {math.degrees(angle):.0f} | "
                      f"{low / args.load:.2f} ({math.exp(-mu * angle):.2f}) | "
                      f"{high / args.load:.2f} ({math.exp(mu * angle):.2f}) |", flush=True)


if __name__ == "__main__":
    main()
