"""The compiled core (petswarm_env/_core.py): built and imported as C unless the interpreted form is
asked for, the interpreted form (the oracle) gives the golden episode bit for bit, and a missing
build is one line that names the fix."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from petswarm_env import _core

ROOT = Path(__file__).resolve().parents[2]


def in_both_forms(function: str) -> dict:
    """``function`` of this module run in a child process compiled (``"0"``) and interpreted (``"1"``,
    ``PETSWARM_PURE_PYTHON=1``): its JSON results by form."""
    from tests.golden.episodes import portable_environ

    code = f"import json; from tests.unit.test_compiled_core import {function}; print(json.dumps({function}()))"
    out = {}
    for pure in ("0", "1"):
        env = dict(portable_environ(), **{_core.PURE_ENV: pure})
        env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
        run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True,
                             check=False, timeout=300)
        assert run.returncode == 0, run.stderr[-2000:]
        out[pure] = json.loads(run.stdout.strip().splitlines()[-1])
    return out


@pytest.mark.skipif(_core.pure(), reason="PETSWARM_PURE_PYTHON is set: this run tests the interpreted form")
def test_every_core_module_runs_compiled():
    assert _core.compiled_modules() == {m: True for m in _core.COMPILED}


def test_the_interpreted_form_gives_the_golden_episode_bit_for_bit():
    """Golden cases in a child process with ``PETSWARM_PURE_PYTHON=1``: every core module is its
    ``.py``, and the episodes' hashes are the golden ones that the compiled form meets
    (tests/env/test_golden_episodes.py): the default swarm, and 1 + 9, whose token ring runs crowded
    (middleware/token_ring.py)."""
    from tests.golden.episodes import GOLDEN_PATH, portable_environ

    cases = ["default_seed0", "nine_slaves_u_turn"]
    code = ("import json; from petswarm_env import _core; from tests.golden.episodes import run_case; "
            f"print(json.dumps([_core.compiled_modules(), [run_case(c)['sha256'] for c in {cases!r}]]))")
    env = dict(portable_environ(), **{_core.PURE_ENV: "1"})
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, check=False,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    compiled, shas = json.loads(out.stdout.strip().splitlines()[-1])
    assert compiled == {m: False for m in _core.COMPILED}
    golden = json.loads(GOLDEN_PATH.read_text())
    assert shas == [golden[c]["sha256"] for c in cases]


def test_a_missing_build_is_one_line_naming_the_fix(tmp_path, monkeypatch):
    """Without the extensions (here: the package's sources copied without them) the import fails
    with one line that names the build command and the interpreted form's variable."""
    import shutil

    dst = tmp_path / "petswarm_env"
    shutil.copytree(ROOT / "petswarm_env", dst, ignore=shutil.ignore_patterns("*.so", "*.pyd", "*.c", "__pycache__"))
    environ = {k: v for k, v in os.environ.items() if k != _core.PURE_ENV}
    environ["PYTHONPATH"] = str(tmp_path)
    out = subprocess.run([sys.executable, "-c", "import petswarm_env"], cwd=tmp_path, env=environ,
                         capture_output=True, text=True, check=False, timeout=120)
    assert out.returncode != 0
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: petswarm: compiled core not built (")
    assert "pip install -e ." in last and _core.PURE_ENV in last
    environ[_core.PURE_ENV] = "1"
    ok = subprocess.run([sys.executable, "-c", "import petswarm_env"], cwd=tmp_path, env=environ,
                        capture_output=True, text=True, check=False, timeout=120)
    assert ok.returncode == 0, ok.stderr[-2000:]


def scripted_observations_hash(env, obs: dict, seed: int) -> str:
    """``env``, just reset to ``obs``, driven to its end by the scripted reference (``seed``): a SHA-256
    of every agent's observation at every step."""
    import hashlib

    from petswarm.baselines.policy import PolicySpec
    from petswarm.baselines.registry import make_policy

    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    h = hashlib.sha256()
    while env.agents:
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        for a in sorted(obs):
            h.update(a.encode() + obs[a].tobytes())
    return h.hexdigest()


def fault_episode() -> list:
    """A walk in which three robots' sensors break (ultrasonic, IR, AHRS): every robot's own
    detections (middleware/diagnosis.py, on its own clock) and a hash of every observation."""
    import petswarm_env

    faults = [{"at_s": 3.0, "robot": 3, "kind": "ultrasonic"}, {"at_s": 4.0, "robot": 2, "kind": "ir"},
              {"at_s": 5.0, "robot": 4, "kind": "ahrs"}]
    env = petswarm_env.parallel_env(**{"user.scenario": "straight", "max_cycles": 110, "faults": faults})
    obs, _ = env.reset(seed=0)
    digest = scripted_observations_hash(env, obs, seed=0)
    detected = {str(n): [[t, part] for t, part in node.diagnosis.detected] for n, node in env.episode.fleet.nodes.items()}
    return [detected, digest]


def test_the_interpreted_form_finds_the_same_sensor_faults_bit_for_bit():
    """The self-diagnosis (compiled since its checks run for every reading) finds the same faults at
    the same times in both forms, and the episodes are the same to the bit (the golden cases have
    no faults)."""
    out = in_both_forms("fault_episode")
    detected, _ = out["0"]
    assert {part for parts in detected.values() for _, part in parts} == {"ultrasonic", "ir", "ahrs"}
    assert out["1"] == out["0"]


def ir_slots() -> list:
    """Every robot's IR slot measured by all the others (``IRChannel.measure``: lines of sight, the
    ring's readings and the estimator, ``comms/ir_channel.py`` and ``comms/ir.py``) in a crowd with
    bodies in the lines of sight, some robots out of range and one behind the arena's wall: the
    results as exact hex strings (NaN included)."""
    import numpy as np

    from petswarm_env.comms.ir_channel import IRChannel
    from petswarm_env.config import load_config
    from petswarm_env.scenarios import SCENARIOS
    from petswarm_env.sim.world import World

    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    rng = np.random.default_rng(5)
    for p, th in zip(rng.uniform(-2.5, 2.5, (8, 2)), rng.uniform(-3.0, 3.0, 8)):
        world.add_robot(p, th)
    channel = IRChannel(world, cfg.ir, np.random.default_rng(11))
    out = []
    for tx in range(8):
        rxs = [r for r in range(8) if r != tx]
        out.append([[float(v).hex() for v in values] for values in channel.measure(tx, rxs)])
    return out


def test_the_interpreted_form_measures_the_same_ir_slots_bit_for_bit():
    """The IR medium's measurement of a slot (compiled: it runs for every slot of every ring) gives
    the same distances, bearings and validity to the bit in both forms."""
    out = in_both_forms("ir_slots")
    valid = [v for slot in out["0"] for v in slot[2]]
    assert float.fromhex("0x1.0p+0").hex() in valid and float.fromhex("0x0.0p+0").hex() in valid  # both kinds
    assert out["1"] == out["0"]


def radio_frames() -> list:
    """The radio medium alone (``comms/radio.py``: its clear-channel assessments and deliveries are
    the clock's Dues) with seven stations on two PANs, bursts of broadcasts and unicasts that collide,
    back off and are lost (loss 0.2): every reception as (time, receiver, sender, kind, RSSI estimate)
    in exact hex, and the medium's counters."""
    import numpy as np

    from petswarm_env.comms.radio import BROADCAST, Frame, RadioMedium
    from petswarm_env.config import load_config
    from petswarm_env.sim.clock import Clock

    class Listener:
        def __init__(self, node_id, pan, pos, got):
            self.node_id, self.pans, self.pos, self.got = node_id, frozenset({pan}), pos, got

        def position(self):
            return self.pos

        def receive(self, frame):
            self.got.append([clock.now.hex(), self.node_id, frame.src, frame.kind, frame.rx_distance_est_m.hex()])

    cfg = load_config(overrides={"radio.loss_prob": 0.2}).radio
    clock = Clock()
    radio = RadioMedium(clock, cfg, np.random.default_rng(3))
    got: list = []
    rng = np.random.default_rng(8)
    listeners = [Listener(i, 0x1001 if i % 3 else 0x2002, tuple(rng.uniform(-4.0, 4.0, 2).tolist()), got)
                 for i in range(7)]
    for st in listeners:
        radio.attach(st)
    for burst in range(6):
        for st in listeners:
            dst = BROADCAST if (st.node_id + burst) % 2 else (st.node_id + 1) % 7
            clock.later(burst * 0.02 + 0.0015 * (st.node_id % 3), radio.send, st,
                        Frame(f"k{burst}", st.node_id, dst, next(iter(st.pans)), {}, 4 + st.node_id))
    clock.run_until(1.0)
    return [got, radio.stats.as_dict()]


def test_the_interpreted_form_carries_the_same_frames_bit_for_bit():
    """The radio medium (compiled: its assessments and deliveries run for every frame) gives the same
    receptions, at the same times with the same RSSI estimates, and the same counters in both forms."""
    out = in_both_forms("radio_frames")
    stats = out["0"][1]
    assert stats["frames_collided"] > 0 and stats["frames_lost"] > 0 and stats["foreign_pan_dropped"] > 0
    assert len(out["0"][0]) > 20
    assert out["1"] == out["0"]


def ring_readings() -> list:
    """The ultrasonic rings of a crowd beside a box (every robot in one cast, then a subset in
    another order), noisy, and a slipping robot's noisy odometry: exact hex strings."""
    import numpy as np

    from petswarm_env.config import load_config
    from petswarm_env.scenarios import SCENARIOS
    from petswarm_env.sim.sensors import Sensors
    from petswarm_env.sim.world import World

    cfg = load_config(overrides={"world.obstacles": [{"center_m": [1.5, 0.5], "size_m": [0.6, 0.8]}]})
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    rng = np.random.default_rng(4)
    for p, th in zip(rng.uniform(-2.0, 2.0, (7, 2)), rng.uniform(-3.0, 3.0, 7)):
        world.add_robot(p, th)
    sensors = Sensors(world, cfg.robot, np.random.default_rng(12))
    world.robots[3].wheel_gain = 1.0 / 0.9
    world.robots[3]._wheels = (0.31, -0.12, 0.45)
    rings = [sensors.read_rings().tolist(), sensors.ring.ranges(world, [5, 1, 2], np.random.default_rng(3)).tolist()]
    odometry = [sensors.odometry(3), sensors.odometry(3, [0.01, -0.02, 0.03])]
    return [[[[float(v).hex() for v in row] for row in ring] for ring in rings], [[v.hex() for v in o] for o in odometry]]


def test_the_interpreted_form_reads_the_same_rings_and_odometry_bit_for_bit():
    """The ring's cast and readings (compiled: every robot's ring at every step) and the wheel
    odometry (a slipping robot's) give the same values to the bit in both forms."""
    out = in_both_forms("ring_readings")
    assert any(v != out["0"][0][0][0][0] for row in out["0"][0][0] for v in row)  # not all one value
    assert out["1"] == out["0"]


def heterogeneous_episode() -> list:
    """The heterogeneous pool (seed 001: each type casts its own ring, mapped onto the virtual one)
    with one slave's battery nearly empty (the drive stops it mid-episode): a hash of every
    observation and of every robot's drive triples and charge at the end."""
    import petswarm_env

    env = petswarm_env.parallel_env(**{"user.scenario": "heterogeneous", "max_cycles": 90})
    obs, _ = env.reset(seed=2)
    robots = env.episode.world.robots
    robots[2].battery.set_remaining(0.02)  # mAh: empties within the episode
    digest = scripted_observations_hash(env, obs, seed=2)
    ends = [[r.command, r.velocity_body, r.wheel_velocity, r.battery.remaining_mah, r.battery.empty] for r in robots]
    return [digest, repr(ends)]


def test_the_interpreted_form_gives_the_heterogeneous_ring_and_the_drive_bit_for_bit():
    """Each body type's own ring (one cast and one noise draw per type) and the drive's C triples
    (command, achieved velocity, wheels) with a battery that empties: the same episode to the bit in
    both forms."""
    out = in_both_forms("heterogeneous_episode")
    assert "True" in out["0"][1]  # the battery did empty
    assert out["1"] == out["0"]


def frame_episode() -> list:
    """The per-step bookkeeping around the physics (petswarm_env/step_kernel.py, reward.py): a walk in
    which a slave's IR breaks (it asks out and drives out of its slot) and another's battery is
    emptied (the battery fault), under random actions (contacts): a hash of every reward, termination and info, and the summary."""
    import hashlib

    import petswarm_env
    from petswarm.baselines.policy import PolicySpec
    from petswarm.baselines.registry import make_policy

    faults = [{"at_s": 3.0, "robot": 2, "kind": "ir"}]
    env = petswarm_env.parallel_env(**{"control.safety_layer": False, "max_cycles": 200, "faults": faults})
    obs, _ = env.reset(seed=3)
    policy = make_policy("random", PolicySpec.from_env(env), seed=3)  # random actions: contacts
    h = hashlib.sha256()
    steps = 0
    while env.agents:
        if steps == 60:
            env.truth.robots[4].battery.set_remaining(0.0)
        obs, rewards, terms, truncs, infos = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        h.update(repr([sorted(rewards.items()), sorted(terms.items()), sorted(truncs.items()),
                       sorted((a, sorted(i.items())) for a, i in infos.items())]).encode())
        steps += 1
    return [h.hexdigest(), json.dumps(env.episode_summary(), sort_keys=True, default=str)]


def test_the_interpreted_form_gives_the_same_rewards_infos_and_summary_bit_for_bit():
    """The per-step loops (the slaves' commands, the move out of a slot, the contacts, the stale
    fixes, the infos, the drained batteries, the rewards) give the same episode in both forms."""
    out = in_both_forms("frame_episode")
    summary = json.loads(out["0"][1])
    assert summary["faults_injected"] == 2 and summary["collisions"]["robot_robot"] + summary["collisions"]["robot_user"] > 0
    assert out["1"] == out["0"]


def test_the_action_clip_takes_only_finite_actions():
    import numpy as np

    from petswarm_env.step_kernel import clip_finite

    arr = np.array([[2.0, -3.0, 0.5], [-0.0, 1.0, -1.5]], np.float32)
    assert clip_finite(arr)
    assert arr.tolist() == [[1.0, -1.0, 0.5], [-0.0, 1.0, -1.0]]
    bad = np.array([[2.0, 0.0, 0.0], [0.0, np.nan, 0.0]], np.float32)
    assert not clip_finite(bad)
    assert bad[0, 0] == 2.0  # left as it was: the caller names the agent


def master_drive() -> list:
    """The master-role controller and its user tracker (control/master.py) on random tracker fixes,
    odometry, belt reports (stop / walk, rotating or not) and both modes, and on seed 002 Table 4's
    turn on the spot (the leading arc): every command, track and walking direction as exact hex
    strings."""
    import math

    import numpy as np

    from petswarm_env.config import load_config
    from petswarm_env.control.master import BeltView, MasterController, UserTracker
    from tests.unit.test_master import _arc_in_place

    cfg = load_config()
    rng = np.random.default_rng(7)
    out = []
    for mode in ("following", "leading"):
        ctrl = MasterController(cfg.master, math.radians(cfg.lf.reliable_half_angle_deg))
        tracker = UserTracker(cfg.master.tracker_alpha, cfg.master.tracker_beta)
        tracker.reset(float(rng.uniform(-3.0, 3.0)))
        angle = 0.0
        for k in range(400):
            odo = tuple(rng.normal(0.0, 0.4, 3).tolist())
            tracker.move(odo, float(rng.uniform(-3.0, 3.0)), 0.1)
            if k % 4 == 0:
                tracker.fix(tuple(rng.normal((1.0, 0.0), 0.5).tolist()), 0.1 * k, float(rng.uniform(0.5, 1.0)))
            rotating = bool((k // 25) % 2)
            angle = angle + 0.05 if rotating else 0.0
            belt = BeltView(("stop", "walk", "rest", "run")[(k // 40) % 4], rotating, 0.5 if rotating else 0.0, angle)
            est = tracker.user_body(0.1 * k + 0.05)
            cmd = ctrl.command(est[0], est[1], belt, odo, mode, 1.0, 0.1)
            out.append([float(v).hex() for v in (*cmd, *est[0], *est[1], ctrl.walk_direction_rad)])
    for target in (90.0, -45.0):
        trace: list = []
        _arc_in_place(target, 3, None, trace)
        out.append([float(v).hex() for step in trace for v in step])
    return out


def test_the_interpreted_form_gives_the_same_master_commands_bit_for_bit():
    """The master-role controller (compiled: it runs every control period) gives the same commands,
    tracks and walking directions to the bit in both forms."""
    out = in_both_forms("master_drive")
    assert len(out["0"]) == 802
    assert out["1"] == out["0"]


def lf_fixes() -> list:
    """The LF chain (wearables/lf.py: the belt's RSSI readings of a burst pair and the paper's
    estimator, Eqs. 1–3) at belt positions in and outside the reliable region, behind the robot,
    beyond the hearing range and at the antennas, with RSSI quantisation and without: every fix as
    exact hex strings, and the rng's state after."""
    import numpy as np

    from petswarm_env.config import load_config
    from petswarm_env.wearables.lf import locate
    from tests.unit.test_lf import one_point_positions

    out = []
    for update in ({}, {"rssi_step_db": 0.0, "antenna_forward_m": 0.15}):
        cfg = load_config().lf.model_copy(update=update)
        rng = np.random.default_rng(3)
        for x, y in one_point_positions(cfg, np.random.default_rng(4), 60).tolist():
            out.append([float(v).hex() for v in locate(cfg, x, y, rng)])
        out.append(str(rng.bit_generator.state))
    return out


def test_the_interpreted_form_gives_the_same_lf_fixes_bit_for_bit():
    """The LF localisation (compiled: the master bursts every 350 ms) gives the same fixes, valid or
    not, and draws the same numbers in both forms."""
    out = in_both_forms("lf_fixes")
    valid = [fix[4] for fix in out["0"] if isinstance(fix, list)]
    assert valid.count(float(True).hex()) > 100 and valid.count(float(False).hex()) > 100
    assert out["1"] == out["0"]


def actions_stacks() -> list:
    """step_kernel.stack_actions (env._validate's fast path) on float32 actions (copied value by
    value), float64 and float16 ones (numpy's cast), a mix, read-only and strided arrays, values
    beyond [-1, 1] and beyond float32, and what it must refuse: each result as hex strings, or None."""
    import numpy as np

    from petswarm_env.step_kernel import stack_actions

    f32 = np.array([[2.0, -0.5, 0.25], [0.1, 0.2, -7.0], [1e-30, -1.0, 1.0]], np.float32)
    ro = f32[1].copy()
    ro.flags.writeable = False
    cases = [{"a": f32[0], "b": f32[1], "c": f32[2]},  # rows of one array (views)
             {"a": np.array([0.3, 1.5, -0.1]), "b": f32[1], "c": np.array([0.5, 0.5, 0.5], np.float16)},
             {"a": f32[0], "b": ro, "c": f32[:, 1]},  # read-only, strided
             {"a": f32[0], "b": np.array([1e39, 0.0, 0.0]), "c": f32[2]},  # beyond float32: inf, refused
             {"a": f32[0], "b": np.array([0.0, np.nan, 0.0], np.float32), "c": f32[2]},
             {"a": f32[0], "b": np.array([1, 0, 0]), "c": f32[2]},
             {"a": f32[0], "b": np.zeros(2, np.float32), "c": f32[2]},
             {"a": f32[0], "b": np.zeros((1, 3), np.float32), "c": f32[2]},
             {"a": f32[0], "b": np.zeros((3, 1), np.float32), "c": f32[2]},
             {"a": f32[0], "b": np.float32(0.0), "c": f32[2]},
             {"a": f32[0], "b": [0.0, 0.0, 0.0], "c": f32[2]},
             {"a": f32[0], "c": f32[2]}]
    out = []
    for acts in cases:
        values = lambda: {k: [float(x).hex() for x in np.ravel(v)] for k, v in acts.items() if isinstance(v, np.ndarray)}  # noqa: E731
        before = values()
        arr = stack_actions(acts, ["c", "a", "b"])
        assert values() == before  # the caller's arrays are left as they were
        out.append(None if arr is None else [arr.dtype.str, list(arr.shape), [float(v).hex() for v in arr.ravel()]])
    return out


def test_the_actions_stack_takes_only_float_arrays_of_three_finite_values():
    """step_kernel.stack_actions: a new clipped float32 array in the agents' order, or None for
    anything the checked loop must name (env.py); the same in both forms."""
    import numpy as np

    out = in_both_forms("actions_stacks")
    assert out["1"] == out["0"]
    stacks = out["0"]
    first = [float(np.float32(v)).hex() for v in (1e-30, -1.0, 1.0, 1.0, -0.5, 0.25, 0.1, 0.2, -1.0)]
    assert stacks[0] == ["<f4", [3, 3], first]
    assert stacks[1] is not None and stacks[2] is not None
    assert stacks[2][2][:3] == [float(np.float32(v)).hex() for v in (-0.5, 0.2, -1.0)]  # the strided column
    assert stacks[3:] == [None] * 9


def test_the_sum_of_squares_is_the_builtin_sums():
    from petswarm_env.step_kernel import sum_squares

    values = [0.1, 1e-17, 3.0, 0.7, 1e16, -2.5]
    assert sum_squares(values) == sum(v * v for v in values)
    assert sum_squares([]) == 0 and type(sum_squares([])) is int


def safety_rows() -> list:
    """The arbiter's safety stage on a ring as a numpy row and as the row's list of floats (the
    kernel's form, step_kernel.command_slaves): each result as hex strings, or None."""
    import numpy as np

    from petswarm_env.control.arbiter import ControlArbiter, SafetyStage

    rng = np.random.default_rng(11)
    arbiter = ControlArbiter(SafetyStage(8, 0.35, 0.3, 2.0))
    rings = np.where(rng.random((300, 8)) < 0.6, rng.uniform(0.05, 2.0, (300, 8)), 2.0)
    out = []
    for k, row in enumerate(rings.tolist()):
        cmd = tuple(float(v) for v in rng.uniform(-1.5, 1.5, 3))
        got = [arbiter.decide(cmd, None, ring, k % 50 == 0) for ring in (rings[k], row)]
        assert got[0] == got[1]
        out.append([[float(v).hex() for v in got[1][0]], got[1][1]])
    return out


def test_the_safety_stage_reads_a_ring_row_list_as_its_array():
    out = in_both_forms("safety_rows")
    assert out["1"] == out["0"]
    sources = [source for _, source in out["0"]]
    assert 30 < sources.count("safety") < 270 and "policy" in sources


def slave_lists() -> list:
    """step_kernel.slaves_of (``Swarm.slave_ids``) over a two-user episode's steps: each swarm's list,
    checked against the stations' own state and swarm PAN read one by one."""
    import numpy as np

    import petswarm_env
    from petswarm_env.step_kernel import slaves_of

    env = petswarm_env.parallel_env(**{"world.num_users": 2, "max_cycles": 40})
    env.reset(seed=1)
    out = []
    while env.agents:
        for sw in env.episode.swarms:
            got = slaves_of(sw.nodes, sw.pan)
            assert got == sorted(n for n, nd in sw.nodes.items() if nd.state == "slave" and nd.swarm_pan == sw.pan)
            out.append(got)
        env.step({a: np.zeros(3, np.float32) for a in env.agents})
    return out


def test_the_slave_lists_are_the_stations_in_slave_role_of_the_swarm():
    out = in_both_forms("slave_lists")
    assert out["1"] == out["0"] and any(out["0"])


def angle_wraps() -> list:
    """``geometry.wrap_float`` (the compiled modules' C call) against ``wrap_angle`` on the same floats
    (the edges of the wrap among them): each as a hex string."""
    import math

    import numpy as np

    from petswarm_env.sim.geometry import wrap_angle, wrap_float

    edges = [0.0, -0.0, math.pi, -math.pi, 2 * math.pi, -2 * math.pi, 3 * math.pi, -3 * math.pi, 1e6, -1e6,
             math.nextafter(-math.pi, 0.0), math.nextafter(-math.pi, -4.0), math.nextafter(math.pi, 4.0)]
    out = []
    for v in edges + np.random.default_rng(5).uniform(-50.0, 50.0, 3000).tolist():
        got = wrap_float(v)
        assert type(got) is float and got.hex() == wrap_angle(v).hex(), v
        out.append(got.hex())
    return out


def test_the_float_angle_wrap_is_wrap_angle_bit_for_bit():
    out = in_both_forms("angle_wraps")
    assert out["1"] == out["0"]


def stream_draws() -> list:
    """A ``Draws``' uniforms then normals (blocks of 16) against numpy's blocks of the same seed, each
    handed out last first: each as a hex string."""
    import numpy as np

    from petswarm_env.sim.draws import Draws

    draws = Draws(np.random.default_rng(4), block=16)
    got = [draws.uniform() for _ in range(40)] + [draws.normal() for _ in range(20)]
    ref = np.random.default_rng(4)  # the uniform stream's three blocks come first, then the normal one's two
    want = np.concatenate([ref.random(16)[::-1] for _ in range(3)])[:40].tolist()
    want += np.concatenate([ref.standard_normal(16)[::-1] for _ in range(2)])[:20].tolist()
    assert all(type(v) is float for v in got) and got == want
    return [v.hex() for v in got]


def test_the_draw_streams_hand_out_numpy_blocks_last_first_in_both_forms():
    out = in_both_forms("stream_draws")
    assert out["1"] == out["0"]


def _session_trace(env, obs: dict, steps: int, at_step=None) -> list:
    """``env`` driven ``steps`` steps by the scripted reference (``at_step(k)`` before step ``k``): per step,
    the first session's state, the master's command and the user's true position as exact hex strings,
    then the session's events, lost links and pairings."""
    from petswarm.baselines.policy import PolicySpec
    from petswarm.baselines.registry import make_policy

    policy = make_policy("scripted", PolicySpec.from_env(env), seed=0)
    episode = env.episode
    session = episode.sessions[0]
    out = []
    for k in range(steps):
        if at_step is not None:
            at_step(k)
        if not env.agents:
            break
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        robot = episode.world.robots[episode.swarm.master.node_id]
        out.append([session.state, session.paused, [float(v).hex() for v in (*robot.command, *episode.world.user.position)]])
    out.append([session.events, session.link_losses, session.pairings, session.commands_received])
    return out


def session_episodes() -> list:
    """The user session (middleware/user_session.py, compiled: it runs every control period) on the paths the
    golden cases do not take: a radio-silent master that releases its user (cut off), a dead leading master
    (the belt's supervision timeout, the successor's search and pairing), a master whose AHRS breaks (its
    tracker turned by its wheels), and an emergency whose alert makes the user step back (``_walk_back``)."""
    import math

    import petswarm_env

    out = []
    for overrides in ({"faults": [{"at_s": 1.0, "robot": "master", "kind": "radio_silent"}]},
                      {"swarm.mode": "leading", "faults": [{"at_s": 1.0, "robot": "master", "kind": "dead"}]},
                      {"user.scenario": "zigzag", "faults": [{"at_s": 2.0, "robot": "master", "kind": "ahrs"}]}):
        env = petswarm_env.parallel_env(**{"max_cycles": 400, **overrides})
        obs, _ = env.reset(seed=1)
        out.append(_session_trace(env, obs, 300))
    env = petswarm_env.parallel_env(**{"user.scenario": "straight", "max_cycles": 400})
    obs, _ = env.reset(seed=0)
    user = env.episode.world.user

    def displace(k: int) -> None:  # the walking user 2.5 m ahead at once, out of the master's reliable range
        if k == 100:
            h = user.heading
            user.body.position = (user.position[0] + 2.5 * math.cos(h), user.position[1] + 2.5 * math.sin(h))

    out.append(_session_trace(env, obs, 300, displace))
    return out


def test_the_interpreted_form_drives_the_same_user_sessions_bit_for_bit():
    """The user session gives the same states, master commands and user walks to the bit in both forms, on a
    release, a dead leading master's succession, a broken AHRS and an emergency with the user stepping back."""
    out = in_both_forms("session_episodes")
    released, succeeded, ahrs, emergency = out["0"]
    assert [r for _, r in released[-1][1]] == ["released"] and released[-1][2]  # cut off, then paired again
    assert [r for _, r in succeeded[-1][1]] == ["supervision_timeout"] and succeeded[-1][2]
    assert any(s == "leading" for s, *_ in succeeded[:-1])
    assert emergency[-1][0]["emergencies"] == 1 and any(paused for s, paused, _ in emergency[:-1] if s == "emergency")
    assert out["1"] == out["0"]
