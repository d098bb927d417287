"""Bad config input, every section: each case is refused with a one-line
ConfigError that names the key; booleans are not numbers; NaN and infinity are not floats; min/max
pairs are ordered; YAML that is not a mapping, does not parse or has unknown keys is refused."""

import math

import numpy as np
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
    ({"succession.election_window_s": 0}, "succession.election_window_s"),
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
    ({"faults": [{"at_s": 1, "robot": 1, "kind": "dead", "duration_s": 1e-300}]}, "duration_s"),
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


# -- YAML within bounds: alias bombs, deep nesting, huge numbers (one line, fast, naming the input) --
def _alias_bomb(levels: int = 9, width: int = 9) -> str:
    """A "billion laughs": each anchor a list of ``width`` aliases of the previous one."""
    rows = ["&a0 [" + ", ".join(['"lol"'] * width) + "]"]
    rows += [f"&a{k} [" + ", ".join([f"*a{k - 1}"] * width) + "]" for k in range(1, levels)]
    return "[" + ", ".join(rows) + "]"


@pytest.mark.parametrize("levels, width", [(9, 9), (12, 5), (30, 2)])
@pytest.mark.parametrize("key", ["world.obstacles", "reward.formation", "swarm.custom_links", "faults"])
def test_an_alias_bomb_is_refused_in_a_file_and_in_set(tmp_path, key, levels, width):
    import time

    section, _, leaf = key.rpartition(".")
    text = f"{section}:\n  {leaf}: {_alias_bomb(levels, width)}\n" if section else f"{leaf}: {_alias_bomb(levels, width)}\n"
    (tmp_path / "bomb.yaml").write_text(text)
    t0 = time.perf_counter()
    assert "aliases" in _refused(path=tmp_path / "bomb.yaml") and "bomb.yaml" in _refused(path=tmp_path / "bomb.yaml")
    with pytest.raises(ConfigError, match=f"--set {key} expands"):
        parse_override(f"{key}={_alias_bomb(levels, width)}")
    assert time.perf_counter() - t0 < 5


def test_a_recursive_alias_is_refused(tmp_path):
    (tmp_path / "r.yaml").write_text("reward:\n  formation: &x [*x]\n")
    assert "its own anchor" in _refused(path=tmp_path / "r.yaml")


@pytest.mark.parametrize("depth", [60, 20_000, 60_000])
@pytest.mark.parametrize("kind", ["flow", "block"])
def test_deep_yaml_is_refused_in_one_line(tmp_path, depth, kind):
    if kind == "flow":
        text = "swarm: " + "[" * depth + "]" * depth + "\n"
    else:
        text = "".join(" " * k + f"k{k}:\n" for k in range(min(depth, 300))) + " " * min(depth, 300) + "x: 1\n"
    (tmp_path / "deep.yaml").write_text(text)
    message = _refused(path=tmp_path / "deep.yaml")
    assert "deep.yaml" in message and "nested more than" in message


@pytest.mark.parametrize("number", ["9" * 5000, "-" + "1" * 4301, "1" * 200 + ".5", "0x" + "f" * 300])
def test_a_huge_number_names_the_file_or_the_key(tmp_path, number):
    (tmp_path / "big.yaml").write_text(f"max_cycles: {number}\n")
    message = _refused(path=tmp_path / "big.yaml")
    assert "big.yaml" in message and "characters" in message
    with pytest.raises(ConfigError, match="--set seed has a number of"):
        parse_override(f"seed={number}")


def test_a_key_that_is_not_text_is_refused(tmp_path):
    (tmp_path / "k.yaml").write_text("1: 2\n")
    assert "k.yaml" in _refused(path=tmp_path / "k.yaml")


def test_a_device_as_a_config_file_is_refused():
    assert "not a regular file" in _refused(path="/dev/zero")


def test_a_grid_and_a_training_file_use_the_same_bounds(tmp_path):
    from petswarm.evaluation.grid_spec import load_grid

    (tmp_path / "g.yaml").write_text(f"seed: 0\nepisodes: 1\ncells: {_alias_bomb()}\n")
    with pytest.raises(ConfigError, match="grid file '.*g.yaml' expands"):
        load_grid(str(tmp_path / "g.yaml"))
    pytest.importorskip("stable_baselines3")
    from petswarm.training.config import load_train_config

    (tmp_path / "t.yaml").write_text(f"ppo:\n  net_arch: {_alias_bomb()}\n")
    with pytest.raises(ConfigError, match="t.yaml' expands"):
        load_train_config(path=tmp_path / "t.yaml")


def test_a_long_value_in_a_message_is_cut(tmp_path):
    message = _refused({"reward.formation": list(range(100_000))})
    assert len(message) < 300


# -- every number of the config has a physical range, and its extremes are refused or run --------
def _sections():
    """Every config section class reachable from Config (nested sections, list and dict items)."""
    import typing

    from petswarm_env.config import Config
    from petswarm_env.config_base import Section

    seen, todo = [], [Config]
    while todo:
        cls = todo.pop()
        if cls in seen:
            continue
        seen.append(cls)
        for info in cls.model_fields.values():
            stack = [info.annotation]
            while stack:
                t = stack.pop()
                if isinstance(t, type) and issubclass(t, Section):
                    todo.append(t)
                stack.extend(typing.get_args(t))
    return seen


