"""The privileged teacher (training/teacher.py): a training labeller and an evaluation ceiling that
reads ground truth — never a policy a robot runs."""

import math
from pathlib import Path

import numpy as np
import pytest

from petswarm.baselines.registry import make_policy
from petswarm.baselines.policy import PolicySpec
from petswarm.evaluation.evaluate import make_team
from petswarm_env import parallel_env
from petswarm_env.config import ConfigError
from petswarm.training.config import load_train_config
from petswarm.training.teacher import TEACHER_NAME, PrivilegedTeacher, TeacherDriver, TeacherGains
from petswarm.training.warm_start import collect_demonstrations


def _world_command(env, agent, action):
    """The action's translation in the world frame (m/s)."""
    i = env.agent_robot(agent)
    robot = env.episode.world.robots[i]
    vx, vy = float(action[0]) * robot.cfg.max_speed_mps, float(action[1]) * robot.cfg.max_speed_mps
    c, s = math.cos(robot.heading), math.sin(robot.heading)
    return c * vx - s * vy, s * vx + c * vy


def test_the_teacher_heads_for_each_slaves_true_reference_point():
    env = parallel_env(**{"swarm.num_slaves": 4})
    env.reset(seed=3)
    teacher = PrivilegedTeacher(env, TeacherGains(push=0.0))  # no avoidance: the approach alone
    acts = teacher.act_all(env.agents)
    refs = env.episode.experimenter.references()
    far = 0
    for agent in env.agents:
        i = env.agent_robot(agent)
        px, py = env.episode.world.robots[i].position
        ex, ey = refs[i][0] - px, refs[i][1] - py
        d = math.hypot(ex, ey)
        if d < 0.3:
            continue
        far += 1
        wx, wy = _world_command(env, agent, acts[agent])
        assert (wx * ex + wy * ey) / (math.hypot(wx, wy) * d) > 0.99, agent  # straight at it (the reference stands)
        speed = math.hypot(wx, wy)
        vmax = env.episode.world.robots[i].cfg.max_speed_mps
        assert speed == pytest.approx(min(vmax, 4.0 * d, math.sqrt(3.0 * d)), rel=1e-4)  # the braking profile
    assert far >= 1, "the scattered start leaves some slave away from its slot"


def test_the_teacher_closes_the_formation_faster_than_the_scripted_reference():
    def rmse(drive):
        env = parallel_env(**{"swarm.num_slaves": 4, "max_cycles": 100})
        obs, _ = env.reset(seed=11)
        team = drive(env)
        team.reset(11)
        while env.agents:
            obs, *_ = env.step(team.act_all({a: obs[a] for a in env.agents}))
        return env.episode_summary()["formation_rmse_m"]

    scripted = rmse(lambda env: make_policy("scripted", PolicySpec.from_env(env)))
    teacher = rmse(TeacherDriver)
    assert teacher < 0.9 * scripted, (teacher, scripted)


def test_asking_one_robot_at_a_time_gives_the_actions_of_asking_all():
    env = parallel_env(**{"swarm.num_slaves": 3})
    obs, _ = env.reset(seed=5)
    together, alone = TeacherDriver(env), TeacherDriver(env)
    for _ in range(20):
        a = together.act_all({k: obs[k] for k in env.agents})
        b = {k: alone.act(k, obs[k]) for k in env.agents}
        assert all(np.array_equal(a[k], b[k]) for k in env.agents)
        obs, *_ = env.step(a)


def test_a_robot_without_a_reference_point_gets_a_zero_action():
    env = parallel_env()
    env.reset(seed=0)
    teacher = PrivilegedTeacher(env)
    teacher.act_all(env.agents)
    agent = env.agents[0]
    del teacher._refs[env.agent_robot(agent)]  # as for a robot that left the formation
    assert np.array_equal(teacher._act(agent, None), np.zeros(3, np.float32))


