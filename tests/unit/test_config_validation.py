"""Bad config input, every section (issue 14 part 2): each case is refused with a one-line
ConfigError that names the key; booleans are not numbers; NaN and infinity are not floats; min/max
pairs are ordered; YAML that is not a mapping, does not parse or has unknown keys is refused."""

import math

import pytest
import yaml

from petswarm_env.config import ConfigError, default_config_path, flatten_dotted, load_config, parse_override

DEFAULTS = flatten_dotted(yaml.safe_load(default_config_path().read_text()))


def _refused(overrides=None, path=None) -> str:
    with pytest.raises(ConfigError) as info:
        load_config(path, overrides)
    message = str(info.value)
    assert "\n" not in message and "Traceback" not in message
    return message


# (overrides, words the message must hold): at least one case in every section
CASES = [
    ({"seed": -1}, "seed"),
    ({"seed": 1.5}, "seed"),
    ({"max_cycles": 0}, "max_cycles"),
    ({"control_period_s": 0}, "control_period_s"),
    ({"physics_substeps": 0}, "physics_substeps"),
    ({"physics_substeps": 101}, "physics_substeps"),
    ({"world.arena_m": [0, 5]}, "world.arena_m"),
    ({"world.arena_m": [-4, -4]}, "world.arena_m"),
    ({"world.arena_m": [1, 2, 3]}, "world.arena_m"),
    ({"world.arena_m": "big"}, "world.arena_m"),
    ({"world.obstacles": [{"center_m": [2, 0], "size_m": [0, 1]}]}, "world.obstacles[0].size_m"),
    ({"world.obstacles": [{"center_m": [99.5, 0], "size_m": [2, 1]}]}, "world.obstacles[0]"),
    ({"world.obstacles": [{"center_m": [2, 0]}]}, "size_m"),
    ({"world.obstacles": [{"center_m": [2, 0], "size_m": [1, 1], "colour": "red"}]}, "colour"),
    ({"world.obstacles": 3}, "world.obstacles"),
    ({"world.num_users": 0}, "world.num_users"),
    ({"world.num_users": 9}, "world.num_users"),
    ({"world.user_spacing_m": 0}, "world.user_spacing_m"),
    ({"robot.radius_m": 0}, "robot.radius_m"),
    ({"robot.max_speed_mps": -1}, "robot.max_speed_mps"),
    ({"robot.ultrasonic.min_range_m": 3.0}, "robot.ultrasonic.min_range_m"),
    ({"robot.ultrasonic.min_range_m": 2.0}, "robot.ultrasonic.max_range_m"),
    ({"robot.ultrasonic.count": 33}, "robot.ultrasonic.count"),
    ({"robot.ahrs_noise_deg": -1}, "robot.ahrs_noise_deg"),
    ({"swarm.num_slaves": 0}, "swarm.num_slaves"),
    ({"swarm.num_slaves": 17}, "swarm.num_slaves"),
    ({"swarm.num_slaves": "four"}, "swarm.num_slaves"),
    ({"swarm.formation": "circle"}, "swarm.formation"),
    ({"swarm.formation": "custom"}, "swarm.custom_links"),
    ({"swarm.custom_links": [{"robot": 0, "neighbour": 0, "offset_m": [1, 0]}]}, "swarm.custom_links.0.robot"),
    ({"swarm.mode": "sideways"}, "swarm.mode"),
    ({"swarm.master_change": "maybe"}, "swarm.master_change"),
    ({"swarm.spawn_jitter_m": -0.1}, "swarm.spawn_jitter_m"),
    ({"swarm.pool": [{"type": "tank", "count": 4}]}, "swarm.pool[0].type"),
    ({"robot_types.mybot.max_speed_mps": -1.0}, "robot_types.mybot.max_speed_mps"),
    ({"radio.loss_prob": 1.5}, "radio.loss_prob"),
    ({"radio.min_be": 6}, "radio.max_be"),
    ({"radio.max_be": 9}, "radio.max_be"),
    ({"radio.bitrate_bps": 0}, "radio.bitrate_bps"),
    ({"protocol.join_radius_m": 0}, "protocol.join_radius_m"),
    ({"protocol.max_retries": -1}, "protocol.max_retries"),
    ({"protocol.organize_timeout_s": 0}, "protocol.organize_timeout_s"),
    ({"swarm.assignment": "auction"}, "swarm.assignment"),
    ({"ruta.bid_timeout_s": 0}, "ruta.bid_timeout_s"),
    ({"ruta.max_trials": 0}, "ruta.max_trials"),
    ({"ir.num_receivers": 6}, "ir.num_receivers"),
    ({"ir.detect_threshold": 5000.0}, "ir.detect_threshold"),
    ({"ir.occlusion_attenuation": 2}, "ir.occlusion_attenuation"),
    ({"lf.table_max_m": 0.01}, "lf.table_max_m"),
    ({"lf.table_step_m": 5.0}, "lf.table_step_m"),
    ({"lf.sensitivity_db": 55.0}, "lf.sensitivity_db"),
    ({"lf.reliable_half_angle_deg": 90}, "lf.reliable_half_angle_deg"),
    ({"user.scenario": "moonwalk"}, "user.scenario"),
    ({"user.scenario_pool": ["zigzag", "moonwalk"]}, "user.scenario_pool"),
    ({"user.run_speed_mps": 0.5}, "user.run_speed_mps"),
    ({"user.walk_speed_mps": 0}, "user.walk_speed_mps"),
    ({"belt.sma_level3_mps2": 0.4}, "belt.sma_level3_mps2"),
    ({"belt.rotation_off_dps": 30.0}, "belt.rotation_off_dps"),
    ({"belt.window_s": 0.01}, "belt.window_s"),
    ({"belt.walk_cadence_hz": [1.0]}, "belt.walk_cadence_hz"),
    ({"watch.recognition_delay_s": 0.1}, "watch.recognition_delay_s"),
    ({"watch.circle_energy_ratio": 1.5}, "watch.circle_energy_ratio"),
    ({"master.tracker_alpha": 0}, "master.tracker_alpha"),
    ({"master.rotate_deadband_deg": 30}, "master.rotate_deadband_deg"),
    ({"control.safety_stop_m": 2.5}, "control.safety_stop_m"),
    ({"control.safety_layer": "maybe"}, "control.safety_layer"),
    ({"ble.report_period_s": 0}, "ble.report_period_s"),
    ({"reward.formation": "high"}, "reward.formation"),
    ({"render.size_px": [0, 10]}, "render.size_px"),
    ({"render.fps": 0}, "render.fps"),
    ({"swarm.nm_slaves": 3}, "swarm.nm_slaves"),
    ({"physics": {"g": 9.81}}, "physics"),
    ({"swarm": 5}, "swarm"),
    ({"swarm.num_slaves.x": 1}, "swarm.num_slaves"),
    ({"protocol.lost_after_rounds": 0}, "protocol.lost_after_rounds"),
    ({"protocol.status_timeout_s": 0}, "protocol.status_timeout_s"),
    ({"faults": [{"at_s": 1, "robot": 1, "kind": "zap"}]}, "faults[].kind"),
    ({"faults": [{"at_s": 1, "robot": 99, "kind": "dead"}]}, "faults[0].robot"),
    ({"faults": [{"at_s": 1, "robot": "boss", "kind": "dead"}]}, "faults[].robot"),
    ({"faults": [{"at_s": 1, "robot": 1, "kind": "dead", "duration_s": 0}]}, "duration_s"),
    ({"faults_random.kinds": ["zap"]}, "faults_random.kinds"),
    ({"faults_random.rate_per_min": -1}, "faults_random.rate_per_min"),
    ({"arrivals": [{"at_s": 1, "type": "tank"}]}, "arrivals[0].type"),
    ({"arrivals": [{"at_s": -1, "type": "petbot"}]}, "arrivals.0.at_s"),
]