def _bounds(metadata) -> tuple[bool, bool]:
    metadata = [m for item in metadata for m in (getattr(item, "metadata", None) or [item])]  # a Field() inside Annotated
    low = any(hasattr(m, "gt") or hasattr(m, "ge") for m in metadata)
    high = any(hasattr(m, "lt") or hasattr(m, "le") for m in metadata)
    return low, high


def _unbounded_numbers(annotation, metadata, where) -> list[str]:
    """The numbers in a field's type (the field itself, or the items of a tuple) without a lower
    and an upper bound."""
    import typing

    if annotation in (int, float):
        low, high = _bounds(metadata)
        return [] if low and high else [where]
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Annotated:
        return _unbounded_numbers(args[0], [*metadata, *args[1:]], where)
    if origin is tuple:
        return [w for k, a in enumerate(a for a in args if a is not Ellipsis) for w in _unbounded_numbers(a, [], f"{where}[{k}]")]
    if origin in (typing.Union, __import__("types").UnionType):
        return [w for a in args if a is not type(None) for w in _unbounded_numbers(a, metadata, where)]
    return []


SIZE_EXEMPT = {"RenderConfig.size_px[0]", "RenderConfig.size_px[1]"}  # 1..8192 in RenderConfig._check_size


def test_every_number_of_the_config_has_a_lower_and_an_upper_bound():
    missing = [w for cls in _sections() for name, info in cls.model_fields.items()
               for w in _unbounded_numbers(info.annotation, info.metadata, f"{cls.__name__}.{name}")]
    assert sorted(set(missing) - SIZE_EXEMPT) == []
    assert len(_sections()) >= 25


WALK_VALUES = [1e-9, 0, -1, 1e300, math.inf, math.nan]
WALK_KEYS = NUMERIC_KEYS + PAIR_KEYS + [f"robot_types.mybot.{k}" for k in ("radius_m", "max_speed_mps", "lookahead_m",
                                                                           "battery_mah", "wheel_slip_pct", "servo_ma")]


class _Hang(Exception):
    pass


def _alarm(signum, frame):
    raise _Hang


def _own_bounds(key: str) -> list[float]:
    """The field's own lowest and highest allowed values (just inside an excluded bound)."""
    from petswarm_env.config import Config
    from petswarm_env.config_base import field_bounds

    loc = tuple(key.split(".")) + ((0,) if key in PAIR_KEYS else ())
    bounds = field_bounds(Config, loc)
    if bounds is None:
        return []
    lo, above, hi, below = bounds
    whole = isinstance(DEFAULTS[key][0] if key in PAIR_KEYS else DEFAULTS.get(key, 0.0), int)
    step = 1 if whole else max(abs(lo), abs(hi), 1.0) * 1e-9
    return [lo + step if above else lo, hi - step if below else hi]


@pytest.mark.parametrize("key", WALK_KEYS)
def test_the_extremes_of_every_number_are_refused_in_one_line_or_run(key):
    """1e-9, 0, -1, 1e300, inf, NaN and the field's own bounds in every number of the config: refused
    in one line naming the key, or accepted and an episode resets and steps within 20 s with finite observations
    (a refusal at reset, one line naming its keys, is legitimate: the swarm cannot organize)."""
    import signal

    from petswarm_env.env import PetSwarmEnv

    previous = signal.signal(signal.SIGALRM, _alarm)
    try:
        for v in WALK_VALUES + _own_bounds(key):
            value = [v, DEFAULTS[key][1]] if key in PAIR_KEYS else v
            signal.alarm(20)
            try:
                try:
                    cfg = load_config(overrides={key: value})
                except ConfigError as exc:  # the key itself, or a rule across keys that names them
                    message = str(exc)
                    assert "\n" not in message and (key.rsplit(".", 1)[-1] in message or message.startswith("bad config: ")), (
                        key, v, message)
                    continue
                try:
                    env = PetSwarmEnv(cfg)
                    obs, _ = env.reset(seed=0)
                    for _ in range(2):
                        assert all(np.all(np.isfinite(o)) for o in obs.values()), (key, v)
                        if not env.agents:
                            break
                        obs, *_ = env.step({a: np.zeros(3, np.float32) for a in env.agents})
                    env.close()
                except (ConfigError, ValueError, RuntimeError) as exc:  # refused at build or reset
                    assert "\n" not in str(exc) and "." in str(exc), (key, v, str(exc))
            except _Hang:
                pytest.fail(f"{key}={v!r} took more than 20 s")
            finally:
                signal.alarm(0)
    finally:
        signal.signal(signal.SIGALRM, previous)


