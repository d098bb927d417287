"""The master's status broadcast (seed 000 §3.5, Fig. 9) carries what the master itself knows.

Seed 000 §3.5: the master sends "its speed ... to sensitively react to the user's speed or direction
changes". The (Vx, Vy) it broadcasts is its own last command to its wheels (its MCU sent it; the motors
reach it under their acceleration limits), its ω what its own wheel odometry measures, with the slaves'
odometry noise model (sim/sensors.py); never the body's true velocity (Station.driving_speed).
"""

import numpy as np
import pytest

import petswarm_env
from petswarm_env.comms.radio import BROADCAST
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.node import Node  # every station is a Node (a Python subclass)


def _broadcasts(monkeypatch, steps=150, **overrides):
    """(broadcast velocity, the master's motor command, what its wheels turn, its true body velocity) of every
    STATUS the master sent."""
    sent = []
    original = Node.send

    def spy(self, kind, dst=BROADCAST, pan=None, **payload):
        if kind == msg.STATUS:
            r = self._robot
            sent.append((payload["velocity"], r.motor_command, r.wheel_velocity, r.velocity_body))
        return original(self, kind, dst, pan, **payload)

    monkeypatch.setattr(Node, "send", spy)
    env = petswarm_env.parallel_env(max_cycles=steps, **{"user.formation_wait_s": 0.0, **overrides})  # the user walks at once
    env.reset(seed=4)
    for _ in range(steps):
        env.step({a: np.array([0.2, 0.0, 0.0], np.float32) for a in env.agents})
    return sent


def test_the_broadcast_speed_is_the_masters_own_command_ahead_of_its_wheels(monkeypatch):
    sent = _broadcasts(monkeypatch)
    moving = [s for s in sent if abs(s[3][0]) > 0.2]
    assert len(moving) > 50, "the master must drive for the test to mean something"
    assert all(tuple(b[:2]) == tuple(c[:2]) for b, c, _, _ in sent)  # its command's (Vx, Vy), exactly
    # the command leads what the wheels turn while the motors ramp (the user starts walking: the slaves' feed-forward
    # no longer waits for the ramp); a broadcast of the wheels' or the body's speed fails here
    assert max(abs(c[0] - w[0]) for _, c, w, _ in sent) > 0.1
    assert any(abs(b[0] - v[0]) > 0.05 for b, _, _, v in moving)


def test_the_broadcast_turn_rate_is_the_masters_own_noisy_odometry(monkeypatch):
    sent = _broadcasts(monkeypatch, steps=300, **{"user.scenario": "turn_left_60"})
    turning = [(b[2], v[2]) for b, _, _, v in sent if abs(v[2]) > 0.2]
    assert len(turning) > 10, "the master must turn for the test to mean something"
    rel = np.array([b / v - 1.0 for b, v in turning])
    assert not np.allclose(rel, 0.0), "the broadcast ω is the true body rate"
    k = petswarm_env.load_config().robot.odometry_noise_rel
    assert rel.std() == pytest.approx(k, rel=0.5)  # the same relative noise as a slave's odometry


def test_noiseless_odometry_broadcasts_the_turn_rate_the_wheels_turn(monkeypatch):
    """The wheel encoders count the motors' speed (Robot.wheel_velocity), not the body's: a shove or a
    contact moves the body, not the wheels."""
    sent = _broadcasts(monkeypatch, steps=60, **{"robot.odometry_noise_rel": 0.0})
    assert sent and all(b[2] == w[2] for b, _, w, _ in sent)