def test_the_sonar_keep_out_pushes_away_from_a_close_echo():
    env = parallel_env()
    obs, _ = env.reset(seed=0)
    teacher = PrivilegedTeacher(env, TeacherGains(gain=0.0, push=0.0, heading_gain=0.0))  # only the keep-out moves it
    agent = env.agents[0]
    n = env.cfg.robot.ultrasonic.count
    ranges = np.full(n, 2.0)
    ranges[0] = 0.2  # something 0.2 m ahead
    act = teacher.act_all([agent], {agent: ranges})[agent]
    ref_only = teacher.act_all([agent], {agent: np.full(n, 2.0)})[agent]
    assert act[0] < ref_only[0] - 0.5  # backs away from it
    assert act[1] == pytest.approx(ref_only[1], abs=1e-6)


def test_the_policy_registry_does_not_know_the_teacher_but_evaluation_does():
    env = parallel_env()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="unknown policy"):
        make_policy(TEACHER_NAME, PolicySpec.from_env(env))
    assert isinstance(make_team(env, TEACHER_NAME, {}, 0), TeacherDriver)
    mixed = make_team(env, "scripted", {"robot_2": TEACHER_NAME}, 0)
    assert isinstance(mixed.per_agent["robot_2"], TeacherDriver)


def test_a_teacher_word_names_the_teacher_of_a_training_config(tmp_path):
    """``privileged-teacher:CONFIG``: the ceiling of the policy a training config trains (its labelling teacher)."""
    from petswarm.training.teacher import teacher_gains_of

    assert teacher_gains_of(TEACHER_NAME) == TeacherGains()
    named = load_train_config(RECURRENT.with_name("recurrent_command_teacher.yaml")).recurrent.teacher_gains()
    assert named.master_command and teacher_gains_of(f"{TEACHER_NAME}:recurrent_command_teacher") == named
    assert teacher_gains_of(f"{TEACHER_NAME}:{RECURRENT.with_name('recurrent_command_teacher.yaml')}") == named
    env = parallel_env()
    env.reset(seed=0)
    assert make_team(env, f"{TEACHER_NAME}:recurrent_command_teacher", {}, 0).teacher.g == named
    for bad in ("nope", ""):
        with pytest.raises(ConfigError, match="no training config"):
            teacher_gains_of(f"{TEACHER_NAME}:{bad}")
    broken = tmp_path / "broken.yaml"
    broken.write_text("recurrent: {teacher_push: -1}\n")
    with pytest.raises(ConfigError, match="teacher_push"):
        teacher_gains_of(f"{TEACHER_NAME}:{broken}")


def test_privileged_labels_are_the_teachers_and_differ_from_the_references():
    cfg = load_train_config(overrides={"env.max_cycles": 30, "pretrain.teacher": "privileged"})
    env_cfg = cfg.env_config()
    obs, act, _ = collect_demonstrations(env_cfg, 60, 0.0, 7, 0.98, teacher="privileged")
    obs2, act2, _ = collect_demonstrations(env_cfg, 60, 0.0, 7, 0.98, teacher="privileged")
    _, scripted, _ = collect_demonstrations(env_cfg, 60, 0.0, 7, 0.98)
    assert np.array_equal(act, act2), "the same seed gives the same labels"
    assert act.shape == scripted.shape == (60, 3) and np.abs(act - scripted).max() > 0.1


def test_a_training_config_that_trains_nothing_is_refused():
    with pytest.raises(ConfigError, match="nothing would be trained"):
        load_train_config(overrides={"timesteps": 0, "pretrain.samples": 0})
    with pytest.raises(ConfigError, match="pretrain.teacher"):
        load_train_config(overrides={"pretrain.teacher": "oracle"})


