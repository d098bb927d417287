"""The estimating policy (baselines/estimator.py, training/estimator.py): its law is the teacher's on
the teacher's own reads, its file round-trips through the policy loader and refuses a bad record by
name, a lost robot drives by the scripted reference, and the labels and the error measurement read
the truth only at training time."""

import json
import math

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from petswarm.baselines.estimator import OUTPUTS, EstimatorPolicy, estimate_law, fix_indices, lost_mask  # noqa: E402
from petswarm.baselines.learned import LearnedPolicy, PolicyLoadError, read_policy  # noqa: E402
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm.baselines.registry import make_policy  # noqa: E402
from petswarm.training.estimator import (EstimateLabels, clip_length, estimate_error, estimator_meta,  # noqa: E402
                                         scripted_offset, scripted_pair)
from petswarm.training.recurrent import RecurrentActor, export_actor, numpy_policy  # noqa: E402
from petswarm.training.teacher import PrivilegedTeacher, TeacherGains  # noqa: E402
from petswarm_env import parallel_env  # noqa: E402
from petswarm_env.wrappers import FixedAgents  # noqa: E402


@pytest.fixture(scope="module")
def spec():
    return PolicySpec.from_env(parallel_env())


def _actor(spec, seed=0):
    torch.manual_seed(seed)
    return RecurrentActor(spec.layout.size, [32], 12, [16], outputs=len(OUTPUTS))


def _estimate(read):
    ex, ey, vx, vy, dth, w = read
    return [ex, ey, vx, vy, math.sin(dth), math.cos(dth), w]


def test_the_law_on_the_teachers_reads_is_the_teachers_action_without_its_truth_avoidance():
    env = parallel_env(**{"swarm.num_slaves": 4, "max_cycles": 60})
    obs, _ = env.reset(seed=5)
    gains = TeacherGains(push=0.0)  # the teacher's avoidance of other bodies (true positions) off: what the law keeps
    teacher = PrivilegedTeacher(env, gains)
    spec = PolicySpec.from_env(env)
    law = estimator_meta(1.0, spec, gains)["law"]
    sonar = env.layout.slices["self.ultrasonic"]
    checked = moving = 0
    while env.agents:
        ranges = {a: obs[a][sonar] * spec.us_max_range_m for a in env.agents}
        acts = teacher.act_all(env.agents, ranges)
        reads = teacher.reads(env.agents)
        for a in env.agents:
            if reads[a] is None:
                continue
            got = estimate_law(np.array([_estimate(reads[a])]), ranges[a][None], spec.max_speed_mps, spec.max_omega_rps, law)[0]
            assert np.abs(got - acts[a]).max() < 1e-5, a
            checked += 1
            moving += math.hypot(reads[a][2], reads[a][3]) > 0.05
        obs, *_ = env.step(acts)
    assert checked > 100 and moving > 20  # the reference points moved: the feed-forward was checked too


def test_an_estimating_policy_round_trips_its_file_and_acts_by_its_law(spec, tmp_path):
    actor = _actor(spec)
    meta = estimator_meta(1.0, spec)
    export_actor(actor, tmp_path / "est.npz", spec.layout, {"note": "test"}, estimator=meta)
    file_meta, layers, _ = read_policy(tmp_path / "est.npz")
    assert file_meta["estimator"] == json.loads(json.dumps(meta)) and layers[-1][0].shape[0] == len(OUTPUTS)
    loaded = LearnedPolicy.load(tmp_path / "est.npz", spec)
    assert isinstance(loaded, EstimatorPolicy)
    direct = numpy_policy(actor, spec, None, meta)
    env = parallel_env(**{"swarm.num_slaves": 3, "max_cycles": 40})
    obs, _ = env.reset(seed=2)
    seqs = []
    while env.agents:
        a1, a2 = loaded.act_all(obs), direct.act_all(obs)
        for a in obs:
            assert np.array_equal(a1[a], a2[a])
        seqs.append(obs["robot_1"])
        obs, *_ = env.step(a1)
    with torch.no_grad():  # the estimate is the torch network's output times the file's scale, step by step
        out, _ = actor(torch.as_tensor(np.stack(seqs)[None], dtype=torch.float32))
    assert np.abs(loaded.last_estimate["robot_1"] - out[0, -1].numpy() * np.array(meta["scale"])).max() < 1e-4


def test_a_bad_estimator_record_is_refused_by_name(spec, tmp_path):
    actor = _actor(spec)
    good = estimator_meta(1.0, spec)
    bad = [{**good, "outputs": list(OUTPUTS[:-1])}, {**good, "scale": [1.0] * 6}, {**good, "law": {"gain": 4.0}},
           {**good, "scale": [1.0, 1.0, -1.0, 1.0, 1.0, 1.0, 1.0]}]
    for k, record in enumerate(bad):
        export_actor(actor, tmp_path / f"bad{k}.npz", spec.layout, {}, estimator=record)
        with pytest.raises(PolicyLoadError, match="field 'estimator'"):
            LearnedPolicy.load(tmp_path / f"bad{k}.npz", spec)
    from petswarm.baselines.learned import Residual

    export_actor(actor, tmp_path / "res.npz", spec.layout, {}, residual=Residual("scripted", 0.5), estimator=good)
    with pytest.raises(PolicyLoadError, match="field 'estimator'.*residual_of"):
        LearnedPolicy.load(tmp_path / "res.npz", spec)


