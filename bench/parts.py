"""The parts of a step's cost, and which part a function's time belongs to: the part of the
module it lives in, never its name.

:data:`MODULE_PARTS` maps dotted module prefixes to a part; the longest prefix of a function's
module wins (``petswarm_env.middleware.user_session`` before ``petswarm_env.middleware``). A part
of ``None`` is *neutral*: the time counts for whoever called the function (numpy, the standard
library, pymunk's property accessors, geometry helpers shared by several parts). A function of
``petswarm_env`` whose module matches no row is *uncategorised* (:class:`Uncategorised`; the
profiles count it as "other"): tests/e2e/test_bench.py fails on one, so a new module gets its part
when it is written, and renaming a function can never move its time.
"""

from __future__ import annotations

import importlib.machinery
import sysconfig
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]  # the repository (or site-packages) holding the packages

CATEGORIES = ("physics", "radio_middleware", "user_sensing", "control", "observation", "reward_metrics", "other")

# part -> its name on the benchmark page
PART_TITLES = {
    "physics": "physics",
    "radio_middleware": "radio and middleware events",
    "user_sensing": "user sensing",
    "control": "control",
    "observation": "observation",
    "reward_metrics": "reward and metrics",
    "other": "other",
}

PROJECT = "petswarm_env"  # the package whose every module must have a part (what env.step runs)

MODULE_PARTS: dict[str, str | None] = {
    # the environment library
    "petswarm_env.__init__": "other",
    "petswarm_env._core": "other",  # the compiled core's import check (import time only)
    "petswarm_env.config": "other",
    "petswarm_env.config_base": "other",
    "petswarm_env.config_runtime": "other",
    "petswarm_env.config_yaml": "other",
    "petswarm_env.config_wearables": "other",
    "petswarm_env.inputs": "other",  # reset options and actions, checked
    "petswarm_env.runtime": "other",  # the episode's faults and arrivals, scheduled on the clock (docs/faults.md)
    "petswarm_env.robot_types": "other",  # the robot types resolved at the env's construction
    "petswarm_env.env": "other",  # env.step itself: action checks
    "petswarm_env.episode": "other",  # the episode's own bookkeeping: commands to the arbiters, the agent lifecycle
    "petswarm_env.step_kernel": "other",  # the episode's per-step loops (commands, contacts, infos), compiled
    "petswarm_env.vector": "other",  # the vector env: arrays in and out around each copy's episode
    "petswarm_env.files": "other",
    "petswarm_env.render": "other",
    "petswarm_env.sim": "physics",  # bodies, the world's substep loop, the user, contact callbacks
    "petswarm_env.sim.clock": "radio_middleware",  # the event loop: frames, IR slots, token passes, broadcasts
    "petswarm_env.sim.body": None,  # position/heading/velocity accessors: whoever reads or writes them
    "petswarm_env.sim.battery": "physics",  # each robot's battery drain, every substep
    "petswarm_env.sim.sensors": "observation",  # the slaves' ultrasonic ring, odometry and AHRS readings
    "petswarm_env.sim.geometry": None,  # ray casts (observation) and IR occlusion (middleware)
    "petswarm_env.scenarios": None,  # the user's script, read by User.apply
    "petswarm_env.comms": "radio_middleware",  # the 802.15.4 medium, IR optics
    "petswarm_env.comms.ir_channel": "radio_middleware",  # an IR slot's lines of sight and measurements
    "petswarm_env.middleware": "radio_middleware",  # every robot's managers and messages
    "petswarm_env.middleware.token_ring": "radio_middleware",  # the IR token ring and heading exchange, every ring frame
    "petswarm_env.middleware.node": "radio_middleware",  # each robot's middleware: the master's status broadcast, every frame
    "petswarm_env.middleware.fleet": "radio_middleware",  # the IR medium: every slot of every token ring
    "petswarm_env.middleware.diagnosis": "radio_middleware",  # each robot's sensor self-diagnosis, every ring and AHRS reading
    "petswarm_env.middleware.user_session": "user_sensing",  # the master's wearables chain (LF, belt)
    "petswarm_env.middleware.successor_side": "user_sensing",  # the user session of a new master after a succession
    "petswarm_env.middleware.pairing": "user_sensing",  # the user session's pairing of the belt with a robot
    "petswarm_env.wearables": "user_sensing",
    "petswarm_env.wearables.belt": "user_sensing",  # the belt's IMU and recognition, every control period
    "petswarm_env.wearables.belt_window": "user_sensing",  # the belt's window statistics, every accelerometer sample
    "petswarm_env.wearables.lf": "user_sensing",  # the LF localisation, every burst of the master
    "petswarm_env.control": "control",  # master-role controller, control arbiter
    "petswarm_env.control.master": "control",  # the master-role controller and its user tracker, every control period
    "petswarm_env.observe": "observation",
    "petswarm_env.observation_page": "other",  # docs/observation.md generated (not in step)
    "petswarm_env.mapping": "observation",  # seed 001's sensor/behaviour mapper between a body and the layout
    "petswarm_env.middle_layer": "observation",  # the mapper wired: each body type's table onto the virtual ring
    "petswarm_env.reward": "reward_metrics",
    "petswarm_env.metrics": "reward_metrics",
    "petswarm_env.references": "reward_metrics",  # the experimenter's reference points and errors, every step
    "petswarm_env.state": "reward_metrics",  # the global state for critics: truth, like the metrics (not in step)
    "petswarm_env.wrappers": "other",  # FixedAgents: padding around env.step
    "petswarm_env.petswarm_v1": "other",  # the versioned module's constructors
    "petswarm_env.petswarm_v0": "other",
    # the libraries it runs on
    "simpy": "radio_middleware",  # the clock's event loop
    "pymunk.space": "physics",  # Space.step (Chipmunk's cpSpaceStep)
    "pymunk": None,  # bodies' property accessors: whoever reads or writes them
    "numpy": None,
}


