"""Tests for petswarm_env.render: the scene renderer and the GIF writer (headless, fast)."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import imageio.v3 as iio
import numpy as np
import pytest

from petswarm_env.render import (
    BACKGROUND,
    ROLE_COLOURS,
    USER_FILL,
    GifWriter,
    Renderer,
    RobotView,
    Scene,
)

SIZE = (320, 240)  # small and non-square, so a transposed image would be caught
PPM = 40.0


def wedge_scene(origin=(0.0, 0.0), t=1.0, heading=0.0) -> Scene:
    """User at ``origin``, master 2 m ahead, four slaves in a wedge behind the master."""
    ox, oy = origin
    c, s = math.cos(heading), math.sin(heading)

    def at(x, y):
        return (ox + c * x - s * y, oy + s * x + c * y)

    master = at(2.0, 0.0)
    slaves = [at(1.0, 1.0), at(1.0, -1.0), at(0.0, 2.0), at(0.0, -2.0)]
    robots = [RobotView(master, heading, 0.2, "master", "0")]
    robots += [RobotView(p, heading, 0.2, "slave", str(i + 1)) for i, p in enumerate(slaves)]
    robots.append(RobotView(at(-1.5, 1.5), 0.0, 0.2, "waiting", "w"))
    return Scene(
        time_s=t,
        user_position_m=at(0.0, 0.0),
        user_heading_rad=heading,
        user_radius_m=0.25,
        robots=robots,
        links=[
            (master, slaves[0]),
            (master, slaves[1]),
            (slaves[0], slaves[2]),
            (slaves[1], slaves[3]),
        ],
        references_m=[(p[0] + 0.1, p[1]) for p in slaves],
        walls=[(at(-2.5, 2.8), at(3.0, 2.8))],
        boxes=[(at(2.5, -2.0), (0.5, 0.4))],
        text=["formation: wedge", "members: 5"],
    )


def colour_mask(img: np.ndarray, colour) -> np.ndarray:
    return np.all(img == np.asarray(colour, dtype=np.uint8), axis=-1)


def test_rgb_array_shape_dtype_and_not_blank():
    r = Renderer(size_px=SIZE, pixels_per_m=PPM)
    img = r.render(wedge_scene())
    r.close()
    assert isinstance(img, np.ndarray)
    assert img.shape == (SIZE[1], SIZE[0], 3)
    assert img.dtype == np.uint8
    assert img.flags["C_CONTIGUOUS"]
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 5
    assert colour_mask(img, BACKGROUND).mean() < 0.99


def test_master_colour_at_projected_position():
    r = Renderer(size_px=SIZE, pixels_per_m=PPM)
    scene = wedge_scene(origin=(0.3, -0.7), heading=0.4)
    scene.text = []  # keep the HUD panel (top-left) off the robots in this small image
    img = r.render(scene)
    master = scene.robots[0]
    col, row = r.world_to_px(master.position_m, r.camera_center(scene))
    assert (col, row) == r.world_to_px(master.position_m)  # last camera is remembered
    assert 0 <= col < SIZE[0] and 0 <= row < SIZE[1]
    # the heading line runs from the centre forward; half a radius behind is body colour
    rad = master.radius_m * PPM
    bc = round(col - 0.5 * rad * math.cos(master.heading_rad))
    br = round(row + 0.5 * rad * math.sin(master.heading_rad))
    assert tuple(img[br, bc]) == ROLE_COLOURS["master"]
    mask = colour_mask(img, ROLE_COLOURS["master"])
    ys, xs = np.nonzero(mask)
    # all master-coloured pixels (body and ring) are near the master, none elsewhere
    assert len(xs) > 50
    assert np.max(np.hypot(xs - col, ys - row)) <= rad + 8
    # slaves are blue, drawn where projected
    for rv in scene.robots[1:5]:
        c, rr = r.world_to_px(rv.position_m)
        window = colour_mask(img[rr - 4 : rr + 5, c - 4 : c + 5], ROLE_COLOURS["slave"])
        assert window.sum() > 20
    r.close()


def test_camera_follows_far_from_origin():
    r = Renderer(size_px=SIZE, pixels_per_m=PPM)
    scene = wedge_scene(origin=(1234.5, -987.0), t=300.0)
    img = r.render(scene)
    assert colour_mask(img, USER_FILL).sum() > 50
    assert colour_mask(img, ROLE_COLOURS["master"]).sum() > 50
    # camera is the mean of the user and the robots
    pts = np.array([scene.user_position_m] + [rv.position_m for rv in scene.robots])
    assert np.allclose(r.camera_center(scene), pts.mean(axis=0))
    r.close()


def test_user_stays_in_view_when_robots_are_far():
    r = Renderer(size_px=SIZE, pixels_per_m=PPM)
    scene = Scene(
        time_s=0.0,
        user_position_m=(0.0, 0.0),
        user_heading_rad=0.0,
        user_radius_m=0.25,
        robots=[RobotView((200.0, 50.0), 0.0, 0.2, "other", "b1")],
    )
    img = r.render(scene)
    col, row = r.world_to_px(scene.user_position_m)
    assert 0 <= col < SIZE[0] and 0 <= row < SIZE[1]
    assert colour_mask(img, USER_FILL).sum() > 50
    r.close()


def test_gif_writer_frames_and_atomic(tmp_path):
    r = Renderer(size_px=SIZE, pixels_per_m=PPM)
    path = tmp_path / "out" / "episode.gif"
    writer = GifWriter(path, fps=10)
    n = 4
    for k in range(n):  # distinct frames (the GIF encoder merges identical consecutive ones)
        writer.append(r.render(wedge_scene(origin=(0.5 * k, 0.0), t=0.1 * k, heading=0.3 * k)))
    assert len(writer) == n
    assert not path.exists()  # nothing is written before close
    assert writer.close() == str(path)
    r.close()
    frames = iio.imread(path, index=None)
    assert frames.shape[0] == n
    assert frames.shape[1:3] == (SIZE[1], SIZE[0])
    assert os.listdir(path.parent) == ["episode.gif"]  # no temp file left behind
    meta = iio.immeta(path, index=0)
    assert meta.get("duration") == pytest.approx(100, abs=1)
    with pytest.raises(RuntimeError):
        writer.append(frames[0][..., :3])


def test_gif_writer_rejects_bad_frames(tmp_path):
    w = GifWriter(tmp_path / "x.gif", fps=5)
    with pytest.raises(ValueError, match="H, W, 3"):
        w.append(np.zeros((10, 10), dtype=np.uint8))
    w.append(np.zeros((10, 12, 3), dtype=np.uint8))
    with pytest.raises(ValueError, match="same shape"):
        w.append(np.zeros((12, 10, 3), dtype=np.uint8))
    w.close()
    assert os.listdir(tmp_path) == ["x.gif"]
    empty = GifWriter(tmp_path / "empty.gif", fps=5)
    assert empty.close() is None
    assert not (tmp_path / "empty.gif").exists()
    with pytest.raises(ValueError, match="fps"):
        GifWriter(tmp_path / "y.gif", fps=0)


def test_human_mode_under_dummy_driver(monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    r = Renderer(size_px=SIZE, pixels_per_m=PPM, fps=1000, mode="human")
    assert r.render(wedge_scene()) is None
    assert r.render(wedge_scene(t=2.0)) is None
    r.close()
    r.close()  # idempotent


def test_clear_errors():
    with pytest.raises(ValueError, match="rgb_array, human"):
        Renderer(mode="ansi")
    with pytest.raises(ValueError, match="pixels_per_m"):
        Renderer(pixels_per_m=0)
    with pytest.raises(ValueError, match="size_px"):
        Renderer(size_px=(0, 10))
    with pytest.raises(ValueError, match="master"):
        RobotView((0.0, 0.0), 0.0, 0.2, "leader", "0")


def test_import_does_not_import_pygame():
    code = "import sys, petswarm_env.render; sys.exit('pygame' in sys.modules)"
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=False
    )
    assert proc.returncode == 0, proc.stderr or "pygame was imported by petswarm_env.render"