@pytest.mark.parametrize("overrides, words", [
    ({"max_cycles": 10**6, "control_period_s": 0.5}, "a day"),
    ({"max_cycles": 10**6, "control_period_s": 0.01, "world.num_users": 8, "swarm.num_slaves": 16}, "GB budget"),
    ({"swarm.formation": "custom", "swarm.num_slaves": 2, "swarm.custom_links": [
        {"robot": 1, "neighbour": 2, "offset_m": [-1, 0]}, {"robot": 2, "neighbour": 1, "offset_m": [-1, 0]}]}, "swarm.custom_links"),
    ({"swarm.formation": "custom", "swarm.num_slaves": 3, "swarm.custom_links": [
        {"robot": 1, "neighbour": 0, "offset_m": [-1, 0]}, {"robot": 2, "neighbour": 3, "offset_m": [-1, 0]},
        {"robot": 3, "neighbour": 2, "offset_m": [-1, 0]}]}, "swarm.custom_links"),
    ({"robot_types.mybot.sensors": [{"id": 1, "type": "LASER", "radius_m": 0.1, "angle_deg": 0}]}, "robot_types.mybot.sensors.0.type"),
    ({"robot_types.r2.sensors": [{"id": 1, "type": "distance", "radius_m": 0.1, "angle_deg": 0}]}, "robot_types.r2.sensors.0.type"),
    ({"faults": [{"at_s": 1, "robot": 1, "kind": "dead"}] * 1001}, "faults"),
])
def test_budgets_custom_link_cycles_and_sensor_types(overrides, words):
    assert words in _refused(overrides)


def test_a_bad_value_in_a_file_names_the_file(tmp_path):
    (tmp_path / "mine.yaml").write_text("lf:\n  burst_period_s: 1.0e-9\n")
    message = _refused(path=tmp_path / "mine.yaml")
    assert "lf.burst_period_s" in message and "mine.yaml" in message
    (tmp_path / "typo.yaml").write_text("lf:\n  burst_period: 1.0\n")
    assert "typo.yaml" in _refused(path=tmp_path / "typo.yaml")


@pytest.mark.parametrize("config", [123, 4.5, [1], {"seed": 1}, b"x.yaml"])
def test_a_config_that_is_not_a_config_or_a_path_is_a_clear_type_error(config):
    from petswarm_env import petswarm_v1

    with pytest.raises(TypeError, match="config must be a Config, the path of a YAML file or None"):
        petswarm_v1.parallel_env(config=config)


@pytest.mark.parametrize("key, value, span", [
    ("lf.burst_period_s", 1e-9, "0.01 to 600"), ("max_cycles", 0, "above 0 to 1e+06"),
    ("robot_types.mybot.max_speed_mps", 99, "above 0 to 20"), ("faults_random.rate_per_min", 1e9, "0 to 60"),
    ("lf.reliable_half_angle_deg", 90, "above 0 to below 90"),
])
def test_a_number_out_of_range_names_its_physical_range(key, value, span):
    message = _refused({key: value})
    assert key in message and f"its physical range is {span}" in message


def test_a_file_beyond_the_size_limit_is_refused_before_parsing(tmp_path):
    import time

    (tmp_path / "wide.yaml").write_text("reward:\n  formation: [" + ",".join(["1"] * 300_000) + "]\n")
    t0 = time.perf_counter()
    message = _refused(path=tmp_path / "wide.yaml")
    assert "wide.yaml" in message and "bytes, more than the" in message and time.perf_counter() - t0 < 2


def test_docs_inputs_states_the_limits_the_code_has():
    """docs/inputs.md quotes the limits; they must be the code's."""
    from pathlib import Path

    from petswarm.evaluation.grid_spec import MAX_CELLS, MAX_RUNS
    from petswarm_env import config_base, config_yaml
    from petswarm_env.config import MEMORY_BUDGET_BYTES

    doc = (Path(__file__).resolve().parents[2] / "docs" / "inputs.md").read_text()
    assert f"| file size | {config_yaml.MAX_YAML_BYTES // 1000} kB |" in doc
    assert f"| nesting depth | {config_yaml.MAX_YAML_DEPTH} |" in doc
    assert f"| values after expanding aliases | {config_yaml.MAX_YAML_VALUES:,} |" in doc
    assert f"| characters of one number | {config_yaml.MAX_NUMBER_CHARS} |" in doc
    assert f"| `TICK_S` | {config_base.TICK_S * 1000:g} ms |" in doc and f"| `LONG_S` | {config_base.LONG_S:g} s |" in doc
    assert f"| `EPISODE_S` | {config_base.EPISODE_S:,.0f} s |" in doc and f"| `MAX_CYCLES` | {config_base.MAX_CYCLES:,} |" in doc
    assert f"{config_base.FAST_MPS:g} m/s" in doc and f"{config_base.LEVEL_DB:g} dB" in doc and f"| `ADC_MAX` | {config_base.ADC_MAX:g} |" in doc
    assert f"At most {MAX_CELLS:,} cells" in doc and f"{MAX_RUNS:,} episodes" in doc and f"fit {MEMORY_BUDGET_BYTES / 1e9:g} GB" in doc
