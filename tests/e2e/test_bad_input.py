"""Every input a user can get wrong, through the command line and the loaders:
CLI flags, config values, scenario names, policy files, result JSON for the report, and (with the
training stack) checkpoints and resumes. Each case is one line on stderr naming the problem, exit
status 2, no traceback, and nothing already written is lost (an existing OUT.json, OUT.jsonl or
report untouched; a run folder intact after a refused resume)."""

import base64
import hashlib
import json
import os
import pickle
import re
import shutil
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

from petswarm.baselines.learned import LearnedPolicy, PolicyLoadError, save_policy
from petswarm.baselines.policy import PolicySpec
from petswarm.cli.main import main
from petswarm_env.env import PetSwarmEnv
from petswarm_env.observe import ObservationLayout

OBS_SIZE = ObservationLayout(8).size  # the default layout (8 ultrasonic sensors): one unknown field of its size


def _snapshot(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*")) if p.is_file()}


def _fails(capsys, argv, words, code=2) -> str:
    try:
        got = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse's errors exit from inside parse_args
        got = exc.code
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert got == code, err
    assert "Traceback" not in err and len(lines) == 1, err
    assert lines[0].startswith("petswarm: error:") and words in lines[0], lines[0]
    return lines[0]


@pytest.fixture
def outputs(tmp_path):
    """A folder with the outputs of an earlier run, which a failing command must not touch."""
    (tmp_path / "OUT.json").write_text('{"episodes": [{"seed": 0}], "old": true}\n')
    (tmp_path / "OUT.jsonl").write_text('{"seed": 0}\n')
    (tmp_path / "report.html").write_text("<p>old report</p>")
    (tmp_path / "r.json").write_text("{}")
    (tmp_path / "clips").write_text("a file, not a folder")
    return tmp_path


# -- the command line: flags, config, scenarios, outputs --------------------------------------------
CLI_CASES = [
    (["run", "--episodes", "0"], "--episodes"),
    (["run", "--episodes", "many"], "--episodes"),
    (["run", "--seed", "-1"], "--seed"),
    (["run", "--seed", "1.5"], "--seed"),
    (["run", "--policy", "clever"], "--policy"),
    (["run", "--render", "window"], "--render"),
    (["run", "--bogus"], "unrecognized arguments"),
    (["fly"], "invalid choice"),
    (["eval", "--episodes", "-2"], "--episodes"),
    (["train", "--timesteps", "0"], "--timesteps"),
    (["reproduce", "--only", "banana"], "banana"),
    (["run", "--set", "swarm.num_slaves=true"], "swarm.num_slaves"),
    (["run", "--set", "world.arena_m=[1,1]", "--set", "max_cycles=5"], "world.arena_m"),
    (["run", "--set", "robot.ultrasonic.min_range_m=3"], "robot.ultrasonic.min_range_m"),
    (["run", "--set", "reward.formation=.nan"], "reward.formation"),
    (["run", "--set", "radio.min_be=7"], "radio.max_be"),
    (["run", "--set", "swarm.nm_slaves=2"], "swarm.nm_slaves"),
    (["run", "--set", "noequals"], "KEY=VALUE"),
    (["run", "--set", "user.scenario=moonwalk"], "user.scenario"),
    (["run", "--set", "user.scenario_pool=[zigzag, moonwalk]"], "user.scenario_pool"),
    (["eval", "--scenarios", "zigzag,moonwalk", "--episodes", "1"], "moonwalk"),
    (["eval", "--mix", "robot_2", "--episodes", "1"], "ROBOT=POLICY"),
    (["eval", "--mix", "robot_9=learned", "--episodes", "1", "--set", "max_cycles=5"], "robot_9"),
    (["eval", "--mix", "robot_2=banana", "--episodes", "1", "--set", "max_cycles=5"], "banana"),
    (["run", "--policy", "missing.npz"], "does not exist"),
    (["run", "--video", "clip.mp4"], ".gif"),
    (["run", "--json", "{dir}", "--set", "max_cycles=5"], "is a folder"),
    (["run", "--json", "{dir}/clips/out.json", "--set", "max_cycles=5"], "is a file, not a folder"),
    (["run", "--video", "{dir}/clips/ep.gif", "--set", "max_cycles=5"], "is a file, not a folder"),
    (["eval", "--video-dir", "{dir}/clips", "--episodes", "1", "--set", "max_cycles=5"], "is a file"),
    (["run", "--config", "{dir}/missing.yaml"], "does not exist"),
    (["run", "--config", "{dir}"], "is a folder"),
    (["run", "--config", "{dir}/report.html"], "must hold a mapping"),
    (["train", "--set", "ppo.gamma=2"], "ppo.gamma"),
    (["train", "--set", "env.swarm.num_slaves=true"], "swarm.num_slaves"),
    (["train", "--resume", "--out", "{dir}/no_run"], "no checkpoint"),
    (["eval", "--scenarios", "", "--episodes", "1"], "names no scenario"),
    (["run", "--set", "swarm..num_slaves=2"], "empty part"),
    (["eval", "--scenarios", " , ,", "--episodes", "1"], "names no scenario"),
    (["eval", "--scenarios", "u_turn,straight,u_turn", "--episodes", "1"], "u_turn more than once"),
    (["eval", "--mix", "robot_1=random", "--mix", "robot_1=scripted", "--episodes", "1"], "robot_1 twice"),
]


@pytest.mark.parametrize("argv, words", CLI_CASES, ids=[" ".join(a)[:50] for a, _ in CLI_CASES])
def test_bad_command_line_is_one_line_exit_2_and_loses_nothing(capsys, outputs, argv, words):
    if argv[0] == "train":
        pytest.importorskip("stable_baselines3")
    before = _snapshot(outputs)
    argv = [a.replace("{dir}", str(outputs)) for a in argv]
    if argv[0] in ("run", "eval") and "--json" not in argv:
        argv += ["--json", str(outputs / "OUT.json")]
    _fails(capsys, argv, words)
    assert _snapshot(outputs) == before


# -- policy files ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def spec():
    return PolicySpec.from_env(PetSwarmEnv())


def _good_arrays(size: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    return {"w0": rng.normal(size=(4, size)).astype(np.float32), "b0": np.zeros(4, np.float32),
            "w1": rng.normal(size=(3, 4)).astype(np.float32), "b1": np.zeros(3, np.float32)}


def _write_policy(path: Path, layout, meta=None, raw_meta=None, arrays=None, drop=()):
    save_policy(path, list(zip(*[iter(_good_arrays(layout.size).values())] * 2)), "tanh", layout)
    with np.load(path) as data:
        items = dict(data)
    m = json.loads(items["meta"].tobytes())
    for key, value in (meta or {}).items():
        if value is _DROP:
            m.pop(key)
        else:
            m[key] = value
    items["meta"] = np.frombuffer((raw_meta if raw_meta is not None else json.dumps(m)).encode(), np.uint8)
    items.update(arrays or {})
    for key in drop:
        items.pop(key)
    path.unlink()
    np.savez(path, **items)


def _huge(path: Path, layout) -> None:
    _write_policy(path, layout)
    with np.load(path) as data:
        items = dict(data)
    header = np.lib.format.header_data_from_array_1_0(np.zeros(1, np.float32))
    header["shape"] = (4, 10**11)
    with zipfile.ZipFile(path, "w") as z:
        for name, arr in items.items():
            with z.open(f"{name}.npy", "w") as f:
                if name == "w0":
                    np.lib.format.write_array_header_1_0(f, header)
                    f.write(b"\x00" * 64)
                else:
                    np.lib.format.write_array(f, arr)


class _Evil:
    """Unpickling this creates the file named by PETSWARM_TEST_MARKER: proof that nothing was unpickled."""

    def __reduce__(self):
        return (open, (os.environ["PETSWARM_TEST_MARKER"], "w"))


_DROP = object()
POLICY_CASES = [  # (id, how to damage a good policy file, words)
    ("meta_a_list", dict(raw_meta="[1, 2]"), "field 'meta' must be a JSON object"),
    ("string_weights", dict(arrays={"w0": np.array(["a", "b"])}), "'w0' holds <U1 data"),
    ("no_observation_layout", dict(meta={"observation_layout": _DROP}), "field 'observation_layout' is missing"),
    ("observation_layout_5", dict(meta={"observation_layout": 5}), "field 'observation_layout'"),
    ("num_layers_0", dict(meta={"num_layers": 0}), "field 'num_layers'"),
    ("num_layers_minus_1", dict(meta={"num_layers": -1}), "field 'num_layers'"),
    ("observation_version_999", dict(meta={"observation_version": 999}), "field 'observation_version' is 999"),
    ("observation_version_string", dict(meta={"observation_version": "1"}), "field 'observation_version'"),
    ("observation_version_0", dict(meta={"observation_version": 0}), "field 'observation_version' must be a whole number"),
    ("num_layers_true", dict(meta={"num_layers": True}), "field 'num_layers'"),
    ("num_layers_1000", dict(meta={"num_layers": 1000}), "field 'num_layers'"),
    ("num_layers_3_of_2", dict(meta={"num_layers": 3}), "field 'w2' is missing"),
    ("meta_not_json", dict(raw_meta="{not json"), "field 'meta' is not UTF-8 JSON"),
    ("meta_not_bytes", dict(arrays={"meta": np.zeros(3, np.float64)}), "field 'meta' must be UTF-8 JSON bytes"),
    ("no_meta", dict(drop=("meta",)), "no 'meta' record"),
    ("format_other", dict(meta={"format": "keras"}), "field 'format'"),
    ("format_version_3", dict(meta={"format_version": 3}), "field 'format_version' is 3"),
    ("format_version_2_not_recurrent", dict(meta={"format_version": 2}), "field 'recurrent' must be given exactly when"),
    ("env_name_other", dict(meta={"env_name": "simple_spread_v3"}), "simple_spread_v3"),
    ("activation_sigmoid", dict(meta={"activation": "sigmoid"}), "field 'activation'"),
    ("layout_entry_bad", dict(meta={"observation_layout": [["link0.present", 0]]}), "entry 0"),
    ("layout_entry_not_pair", dict(meta={"observation_layout": ["link0.present"]}), "entry 0"),
    ("layout_twice", dict(meta={"observation_layout": [["self.member", 1], ["self.member", 1]]}), "names a field twice"),
    ("layout_unknown_field", dict(meta={"observation_layout": [["self.compass", OBS_SIZE]]}), "self.compass"),
    ("info_a_list", dict(meta={"info": [1]}), "field 'info'"),
    ("residual_of_other", dict(meta={"residual_of": "random"}), "field 'residual_of'"),
    ("residual_scale_2", dict(meta={"residual_of": "scripted", "residual_scale": 2}), "field 'residual_scale'"),
    ("missing_b1", dict(drop=("b1",)), "field 'b1' is missing"),
    ("int_weights", dict(arrays={"w1": np.ones((3, 4), np.int32)}), "floating-point"),
    ("w0_1d", dict(arrays={"w0": np.zeros(4, np.float32)}), "field 'w0' has shape (4,)"),
    ("bias_wrong", dict(arrays={"b0": np.zeros(5, np.float32)}), "does not chain"),
    ("layers_do_not_chain", dict(arrays={"w1": np.zeros((3, 5), np.float32)}), "field 'w1'"),
    ("output_4", dict(arrays={"w1": np.zeros((4, 4), np.float32), "b1": np.zeros(4, np.float32)}), "outputs 4 values"),
    ("inputs_wrong", dict(arrays={"w0": np.zeros((4, 10), np.float32)}), "takes 10 inputs"),
    ("nan_weights", dict(arrays={"w1": np.full((3, 4), np.nan, np.float32)}), "NaN or infinite"),
    ("inf_bias", dict(arrays={"b0": np.array([np.inf, 0, 0, 0], np.float32)}), "NaN or infinite"),
    ("complex_weights", dict(arrays={"w1": np.zeros((3, 4), np.complex64)}), "not numbers"),
    ("pickled_object_array", dict(arrays={"w0": np.array([_Evil()], dtype=object)}), "Python objects"),
]
FILE_CASES = [  # (id, how to make the file, words)
    ("truncated", lambda p, lay: (_write_policy(p, lay), p.write_bytes(p.read_bytes()[:300])), "cannot be read"),
    ("not_a_zip", lambda p, lay: p.write_text("hello"), "not a zip"),
    ("empty_file", lambda p, lay: p.write_bytes(b""), "not a zip"),
    ("zip_of_text", lambda p, lay: _zip_of_text(p), "not an array"),
    ("huge_declared", _huge, "declares shape (4, 100000000000)"),
    ("a_folder", lambda p, lay: p.mkdir(), "it is a folder"),
]


def _zip_of_text(path: Path) -> None:
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("notes.txt", "hi")


def _make_bad_policy(tmp_path, layout, case) -> Path:
    path = tmp_path / "bad_policy.npz"
    kind, how = case
    if kind == "file":
        how(path, layout)
    else:
        _write_policy(path, layout, **how)
    return path


ALL_POLICY = [(i, ("meta", h), w) for i, h, w in POLICY_CASES] + [(i, ("file", h), w) for i, h, w in FILE_CASES]


@pytest.mark.parametrize("case, words", [(c, w) for _, c, w in ALL_POLICY], ids=[i for i, _, _ in ALL_POLICY])
def test_malformed_policy_file_is_refused_naming_file_and_field(tmp_path, spec, monkeypatch, case, words):
    monkeypatch.setenv("PETSWARM_TEST_MARKER", str(tmp_path / "UNPICKLED"))
    path = _make_bad_policy(tmp_path, spec.layout, case)
    with pytest.raises(PolicyLoadError) as info:
        LearnedPolicy.load(path, spec)
    message = str(info.value)
    assert "bad_policy.npz" in message and words in message and "\n" not in message
    assert not (tmp_path / "UNPICKLED").exists()


CLI_POLICY = [c for c in ALL_POLICY if c[0] in ("meta_a_list", "string_weights", "no_observation_layout", "observation_layout_5",
                                                 "num_layers_0", "num_layers_minus_1", "observation_version_999", "truncated",
                                                 "pickled_object_array", "huge_declared")]


@pytest.mark.parametrize("case, words", [(c, w) for _, c, w in CLI_POLICY], ids=[i for i, _, _ in CLI_POLICY])
def test_malformed_policy_file_through_the_cli(capsys, outputs, spec, monkeypatch, case, words):
    monkeypatch.setenv("PETSWARM_TEST_MARKER", str(outputs / "UNPICKLED"))
    path = _make_bad_policy(outputs, spec.layout, case)
    before = _snapshot(outputs)
    _fails(capsys, ["run", "--policy", path, "--set", "max_cycles=5", "--json", outputs / "OUT.json"], words)
    assert _snapshot(outputs) == before


def test_a_policy_of_an_older_observation_version_loads_with_a_warning(tmp_path, spec, monkeypatch, capsys):
    import petswarm.baselines.learned as learned

    v = learned.OBS_VERSION
    _write_policy(tmp_path / "old.npz", spec.layout)  # today's version, its fields all in today's layout
    monkeypatch.setattr(learned, "OBS_VERSION", v + 1)
    with pytest.warns(learned.PolicyVersionWarning, match=f"observation version {v}, this environment's is {v + 1}"):
        LearnedPolicy.load(tmp_path / "old.npz", spec)
    assert main(["run", "--policy", str(tmp_path / "old.npz"), "--set", "max_cycles=3", "--quiet"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("petswarm: warning: policy file")


def test_a_checkpoint_given_as_a_policy_says_what_it_is(tmp_path, spec):
    np.savez(tmp_path / "latest.npz", state=np.frombuffer(b'{"format": "petswarm-checkpoint"}', np.uint8))
    with pytest.raises(PolicyLoadError, match="training checkpoint"):
        LearnedPolicy.load(tmp_path / "latest.npz", spec)


# -- result JSON for petswarm report ---------------------------------------------------------------
REPORT_CASES = [
    ("{not json", "not valid JSON"), ("", "empty"), ("[1, 2]", "expected a JSON object"), ('"text"', "expected a JSON object"),
    ('{"episodes": 3}', "'episodes' must be a list"), ('{"episodes": [1]}', "episode 0 must be a JSON object"),
    ('{"timesteps": 2048, "evaluations": []}', "has no 'episodes' list"), (b"\xff\xfe\x00", "not UTF-8"),
    ("[" * 100000, "not valid JSON"), ('{"episodes": [], "seed": ' + "9" * 5000 + "}", "not a result file"),
]


@pytest.mark.parametrize("content, words", REPORT_CASES, ids=[f"report{i}" for i in range(len(REPORT_CASES))])
def test_bad_result_file_for_the_report(capsys, outputs, content, words):
    bad = outputs / "bad_result.json"
    bad.write_bytes(content if isinstance(content, bytes) else content.encode())
    before = _snapshot(outputs)
    line = _fails(capsys, ["report", bad, "--out", outputs / "report.html"], words)
    assert "bad_result.json" in line and _snapshot(outputs) == before


@pytest.mark.parametrize("argv, words", [
    (["report", "{dir}/none.json", "--out", "{dir}/report.html"], "not found"),
    (["report", "{dir}", "--out", "{dir}/report.html"], "is a directory"),
    (["report", "{dir}/OUT.json", "--out", "{dir}"], "is a folder"),
    (["report", "{dir}/OUT.json", "--out", "{dir}/clips/report.html"], "is a file, not a folder"),
    (["report", "{dir}/OUT.json", "{dir}/./OUT.json", "--out", "{dir}/report.html"], "is given twice"),
])
def test_bad_report_paths(capsys, outputs, argv, words):
    before = _snapshot(outputs)
    _fails(capsys, [a.replace("{dir}", str(outputs)) for a in argv], words)
    assert _snapshot(outputs) == before


# -- a killed run keeps its finished episodes ------------------------------------------------------
def _start_run(tmp_path, *extra):
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    return subprocess.Popen([sys.executable, "-m", "petswarm.cli.main", "run", "--episodes", "40", "--set", "max_cycles=40", "--quiet",
                             "--json", str(tmp_path / "OUT.json"), *extra], stderr=subprocess.PIPE, text=True, env=env)


def _wait_for_lines(path: Path, n: int, proc) -> None:
    deadline = time.time() + 240
    while time.time() < deadline and proc.poll() is None:
        if path.exists() and len(path.read_text().splitlines()) >= n:
            return
        time.sleep(0.2)
    pytest.fail(f"the run did not write {n} episodes to {path}")


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGKILL, -9), (signal.SIGINT, 130)])
def test_a_killed_run_keeps_its_finished_episodes(tmp_path, sig, code):
    (tmp_path / "OUT.json").write_text('{"old": true}')
    proc = _start_run(tmp_path)
    _wait_for_lines(tmp_path / "OUT.jsonl", 2, proc)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == code, err
    if sig != signal.SIGKILL:
        assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    episodes = [json.loads(line) for line in (tmp_path / "OUT.jsonl").read_text().splitlines()]
    assert len(episodes) >= 2 and [e["seed"] for e in episodes] == list(range(len(episodes)))
    assert all("formation_rmse_m" in e for e in episodes)
    assert (tmp_path / "OUT.json").read_text() == '{"old": true}'  # the final JSON comes only at the end
    assert sorted(p.name for p in tmp_path.iterdir()) == ["OUT.json", "OUT.jsonl"]  # no temp file


def test_the_json_lines_hold_the_episodes_of_the_final_json(tmp_path, capsys):
    assert main(["eval", "--scenarios", "straight,zigzag", "--episodes", "2", "--set", "max_cycles=10",
                 "--json", str(tmp_path / "e.json")]) == 0
    final = json.loads((tmp_path / "e.json").read_text())
    lines = [json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()]
    assert lines == json.loads(json.dumps(final["episodes"]))


# -- checkpoints and resumes (the training stack) --------------------------------------------------
TINY = ["--set", "num_envs=1", "--set", "num_cpus=0", "--set", "ppo.n_steps=32", "--set", "ppo.batch_size=64",
        "--set", "ppo.n_epochs=1", "--set", "ppo.net_arch=[8]", "--set", "eval.every_steps=100000", "--set", "eval.episodes=1",
        "--set", "eval.max_cycles=10", "--set", "checkpoint.every_steps=100000", "--set", "env.max_cycles=20",
        "--set", "pretrain.samples=0"]


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("supersuit")
    out = tmp_path_factory.mktemp("runs") / "tiny"
    assert main(["train", "--out", str(out), "--timesteps", "128", "--no-progress", *TINY]) == 0
    return out


@pytest.fixture
def run(finished_run, tmp_path, monkeypatch):
    """A copy of the finished run, and the marker file a crafted pickle would create."""
    monkeypatch.setenv("PETSWARM_TEST_MARKER", str(tmp_path / "UNPICKLED"))
    copy = tmp_path / "run"
    shutil.copytree(finished_run, copy)
    return copy


def _sb3_zip(path: Path) -> None:
    """An SB3 checkpoint whose 'data' holds a ':serialized:' pickle that creates a file."""
    data = {"policy_class": {":type:": "<class 'abc.ABCMeta'>", ":serialized:": base64.b64encode(pickle.dumps(_Evil())).decode()}}
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("data", json.dumps(data))
        z.writestr("policy.pth", b"")
        z.writestr("_stable_baselines3_version", "2.9.2")


def test_the_crafted_pickles_would_run_code(tmp_path, monkeypatch):
    monkeypatch.setenv("PETSWARM_TEST_MARKER", str(tmp_path / "UNPICKLED"))
    _sb3_zip(tmp_path / "latest.zip")
    payload = json.loads(zipfile.ZipFile(tmp_path / "latest.zip").read("data"))["policy_class"][":serialized:"]
    pickle.loads(base64.b64decode(payload))  # what SB3's PPO.load would do
    assert (tmp_path / "UNPICKLED").exists()


def _edit_checkpoint(run: Path, change) -> None:
    path = run / "checkpoints" / "latest.npz"
    with np.load(path) as data:
        items = dict(data)
    change(items)
    path.unlink()
    np.savez(path, **items)


def _state(items, **over):
    state = json.loads(items["state"].tobytes())
    state.update(over)
    items["state"] = np.frombuffer(json.dumps(state).encode(), np.uint8)


def _first_weight(items):
    return next(k for k in items if k.startswith("policy:") and k.endswith("weight"))


RESUME_CASES = [
    ("pickle_in_checkpoint", lambda r: _edit_checkpoint(r, lambda a: a.update(evil=np.array([_Evil()], dtype=object))), [],
     "Python objects"),
    ("old_sb3_zip", lambda r: ((r / "checkpoints" / "latest.npz").unlink(), _sb3_zip(r / "checkpoints" / "latest.zip")), [],
     "older petswarm in Stable-Baselines3's pickled format"),
    ("truncated", lambda r: (r / "checkpoints" / "latest.npz").write_bytes((r / "checkpoints" / "latest.npz").read_bytes()[:500]),
     [], "cannot be read"),
    ("not_a_zip", lambda r: (r / "checkpoints" / "latest.npz").write_text("garbage"), [], "not a zip"),
    ("no_state", lambda r: _edit_checkpoint(r, lambda a: a.pop("state")), [], "'state' record"),
    ("foreign_format", lambda r: _edit_checkpoint(r, lambda a: _state(a, format="sb3")), [], "field 'format'"),
    ("format_version_9", lambda r: _edit_checkpoint(r, lambda a: _state(a, format_version=9)), [], "format version 9"),
    ("timesteps_negative", lambda r: _edit_checkpoint(r, lambda a: _state(a, num_timesteps=-5)), [], "num_timesteps"),
    ("wrong_shape", lambda r: _edit_checkpoint(r, lambda a: a.update({_first_weight(a): np.zeros((2, 2), np.float32)})), [],
     "the run's network has"),
    ("missing_tensor", lambda r: _edit_checkpoint(r, lambda a: a.pop(_first_weight(a))), [], "missing"),
    ("nan_weights", lambda r: _edit_checkpoint(r, lambda a: a[_first_weight(a)].fill(np.nan)), [], "NaN"),
    ("no_train_config", lambda r: (r / "train_config.yaml").unlink(), [], "no train_config.yaml"),
    ("bad_train_log", lambda r: (r / "train_log.json").write_text("{oops"), [], "train_log.json"),
    ("env_changed", lambda r: (r / "env_config.yaml").write_text((r / "env_config.yaml").read_text().replace(
        "loss_prob: 0.0", "loss_prob: 0.3")), [], "radio.loss_prob"),
    ("set_learning_rate", None, ["--set", "ppo.learning_rate=0.5"], "ppo.learning_rate"),
    ("set_env_key", None, ["--set", "env.max_cycles=99"], "env.max_cycles"),
    ("set_seed", None, ["--set", "seed=5"], "cannot resume"),
    ("config_file_changes_net", lambda r: (r.parent / "t.yaml").write_text("ppo:\n  net_arch: [64]\n"),
     ["--config", "{parent}/t.yaml"], "ppo.net_arch"),
    ("set_bool_timesteps", None, ["--set", "timesteps=true"], "timesteps"),
    # a damaged train_log.json or checkpoint state: refused field by field before anything is written
    ("log_evaluation_not_object", lambda r: _edit_log(r, lambda d: d.__setitem__("evaluations", [1])), [], "'evaluations.0'"),
    ("log_no_reference", lambda r: _edit_log(r, lambda d: d.pop("scripted_eval_rmse_m")), [], "'scripted_eval_rmse_m' is missing"),
    ("log_reference_text", lambda r: _edit_log(r, lambda d: d.__setitem__("scripted_eval_rmse_m", "2.5")), [], "scripted_eval_rmse_m"),
    ("log_wall_time_list", lambda r: _edit_log(r, lambda d: d.__setitem__("wall_time_s", [1])), [], "'wall_time_s'"),
    ("log_resumes_text", lambda r: _edit_log(r, lambda d: d.__setitem__("resumes", "many")), [], "'resumes'"),
    ("log_eval_timesteps_null", lambda r: _edit_log(r, lambda d: d["evaluations"][0].__setitem__("timesteps", None)), [],
     "'evaluations.0.timesteps'"),
    ("n_updates_text", lambda r: _edit_checkpoint(r, lambda a: _state(a, n_updates="7")), [], "'n_updates'"),
    ("learning_rate_text", lambda r: _edit_checkpoint(r, lambda a: _state(a, optimizer_param_groups=[
        {**json.loads(a["state"].tobytes())["optimizer_param_groups"][0], "lr": "fast"}])), [], "'optimizer_param_groups.0.lr'"),
    ("betas_out_of_range", lambda r: _edit_checkpoint(r, lambda a: _state(a, optimizer_param_groups=[
        {**json.loads(a["state"].tobytes())["optimizer_param_groups"][0], "betas": [1.5, 0.9]}])), [], "betas"),
    ("no_numpy_rng", lambda r: _edit_checkpoint(r, lambda a: _state(a, numpy_rng=None)), [], "'numpy_rng'"),
    ("python_rng_short", lambda r: _edit_checkpoint(r, lambda a: _state(a, python_rng=[3, [1, 2], None])), [], "'python_rng'"),
    ("numpy_rng_array_short", lambda r: _edit_checkpoint(r, lambda a: a.update({"rng:numpy": np.zeros(5, np.uint32)})), [], "'rng:numpy'"),
    ("torch_rng_floats", lambda r: _edit_checkpoint(r, lambda a: a.update({"rng:torch": np.zeros(9, np.float64)})), [], "'rng:torch'"),
    ("optimizer_nan", lambda r: _edit_checkpoint(r, lambda a: a[next(k for k in a if k.endswith(":exp_avg"))].fill(np.nan)), [], "NaN"),
    ("timesteps_401_digits", lambda r: _edit_checkpoint(r, lambda a: _state(a, num_timesteps=10**400)), [], "num_timesteps"),
    ("checkpoint_a_folder", lambda r: ((r / "checkpoints" / "latest.npz").unlink(), (r / "checkpoints" / "latest.npz").mkdir()), [],
     "not a regular file"),
    ("checkpoint_links_to_dev_zero", lambda r: ((r / "checkpoints" / "latest.npz").unlink(),
                                                (r / "checkpoints" / "latest.npz").symlink_to("/dev/zero")), [], "not a regular file"),
    ("train_config_unknown_key", lambda r: (r / "train_config.yaml").write_text((r / "train_config.yaml").read_text() + "bogus_key: 1\n"),
     [], "'bogus_key' (in '"),
    ("env_config_a_list", lambda r: (r / "env_config.yaml").write_text("- 1\n"), [], "must hold a mapping of keys, got list"),
    ("timesteps_beyond_any_run", lambda r: _edit_checkpoint(r, lambda a: _state(a, num_timesteps=10**15)), [], "more than the"),
    ("backend_number", lambda r: _edit_checkpoint(r, lambda a: _state(a, backend=5)), [], "'backend'"),
    ("log_nested_deep", lambda r: (r / "train_log.json").write_text("[" * 100_000 + "]" * 100_000), [], "train_log.json"),
    ("log_number_5000_digits", lambda r: (r / "train_log.json").write_text('{"timesteps": ' + "9" * 5000 + "}"), [], "train_log.json"),
    ("env_config_alias_bomb", lambda r: (r / "env_config.yaml").write_text(
        "x: [" + ",".join(["&a0 [1,1,1,1,1,1,1,1,1,1]"] + [f"&a{k} [" + ",".join([f"*a{k - 1}"] * 10) + "]" for k in range(1, 9)]) + "]\n"),
     [], "env_config.yaml"),
    ("train_config_deep", lambda r: (r / "train_config.yaml").write_text("ppo: " + "[" * 30_000 + "]" * 30_000 + "\n"), [],
     "train_config.yaml"),
]


def _edit_log(run: Path, change) -> None:
    data = json.loads((run / "train_log.json").read_text())
    change(data)
    (run / "train_log.json").write_text(json.dumps(data))


@pytest.mark.parametrize("damage, extra, words", [c[1:] for c in RESUME_CASES], ids=[c[0] for c in RESUME_CASES])
def test_refused_resume_leaves_the_run_folder_intact(capsys, run, damage, extra, words):
    if damage:
        damage(run)
    before = _snapshot(run)
    extra = [a.replace("{parent}", str(run.parent)) for a in extra]
    budget = [] if any("timesteps" in a for a in extra) else ["--timesteps", "100000"]  # a budget left: only the refusal stops it
    _fails(capsys, ["train", "--resume", "--out", run, *budget, "--no-progress", *extra], words)
    assert _snapshot(run) == before
    assert not (run.parent / "UNPICKLED").exists()


def test_a_new_run_into_a_run_folder_is_refused(capsys, run):
    before = _snapshot(run)
    _fails(capsys, ["train", "--out", run, "--no-progress", *TINY], "--resume")
    assert _snapshot(run) == before


@pytest.mark.parametrize("extra", [[], ["--timesteps", "64"], ["--set", "timesteps=128"]], ids=["own", "smaller", "same"])
def test_resuming_a_finished_run_says_so_and_writes_nothing(capsys, run, extra):
    before = _snapshot(run)
    assert main(["train", "--resume", "--out", str(run), "--no-progress", *extra]) == 0
    out = capsys.readouterr()
    assert "already finished" in out.out and out.err == "" and len(out.out.strip().splitlines()) == 1
    assert _snapshot(run) == before


def test_a_resumed_run_keeps_its_config_and_records_what_changed(capsys, run):
    import yaml

    saved = yaml.safe_load((run / "train_config.yaml").read_text())
    assert main(["train", "--resume", "--out", str(run), "--no-progress", "--timesteps", "200", "--set", "eval.every_steps=50000"]) == 0
    now = yaml.safe_load((run / "train_config.yaml").read_text())
    assert now == {**saved, "timesteps": 200, "eval": {**saved["eval"], "every_steps": 50000}}  # the run's own, ppo.net_arch [8]
    log = json.loads((run / "train_log.json").read_text())
    assert log["timesteps"] >= 200 and log["resumes"][-1]["changes"] == {
        "eval.every_steps": {"from": 100000, "to": 50000}, "timesteps": {"from": 128, "to": 200}}
    assert "resumed with timesteps 128 -> 200" in capsys.readouterr().out
    assert not [p for p in run.rglob(".*") if p.is_file()]


def test_a_checkpoint_restores_weights_optimizer_counters_and_rngs(run):
    import random

    import torch

    from petswarm.training.checkpoint import read_checkpoint, restore_checkpoint, save_checkpoint
    from petswarm.training.config import load_train_config
    from petswarm.training.train import build_model
    from petswarm.training.vec_env import make_vec_env

    def draws():
        return torch.rand(3).tolist(), np.random.random(3).tolist(), random.random()

    def same_state(a, b):
        assert all(torch.equal(x, y) for x, y in zip(a.policy.state_dict().values(), b.policy.state_dict().values()))
        oa, ob = a.policy.optimizer.state_dict(), b.policy.optimizer.state_dict()
        assert oa["param_groups"][0]["lr"] == ob["param_groups"][0]["lr"] and oa["state"].keys() == ob["state"].keys()
        assert all(torch.equal(oa["state"][k][n], ob["state"][k][n]) for k in oa["state"] for n in oa["state"][k])
        assert a.num_timesteps == b.num_timesteps and a._n_updates == b._n_updates

    cfg = load_train_config(base=run / "train_config.yaml")
    venv = make_vec_env(cfg.env_config(), 1, 0, 0)
    try:
        model = build_model(cfg.ppo, venv, 1)  # other seeds: the checkpoint, not the build, sets the state
        restore_checkpoint(run, model)
        state, arrays = read_checkpoint(run)
        assert model.num_timesteps == state["num_timesteps"] >= 128 and model.policy.optimizer.state_dict()["state"]
        for name, tensor in model.policy.state_dict().items():
            assert np.array_equal(tensor.numpy(), arrays[f"policy:{name}"])
        first = draws()
        again = build_model(cfg.ppo, venv, 2)
        restore_checkpoint(run, again)
        assert draws() == first  # torch's, numpy's and Python's RNGs as they were at the checkpoint
        same_state(model, again)
        save_checkpoint(run / "checkpoints" / "latest.npz", model, "tanh", [8])  # a round trip of a restored model
        third = build_model(cfg.ppo, venv, 3)
        restore_checkpoint(run, third)
        same_state(model, third)
    finally:
        venv.close()


# -- outputs: an output that is an input, two outputs on one file, an unwritable place ----------
@pytest.mark.parametrize("argv, words", [
    (["run", "--config", "{dir}/c.yaml", "--json", "{dir}/c.yaml"], "is also the input --config"),
    (["run", "--config", "{dir}/c.yaml", "--json", "{dir}/./sub/../c.yaml"], "is also the input --config"),
    (["run", "--config", "{dir}/c.yaml", "--video", "{dir}/c.yaml"], "is also the input --config"),
    (["run", "--config", "{dir}/c.gif", "--video", "{dir}/c.gif"], "is also the input --config"),
    (["run", "--config", "{dir}/c.jsonl", "--json", "{dir}/c.json"], "--json's lines file"),
    (["run", "--json", "{dir}/x.gif", "--video", "{dir}/x.gif"], "both name"),
    (["run", "--json", "{dir}/x.pcapng", "--pcap", "{dir}/x.pcapng"], "both name"),
    (["run", "--json", "{dir}/OUT.json", "--video", "{dir}/OUT.jsonl"], "both name"),
    (["report", "{dir}/r.json", "--out", "{dir}/r.json"], "is also the input RESULT.json"),
    (["report", "{dir}/OUT.json", "{dir}/r.json", "--out", "{dir}/link.json"], "is also the input RESULT.json"),
    (["eval", "--config", "{dir}/c.yaml", "--json", "{dir}/c.yaml", "--episodes", "1"], "is also the input --config"),
    (["eval", "--grid", "{dir}/c.yaml", "--json", "{dir}/c.yaml"], "is also the input --grid"),
    (["reproduce", "--config", "{dir}/c.yaml", "--report", "{dir}/c.yaml"], "is also the input --config"),
    (["bench", "--json", "{dir}/b.json", "--md", "{dir}/b.json"], "both name"),
    (["bench", "--json", "/proc/petswarm/b.json"], "cannot be written"),
    (["run", "--video", "/proc/petswarm/v.gif", "--json", "{dir}/OUT.json"], "cannot be written"),
    (["run", "--json", "/sys/OUT.json"], "cannot be written"),
    (["report", "{dir}/OUT.json", "--out", "/proc/r.html"], "cannot be written"),
    (["run", "--json", "/dev/null"], "not a regular file"),
    (["run", "--json", "{dir}/sub.json"], "writes each finished episode"),  # sub.jsonl is a folder
], ids=lambda a: " ".join(a)[:60] if isinstance(a, list) else None)
def test_an_output_that_is_an_input_or_unwritable_is_refused_before_any_work(capsys, outputs, argv, words):
    (outputs / "c.yaml").write_text("seed: 1\nmax_cycles: 5\n")
    (outputs / "c.gif").write_text("seed: 1\n")
    (outputs / "c.jsonl").write_text("seed: 1\n")
    (outputs / "sub").mkdir()
    (outputs / "sub.jsonl").mkdir()
    (outputs / "link.json").symlink_to(outputs / "r.json")
    before = _snapshot(outputs)
    t0 = time.perf_counter()
    _fails(capsys, [a.replace("{dir}", str(outputs)) for a in argv], words)
    assert time.perf_counter() - t0 < 10  # refused before the work (bench alone takes a minute)
    assert _snapshot(outputs) == before
    assert not [p for p in outputs.rglob(".*")]  # no probe or temporary file left


# -- the grid: its size bounded before expansion, a damaged result refused before --resume rewrites it --
GRID = "seed: 0\nepisodes: 1\nset: {max_cycles: 5, swarm.num_slaves: 2}\ncells:\n  - name: a\n    product: {swarm.formation: [wedge, column]}\n"


@pytest.mark.parametrize("product, words", [
    ("{user.start_delay_s: [%s], user.formation_wait_s: [%s], seed: [%s], swarm.spacing_m: [%s]}"
     % (",".join(map(str, range(100))), ",".join(map(str, range(100))), ",".join(map(str, range(100))),
        ",".join(str(1 + k / 100) for k in range(100))), "cells, more than"),  # 10^8 cells
    ("{seed: [%s]}" % ",".join(map(str, range(3000))), "cells, more than"),
])
def test_a_grid_product_beyond_the_limit_is_one_line_and_fast(capsys, outputs, product, words):
    grid = outputs / "big.yaml"
    grid.write_text(f"seed: 0\nepisodes: 1\ncells:\n  - name: huge\n    product: {product}\n")
    before = _snapshot(outputs)
    t0 = time.perf_counter()
    line = _fails(capsys, ["eval", "--grid", grid, "--json", outputs / "OUT.json"], words)
    assert "big.yaml" in line and "2000" in line and time.perf_counter() - t0 < 10
    assert _snapshot(outputs) == before


def test_a_grid_of_too_many_episodes_is_refused(capsys, outputs):
    grid = outputs / "long.yaml"
    grid.write_text("seed: 0\nepisodes: 9000\ncells:\n  - name: a\n    product: {seed: [%s]}\n" % ",".join(map(str, range(50))))
    _fails(capsys, ["eval", "--grid", grid], "episodes")


@pytest.fixture(scope="module")
def grid_result(tmp_path_factory):
    folder = tmp_path_factory.mktemp("grid")
    (folder / "g.yaml").write_text(GRID)
    assert main(["eval", "--grid", str(folder / "g.yaml"), "--json", str(folder / "g.json")]) == 0
    return folder


def _set(path, value):
    def change(cell):
        *parents, last = path
        node = cell
        for p in parents:
            node = node[p]
        if value is _DROP:
            node.pop(last)
        else:
            node[last] = value
    return change


GRID_DAMAGE = [
    ("candidate_list", _set(["candidate"], [1, 2]), "'candidate' must be a JSON object"),
    ("candidate_401_digits", _set(["candidate", "collisions"], 10**400), "candidate.collisions"),
    ("ratio_text", _set(["ratio"], "0.5"), "'ratio'"),
    ("no_key", _set(["key"], _DROP), "'key' is missing"),
    ("per_episode_rmse_list", _set(["reference", "per_episode", 0, "formation_rmse_m"], [1]), "reference.per_episode.0.formation_rmse_m"),
    ("meets_target_number", _set(["meets_target"], 1), "'meets_target'"),
    ("per_episode_rmse_null", _set(["candidate", "per_episode", 0, "formation_rmse_m"], None), "candidate.per_episode.0.formation_rmse_m"),
    ("episodes_mismatch", _set(["candidate", "episodes"], 7), "per_episode"),
    ("cell_a_string", None, "not a cell record"),
    ("ratio_negative", _set(["ratio"], -0.5), "'ratio' input should not be negative"),
    ("rmse_negative", _set(["reference", "formation_rmse_m"], -1.0), "'reference.formation_rmse_m' input should not be negative"),
    ("episode_rmse_negative", _set(["candidate", "per_episode", 0, "formation_rmse_m"], -3.0), "candidate.per_episode.0.formation_rmse_m"),
]


@pytest.mark.parametrize("change, words", [c[1:] for c in GRID_DAMAGE], ids=[c[0] for c in GRID_DAMAGE])
def test_grid_resume_on_a_damaged_cell_is_refused_before_anything_is_rewritten(capsys, grid_result, tmp_path, change, words):
    data = json.loads((grid_result / "g.json").read_text())
    if change is None:
        data["cells"][1] = "cell"
    else:
        change(data["cells"][1])
    (tmp_path / "g.json").write_text(json.dumps(data))
    shutil.copy(grid_result / "g.yaml", tmp_path / "g.yaml")
    before = _snapshot(tmp_path)
    line = _fails(capsys, ["eval", "--grid", tmp_path / "g.yaml", "--json", tmp_path / "g.json", "--resume"], words)
    assert "g.json" in line and "cell 1" in line
    assert _snapshot(tmp_path) == before  # the finished cells are all still there


@pytest.mark.parametrize("content", ["[" * 100_000, '{"kind": "grid", "cells": [], "x": ' + "9" * 5000 + "}"], ids=["deep", "long_number"])
def test_grid_resume_on_an_unreadable_result_is_one_line(capsys, grid_result, tmp_path, content):
    (tmp_path / "g.json").write_text(content)
    before = _snapshot(tmp_path)
    _fails(capsys, ["eval", "--grid", grid_result / "g.yaml", "--json", tmp_path / "g.json", "--resume"], "--resume")
    assert _snapshot(tmp_path) == before


# -- report inputs: only http(s) and relative links; numbers, cells and replays checked -----------
@pytest.fixture(scope="module")
def eval_result(tmp_path_factory):
    folder = tmp_path_factory.mktemp("eval")
    assert main(["eval", "--episodes", "1", "--scenarios", "straight", "--set", "max_cycles=5", "--json", str(folder / "e.json")]) == 0
    return json.loads((folder / "e.json").read_text())


@pytest.mark.parametrize("gif", ["javascript:alert(1)", " JavaScript:alert(1)", "JAVASCRIPT://%0aalert(1)", "data:text/html,<b>x</b>",
                                 "vbscript:msgbox(1)", "file:///etc/passwd", 'https://x.org/" onclick="alert(1)'])
def test_report_links_only_http_and_relative(outputs, eval_result, gif, capsys):
    data = json.loads(json.dumps(eval_result))
    data["episodes"][0]["gif"] = gif
    (outputs / "r.json").write_text(json.dumps(data))
    assert main(["report", str(outputs / "r.json"), "--out", str(outputs / "report.html")]) == 0
    page = (outputs / "report.html").read_text()
    hrefs = re.findall(r'href="([^"]*)"', page) + re.findall(r"href='([^']*)'", page)
    assert not [h for h in hrefs if re.match(r"\s*[a-z][a-z0-9+.-]*:", h, re.I) and not re.match(r"https?://", h, re.I)]
    assert "not a link" in page
    for good in ("https://example.org/clip.gif", "clips/ep 0.gif"):
        data["episodes"][0]["gif"] = good
        (outputs / "r.json").write_text(json.dumps(data))
        assert main(["report", str(outputs / "r.json"), "--out", str(outputs / "report.html")]) == 0
        assert "not a link" not in (outputs / "report.html").read_text()


@pytest.mark.parametrize("edit, words", [
    (lambda d: d["episodes"][0].__setitem__("replay", "/dev/zero"), "not a regular file"),
    (lambda d: d["episodes"][0].__setitem__("replay", "/dev"), "not a regular file"),
    (lambda d: d["episodes"][0].__setitem__("replay", 5), "'replay' must be a path"),
    (lambda d: d["episodes"][0].__setitem__("gif", ["a.gif"]), "'gif' must be a path"),
    (lambda d: d["episodes"][0].__setitem__("formation_rmse_m", 10**400), "401 digits"),
    (lambda d: d["episodes"][0].__setitem__("formation_rmse_m", 1.5e308), "beyond any figure"),
    (lambda d: d.update(kind="grid", cells=[{"candidate": [1, 2]}]), "'candidate' must be a JSON object"),
    (lambda d: d.update(kind="grid", cells=[{"candidate": {"collisions": -10**500}}]), "digits"),
    (lambda d: d.update(kind="grid", cells=["x"]), "cell 0 must be a JSON object"),
    (lambda d: d.update(kind="grid", cells=[{"reference": {"per_episode": "x"}}]), "per_episode"),
    # figures of the wrong type or sign: refused field by field, not drawn as NaN
    (lambda d: d["episodes"][0].__setitem__("formation_rmse_m", "0.4"), "'formation_rmse_m' must be a number"),
    (lambda d: d["episodes"][0].__setitem__("formation_hold_rmse_m", -0.2), "'formation_hold_rmse_m' must not be negative"),
    (lambda d: d["episodes"][0].__setitem__("building_time_s", False), "'building_time_s' must be a number"),
    (lambda d: d["episodes"][0]["collisions"].__setitem__("robot_user", -3), "'collisions.robot_user' must not be negative"),
    (lambda d: d["episodes"][0].__setitem__("seed", "one"), "'seed' must be a number"),
    (lambda d: d["episodes"][0].__setitem__("scenario", 7), "'scenario' must be a scenario name"),
    (lambda d: d["episodes"][0].__setitem__("error_trace", [0.1, "x"]), "'error_trace' holds 'x'"),
    (lambda d: d["episodes"][0].__setitem__("error_trace", [0.0] * 1_000_001), "at most 1000000"),
    (lambda d: d.update(policy={"name": "x"}), "'policy' must be text"),
    (lambda d: d.update(config=[1]), "'config' must be a JSON object"),
    (lambda d: d.update(kind="grid", cells={"a": 1}), "'cells' of a grid result must be a list"),
    (lambda d: d.update(kind=["grid"]), "'kind' must be text"),
], ids=["dev_zero", "a_folder", "replay_number", "gif_list", "huge_rmse", "float_1e308", "candidate_list", "huge_collisions", "cell_text",
        "per_episode_text", "rmse_text", "hold_negative", "building_bool", "collisions_negative", "seed_text", "scenario_number",
        "trace_text", "trace_too_long", "policy_object", "config_list", "cells_object", "kind_list"])
def test_report_refuses_what_it_would_choke_on(capsys, outputs, eval_result, edit, words):
    data = json.loads(json.dumps(eval_result))
    edit(data)
    (outputs / "bad.json").write_text(json.dumps(data))
    before = _snapshot(outputs)
    t0 = time.perf_counter()
    line = _fails(capsys, ["report", outputs / "bad.json", "--out", outputs / "report.html"], words)
    assert "bad.json" in line and time.perf_counter() - t0 < 10
    assert _snapshot(outputs) == before


# -- at run time: reset options, actions, FixedAgents, a box on the start -------------------------
def test_reset_options_and_actions_are_checked():
    import warnings

    from petswarm_env.inputs import ResetOptionWarning
    from petswarm_env.wrappers import FixedAgents

    env = PetSwarmEnv(max_cycles=5)
    for bad in ("x", 5, [("a", 1)], True):
        with pytest.raises(TypeError, match="reset\\(options=...\\) takes a dict or None"):
            env.reset(options=bad)
    with pytest.warns(ResetOptionWarning, match="ignores str 'bogus'"):
        env.reset(seed=0, options={"bogus": 1})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env.reset(seed=0, options=None)
        env.reset(seed=0, options={})
    agent = env.agents[0]
    for bad in ([np.bool_(True), 0.0, 0.0], [True, 0, 0], np.array([True, False, True]), (0.1, np.False_, 0.0),
                [[0.1], [0.2], [0.3]], [0.0, 0.0, 1e39], "abc"):
        with pytest.raises(ValueError, match=f"action of {agent}"):
            env.step({agent: bad})
    wrapped = FixedAgents(PetSwarmEnv(max_cycles=5))
    wrapped.reset(seed=0)
    for bad, error in (({"robot_99": np.zeros(3, np.float32)}, KeyError), ({7: np.zeros(3)}, KeyError), ([0.0, 0.0, 0.0], TypeError),
                       ({wrapped.possible_agents[0]: [np.nan, 0, 0]}, ValueError),
                       ({wrapped.possible_agents[-1]: [np.bool_(True), 0, 0]}, ValueError)):
        with pytest.raises(error):
            wrapped.step(bad)
    wrapped.step({a: np.zeros(3, np.float32) for a in wrapped.possible_agents})  # every fixed agent, live or not


@pytest.mark.parametrize("box", [{"center_m": [0.0, 0.0], "size_m": [0.5, 0.5]}, {"center_m": [-0.8, 0.0], "size_m": [0.3, 0.3]},
                                 {"center_m": [-2.0, 0.0], "size_m": [3.0, 6.0]}], ids=["on_the_user", "on_the_master", "over_the_swarm"])
def test_a_box_on_the_start_positions_is_refused(capsys, outputs, box):
    before = _snapshot(outputs)
    line = _fails(capsys, ["run", "--set", f"world.obstacles=[{json.dumps(box)}]", "--set", "max_cycles=5",
                           "--json", outputs / "OUT.json"], "world.obstacles[0]")
    assert "lies on the start of" in line
    assert _snapshot(outputs) == before


def test_a_box_away_from_the_start_runs(capsys):
    assert main(["run", "--set", 'world.obstacles=[{center_m: [30, 30], size_m: [1, 1]}]', "--set", "max_cycles=5", "--quiet"]) == 0


@pytest.mark.parametrize("argv, words", [
    (["run", "--set", "robot_types.mybot.sensors=[{id: 1, type: LASER, radius_m: 0.1, angle_deg: 0}]"], "robot_types.mybot.sensors.0.type"),
    (["run", "--set", "lf.burst_period_s=1e-9"], "lf.burst_period_s"),
    (["run", "--set", "protocol.token_timeout_s=1e-7"], "protocol.token_timeout_s"),
    (["run", "--set", "ble.report_period_s=0.001"], "ble.report_period_s"),
    (["run", "--set", "control_period_s=1e300"], "control_period_s"),
    (["run", "--set", "max_cycles=1e23"], "max_cycles"),
    (["run", "--set", "faults_random.rate_per_min=1e7"], "faults_random.rate_per_min"),
    (["run", "--set", "radio.rssi_shadowing_db=1e299"], "radio.rssi_shadowing_db"),
    (["run", "--set", "lf.table_step_m=1e-8"], "lf.table_step_m"),
    (["run", "--set", "belt.accel_rate_hz=1e8"], "belt.accel_rate_hz"),
    (["run", "--set", "belt.gyro_period_s=1e-8"], "belt.gyro_period_s"),
    (["run", "--set", "ir.strength_at_1m=1e300"], "ir.strength_at_1m"),
    (["run", "--set", "watch.accel_rate_hz=5e6"], "watch.accel_rate_hz"),
    (["run", "--set", "ir.num_receivers=100000"], "ir.num_receivers"),
    (["run", "--set", "max_cycles=900000"], "a day"),
    (["run", "--set", "master.distance_m=0.3"], "master.distance_m"),  # inside the user's body: organize failed, blaming collisions
    (["run", "--set", "lf.rssi_at_1m_db=20"], "lf.rssi_at_1m_db"),
    (["run", "--set", "robot_types.petbot.battery_mah=1e-300"], "robot_types.petbot.battery_mah"),  # every robot dead at once
    (["run", "--set", "swarm.formation=custom", "--set", "swarm.num_slaves=2", "--set",
      "swarm.custom_links=[{robot: 1, neighbour: 2, offset_m: [-1, 0]}, {robot: 2, neighbour: 1, offset_m: [1, 0]}]"], "swarm.custom_links"),
], ids=lambda a: " ".join(a)[6:60] if isinstance(a, list) else None)
def test_numbers_beyond_their_physical_range_through_the_cli(capsys, outputs, argv, words):
    before = _snapshot(outputs)
    t0 = time.perf_counter()
    _fails(capsys, [*argv, "--json", outputs / "OUT.json"], words)
    assert time.perf_counter() - t0 < 10 and _snapshot(outputs) == before


@pytest.mark.parametrize("argv, words", [
    (["run", "--episodes", "99999999999999999999999"], "--episodes"),
    (["eval", "--episodes", "10000000000"], "--episodes"),
    (["run", "--seed", str(2**64)], "--seed"),
    (["run", "--seed", "9" * 5000], "characters"),
    (["train", "--timesteps", "1" + "0" * 13], "--timesteps"),
    (["train", "--set", "ppo.batch_size=99999999999"], "ppo.batch_size"),
    (["train", "--set", "ppo.net_arch=[100000000]"], "ppo.net_arch.0"),
    (["train", "--set", "num_envs=100000"], "num_envs"),
    (["train", "--set", "ppo.n_steps=60000", "--set", "num_envs=8"], "memory budget"),
    (["train", "--set", "ppo.log_std_init=1e300"], "ppo.log_std_init"),
    (["train", "--set", "pretrain.samples=1e15"], "pretrain.samples"),
])
def test_unbounded_counts_of_the_command_line_and_the_training_config(capsys, outputs, argv, words):
    if argv[0] == "train":
        pytest.importorskip("stable_baselines3")
        argv = [*argv, "--out", str(outputs / "run")]
    before = _snapshot(outputs)
    t0 = time.perf_counter()
    _fails(capsys, argv, words)
    assert time.perf_counter() - t0 < 20 and _snapshot(outputs) == before


@pytest.mark.parametrize("argv", [["run", "--video", "{dir}/v.gif"], ["eval", "--video-dir", "{dir}/clips2", "--episodes", "1"]],
                         ids=["run", "eval"])
def test_a_gif_beyond_the_memory_budget_is_refused_before_the_episode(capsys, outputs, argv):
    before = _snapshot(outputs)
    argv = [a.replace("{dir}", str(outputs)) for a in argv]
    _fails(capsys, [*argv, "--set", "render.size_px=[8192, 8192]", "--json", outputs / "OUT.json"], "GB budget")
    assert _snapshot(outputs) == before and not (outputs / "clips2").exists()


def test_a_bad_value_in_a_training_config_file_names_the_file(capsys, outputs):
    pytest.importorskip("stable_baselines3")
    (outputs / "t.yaml").write_text("ppo:\n  gamma: 3\n")
    line = _fails(capsys, ["train", "--config", outputs / "t.yaml", "--out", outputs / "run", "--timesteps", "64"], "ppo.gamma")
    assert "t.yaml" in line
    line = _fails(capsys, ["train", "--config", outputs / "t.yaml", "--set", "ppo.gamma=5", "--out", outputs / "run"], "ppo.gamma")
    assert "t.yaml" not in line  # the --set's value, not the file's


def test_keyword_overrides_in_both_forms_and_waiting_agents_actions():
    import petswarm_env

    with pytest.raises(ValueError, match="'swarm.num_slaves' is given twice"):
        petswarm_env.parallel_env(**{"swarm.num_slaves": 2, "swarm__num_slaves": 3})
    assert PetSwarmEnv(swarm__num_slaves=3).cfg.swarm.num_slaves == 3  # the class takes section__key as parallel_env does
    env = petswarm_env.parallel_env(**{"user.scenario": "mode_change", "max_cycles": 5})
    _, infos = env.reset(seed=0)
    assert infos["robot_0"]["active"] == 0  # robot_0 waits (the master): its action is still checked, then ignored
    with pytest.raises(ValueError, match="action of robot_0"):
        env.step({"robot_0": [np.nan, 0.0, 0.0]})
    env.step({"robot_0": np.ones(3, np.float32)})


def test_the_report_checks_a_grid_results_cells_as_resume_does(capsys, outputs, grid_result):
    data = json.loads((grid_result / "g.json").read_text())
    data["cells"][0]["key"] = 12
    (outputs / "bad.json").write_text(json.dumps(data))
    before = _snapshot(outputs)
    line = _fails(capsys, ["report", outputs / "bad.json", "--out", outputs / "report.html"], "field 'key'")
    assert "bad.json" in line and "cell 0" in line and _snapshot(outputs) == before