def test_a_robot_that_cannot_know_where_its_swarm_is_is_labelled_with_the_reference():
    from petswarm.training.warm_start import ScriptedLabels, TeacherLabels

    env = parallel_env(**{"swarm.num_slaves": 3})
    obs, _ = env.reset(seed=2)
    for _ in range(15):  # fixes of the master and the neighbours have arrived
        obs, *_ = env.step({a: np.zeros(3, np.float32) for a in env.agents})
    sl = env.layout.slices
    agent = env.agents[0]
    seen = obs[agent].copy()
    lost = seen.copy()
    for p in ("master", "link0", "link1"):
        lost[sl[f"{p}.ir_age"].start] = 1.0  # every fix at the end of the age range
    label = TeacherLabels(env)
    assert not label.lost(seen) and label.lost(lost)
    out = label({agent: lost})
    assert np.array_equal(out[agent], ScriptedLabels(env)({agent: lost})[agent])
    teacher_only = TeacherLabels(env, lost_to_reference=False)
    assert np.array_equal(teacher_only({agent: lost})[agent], teacher_only.teacher.act_all(
        [agent], {agent: lost[sl["self.ultrasonic"]] * env.cfg.robot.ultrasonic.max_range_m})[agent])
    assert not np.array_equal(label({agent: seen})[agent], ScriptedLabels(env)({agent: seen})[agent])


def _until_a_member_is_dead(env, teacher):
    """Drive with ``teacher`` until a member of the master's table is off (dropout: a slave dies at 20 s,
    the master removes it about 1.5 s later); returns that robot's index."""
    obs, _ = env.reset(seed=0)  # (robot 3 dies, member 4's reference neighbour)
    truth = env.episode.truth
    teacher.reset()
    while env.agents:
        members = truth.swarms[0].master.know.members
        dead = [i for i in members.values() if not truth.robots[i].health.powered]
        if dead:
            return dead[0]
        acts = teacher.act_all(env.agents)
        obs, *_ = env.step(acts)
    raise AssertionError("no member died while still in the table")


RECURRENT = Path(__file__).resolve().parents[2] / "configs" / "train" / "recurrent.yaml"


@pytest.mark.parametrize("orphan_to_slot", [False, True])
def test_a_slave_whose_reference_neighbour_died_follows_its_slot_about_the_master(orphan_to_slot):
    env = parallel_env(**{"user.scenario": "dropout", "swarm.num_slaves": 4, "max_cycles": 300})
    teacher = PrivilegedTeacher(env, TeacherGains(orphan_to_slot=orphan_to_slot))
    dead = _until_a_member_is_dead(env, teacher)
    truth = env.episode.truth
    swarm = truth.swarms[0]
    members, formation = swarm.master.know.members, swarm.formation
    orphans = [(m, members[m]) for m, links in formation.links.items()
               if members.get(m) not in (None, dead) and any(members[link.neighbour] == dead for link in links)]
    assert orphans, "the dead member is some live member's reference neighbour"
    teacher.act_all(env.agents)  # reads the truth of this instant
    experimenter = truth.references()
    mx, my = truth.robots[swarm.master.node_id].position
    th = truth.robots[swarm.master.node_id].heading
    slots = formation.slot_positions()
    for m, idx in orphans:
        sx, sy = slots[m]
        slot = (mx + math.cos(th) * sx - math.sin(th) * sy, my + math.sin(th) * sx + math.cos(th) * sy)
        want = slot if orphan_to_slot else experimenter[idx][:2]
        assert teacher._refs[idx][:2] == pytest.approx(want, abs=1e-9)
        assert math.dist(slot, experimenter[idx][:2]) > 1e-6  # the two differ: the dead body is not at its slot's place


def test_a_recurrent_config_sets_the_labelling_teachers_constants():
    cfg = load_train_config(RECURRENT, overrides={"recurrent.teacher_push": 0.5, "recurrent.teacher_user_keep_out_m": 0.9,
                                                    "recurrent.teacher_orphan_to_slot": True})
    gains = cfg.recurrent.teacher_gains()
    assert (gains.push, gains.user_keep_out_m, gains.orphan_to_slot) == (0.5, 0.9, True)
    assert gains.gain == TeacherGains().gain  # the rest are the teacher's defaults
    default = load_train_config(RECURRENT).recurrent.teacher_gains()
    assert default == TeacherGains()
    # the committed config of docs/training.md's "A teacher that holds better"
    slot_teacher = load_train_config(RECURRENT.with_name("recurrent_slot_teacher.yaml")).recurrent.teacher_gains()
    assert slot_teacher == TeacherGains(push=0.5, user_keep_out_m=0.9, orphan_to_slot=True)
    # docs/training.md's "A teacher that leads with its master's command": the slot teacher and two keys more
    command = load_train_config(RECURRENT.with_name("recurrent_command_teacher.yaml")).recurrent.teacher_gains()
    assert command == TeacherGains(push=0.5, user_keep_out_m=0.9, orphan_to_slot=True, master_command=True,
                                   differential_gain=2.0)


