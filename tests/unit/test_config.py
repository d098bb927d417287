"""Typed configuration: defaults, overrides and clear errors (petswarm_env/config.py)."""

import pytest
import yaml

import petswarm_env
from petswarm_env.config import Config, ConfigError, default_config_path, load_config, parse_override


def test_defaults_load():
    cfg = load_config()
    assert isinstance(cfg, Config)
    # a few documented defaults (SPEC §1, §3.1)
    assert cfg.robot.max_speed_mps == 1.5
    assert cfg.robot.max_omega_rps == 2.0
    assert cfg.robot.max_accel_mps2 == 2.0
    assert cfg.control_period_s == 0.1
    assert cfg.physics_substeps >= 5
    assert cfg.protocol.join_radius_m == 3.0
    assert cfg.master.distance_m == 1.0
    assert cfg.radio.bitrate_bps == 250000
    assert cfg.swarm.formation in ("column", "row", "wedge", "grid", "custom")


def test_default_file_is_the_single_source():
    raw = yaml.safe_load(default_config_path().read_text())
    assert load_config().to_dict()["swarm"]["num_slaves"] == raw["swarm"]["num_slaves"]


def test_dotted_override_changes_a_value():
    base = load_config()
    cfg = load_config(overrides={"swarm.num_slaves": 2, "radio.loss_prob": 0.25, "robot.ultrasonic.count": 4})
    assert cfg.swarm.num_slaves == 2
    assert cfg.radio.loss_prob == 0.25
    assert cfg.robot.ultrasonic.count == 4
    # the others untouched
    assert cfg.swarm.formation == base.swarm.formation
    assert cfg.robot.max_speed_mps == base.robot.max_speed_mps


def test_section_override_merges_not_replaces():
    cfg = load_config(overrides={"swarm": {"num_slaves": 3}})
    assert cfg.swarm.num_slaves == 3
    assert cfg.swarm.spacing_m == load_config().swarm.spacing_m


def test_file_then_overrides(tmp_path):
    p = tmp_path / "my.yaml"
    p.write_text("swarm:\n  num_slaves: 2\n  formation: column\nradio:\n  loss_prob: 0.1\n")
    cfg = load_config(p, {"swarm.num_slaves": 5})
    assert cfg.swarm.num_slaves == 5  # the override wins over the file
    assert cfg.swarm.formation == "column"
    assert cfg.radio.loss_prob == 0.1


def test_empty_file_gives_defaults(tmp_path):
    p = tmp_path / "empty.yaml"
    p.write_text("")
    assert load_config(p) == load_config()


def test_config_is_frozen():
    cfg = load_config()
    with pytest.raises(Exception):
        cfg.swarm.num_slaves = 7
    assert cfg.swarm.num_slaves == load_config().swarm.num_slaves


@pytest.mark.parametrize(
    "key, named",
    [
        ("swarm.formaton", "swarm.formaton"),
        ("robot.ultrasonic.cnt", "robot.ultrasonic.cnt"),
        ("nonsense", "nonsense"),
        ("radoi.loss_prob", "radoi"),  # the first unknown part of the path is named
    ],
)
def test_unknown_key_names_the_key(key, named):
    with pytest.raises(ConfigError) as exc:
        load_config(overrides={key: 1})
    msg = str(exc.value)
    assert f"'{named}'" in msg
    assert "unknown" in msg


def test_unknown_key_lists_allowed_keys():
    with pytest.raises(ConfigError, match="formation") as exc:
        load_config(overrides={"swarm.formaton": "row"})
    assert "num_slaves" in str(exc.value)