class Uncategorised(LookupError):
    """A module of the project that no row of :data:`MODULE_PARTS` covers."""


def norm_path(path: str) -> str:
    return path.replace("\\", "/")


_STDLIB = {norm_path(p) for p in (sysconfig.get_paths().get("stdlib"), sysconfig.get_paths().get("platstdlib")) if p}
_TOP_LEVEL = {key.split(".")[0] for key in MODULE_PARTS}


def module_of(filename: str) -> str | None:
    """The dotted module of a source file (``…/petswarm_env/sim/world.py`` → ``petswarm_env.sim.world``,
    a package's ``__init__.py`` → ``pkg.__init__``); None for built-ins, frozen modules, the
    standard library and files of no known package."""
    path = norm_path(filename)
    if filename == "~" or path.startswith("<"):
        return None  # built-ins (C functions, including pymunk's cffi calls) and frozen modules
    if "site-packages" not in path and any(path.startswith(p + "/") for p in _STDLIB):
        return None
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:  # a compiled module (petswarm_env/_core.py): its .py's name
        if path.endswith(suffix):
            path = path.removesuffix(suffix) + ".py"
            break
    parts = path.removesuffix(".py").split("/")
    root = norm_path(str(ROOT)) + "/"
    if path.startswith(root):
        return ".".join(path[len(root):].removesuffix(".py").split("/"))
    if "site-packages" in parts:
        rest = parts[len(parts) - parts[::-1].index("site-packages"):]
        return ".".join(rest) if rest else None
    for i, part in enumerate(parts):
        if part in _TOP_LEVEL:
            return ".".join(parts[i:])
    return None


def module_part(module: str) -> str | None:
    """The part of ``module`` (the row of its longest prefix in :data:`MODULE_PARTS`; None =
    neutral); ``"other"`` for a module of another package. Raises :class:`Uncategorised` for a
    module of :data:`PROJECT` no row covers."""
    name = module
    while True:
        if name in MODULE_PARTS:
            return MODULE_PARTS[name]
        if "." not in name:
            break
        name = name.rsplit(".", 1)[0]
    if module.split(".")[0] == PROJECT:
        raise Uncategorised(f"{module} has no part in bench/parts.py MODULE_PARTS")
    return "other"


def part_of(func: tuple[str, int, str]) -> str | None:
    """The part of a profiled function ``(filename, line, name)``'s own time, or None (neutral:
    its callers'). An uncategorised project module counts as ``"other"``."""
    module = module_of(func[0])
    if module is None:
        return None
    try:
        return module_part(module)
    except Uncategorised:
        return "other"


def part_rules() -> dict[str | None, list[str]]:
    """The modules of each part (``None``: the neutral ones), as the page lists them."""
    out: dict[str | None, list[str]] = {}
    for module, part in MODULE_PARTS.items():
        out.setdefault(part, []).append(module)
    return out
