"""`petswarm eval --replay-dir` and the report's replays: what a replay file holds, and that the page embeds it."""

import json
import re

import pytest

from petswarm.cli.main import main
from petswarm.evaluation.replay import load_replay, undelta


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory):
    d = tmp_path_factory.mktemp("replay")
    out = d / "scripted.json"
    assert main(["eval", "--policy", "scripted", "--scenarios", "zigzag", "--episodes", "1", "--set", "max_cycles=50",
                 "--set", "radio.loss_prob=0.05", "--set", "swarm.spawn=at_slots", "--replay-dir", str(d / "rp"), "--json", str(out)]) == 0
    return d, json.loads(out.read_text())


def test_a_replay_holds_the_experimenters_view_of_every_step(evaluated):
    d, result = evaluated
    ep = result["episodes"][0]
    assert ep["replay"] == "rp/scripted_zigzag_seed0.replay.json"
    data = load_replay(d / ep["replay"])
    assert data["frames"] == ep["steps"] + 1 == 51
    assert {r["type"] for r in data["robots"]} == {"petbot"}
    roles = {r["id"]: r["role"][-1][1] for r in data["robots"]}
    assert roles[0] == "master" and sorted(roles.values()).count("slave") == 4
    assert data["robots"][1]["state"][-1][1] == "slave" and data["robots"][0]["state"][-1][1] == "master"
    for r in data["robots"]:
        for k in ("x", "y", "th", "ref_x", "ref_y"):
            assert len(r[k]) == data["frames"]
    xs = undelta(data["robots"][0]["x"])
    assert abs(xs[-1] - xs[0]) > 500  # the master walked with the user (mm)
    assert undelta(data["robots"][0]["ref_x"]) == [None] * 51 and None not in undelta(data["robots"][2]["ref_x"])
    errors = undelta(data["error"])
    assert errors[0] is None and len(errors[1:]) == len(ep["error_trace"])
    assert all(abs(mm - e * 1000) <= 1 for mm, e in zip(errors[1:], ep["error_trace"]))  # the trace is rounded to 0.1 mm
    assert [c[1] for c in data["users"][0]["commands"]] == ["mode:following", "organize"]
    assert data["users"][0]["activity"][0] == [0, "stop"] and data["users"][0]["state"][-1][1] == "following"
    assert {w for r in data["robots"] for _, w in r["arbiter"]} <= {"", "policy", "user", "safety"}
    assert data["holder"] and all(len(h) <= 1 for _, h in data["holder"])
    assert data["links"][-1][1] and all(len(p) == 2 for p in data["links"][-1][1])
    # the radio strip's counts from the first step on are the summary's frames
    radio = data["radio"]
    counts = {o: sum(sum(row[1:]) for row in radio[o]) for o in ("sent", "lost", "collided")}
    assert counts == ep["frames"] and counts["lost"] > 0
    assert sum(radio["sent"][radio["kinds"].index("scan")]) == sum(radio["sent"][radio["kinds"].index("scan")][:1]) > 0


def test_the_report_embeds_the_replay_as_one_self_contained_page(evaluated):
    d, _ = evaluated
    page = d / "report.html"
    assert main(["report", str(d / "scripted.json"), "--out", str(page)]) == 0
    html = page.read_text()
    assert len(re.findall(r"class=\"rp-data\">[A-Za-z0-9+/]", html)) == 1 and "Episode replays" in html and "petswarmReplays" in html
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", html)  # nothing fetched at view time
    assert main(["report", str(d / "scripted.json"), "--out", str(page), "--replays", "none"]) == 0
    assert not re.search(r"class=\"rp-data\">[A-Za-z0-9+/]", page.read_text())
    assert main(["report", str(d / "scripted.json"), "--out", str(page), "--replays", "u_turn:0"]) == 2
