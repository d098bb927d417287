"""Scenarios of a swarm that changes and fails (seed 003: robots fail and are
added at runtime). The user walks straight on (the default script); each scenario brings its
faults and arrivals (petswarm_env/runtime.py), used when the config lists none. Times are episode
time: seconds after ``reset`` returned."""

from __future__ import annotations

from petswarm_env.scenarios.base import Scenario, register


class Dropout(Scenario):
    """A slave dies at 20 s (drawn from the episode's fault stream). A spare waiting robot is
    switched on beside the master at 19 s (chosen: a waiting robot stands still, so a spare placed
    at the start would be left far behind the walking swarm, out of the master's 3 m region; with
    every slot filled the master does not recruit it); the master detects the loss, removes the
    robot and recruits the spare into the open slot (middleware/recovery.py)."""

    name = "dropout"
    faults = ({"at_s": 20.0, "robot": "random_slave", "kind": "dead"},)
    arrivals = ({"at_s": 19.0, "type": "petbot"},)


class MasterLoss(Scenario):
    """The master dies at 20 s: its slaves stop by their status timeout (protocol.status_timeout_s)
    and return to waiting; the user stops at the belt's alert and pairs again with a waiting robot
    of the pool whose LF wake-up burst the belt hears (within lf.wake_range_m), which organizes a
    swarm again (middleware/user_session.py)."""

    name = "master_loss"
    faults = ({"at_s": 20.0, "robot": "master", "kind": "dead"},)


class Arrival(Scenario):
    """The swarm runs one slave short, then a robot arrives: a slave dies at 15 s with no spare in
    reach (the master re-plans the formation for the remaining members), and a robot switched on
    beside the master's path at 25 s is found by the master's periodic scan (protocol.rescan_period_s)
    and joins into the open slot."""

    name = "arrival"
    faults = ({"at_s": 15.0, "robot": "random_slave", "kind": "dead"},)
    arrivals = ({"at_s": 25.0, "type": "petbot"},)


for _scenario in (Dropout(), MasterLoss(), Arrival()):
    register(_scenario)
