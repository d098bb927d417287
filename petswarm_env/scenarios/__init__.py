"""The scenario registry: every named scenario, each one object with its walking script and its
robot placement (VMAS's ``make_world`` / ``reset_world_at`` are the model).

``SCENARIOS`` maps a name to its :class:`~.base.Scenario`; ``user.scenario`` and
``user.scenario_pool`` in the config are validated against it (an unknown name's error lists the
choices), and ``reset`` builds the world from the chosen one: each user's script from
:meth:`~.base.Scenario.script`, the robots from :meth:`~.base.Scenario.place`.

Adding a scenario is adding one object, and nothing else: subclass :class:`~.base.Scenario` in a
module of this package (a new file is found by itself, or an existing one such as ``walks.py``),
give it a ``name``, override :meth:`~.base.Scenario.walk` (or :meth:`~.base.Scenario.segments`
for a script that does not start with the stand) and, for another start, ``place``; set
``changes_master`` if its script changes the driving mode; then ``register(YourScenario())``. It
can be chosen at once with ``--set user.scenario=NAME``. Scenario modules import only
:mod:`.base` (the config imports this package, so nothing here may import the config or the
simulation).
"""

from __future__ import annotations

import importlib
import pkgutil

from petswarm_env.scenarios.base import (
    ACTIVITIES,
    SCENARIOS,
    USER_COMMANDS,
    Placement,
    Scenario,
    ScenarioScript,
    Segment,
    register,
)

__all__ = ["ACTIVITIES", "SCENARIOS", "USER_COMMANDS", "Placement", "Scenario", "ScenarioScript", "Segment", "get",
           "register"]

importlib.import_module(f"{__name__}.walks")  # the named walks first: their order is the registry's
for _module in pkgutil.iter_modules(__path__):  # then every other scenario module of the package, by file name
    if _module.name not in ("base", "walks"):
        importlib.import_module(f"{__name__}.{_module.name}")


def get(name: str) -> Scenario:
    """The registered scenario ``name``; an unknown name's error lists the choices."""
    try:
        return SCENARIOS[name]
    except KeyError:
        raise ValueError(f"unknown scenario '{name}'; choose one of: {', '.join(SCENARIOS)}") from None
