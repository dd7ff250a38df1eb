"""An episode as a GIF: the real cord, the gripper, the goal and the current plan's shapes.

Pillow (the ``render`` extra) draws the frames; it is imported inside the function, so the
harness runs without it. The colours are the environment renderer's. Files are written
atomically.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.core.atomic import atomic_path
from dlo_env.errors import InputError
from dlo_env.rendering import PALETTE
from dlo_env.shapes import TABLE_HALF
from planners.interfaces import PlanningPolicy, Policy

_GHOST = (150, 170, 225)
_TEXT = (20, 20, 20)
#: The legend: one entry per mark drawn.
LEGEND = ("cord (blue), head (red dot) held by the gripper (orange ring),",
          "goal (green), current plan's shapes (pale blue)")
#: The legend of an episode without plan shapes (an agent that plans moves, not shapes).
LEGEND_NO_PLAN = ("cord (blue), head (red dot) held by the gripper (orange ring),",
                  "goal (green)")


@dataclass(frozen=True)
class Frame:
    """What one GIF frame shows.

    Attributes:
        shape: ``(n, 2)`` the real cord.
        goal: ``(n, 2)`` the goal.
        ghosts: ``(K, n, 2)`` planned shapes drawn faintly (may be empty).
        caption: A line of text at the top.
    """

    shape: np.ndarray
    goal: np.ndarray
    ghosts: np.ndarray
    caption: str = ""


def _view(frames: list[Frame], size: int, margin: float = 0.08):
    """World-to-pixel map zoomed on everything the frames show (within the table)."""
    pts = np.concatenate([np.concatenate([f.shape, f.goal, f.ghosts.reshape(-1, 2)])
                          for f in frames])
    lo = np.maximum(pts.min(axis=0) - margin, -TABLE_HALF)
    hi = np.minimum(pts.max(axis=0) + margin, TABLE_HALF)
    centre, half = 0.5 * (lo + hi), 0.5 * float((hi - lo).max())

    def to_pixels(points: np.ndarray) -> list[tuple[float, float]]:
        p = (np.asarray(points, dtype=np.float64) - centre) / half  # [-1, 1]
        x = (p[:, 0] + 1.0) * 0.5 * size
        y = (1.0 - p[:, 1]) * 0.5 * size  # world y points up
        return list(zip(x.tolist(), y.tolist()))

    return to_pixels


def save_episode_gif(frames: list[Frame], path: str | os.PathLike, size: int = 400,
                     fps: int = 10) -> Path:
    """Draw the frames with Pillow and write an animated GIF.

    Returns:
        The path written.
    """
    from PIL import Image, ImageDraw

    if not frames:
        raise InputError("frames must not be empty")
    path = Path(path)
    to_pixels = _view(frames, size)
    width = max(2, size // 120)
    legend = LEGEND if any(len(frame.ghosts) for frame in frames) else LEGEND_NO_PLAN
    images = []
    for frame in frames:
        image = Image.new("RGB", (size, size), PALETTE["table"])
        draw = ImageDraw.Draw(image)
        draw.line(to_pixels(frame.goal), fill=PALETTE["goal"], width=width + 5, joint="curve")
        for ghost in frame.ghosts:
            draw.line(to_pixels(ghost), fill=_GHOST, width=1)
        cord = to_pixels(frame.shape)
        draw.line(cord, fill=PALETTE["cord"], width=width, joint="curve")
        hx, hy = cord[0]
        r = 2 * width
        draw.ellipse([hx - r, hy - r, hx + r, hy + r], fill=PALETTE["head"])
        r = 3 * width
        draw.ellipse([hx - r, hy - r, hx + r, hy + r], outline=PALETTE["gripper"], width=width)
        if frame.caption:
            draw.text((6, 4), frame.caption, fill=_TEXT)
        for k, line in enumerate(legend):
            draw.text((6, size - 14 * (len(legend) - k) - 2), line, fill=_TEXT)
        images.append(image.convert("P", palette=Image.Palette.ADAPTIVE, colors=64))
    with atomic_path(path) as tmp:
        images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:],
                       duration=int(1000 / fps), loop=0)
    return path


def record_episode(
    policy: Policy, env: Any, *, seed: int | None = None, options: dict | None = None,
    ghosts: int = 12,
) -> tuple[list[Frame], dict]:
    """Run one episode and keep, at every step, the cord, the goal and the current plan.

    Args:
        policy: An SB3-style policy; for a ``PlanningPolicy`` the latest plan's shapes are the
            ghosts of each frame.
        env: A ``dlo_env`` goal environment.
        seed: Reset seed.
        options: Reset options.
        ghosts: Planned shapes drawn per frame, evenly chosen along the plan.

    Returns:
        The frames (the first shows the start) and the last step's ``info``.
    """
    obs, info = env.reset(seed=seed, options=options)
    n = obs["achieved_goal"].size // 2
    goal = obs["desired_goal"].reshape(n, 2)
    empty = np.zeros((0, n, 2), dtype=np.float32)

    def current_ghosts() -> np.ndarray:
        plan = policy.episode_stats().latest_plan if isinstance(policy, PlanningPolicy) else None
        if plan is None:
            return empty
        shapes = plan.shapes
        idx = np.unique(np.linspace(0, len(shapes) - 1, min(ghosts, len(shapes))).astype(int))
        return shapes[idx]

    frames = [Frame(obs["achieved_goal"].reshape(n, 2), goal, empty, "start")]
    step = 0
    while True:
        action, _ = policy.predict(obs, episode_start=np.array([step == 0]))
        obs, _, terminated, truncated, info = env.step(np.asarray(action).reshape(-1))
        step += 1
        caption = f"step {step}  error {100 * info['error']:.1f} cm"
        if terminated and info["is_success"]:
            caption += "  solved"
        frames.append(Frame(obs["achieved_goal"].reshape(n, 2), goal, current_ghosts(), caption))
        if terminated or truncated:
            return frames, info
