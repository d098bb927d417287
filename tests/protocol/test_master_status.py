"""The master's status broadcast (seed 000 §3.5, Fig. 9) carries what the master itself measured.

Seed 000 §3.5: "its driving speed" is what its own wheel odometry measures, with the slaves'
odometry noise model (sim/sensors.py), never the body's true velocity.
"""

import numpy as np
import pytest

import petswarm_env
from petswarm_env.comms.radio import BROADCAST
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.node import Node  # every station is a Node (a Python subclass)


def _broadcasts(monkeypatch, steps=150, truth="velocity_body", **overrides):
    """(broadcast velocity, the robot's ``truth`` at that instant: its true body velocity, or what its
    wheels turn) of every STATUS the master sent."""
    sent = []
    original = Node.send

    def spy(self, kind, dst=BROADCAST, pan=None, **payload):
        if kind == msg.STATUS:
            sent.append((payload["velocity"], getattr(self._robot, truth)))
        return original(self, kind, dst, pan, **payload)

    monkeypatch.setattr(Node, "send", spy)
    env = petswarm_env.parallel_env(max_cycles=steps, **{"user.formation_wait_s": 0.0, **overrides})  # the user walks at once
    env.reset(seed=4)
    for _ in range(steps):
        env.step({a: np.array([0.2, 0.0, 0.0], np.float32) for a in env.agents})
    return sent


def test_the_broadcast_speed_is_the_masters_own_noisy_odometry(monkeypatch):
    sent = _broadcasts(monkeypatch)
    moving = [(np.array(b), np.array(t)) for b, t in sent if abs(t[0]) > 0.2]
    assert len(moving) > 50, "the master must drive for the test to mean something"
    rel = np.array([b[0] / t[0] - 1.0 for b, t in moving])
    assert not np.allclose(rel, 0.0), "the broadcast is the true body velocity"
    k = petswarm_env.load_config().robot.odometry_noise_rel
    assert rel.std() == pytest.approx(k, rel=0.3)  # the same relative noise as a slave's odometry
    assert abs(rel.mean()) < 3 * k / np.sqrt(len(rel)) + 1e-3


def test_noiseless_odometry_broadcasts_what_the_wheels_turn(monkeypatch):
    """The wheel encoders count the motors' speed (Robot.wheel_velocity), not the body's: a shove or a
    contact moves the body, not the wheels."""
    sent = _broadcasts(monkeypatch, steps=60, truth="wheel_velocity", **{"robot.odometry_noise_rel": 0.0})
    assert sent and all(tuple(b) == tuple(t) for b, t in sent)
