"""How the IR token ring runs for a swarm of a given size (middleware/token_ring.py's module docstring, "A crowded
ring"): seed 000 Fig. 7 gives the ring's sequence, not its timing for many robots."""

from __future__ import annotations

from typing import NamedTuple

from petswarm_env.config import Config
from petswarm_env.middleware import messages as msg


class RingPlan(NamedTuple):
    """How the ring runs for a swarm of a given size (token_ring.py's module docstring, "A crowded ring")."""

    answer_slot_s: float  # 0: every member answers a start sign at once (after its MCU delay); else in member order,
    # this far apart
    all_answer_token: bool  # every member answers a token (True), or only the robot it names
    wait_headings: bool  # the holder waits for its neighbours' heading reports before passing the token
    ir_tx_s: float  # how long the holder transmits IR (protocol.ir_tx_s; a crowded ring: protocol.ring_ir_tx_crowded_s)


def ring_plan(cfg: Config, total_members: int) -> RingPlan:
    """The ring's plan for ``total_members`` robots (master included): crowded when the answers to one ring frame need more
    air than the MCU's response jitter spreads them over."""
    radio = cfg.radio
    answer_air_s = (radio.frame_overhead_bytes + msg.SIZE_BYTES[msg.TX_START_ACK]) * 8.0 / radio.bitrate_bps
    if (total_members - 1) * (answer_air_s + radio.turnaround_s) <= radio.processing_jitter_s:
        return RingPlan(0.0, True, True, cfg.protocol.ir_tx_s)
    return RingPlan(cfg.protocol.ring_answer_slot_s, False, False, cfg.protocol.ring_ir_tx_crowded_s)
