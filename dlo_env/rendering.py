"""Drawing the cord, its goal and the grippers on the table, with pygame.

pygame (the ``render`` extra, ``pygame-ce``) is imported only when a renderer is created, so
``dlo_env`` runs without it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from dlo_env.errors import InputError
from dlo_env.shapes import TABLE_HALF

_FLOOR = (60, 60, 60)
_TABLE = (232, 224, 204)
_EDGE = (150, 130, 100)
_GOAL = (120, 200, 120)
_CORD = (30, 60, 140)
_HEAD = (200, 60, 40)
_GRIPPER = (240, 150, 20)
_PEG = (90, 90, 90)
#: The colours (RGB) of every mark, by name; other drawings of the cord (GIFs) use the same.
PALETTE = {"floor": _FLOOR, "table": _TABLE, "edge": _EDGE, "goal": _GOAL, "cord": _CORD,
           "head": _HEAD, "gripper": _GRIPPER, "peg": _PEG}


class CordRenderer:
    """Draws frames of a cord on the table, top view, y up.

    Args:
        render_mode: ``"rgb_array"`` (return images) or ``"human"`` (a window, real time).
        size: Image side, pixels.
        fps: Frames per second of the ``"human"`` window.
    """

    def __init__(self, render_mode: str, size: int = 512, fps: int = 10) -> None:
        if render_mode not in ("rgb_array", "human"):
            raise InputError(f"render_mode must be 'rgb_array' or 'human', got {render_mode!r}")
        try:
            import pygame
        except ImportError as exc:  # pragma: no cover - depends on the installation
            raise ImportError(
                'rendering needs pygame-ce: pip install "dlo[render]"'
            ) from exc
        self._pygame = pygame
        self.render_mode = render_mode
        self.size = int(size)
        self.fps = int(fps)
        self._surface = pygame.Surface((self.size, self.size))
        self._window = None
        self._clock = None
        if render_mode == "human":
            pygame.display.init()  # display only: no audio device is needed
            self._window = pygame.display.set_mode((self.size, self.size))
            pygame.display.set_caption("dlo cord")
            self._clock = pygame.time.Clock()

    def _pixels(self, points: np.ndarray) -> list[tuple[int, int]]:
        # Table [-h, h]^2 fills the image with a small border; world y points up.
        border = 0.04 * self.size
        scale = (self.size - 2 * border) / (2 * TABLE_HALF)
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        x = border + (pts[:, 0] + TABLE_HALF) * scale
        y = border + (TABLE_HALF - pts[:, 1]) * scale
        return [(int(round(a)), int(round(b))) for a, b in zip(x, y)]

    def draw(
        self,
        shape: np.ndarray | None,
        goal: np.ndarray | None,
        grippers: Sequence[Sequence[float]],
        pegs: np.ndarray | None = None,
        peg_radius: float = 0.0,
    ) -> np.ndarray | None:
        """Draw one frame.

        Args:
            shape: ``(n, 2)`` cord shape (None before the first reset).
            goal: ``(n, 2)`` goal shape, drawn as a pale ghost (or None).
            grippers: Positions of the grippers, metres.
            pegs: ``(k, 2)`` peg centres, metres (None: none).
            peg_radius: Their radius, metres.

        Returns:
            ``(size, size, 3)`` uint8 in ``"rgb_array"`` mode, else None.
        """
        pg = self._pygame
        surf = self._surface
        surf.fill(_FLOOR)
        corners = self._pixels(np.array([[-1, 1], [1, -1]]) * TABLE_HALF)
        table = pg.Rect(corners[0], (corners[1][0] - corners[0][0], corners[1][1] - corners[0][1]))
        pg.draw.rect(surf, _TABLE, table)
        pg.draw.rect(surf, _EDGE, table, width=3)
        width = max(2, self.size // 100)
        if pegs is not None and len(pegs):
            scale = (self.size - 2 * 0.04 * self.size) / (2 * TABLE_HALF)
            for p in self._pixels(pegs):
                pg.draw.circle(surf, _PEG, p, max(2, int(round(peg_radius * scale))))
        if goal is not None:
            pts = self._pixels(goal)
            pg.draw.lines(surf, _GOAL, False, pts, width + 4)
            pg.draw.circle(surf, _GOAL, pts[0], 2 * width)
        if shape is not None:
            pts = self._pixels(shape)
            pg.draw.lines(surf, _CORD, False, pts, width)
            for p in pts:
                pg.draw.circle(surf, _CORD, p, width)
            pg.draw.circle(surf, _HEAD, pts[0], int(1.5 * width))
        for p in self._pixels(np.asarray(grippers, dtype=np.float64)) if len(grippers) else []:
            pg.draw.circle(surf, _GRIPPER, p, 3 * width, width=width)
        if self.render_mode == "human":
            assert self._window is not None and self._clock is not None
            pg.event.pump()
            self._window.blit(surf, (0, 0))
            pg.display.update()
            self._clock.tick(self.fps)
            return None
        return np.transpose(np.array(pg.surfarray.pixels3d(surf)), (1, 0, 2)).copy()

    def close(self) -> None:
        """Close the window (if any); safe to call more than once."""
        if self._window is not None:
            self._pygame.display.quit()
            self._window = None
