"""Pictures of plans: an episode as a GIF (cord, goal, planned ghosts), the interpolation PNG.

Pillow draws the GIF frames and matplotlib the PNG; both are imported inside the functions, so
the planners run without them. Files are written atomically.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dlo_env.atomic import atomic_path
from dlo_env.shapes import TABLE_HALF

_FLOOR = (60, 60, 60)
_TABLE = (232, 224, 204)
_GOAL = (120, 200, 120)
_GHOST = (150, 170, 225)
_CORD = (30, 60, 140)
_HEAD = (200, 60, 40)
_TEXT = (20, 20, 20)


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
        raise ValueError("frames must not be empty")
    path = Path(path)
    to_pixels = _view(frames, size)
    width = max(2, size // 120)
    images = []
    for frame in frames:
        image = Image.new("RGB", (size, size), _TABLE)
        draw = ImageDraw.Draw(image)
        draw.line(to_pixels(frame.goal), fill=_GOAL, width=width + 5, joint="curve")
        for ghost in frame.ghosts:
            draw.line(to_pixels(ghost), fill=_GHOST, width=1)
        cord = to_pixels(frame.shape)
        draw.line(cord, fill=_CORD, width=width, joint="curve")
        hx, hy = cord[0]
        r = 2 * width
        draw.ellipse([hx - r, hy - r, hx + r, hy + r], fill=_HEAD)
        if frame.caption:
            draw.text((6, 4), frame.caption, fill=_TEXT)
        draw.text((6, size - 16), "cord (blue), goal (green), current plan (pale)", fill=_TEXT)
        images.append(image.convert("P", palette=Image.Palette.ADAPTIVE, colors=64))
    with atomic_path(path) as tmp:
        images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:],
                       duration=int(1000 / fps), loop=0)
    return path


def save_interpolation_png(
    path: str | os.PathLike,
    interpolation: np.ndarray,
    start: np.ndarray,
    goal: np.ndarray,
    planned: np.ndarray | None = None,
    real: np.ndarray | None = None,
    title: str = "",
) -> Path:
    """The paper's Fig. 2: decoded shapes along the latent line from start to goal.

    With ``planned`` and ``real`` a second panel compares a plan's shapes with what the
    simulator did under the same end motion (where they part ways).

    Args:
        path: The PNG to write.
        interpolation: ``(T, n, 2)`` decoded shapes of the latent line.
        start: ``(n, 2)`` the real start shape.
        goal: ``(n, 2)`` the real goal shape.
        planned: ``(K, n, 2)`` a plan's shapes (optional).
        real: ``(K, n, 2)`` the simulator's shapes at the same end positions (optional).
        title: Figure title.

    Returns:
        The path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    panels = 2 if planned is not None and real is not None else 1
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 5.0), squeeze=False)
    colours = plt.cm.viridis(np.linspace(0.0, 1.0, len(interpolation)))
    ax = axes[0, 0]
    for shape, colour in zip(interpolation, colours):
        ax.plot(shape[:, 0], shape[:, 1], "-", color=colour, lw=1.5)
        ax.plot(shape[0, 0], shape[0, 1], "o", color=colour, ms=3)
    ax.plot(start[:, 0], start[:, 1], "k--", lw=1, label="start (real)")
    ax.plot(goal[:, 0], goal[:, 1], "k:", lw=1.5, label="goal (real)")
    ax.set_title("latent interpolation, start (purple) to goal (yellow)", fontsize=9)
    ax.legend(fontsize=8, loc="best")
    if panels == 2:
        ax = axes[0, 1]
        idx = np.unique(np.linspace(0, len(planned) - 1, min(len(planned), 8)).round().astype(int))
        colours = plt.cm.plasma(np.linspace(0.0, 0.85, len(idx)))
        for i, colour in zip(idx, colours):
            ax.plot(planned[i, :, 0], planned[i, :, 1], "-", color=colour, lw=1.5)
            ax.plot(real[i, :, 0], real[i, :, 1], "--", color=colour, lw=1.0)
        ax.plot([], [], "k-", label="planned (surrogate)")
        ax.plot([], [], "k--", label="real (simulator)")
        ax.set_title("latent-tree plan vs the real cord at the same head positions", fontsize=9)
        ax.legend(fontsize=8, loc="best")
    for ax in axes[0]:
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png", dpi=110)
    finally:
        plt.close(fig)
    return path


def record_episode(
    policy: object, env: object, *, seed: int | None = None, options: dict | None = None,
    ghosts: int = 12,
) -> tuple[list[Frame], dict]:
    """Run one episode and keep, at every step, the cord, the goal and the current plan.

    Args:
        policy: An SB3-style policy; if it has ``plans``, the latest plan's shapes are the
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
    if hasattr(policy, "reset"):
        policy.reset()
    empty = np.zeros((0, n, 2), dtype=np.float32)

    def current_ghosts() -> np.ndarray:
        plans = getattr(policy, "plans", None)
        if not plans:
            return empty
        shapes = plans[-1].shapes
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