def test_unknown_key_in_file(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("swarm:\n  formaton: row\n")
    with pytest.raises(ConfigError, match=r"'swarm\.formaton'"):
        load_config(p)


def test_unknown_key_inside_a_list_item():
    links = [{"robot": 1, "neighbour": 0, "offset_m": [-1, 0], "weight": 2}]
    with pytest.raises(ConfigError, match=r"swarm\.custom_links\.0\.weight"):
        load_config(overrides={"swarm.formation": "custom", "swarm.custom_links": links})


@pytest.mark.parametrize(
    "key, value, must_contain",
    [
        ("swarm.formation", "hexagon", ["'column'", "'row'", "'wedge'", "'grid'", "'custom'", "hexagon"]),
        ("swarm.mode", "sideways", ["'following'", "'leading'"]),
        ("user.scenario", "moonwalk", ["'straight'", "'zigzag'", "'u_turn'", "'random_walk'", "moonwalk"]),
        ("radio.loss_prob", 1.5, ["1.5", "less than or equal to 1"]),
        ("radio.loss_prob", -0.1, ["greater than or equal to 0"]),
        ("swarm.num_slaves", 0, ["greater than or equal to 1"]),
        ("swarm.num_slaves", "three", ["integer"]),
        ("control_period_s", 0, ["greater than or equal to 0.001"]),
    ],
)
def test_bad_value_names_key_and_allowed(key, value, must_contain):
    with pytest.raises(ConfigError) as exc:
        load_config(overrides={key: value})
    msg = str(exc.value)
    assert f"'{key}'" in msg
    for part in must_contain:
        assert part in msg


def test_cross_field_check_names_the_keys():
    with pytest.raises(ConfigError, match=r"radio\.max_be") as exc:
        load_config(overrides={"radio.min_be": 5, "radio.max_be": 3})
    assert "radio.min_be" in str(exc.value)


def test_bad_yaml_file(tmp_path):
    p = tmp_path / "broken.yaml"
    p.write_text("swarm: [1, 2\n")
    with pytest.raises(ConfigError, match="not valid YAML") as exc:
        load_config(p)
    assert str(p) in str(exc.value)


def test_yaml_that_is_not_a_mapping(tmp_path):
    p = tmp_path / "list.yaml"
    p.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="mapping"):
        load_config(p)


def test_missing_file(tmp_path):
    p = tmp_path / "nope.yaml"
    with pytest.raises(ConfigError, match="does not exist") as exc:
        load_config(p)
    assert "nope.yaml" in str(exc.value)


def test_config_error_is_a_value_error():
    assert issubclass(ConfigError, ValueError)


def test_parse_override():
    assert parse_override("swarm.num_slaves=3") == ("swarm.num_slaves", 3)
    assert parse_override("radio.loss_prob=0.1") == ("radio.loss_prob", 0.1)
    assert parse_override("world.arena_m=[10, 20]") == ("world.arena_m", [10, 20])
    assert parse_override("swarm.formation=row") == ("swarm.formation", "row")
    with pytest.raises(ConfigError, match="KEY=VALUE"):
        parse_override("swarm.num_slaves")


def test_parallel_env_with_dotted_override():
    env = petswarm_env.parallel_env(**{"swarm.num_slaves": 2})
    assert env.cfg.swarm.num_slaves == 2
    assert env.possible_agents == ["robot_1", "robot_2"]
    _, infos = env.reset(seed=0)
    assert len(env.agents) == 2
    assert set(infos) == set(env.agents)


def test_parallel_env_with_double_underscore_override():
    env = petswarm_env.parallel_env(swarm__num_slaves=3, radio__loss_prob=0.05)
    assert env.cfg.swarm.num_slaves == 3
    assert env.cfg.radio.loss_prob == 0.05


def test_parallel_env_refuses_bad_override():
    with pytest.raises(ConfigError, match=r"'swarm\.formaton'"):
        petswarm_env.parallel_env(**{"swarm.formaton": "row"})


def test_parallel_env_with_config_object_and_overrides():
    cfg = load_config(overrides={"swarm.formation": "column"})
    env = petswarm_env.parallel_env(cfg, **{"swarm.num_slaves": 2})
    assert env.cfg.swarm.formation == "column"
    assert env.cfg.swarm.num_slaves == 2
