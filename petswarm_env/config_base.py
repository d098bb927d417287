"""The base of every config section (:class:`Section`): unknown keys refused, values frozen,
floats finite, no boolean for a number. Its own module so that sections defined outside
:mod:`petswarm_env.config` (:mod:`petswarm_env.robot_types`, :mod:`petswarm_env.config_runtime`) share it without an import circle."""

from __future__ import annotations

import reprlib
import typing
from collections.abc import Mapping
from typing import Annotated, Any

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError, ValidationInfo, field_validator
from pydantic_core import PydanticCustomError


class ConfigError(ValueError):
    """A configuration key or value is wrong; the message says which and how to fix it."""


_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxlist, _SHORT.maxdict, _SHORT.maxtuple, _SHORT.maxstring, _SHORT.maxother, _SHORT.maxlong = 3, 6, 6, 6, 50, 50, 40


def describe_value(value: Any, limit: int = 60) -> str:
    """A value a user gave, for a one-line error message: its type and a short repr (bounded:
    a huge value costs no more than a small one)."""
    text = " ".join(_SHORT.repr(value).split())
    return f"{type(value).__name__} {text if len(text) <= limit else text[:limit - 3] + '...'}"


# -- the physical ranges of the config's numbers ---------------------------------------------------
# Every number of the config is bounded by what the modelled hardware (or a person) can do, so a
# value outside is refused when the config loads, before anything is built or allocated: a period
# below an MCU tick would schedule millions of events per simulated second (a hang), a sample rate
# of 1e9 Hz or a table step of 1e-9 m would allocate gigabytes, a level of 1e300 dB overflows.
# The sections use these names; a field's own physical limit (a radio's, the BLE spec's) is beside it.
TICK_S = 1e-3  # the shortest period, timeout or delay the robots' and wearables' firmware schedules: a 1 ms timer tick (chosen; an 802.15.4 frame alone takes 0.4-4 ms of air at 250 kb/s)
LONG_S = 600.0  # the longest period, timeout or start-up delay: ten minutes (chosen: far beyond any the papers use, the longest 200 s, seed 003 §5.2.1's t_m)
EPISODE_S = 86_400.0  # an episode's simulated time, max_cycles x control_period_s, and any episode time (a fault's at_s): one day at most
MAX_CYCLES = 1_000_000  # control steps in an episode (1e6 x 0.1 s = 28 h)
SHORT_M = 1e-3  # the smallest length (a body, a spacing, a table step): a millimetre, ten times finer than the ultrasonic's noise
FAR_M = 1000.0  # the largest distance (an arena, a radio range): a kilometre; an 802.15.4 radio reaches about 100 m outdoors
NEAR_M = 100.0  # the largest sensing or formation distance (ultrasonic, IR, LF, a formation offset): 100 m, ten times beyond the sensors' reach
FAST_MPS = 20.0  # the fastest robot, user or remote-control speed: 20 m/s (72 km/h; a sprinter runs 12 m/s)
SPIN_RPS = 100.0  # the fastest turn rate: 100 rad/s (a wheel, not a body, spins that fast)
SPIN_DPS = 5_000.0  # the same limit in degrees per second (a MEMS gyro's full scale is at most ±4000 °/s)
ACCEL_MPS2 = 1_000.0  # the largest acceleration: 100 g (a MEMS accelerometer's full scale is at most ±400 g)
RATE_HZ = 1_000.0  # the highest sample rate of a wearable's accelerometer: 1 kHz (waist and wrist IMUs sample at 25-200 Hz)
GAIN = 1_000.0  # the largest controller gain (1/s, or rad/s per rad): 1000, beyond what a 1 ms step can integrate
LEVEL_DB = 200.0  # the largest level, loss or noise in dB: 200 dB spans every RSSI scale; 1e300 dB overflows 10 ** (dB / 10)
ADC_MAX = 1e6  # the largest ADC reading (IR strength, saturation): a 20-bit converter
COUNT = 1_000  # the largest count of retries, rounds, samples or sign changes
REL = 10.0  # the largest relative noise: σ of 1000 %
MASS_KG = 1_000.0  # the heaviest body: a tonne
WEIGHT = 1e6  # the largest reward weight in magnitude (a reward stays finite in float32)
MAX_LIST = 1_000  # the longest list of faults, arrivals, obstacles or sensors (memory and time stay bounded)


