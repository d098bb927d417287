"""The report's replay viewer in a real browser: Debian's headless Chromium over its DevTools protocol.

Skips only where Chromium is not installed (``bash scripts/setup.sh test`` and ``.ci/run`` install it);
where it is installed but does not start, the test fails. The page must load without a console error
or exception; the slider and the keys must move the robots (read back from the viewer's drawn state);
the screenshot goes to the test's folder (``PETSWARM_SCREENSHOT=PATH`` copies it there too).
"""

import os
import shutil

import pytest

from petswarm.cli.main import main
from tests.e2e.browser import Browser, chromium_path

STEPS = 150


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    d = tmp_path_factory.mktemp("browser")
    for policy in ("scripted", "learned"):
        assert main(["eval", "--policy", policy, "--scenarios", "zigzag", "--episodes", "1", "--set", f"max_cycles={STEPS}", "--set", "swarm.spawn=at_slots",
                     "--replay-dir", str(d / "rp"), "--json", str(d / f"{policy}.json")]) == 0
    page = d / "report.html"
    assert main(["report", str(d / "scripted.json"), str(d / "learned.json"), "--out", str(page)]) == 0
    return page


def test_the_replay_plays_in_chromium(report, tmp_path):
    if chromium_path() is None:
        pytest.skip("chromium is not installed here (bash scripts/setup.sh test installs Debian's chromium)")
    with Browser(width=1280, height=900) as b:  # a browser that is there but does not start fails the test
        b.open(report)
        b.wait_for("window.petswarmReplaysReady === true")
        assert b.errors() == []
        panels = b.eval("petswarmReplays.length")
        labels = b.eval("petswarmReplays[0].episodes.map(e => e.data.label)")
        assert panels == 1 and labels == ["scripted", "learned"]
        start = b.eval("petswarmReplays[0].episodes.map(e => e.drawn)")
        assert [d["frame"] for d in start] == [0, 0]
        assert {r["type"] for d in start for r in d["robots"]} == {"petbot"}
        assert [r["role"] for r in start[0]["robots"]] == ["master"] + ["slave"] * 4
        # the slider, moved as a person would (its value, then the input event): both episodes follow
        b.eval("(() => { const s = document.querySelector('.rp-slider'); s.value = 120;"
               " s.dispatchEvent(new Event('input', {bubbles: true})); })()")
        moved = b.eval("petswarmReplays[0].episodes.map(e => e.drawn)")
        assert [d["frame"] for d in moved] == [120, 120]
        for before, after in zip(start, moved):
            for r0, r1 in zip(before["robots"], after["robots"]):
                assert ((r1["x"] - r0["x"]) ** 2 + (r1["y"] - r0["y"]) ** 2) ** 0.5 > 1.0  # every robot moved (m)
            assert after["robots"][1]["ref"] is not None and len(after["links"]) == 4
        # the keys: arrows step, space plays and pauses
        b.eval("document.querySelector('.rp-slider').focus()")
        b.key("ArrowRight", "ArrowRight", 39)
        assert b.eval("petswarmReplays[0].frame") == 121
        b.key("ArrowLeft", "ArrowLeft", 37)
        b.key("ArrowLeft", "ArrowLeft", 37)
        assert b.eval("petswarmReplays[0].frame") == 119
        b.key(" ", "Space", 32)
        assert b.eval("petswarmReplays[0].playing") is True
        b.wait_for("petswarmReplays[0].frame >= 123", timeout_s=10)
        b.key(" ", "Space", 32)
        assert b.eval("petswarmReplays[0].playing") is False
        frame = b.eval("petswarmReplays[0].frame")
        assert b.eval("petswarmReplays[0].episodes.map(e => e.drawn.frame)") == [frame, frame]
        b.eval("petswarmReplays[0].setFrame(100); document.querySelector('div.rp').previousElementSibling.scrollIntoView()")
        shot = tmp_path / "replay.png"
        b.screenshot(shot, full_page=False)
        assert b.errors() == []
    assert shot.stat().st_size > 20_000 and shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    if os.environ.get("PETSWARM_SCREENSHOT"):
        shutil.copyfile(shot, os.environ["PETSWARM_SCREENSHOT"])