def test_a_lost_robot_drives_by_the_scripted_reference(spec):
    policy = numpy_policy(_actor(spec), spec, None, estimator_meta(1.0, spec))
    reference = make_policy("scripted", spec)
    env = parallel_env(**{"swarm.num_slaves": 3, "swarm.spawn": "at_slots"})
    obs, _ = env.reset(seed=1)
    for _ in range(5):  # the first IR fixes arrive
        obs, *_ = env.step(reference.act_all(obs))
    row = obs["robot_1"].copy()
    fixes = fix_indices(spec.layout)
    assert not lost_mask(row, fixes)[0]
    lost = row.copy()
    lost[fixes[:, 0]] = 0.0  # no IR fix of anyone
    assert lost_mask(lost, fixes)[0]
    policy.reset()
    got = policy.act_all({"robot_1": lost, "robot_2": row})
    assert np.array_equal(got["robot_1"], reference.act_all({"robot_1": lost})["robot_1"])
    assert not np.array_equal(got["robot_2"], reference.act_all({"robot_2": row})["robot_2"])  # the law acts where not lost


def test_the_labels_weigh_a_lost_step_zero_and_clip_the_offset(spec):
    env = FixedAgents(parallel_env(**{"swarm.num_slaves": 3}))
    rows, _ = env.reset(seed=4)
    teacher = PrivilegedTeacher(env)
    labels = EstimateLabels(env, 0.5)
    live = {a: rows[a] for a in env.agents}
    out = labels(teacher, live)
    reads = teacher.reads(list(live))
    for a, (target, valid) in out.items():
        off = np.hypot(*reads[a][:2])
        assert np.hypot(*target[:2]) == pytest.approx(min(off, 0.5) / 0.5, rel=1e-5)
        assert target[4] ** 2 + target[5] ** 2 == pytest.approx(1.0, rel=1e-5)
        assert valid == (not lost_mask(rows[a], labels.fixes)[0])
    a = next(iter(live))
    lost = dict(live)
    lost[a] = live[a].copy()
    lost[a][labels.fixes[:, 0]] = 0.0
    assert labels(teacher, lost)[a][1] is False


def test_the_scripted_offset_is_its_reference_location_and_the_error_is_measured():
    env = FixedAgents(parallel_env(**{"swarm.num_slaves": 4, "swarm.spawn": "at_slots", "max_cycles": 80}))
    rows, infos = env.reset(seed=3)
    spec = PolicySpec.from_env(env)
    pair, teacher = scripted_pair(spec), PrivilegedTeacher(env)
    errs = []
    reference = make_policy("scripted", spec)
    while env.agents:
        reads = teacher.reads(env.agents)
        for a in env.agents:
            est = scripted_offset(pair, rows[a], spec.max_speed_mps)
            errs.append(np.hypot(*(est - np.array(reads[a][:2]))))
        rows, _, _, _, infos = env.step(reference.act_all({a: rows[a] for a in env.agents}))
    assert np.sqrt(np.mean(np.square(errs))) < 0.25  # at the slots the reference's frame knows its location to ~0.1 m
    policy = numpy_policy(_actor(spec), spec, None, estimator_meta(1.0, spec))
    res = estimate_error(env, policy, [3], 1.0, "teacher")
    assert res["samples"] > 200 and set(res["offset_rms_m"]) == {"gru", "scripted", "zero"}
    assert res["offset_rms_m"]["gru"]["all"] > res["offset_rms_m"]["scripted"]["all"]  # an untrained GRU knows nothing


def test_clip_length_keeps_direction():
    v = clip_length(np.array([[3.0, 4.0], [0.3, 0.4]]), 1.0)
    assert np.allclose(v, [[0.6, 0.8], [0.3, 0.4]])


def test_a_law_rewritten_after_training_keeps_the_weights(spec, tmp_path):
    from petswarm.training.estimator import relaw

    export_actor(_actor(spec), tmp_path / "a.npz", spec.layout, {}, estimator=estimator_meta(1.0, spec))
    relaw(str(tmp_path / "a.npz"), str(tmp_path / "b.npz"), {"gain": 2.0})
    (ma, la, ca), (mb, lb, cb) = read_policy(tmp_path / "a.npz"), read_policy(tmp_path / "b.npz")
    assert ma["estimator"]["law"]["gain"] == 4.0 and mb["estimator"]["law"]["gain"] == 2.0
    assert all(np.array_equal(x[0], y[0]) for x, y in zip(la, lb)) and np.array_equal(ca.cell.w_hh, cb.cell.w_hh)
    with pytest.raises(SystemExit, match="not a law constant"):
        relaw(str(tmp_path / "a.npz"), str(tmp_path / "c.npz"), {"push": 1.0})