def _wants_number_only(annotation: Any) -> bool:
    """Whether a field's type holds numbers (int or float, inside tuples and lists too) and no
    boolean and nothing of any type: a boolean given there is a mistake, not 0 or 1."""
    if annotation is bool or annotation is Any:
        return False
    if annotation in (int, float):
        return True
    args = [a for a in typing.get_args(annotation) if a is not Ellipsis and a is not type(None)]  # Optional[int] too
    if typing.get_origin(annotation) is Annotated:
        args = args[:1]
    return bool(args) and all(_wants_number_only(a) for a in args)


def _holds_bool(value: Any) -> bool:
    if isinstance(value, (list, tuple)):
        return any(_holds_bool(v) for v in value)
    return isinstance(value, (bool, np.bool_))


class Section(BaseModel):
    """A config section: unknown keys are refused, values are frozen once validated. A float
    must be finite (no NaN, no infinity), and a boolean is not a number (pydantic's lax mode
    would read ``true`` as 1)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @field_validator("*", mode="before")
    @classmethod
    def _no_bool_for_numbers(cls, value: Any, info: ValidationInfo) -> Any:
        field = cls.model_fields.get(info.field_name or "")
        if field is not None and _holds_bool(value) and _wants_number_only(field.annotation):
            raise PydanticCustomError("bool_not_number", "a boolean is not a number here; give a number")
        return value


def format_validation_error(exc: ValidationError, root: Any = None) -> str:
    """One line for the first error of a validation: the key, what is wrong, the value given, and
    for a number out of range the field's range (``root``: the model validated, to look it up)."""
    err = exc.errors()[0]
    loc = ".".join(str(p) for p in err["loc"]) or "(config)"
    msg = err["msg"]
    if err["type"] == "extra_forbidden":
        return f"unknown config key '{loc}'"
    if err["type"] == "finite_number":
        msg = "must be a finite number (NaN and infinity are not allowed)"
    if not err["loc"] or (err["type"] == "value_error" and isinstance(err.get("input"), Mapping)):
        # a rule across keys (a model validator of the config or of a section): the message names the keys
        return f"bad config: {msg.removeprefix('Value error, ')}"
    text = f"bad config value for '{loc}': {msg} (got {describe_value(err.get('input'))})"
    if err["type"] in ("greater_than", "greater_than_equal", "less_than", "less_than_equal", "finite_number"):
        span = _field_range(root, err["loc"]) if root is not None else None
        if span:
            text += f"; its physical range is {span}"
    return text


def _field_range(root: Any, loc: tuple) -> str | None:
    """``"0.001 to 600"`` for the field at a pydantic location of ``root`` (its bounds), or None."""
    bounds = field_bounds(root, loc)
    if bounds is None:
        return None
    lo, above, hi, below = bounds
    return f"{'above ' if above else ''}{lo:g} to {'below ' if below else ''}{hi:g}"


def field_bounds(root: Any, loc: tuple) -> tuple[float, bool, float, bool] | None:
    """The bounds of the numeric field at a pydantic location of ``root``: (low, low excluded,
    high, high excluded), or None if it has not both. A dict of sections (``robot_types.NAME``)
    is stepped over by its key."""
    cls: Any = root
    info = None
    dict_of = None
    for part in loc:
        if isinstance(part, int) or cls is None:
            continue
        fields = getattr(cls, "model_fields", None)
        if fields is None or part not in fields:
            if dict_of is not None:
                cls, dict_of = dict_of, None  # the key of a dict of sections (robot_types.NAME)
                continue
            return None
        info = fields[part]
        ann, cls = info.annotation, None
        dict_of = None
        stack = [ann]
        while stack:
            t = stack.pop()
            if isinstance(t, type) and issubclass(t, Section):
                cls = t
                break
            stack.extend(typing.get_args(t))
        if cls is not None and typing.get_origin(ann) is dict:
            cls, dict_of = cls, cls
    if info is None:
        return None
    lo = hi = None
    above = below = False
    for m in info.metadata:
        if getattr(m, "gt", None) is not None:
            lo, above = m.gt, True
        if getattr(m, "ge", None) is not None:
            lo, above = m.ge, False
        if getattr(m, "lt", None) is not None:
            hi, below = m.lt, True
        if getattr(m, "le", None) is not None:
            hi, below = m.le, False
    return (lo, above, hi, below) if lo is not None and hi is not None else None
