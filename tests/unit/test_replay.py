"""The replay format's codings and the report's choice of replays (evaluation/replay.py, replay_viewer.py)."""

import json
from pathlib import Path
from types import SimpleNamespace

import pytest

from petswarm.evaluation.replay import delta, load_replay, replay_name, undelta
from petswarm.evaluation.replay_viewer import choose, embed, parse_spec


def test_delta_coding_round_trips_and_keeps_nulls():
    values = [None, 5, 7, None, 2, 2, -3]
    assert delta(values) == [None, 5, 2, None, -5, 0, -5]
    assert undelta(delta(values)) == values


def test_replay_names_are_safe_file_names():
    assert replay_name("scripted+robot_2=learned", "zigzag", 3) == "scripted-robot_2-learned_zigzag_seed3.replay.json"


def test_replays_spec():
    assert parse_spec("first") == "first" and parse_spec(" all ") == "all" and parse_spec("none") == "none"
    assert parse_spec("zigzag:0,u_turn:12") == [("zigzag", 0), ("u_turn", 12)]
    for bad in ("zigzag", "zigzag:x", ":3"):
        with pytest.raises(ValueError, match="--replays"):
            parse_spec(bad)


def _result(label, eps):
    return SimpleNamespace(label=label, dir=Path("/r"), episodes=eps, scenario_of=lambda ep: ep["scenario"])


def test_choose_pairs_the_results_episodes_by_scenario_and_seed():
    a = _result("scripted", [{"scenario": "zigzag", "seed": s, "replay": f"a{s}.json"} for s in (0, 1)] +
                [{"scenario": "u_turn", "seed": 0}])  # no replay recorded
    b = _result("learned", [{"scenario": "zigzag", "seed": 1, "replay": "/abs/b1.json"}])
    first = choose([a, b], "first")
    assert first == [(("zigzag", 0), [("scripted", Path("/r/a0.json"))])]
    assert choose([a, b], "zigzag:1") == [(("zigzag", 1), [("scripted", Path("/r/a1.json")), ("learned", Path("/abs/b1.json"))])]
    assert len(choose([a, b], "all")) == 2 and choose([a, b], "none") == []
    with pytest.raises(ValueError, match="u_turn:0: no replay recorded"):
        choose([a, b], "u_turn:0")


def test_embedding_is_deterministic(tmp_path):
    assert embed({"a": [1, 2]}) == embed({"a": [1, 2]})


def test_a_foreign_file_is_refused_with_its_name(tmp_path):
    p = tmp_path / "x.replay.json"
    p.write_text(json.dumps({"format": "other"}))
    with pytest.raises(ValueError, match="x.replay.json: not a replay file"):
        load_replay(p)
    p.write_text("{")
    with pytest.raises(ValueError, match="not a replay file"):
        load_replay(p)
    with pytest.raises(ValueError, match="replay file not found"):
        load_replay(tmp_path / "missing.json")