def test_with_master_command_the_reference_points_lead_by_the_masters_command_beyond_its_motion():
    env = parallel_env(**{"user.scenario": "stop_and_go", "swarm.spawn": "at_slots", "max_cycles": 200})
    env.reset(seed=2)
    follows, leads = PrivilegedTeacher(env), PrivilegedTeacher(env, TeacherGains(master_command=True))
    truth, leading = env.episode.truth, 0
    for _ in range(150):
        acts = follows.act_all(env.agents)
        leads.act_all(env.agents)
        master = truth.robots[truth.swarms[0].master.node_id]
        (mx, my), th = master.position, master.heading
        cvx, cvy, _ = master.motor_command  # its own frame: what its MCU sent the motors
        mvx, mvy = follows._vel[master.index]
        lead = (math.cos(th) * cvx - math.sin(th) * cvy - mvx, math.sin(th) * cvx + math.cos(th) * cvy - mvy)
        for i, v in follows._ref_vel.items():
            assert leads._ref_vel[i] == pytest.approx((v[0] + lead[0], v[1] + lead[1], v[2]), abs=1e-9)
        leading += math.hypot(*lead) > 0.05  # the user starts and stops: the command runs ahead of the wheels
        env.step(acts)
    assert leading >= 5


def _stop_and_go_hold(gains: TeacherGains) -> float:
    env = parallel_env(**{"user.scenario": "stop_and_go", "swarm.formation": "grid", "swarm.spawn": "at_slots",
                          "max_cycles": 400})
    obs, _ = env.reset(seed=5)
    team = TeacherDriver(env, gains)
    team.reset(5)
    while env.agents:
        obs, *_ = env.step(team.act_all({a: obs[a] for a in env.agents}))
    return env.episode_summary()["formation_hold_rmse_m"]


def test_a_teacher_that_leads_with_the_masters_command_holds_a_stop_and_go_walk_better():
    # the slaves start and stop with the master, not one motor ramp after it (docs/training.md; with the slot
    # teacher's push and keep-out, which a grid's close neighbours need: 0.087 -> 0.058 m on this seed)
    slot = {"push": 0.5, "user_keep_out_m": 0.9}
    assert _stop_and_go_hold(TeacherGains(**slot, master_command=True)) < 0.8 * _stop_and_go_hold(TeacherGains(**slot))


def test_a_differential_body_approaches_its_point_with_the_differential_gain():
    env = parallel_env(**{"user.scenario": "heterogeneous"})
    env.reset(seed=3)
    teacher = PrivilegedTeacher(env, TeacherGains(push=0.0, differential_gain=2.0, sonar_keep_out_m=0.0))
    acts, refs = teacher.act_all(env.agents), env.episode.experimenter.references()
    seen = set()
    for agent in env.agents:
        i = env.agent_robot(agent)
        robot = env.episode.world.robots[i]
        d = math.dist(refs[i][:2], robot.position)
        if i not in refs or d < 0.3:
            continue
        gain = 2.0 if robot.spec.drive == "differential" else 4.0
        speed = math.hypot(*_world_command(env, agent, acts[agent]))
        assert speed == pytest.approx(min(robot.cfg.max_speed_mps, gain * d, math.sqrt(3.0 * d)), rel=1e-4), agent
        seen.add(robot.spec.drive)
    assert "differential" in seen
