"""Top-down 2-D rendering of a plain scene description.

The renderer knows nothing about the simulation: the environment builds a :class:`Scene` (user,
robots, formation links, reference positions, walls, boxes, HUD text) in world metres and the
:class:`Renderer` draws it with pygame, either to an RGB array (``mode="rgb_array"``) or to a window
(``mode="human"``). :class:`GifWriter` collects RGB frames and writes an animated GIF atomically.

World frame: x to the right, y up, headings counter-clockwise from +x (radians). The camera is
centred on the mean of the user and the robots (clamped so the user always stays in view), so a
long walk stays on screen at a fixed scale.

pygame is imported lazily, inside :class:`Renderer`, so importing this module is cheap and does not
need pygame.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Self

import numpy as np

from petswarm_env.files import write_atomic

ROLES = ("master", "slave", "waiting", "other")
MODES = ("rgb_array", "human")

Point = tuple[float, float]

# -- colours (RGB) ---------------------------------------------------------------------------------
BACKGROUND = (246, 246, 242)
GRID_MINOR = (222, 222, 218)
GRID_MAJOR = (196, 196, 190)  # every 5 m
WALL = (55, 55, 60)
BOX_FILL = (190, 165, 125)
BOX_EDGE = (115, 92, 60)
USER_FILL = (255, 140, 0)
USER_EDGE = (120, 60, 0)
LINK = (110, 110, 135)
REFERENCE = (10, 10, 40)
OUTLINE = (30, 30, 35)
HEADING = (255, 255, 255)
LABEL = (20, 20, 25)
HUD_TEXT = (15, 15, 20)
ROLE_COLOURS = {
    "master": (214, 36, 56),  # crimson, with a ring
    "slave": (40, 95, 225),  # blue
    "waiting": (150, 150, 150),  # grey
    "other": (145, 60, 190),  # purple (another user's swarm)
}
FAULT_MARK = (235, 20, 20)  # a robot's fault state (docs/faults.md): a red cross when off, a red rim for a broken part
FAULT_SHORT = {"dead": "X", "battery": "B0", "radio_silent": "RF", "ir": "IR", "ultrasonic": "US", "ahrs": "AHRS"}

_MAX_PX = 1_000_000  # clamp for far-off coordinates so pygame never sees absurd integers


@dataclass
class RobotView:
    """One robot as drawn: true position and heading, body radius, role and a short label."""

    position_m: Point
    heading_rad: float
    radius_m: float
    role: str  # "master" | "slave" | "waiting" | "other"
    label: str = ""  # e.g. member number "0" or a robot id
    faults: tuple[str, ...] = ()  # the robot's active fault kinds (petswarm_env/sim/faults.py), drawn over it
    kind: str = ""  # its robot type (robot_types), drawn beside the body; "" = not drawn

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"RobotView.role must be one of {ROLES}, got {self.role!r}")


@dataclass
class Scene:
    """Everything the renderer draws for one frame, in world metres."""

    time_s: float
    user_position_m: Point
    user_heading_rad: float
    user_radius_m: float
    robots: list[RobotView] = field(default_factory=list)
    links: list[tuple[Point, Point]] = field(default_factory=list)  # neighbour -> slave
    references_m: list[Point] = field(default_factory=list)  # each slave's reference position
    walls: list[tuple[Point, Point]] = field(default_factory=list)  # segments
    boxes: list[tuple[Point, Point]] = field(default_factory=list)  # (center, size)
    text: list[str] = field(default_factory=list)  # HUD lines, top-left
    other_users: list[tuple[Point, float]] = field(default_factory=list)  # further users: (position, heading)


def _xy(p: Sequence[float]) -> tuple[float, float]:
    return float(p[0]), float(p[1])


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def camera_center(
    scene: Scene, view_size_m: tuple[float, float] | None = None
) -> tuple[float, float]:
    """World point at the centre of the view: mean of the user and all robots.

    With ``view_size_m`` (width, height of the view in metres) the centre is clamped so the user
    stays inside the view with a margin, even if the robots are spread far away.
    """
    ux, uy = _xy(scene.user_position_m)
    pts = [(ux, uy)] + [_xy(r.position_m) for r in scene.robots]
    pts = [p for p in pts if _finite(*p)]
    if not pts:
        return 0.0, 0.0
    cx = sum(p[0] for p in pts) / len(pts)
    cy = sum(p[1] for p in pts) / len(pts)
    if view_size_m is not None and _finite(ux, uy):
        half_w, half_h = view_size_m[0] / 2.0, view_size_m[1] / 2.0
        margin = max(float(scene.user_radius_m), 0.0) + 0.5
        slack_x = max(half_w - margin, 0.0)
        slack_y = max(half_h - margin, 0.0)
        cx = min(max(cx, ux - slack_x), ux + slack_x)
        cy = min(max(cy, uy - slack_y), uy + slack_y)
    return cx, cy


class Renderer:
    """Draws :class:`Scene` objects with pygame.

    ``mode="rgb_array"``: :meth:`render` returns an ``(H, W, 3)`` uint8 array (no window is opened).
    ``mode="human"``: :meth:`render` draws to a pygame window, waits to keep ``fps`` and returns
    ``None``. On a headless Linux machine (no ``DISPLAY``/``WAYLAND_DISPLAY``) the SDL "dummy" video
    driver is selected unless ``SDL_VIDEODRIVER`` is already set. Closing the window stops drawing
    (later calls return ``None``; :attr:`window_closed` is then True).
    """

    def __init__(
        self,
        size_px: tuple[int, int] = (720, 720),
        pixels_per_m: float = 60.0,
        fps: float = 10,
        mode: str = "rgb_array",
    ) -> None:
        if mode not in MODES:
            raise ValueError(f"unknown render mode {mode!r}; allowed modes: {', '.join(MODES)}")
        try:
            w, h = (int(v) for v in size_px)
        except (TypeError, ValueError):
            raise ValueError(
                f"size_px must be (width, height) in pixels, got {size_px!r}"
            ) from None
        if w <= 0 or h <= 0:
            raise ValueError(f"size_px must be positive, got {size_px!r}")
        if not (math.isfinite(pixels_per_m) and pixels_per_m > 0):
            raise ValueError(f"pixels_per_m must be a positive number, got {pixels_per_m!r}")
        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        self.size_px = (w, h)
        self.pixels_per_m = float(pixels_per_m)
        self.fps = fps
        self.mode = mode
        self.window_closed = False
        self._pg: Any = None
        self._surface: Any = None
        self._window: Any = None
        self._clock: Any = None
        self._fonts: dict[int, Any] = {}
        self._fonts_unavailable = False
        self._center = (0.0, 0.0)

    # -- geometry ----------------------------------------------------------------------------------
    @property
    def view_size_m(self) -> tuple[float, float]:
        return self.size_px[0] / self.pixels_per_m, self.size_px[1] / self.pixels_per_m

    def camera_center(self, scene: Scene) -> tuple[float, float]:
        """World point drawn at the centre of the image for ``scene``."""
        return camera_center(scene, self.view_size_m)

    def world_to_px(
        self, p: Sequence[float], center: Sequence[float] | None = None
    ) -> tuple[int, int]:
        """Pixel (column, row) of world point ``p`` for a camera centred on ``center``.

        Without ``center`` the camera of the last rendered scene is used.
        """
        cx, cy = _xy(center) if center is not None else self._center
        x, y = _xy(p)
        col = self.size_px[0] / 2.0 + (x - cx) * self.pixels_per_m
        row = self.size_px[1] / 2.0 - (y - cy) * self.pixels_per_m
        col = min(max(col, -_MAX_PX), _MAX_PX)
        row = min(max(row, -_MAX_PX), _MAX_PX)
        return round(col), round(row)

    # -- pygame set-up -----------------------------------------------------------------------------
    def _pygame(self) -> Any:
        if self._pg is None:
            os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
            if (
                self.mode == "human"
                and sys.platform.startswith("linux")
                and not os.environ.get("DISPLAY")
                and not os.environ.get("WAYLAND_DISPLAY")
            ):
                os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
            try:
                import pygame
            except ImportError as exc:  # pragma: no cover - depends on the environment
                raise ImportError(
                    "petswarm rendering needs pygame; install it with `pip install pygame-ce`"
                ) from exc
            self._pg = pygame
            try:
                pygame.font.init()
            except (pygame.error, NotImplementedError):  # pragma: no cover - draw without text
                self._fonts_unavailable = True
        return self._pg

    def _font(self, size: int) -> Any:
        pg = self._pygame()
        if self._fonts_unavailable:  # pragma: no cover
            return None
        if size not in self._fonts:
            try:
                self._fonts[size] = pg.font.Font(None, size)
            except (pg.error, NotImplementedError, OSError):  # pragma: no cover - skip text
                self._fonts[size] = None
        return self._fonts[size]

    def _target(self) -> Any:
        pg = self._pygame()
        if self.mode == "human":
            if self._window is None:
                pg.display.init()
                self._window = pg.display.set_mode(self.size_px)
                pg.display.set_caption("petswarm")
                self._clock = pg.time.Clock()
            return self._window
        if self._surface is None:
            self._surface = pg.Surface(self.size_px)
        return self._surface

    # -- public API --------------------------------------------------------------------------------
    def render(self, scene: Scene) -> np.ndarray | None:
        """Draw ``scene``; return an ``(H, W, 3)`` uint8 array in rgb_array mode, else ``None``."""
        if self.mode == "human":
            if self.window_closed:
                return None
            pg = self._pygame()
            surf = self._target()
            for event in pg.event.get():
                if event.type == pg.QUIT:
                    self.close()
                    self.window_closed = True
                    return None
            self._draw(surf, scene)
            pg.display.flip()
            self._clock.tick(self.fps)
            return None
        surf = self._target()
        self._draw(surf, scene)
        arr = self._pg.surfarray.array3d(surf)  # (W, H, 3)
        return np.ascontiguousarray(arr.transpose(1, 0, 2), dtype=np.uint8)

    def close(self) -> None:
        """Close the window (human mode) and drop cached surfaces. Safe to call twice."""
        if self._window is not None and self._pg is not None:
            self._pg.display.quit()
        self._window = None
        self._clock = None
        self._surface = None
        self._fonts = {}

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- drawing -----------------------------------------------------------------------------------
    def _draw(self, surf: Any, scene: Scene) -> None:
        pg = self._pygame()
        self._center = self.camera_center(scene)
        ppm = self.pixels_per_m
        surf.fill(BACKGROUND)
        self._draw_grid(surf)

        for center, size in scene.boxes:
            (bx, by), (sx, sy) = _xy(center), _xy(size)
            if not _finite(bx, by, sx, sy):
                continue
            left, top = self.world_to_px((bx - abs(sx) / 2.0, by + abs(sy) / 2.0))
            rect = pg.Rect(left, top, max(1, round(abs(sx) * ppm)), max(1, round(abs(sy) * ppm)))
            pg.draw.rect(surf, BOX_FILL, rect)
            pg.draw.rect(surf, BOX_EDGE, rect, width=2)

        wall_w = max(3, round(0.06 * ppm))
        for a, b in scene.walls:
            if not _finite(*_xy(a), *_xy(b)):
                continue
            pg.draw.line(surf, WALL, self.world_to_px(a), self.world_to_px(b), wall_w)

        for a, b in scene.links:
            if not _finite(*_xy(a), *_xy(b)):
                continue
            pg.draw.aaline(surf, LINK, self.world_to_px(a), self.world_to_px(b))

        # waiting / other robots first, the swarm on top, the master last
        order = {"waiting": 0, "other": 1, "slave": 2, "master": 3}
        for robot in sorted(scene.robots, key=lambda rv: order.get(rv.role, 0)):
            self._draw_robot(surf, robot)

        # reference crosses on top of the robots, so the tracking error stays visible
        arm = 5
        for ref in scene.references_m:
            if not _finite(*_xy(ref)):
                continue
            c, r = self.world_to_px(ref)
            pg.draw.line(surf, REFERENCE, (c - arm, r - arm), (c + arm, r + arm), 2)
            pg.draw.line(surf, REFERENCE, (c - arm, r + arm), (c + arm, r - arm), 2)

        for position, heading in scene.other_users:
            self._draw_user(surf, position, heading, scene.user_radius_m)
        self._draw_user(surf, scene.user_position_m, scene.user_heading_rad, scene.user_radius_m)
        self._draw_hud(surf, scene)

    def _draw_grid(self, surf: Any) -> None:
        pg = self._pygame()
        w, h = self.size_px
        cx, cy = self._center
        half_w, half_h = self.view_size_m[0] / 2.0, self.view_size_m[1] / 2.0
        for gx in range(math.floor(cx - half_w), math.ceil(cx + half_w) + 1):
            col = self.world_to_px((gx, cy))[0]
            pg.draw.line(surf, GRID_MAJOR if gx % 5 == 0 else GRID_MINOR, (col, 0), (col, h - 1))
        for gy in range(math.floor(cy - half_h), math.ceil(cy + half_h) + 1):
            row = self.world_to_px((cx, gy))[1]
            pg.draw.line(surf, GRID_MAJOR if gy % 5 == 0 else GRID_MINOR, (0, row), (w - 1, row))

    def _draw_robot(self, surf: Any, robot: RobotView) -> None:
        pg = self._pygame()
        x, y = _xy(robot.position_m)
        th = float(robot.heading_rad)
        if not _finite(x, y):
            return
        try:
            colour = ROLE_COLOURS[robot.role]
        except KeyError:
            raise ValueError(f"RobotView.role must be one of {ROLES}, got {robot.role!r}") from None
        c, r = self.world_to_px((x, y))
        rad = max(3, round(float(robot.radius_m) * self.pixels_per_m))
        pg.draw.circle(surf, colour, (c, r), rad)
        pg.draw.circle(surf, OUTLINE, (c, r), rad, width=1)
        if robot.role == "master":
            pg.draw.circle(surf, colour, (c, r), rad + 5, width=2)
        if math.isfinite(th):
            tip = (c + round(rad * math.cos(th)), r - round(rad * math.sin(th)))
            pg.draw.line(surf, HEADING, (c, r), tip, max(2, rad // 5))
        if robot.label:
            font = self._font(18)
            if font is not None:
                img = font.render(str(robot.label), True, LABEL)
                off = rad + (6 if robot.role == "master" else 2)
                surf.blit(img, (c + off, r - off - img.get_height() // 2))
        if robot.kind:
            font = self._font(14)
            if font is not None:
                img = font.render(str(robot.kind), True, LABEL)
                surf.blit(img, (c + rad + 2, r + 2))
        if robot.faults:
            self._draw_faults(surf, robot.faults, c, r, rad)

    def _draw_faults(self, surf: Any, faults: tuple[str, ...], c: int, r: int, rad: int) -> None:
        """A robot's fault state: a red cross over a robot that is off (dead, battery empty), a red
        rim for a broken part, and the faults' short names below it."""
        pg = self._pygame()
        if {"dead", "battery"} & set(faults):
            d = round(rad * 0.75)
            pg.draw.line(surf, FAULT_MARK, (c - d, r - d), (c + d, r + d), 3)
            pg.draw.line(surf, FAULT_MARK, (c - d, r + d), (c + d, r - d), 3)
        else:
            pg.draw.circle(surf, FAULT_MARK, (c, r), rad + 2, width=2)
        font = self._font(14)
        if font is not None:
            img = font.render(" ".join(FAULT_SHORT.get(k, k) for k in sorted(faults)), True, FAULT_MARK)
            surf.blit(img, (c - img.get_width() // 2, r + rad + 2))

    def _draw_user(self, surf: Any, position: Point, heading: float, radius_m: float) -> None:
        pg = self._pygame()
        x, y = _xy(position)
        if not _finite(x, y):
            return
        th = float(heading)
        c, r = self.world_to_px((x, y))
        rad = max(4, round(float(radius_m) * self.pixels_per_m))
        if math.isfinite(th):  # a pointed "nose" in the walking direction
            ux, uy = math.cos(th), -math.sin(th)
            nx, ny = -uy, ux
            tip = (c + 1.7 * rad * ux, r + 1.7 * rad * uy)
            left = (c + 0.7 * rad * ux + 0.6 * rad * nx, r + 0.7 * rad * uy + 0.6 * rad * ny)
            right = (c + 0.7 * rad * ux - 0.6 * rad * nx, r + 0.7 * rad * uy - 0.6 * rad * ny)
            pg.draw.polygon(surf, USER_FILL, [tip, left, right])
            pg.draw.polygon(surf, USER_EDGE, [tip, left, right], width=1)
        pg.draw.circle(surf, USER_FILL, (c, r), rad)
        pg.draw.circle(surf, USER_EDGE, (c, r), rad, width=2)
        if math.isfinite(th):
            tick = (c + round(rad * math.cos(th)), r - round(rad * math.sin(th)))
            pg.draw.line(surf, USER_EDGE, (c, r), tick, 3)

    def _draw_hud(self, surf: Any, scene: Scene) -> None:
        pg = self._pygame()
        font = self._font(20)
        if font is None:  # pragma: no cover
            return
        lines = [f"t = {float(scene.time_s):.2f} s"] + [str(t) for t in scene.text]
        imgs = [font.render(line, True, HUD_TEXT) for line in lines]
        pad, gap = 6, 2
        width = max(img.get_width() for img in imgs) + 2 * pad
        height = sum(img.get_height() + gap for img in imgs) - gap + 2 * pad
        panel = pg.Surface((width, height), pg.SRCALPHA)
        panel.fill((255, 255, 255, 200))
        surf.blit(panel, (4, 4))
        yy = 4 + pad
        for img in imgs:
            surf.blit(img, (4 + pad, yy))
            yy += img.get_height() + gap

        # scale bar: 1 m, bottom-left
        h = self.size_px[1]
        x0, y0 = 12, h - 14
        x1 = x0 + round(self.pixels_per_m)
        pg.draw.line(surf, HUD_TEXT, (x0, y0), (x1, y0), 2)
        pg.draw.line(surf, HUD_TEXT, (x0, y0 - 4), (x0, y0 + 4), 2)
        pg.draw.line(surf, HUD_TEXT, (x1, y0 - 4), (x1, y0 + 4), 2)
        small = self._font(18)
        if small is not None:
            img = small.render("1 m", True, HUD_TEXT)
            surf.blit(img, (x1 + 6, y0 - img.get_height() // 2))


class GifWriter:
    """Collects RGB frames and writes them as an animated GIF on :meth:`close`.

    The GIF is written with :func:`petswarm_env.files.write_atomic` (a temporary file in the
    target directory moved into place), so readers never see a half-written file. Each frame is reduced to a
    256-colour palette image as it arrives (one byte a pixel: about 0.5 MB per 720x720 frame) and
    kept until :meth:`close`. Closing with no frames writes nothing. Note that the GIF encoder
    (Pillow) merges consecutive identical frames into one longer frame.
    """

    def __init__(self, path: str | os.PathLike[str], fps: float) -> None:
        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        self.path = os.fspath(path)
        self.fps = float(fps)
        self._frames: list[Any] = []  # PIL palette images
        self._shape: tuple[int, ...] | None = None
        self._closed = False

    def __len__(self) -> int:
        return len(self._frames)

    def append(self, frame: np.ndarray) -> None:
        if self._closed:
            raise RuntimeError(f"GifWriter for {self.path!r} is already closed")
        arr = np.asarray(frame)
        if arr.ndim != 3 or arr.shape[2] != 3:
            raise ValueError(f"frame must be an (H, W, 3) RGB array, got shape {arr.shape}")
        if self._shape is not None and arr.shape != self._shape:
            raise ValueError(f"all frames must have the same shape; first was {self._shape}, got {arr.shape}")
        if arr.dtype != np.uint8:
            arr = np.clip(arr, 0, 255).astype(np.uint8)
        from PIL import Image

        self._shape = arr.shape
        self._frames.append(Image.fromarray(np.ascontiguousarray(arr)).quantize(256, method=Image.Quantize.FASTOCTREE))

    def close(self) -> str | None:
        """Write the GIF (atomically); return its path, or ``None`` if there were no frames."""
        if self._closed:
            return None
        self._closed = True
        frames, self._frames = self._frames, []
        if not frames:
            return None

        duration_ms = 1000.0 / self.fps
        write_atomic(self.path, lambda tmp: frames[0].save(
            tmp, format="GIF", save_all=True, append_images=frames[1:], duration=duration_ms, loop=0))
        return self.path

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