@pytest.mark.parametrize("overrides, words", CASES, ids=[next(iter(o)) for o, _ in CASES])
def test_bad_value_is_refused_naming_the_key(overrides, words):
    assert words in _refused(overrides)


def test_every_section_has_a_bad_value_case():
    sections = {k.split(".")[0] for k in DEFAULTS}
    covered = {next(iter(o)).split(".")[0] for o, _ in CASES}
    assert sections - {"seed", "max_cycles", "control_period_s", "physics_substeps"} <= covered


NUMERIC_KEYS = [k for k, v in DEFAULTS.items() if isinstance(v, (int, float)) and not isinstance(v, bool)]
FLOAT_KEYS = [k for k, v in DEFAULTS.items() if isinstance(v, float)]
PAIR_KEYS = [k for k, v in DEFAULTS.items() if isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) for x in v)]


@pytest.mark.parametrize("key", NUMERIC_KEYS + PAIR_KEYS)
def test_a_boolean_is_not_a_number(key):
    value = [True, DEFAULTS[key][1]] if key in PAIR_KEYS else True
    message = _refused({key: value})
    assert key in message and "boolean" in message


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf], ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("key", FLOAT_KEYS + [k for k in PAIR_KEYS if isinstance(DEFAULTS[k][0], float)])
def test_nan_and_infinity_are_not_floats(key, bad):
    value = [bad, DEFAULTS[key][1]] if key in PAIR_KEYS else bad
    message = _refused({key: value})
    assert key in message and "finite" in message


