"""The radio medium's trace hook: it sees every frame and reception the medium counts, and changes nothing."""

import math

from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm.evaluation.runner import run_episode
from petswarm_env import PetSwarmEnv
from petswarm_env.comms.radio import OUTCOMES
from petswarm_env.config import load_config


class CountingTrace:
    def __init__(self):
        self.counts = {"sent": 0, "busy": 0, **{o: 0 for o in OUTCOMES}}
        self.times_ok = True
        self.last = -math.inf

    def on_air(self, now, station, frame, start_s, end_s):
        self.counts["sent"] += 1
        self.times_ok &= frame.src == station and now < start_s < end_s and now >= self.last
        self.last = now

    def reception(self, now, frame, receiver, outcome, distance_est_m):
        self.counts[outcome] += 1
        self.times_ok &= receiver != frame.src and now >= self.last and (outcome == "delivered") == math.isfinite(distance_est_m)
        self.last = now

    def busy(self, now, station, frame):
        self.counts["busy"] += 1


def _episode(trace, steps=80):
    cfg = load_config(overrides={"max_cycles": steps, "radio.loss_prob": 0.05, "world.num_users": 2})
    env = PetSwarmEnv(cfg)
    env.radio_trace = trace
    summary = run_episode(env, make_policy("scripted", PolicySpec.from_env(env)), 3)
    return env, summary


def test_the_trace_sees_what_the_medium_counts_and_changes_nothing():
    trace = CountingTrace()
    env, summary = _episode(trace)
    st = env.radio.stats
    assert trace.counts["sent"] == st.frames_sent and trace.counts["busy"] == st.frames_dropped_busy
    assert trace.counts["lost"] == st.frames_lost > 0
    assert trace.counts["collided"] == st.frames_collided > 0
    assert trace.counts["filtered"] == st.foreign_pan_dropped > 0  # two users' swarms share the medium
    assert sum(trace.counts[o] for o in OUTCOMES) == st.receptions + st.foreign_pan_dropped
    assert trace.times_ok
    _, untraced = _episode(None)
    assert untraced == summary