def test_booleans_stay_booleans():
    cfg = load_config(overrides={"control.safety_layer": False, "swarm.master_change": False})
    assert cfg.control.safety_layer is False and cfg.swarm.master_change is False


@pytest.mark.parametrize(
    "text, words",
    [
        ("- 1\n- 2\n", "must hold a mapping"),
        ("just a string\n", "must hold a mapping"),
        ("swarm: [1\n", "not valid YAML"),
        ("swarm:\n  num_slaves: 3\n bad_indent: 1\n", "not valid YAML"),
        ("swarm:\n  nm_slaves: 3\n", "swarm.nm_slaves"),
        ("warp_drive: true\n", "warp_drive"),
        ("swarm: 4\n", "swarm"),
        ("reward:\n  formation: .nan\n", "reward.formation"),
        ("swarm:\n  num_slaves: yes\n", "swarm.num_slaves"),
    ],
)
def test_bad_yaml_file_is_refused_naming_file_or_key(tmp_path, text, words):
    path = tmp_path / "my.yaml"
    path.write_text(text)
    message = _refused(path=path)
    assert words in message
    if "YAML" in words or "mapping" in words:
        assert "my.yaml" in message


def test_yaml_that_is_not_text_a_folder_or_missing(tmp_path):
    binary = tmp_path / "b.yaml"
    binary.write_bytes(bytes(range(256)))
    assert "not UTF-8" in _refused(path=binary)
    assert "is a folder" in _refused(path=tmp_path)
    assert "does not exist" in _refused(path=tmp_path / "nope.yaml")


def test_override_that_is_not_key_value_or_conflicts():
    with pytest.raises(ConfigError, match="KEY=VALUE"):
        parse_override("swarm.num_slaves")
    assert "conflicts" in _refused({"swarm": 1, "swarm.num_slaves": 2})


def test_training_config_refuses_bad_values_naming_the_key():
    pytest.importorskip("stable_baselines3")
    from petswarm.training.config import load_train_config

    for overrides, words in [({"ppo.gamma": 2}, "ppo.gamma"), ({"ppo.net_arch": [True, 8]}, "ppo.net_arch"),
                             ({"ppo.learning_rate": math.nan}, "ppo.learning_rate"), ({"bogus": 1}, "bogus"),
                             ({"env.swarm.num_slaves": True}, "env.KEY"), ({"timesteps": True}, "timesteps")]:
        with pytest.raises(ConfigError) as info:
            load_train_config(overrides=overrides)
        assert words in str(info.value) and "\n" not in str(info.value)
