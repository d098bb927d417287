"""An IEEE 802.15.4-like shared radio medium (seed 000 §3.2, §3.4; SPEC §2).

- Frames take airtime ``(overhead + payload) * 8 / bitrate`` after a driver latency.
- Unslotted CSMA-CA: random backoff of ``0 … 2^BE − 1`` unit periods, then a clear-channel
  assessment (CCA). A busy channel raises BE and backs off again (frame dropped after
  ``max_backoffs``). After a clear CCA the radio needs ``turnaround_s`` to start sending, so two
  senders whose CCAs fall within one turnaround both transmit: that is how simultaneous
  responses collide.
- At each receiver a frame is destroyed when another transmission in range overlaps it in time
  (collision), when the receiver was itself transmitting (half duplex), or by independent random
  loss ``loss_prob`` (injected corruption).
- Every frame carries a PAN ID. The MAC of a receiver drops frames of any PAN other than the one it
  is on, so a foreign swarm's frames never reach its middleware (several swarms share one medium).
- No MAC-level acknowledgement or retransmission: the middleware retries (seed 000 §4.5).

Events per frame: one for latency + backoff ending in the CCA (one more per busy re-assessment),
one when the frame has left the air (delivery to every receiver at once). The turnaround is not an
event of its own: a clear CCA puts the frame on the medium's list with its start one turnaround
later, so a CCA inside that turnaround does not sense it (``start <= now``) while the overlap test
at delivery (``start < end``) still sees it. The sender's antenna position is read at its CCA
(a robot moves < 0.3 mm in the 192 µs turnaround).

The medium also gives each received frame a received-signal distance estimate (log-distance path
loss with shadowing), which is what a master uses to rank candidates by closeness (Table 2).

**Trace hook** (the experimenter's tool: the pcap writer and the replay recorder of
``evaluation/``; never a robot's): :attr:`RadioMedium.trace`, ``None`` unless set, gets every frame
the medium carried — :meth:`RadioTrace.on_air` when a clear CCA puts it on the air (where
``frames_sent`` counts it), :meth:`RadioTrace.reception` once per station in range it reached, with
how the reception ended (where the counters of receptions count it), and :meth:`RadioTrace.busy` for
a frame CSMA-CA gave up on. The hook only reads; when off it costs one ``is not None`` test per
frame and per reception.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from petswarm_env.config import RadioConfig
from petswarm_env.sim.clock import Clock
from petswarm_env.sim.draws import Draws

__all__ = ["BROADCAST", "COLLIDED", "DELIVERED", "FILTERED", "LOST", "OUTCOMES", "PAN_WAITING", "Frame", "RadioMedium",
           "RadioStats", "RadioTrace", "Station"]

BROADCAST = -1
PAN_WAITING = 0x0000  # robots not in a swarm listen here (chosen)

# how one reception ended (RadioTrace.reception), in the order the medium decides it
FILTERED = "filtered"  # another PAN: the receiver's MAC dropped it (RadioStats.foreign_pan_dropped)
COLLIDED = "collided"  # overlapped by another transmission in range, or the receiver was sending (frames_collided)
LOST = "lost"  # random loss, radio.loss_prob (frames_lost)
DELIVERED = "delivered"  # handed to the station's middleware
OUTCOMES = (DELIVERED, LOST, COLLIDED, FILTERED)


@dataclass(slots=True)
class Frame:
    kind: str
    src: int
    dst: int  # BROADCAST or a node id
    pan: int
    payload: dict[str, Any] = field(default_factory=dict)
    size_bytes: int = 12
    rx_distance_est_m: float = math.nan  # filled per reception


class Station(Protocol):
    node_id: int
    pans: frozenset[int]  # PAN IDs its MAC accepts

    def position(self) -> tuple[float, float]: ...

    def receive(self, frame: Frame) -> None: ...


@dataclass
class RadioStats:
    frames_sent: int = 0
    frames_dropped_busy: int = 0  # CSMA gave up
    receptions: int = 0
    frames_lost: int = 0  # random loss at a receiver
    frames_collided: int = 0  # receptions destroyed by overlap
    foreign_pan_dropped: int = 0  # filtered by the MAC


class RadioTrace(Protocol):
    """What the medium tells a trace (:attr:`RadioMedium.trace`); ``now`` is the clock's time."""

    def on_air(self, now: float, station: int, frame: Frame, start_s: float, end_s: float) -> None:
        """At ``now``, ``station``'s clear CCA put ``frame`` on the air from ``start_s`` (one
        turnaround later) to ``end_s`` (counted in ``frames_sent``)."""

    def reception(self, now: float, frame: Frame, receiver: int, outcome: str, distance_est_m: float) -> None:
        """At ``now``, ``frame`` left the air and reached station ``receiver`` (in range, not its
        sender): ``outcome`` is one of :data:`OUTCOMES`; ``distance_est_m`` the RSSI distance
        estimate of a delivered frame (NaN otherwise)."""

    def busy(self, now: float, station: int, frame: Frame) -> None:
        """At ``now``, CSMA-CA gave ``frame`` up after ``max_backoffs`` busy channels (never on the air)."""


class _Tx:
    __slots__ = ("end", "frame", "start", "x", "y")

    def __init__(self, frame: Frame, start: float, end: float, x: float, y: float):
        self.frame, self.start, self.end, self.x, self.y = frame, start, end, x, y


class RadioMedium:
    """One shared channel; stations attach, then send frames."""

    def __init__(self, clock: Clock, cfg: RadioConfig, rng: np.random.Generator):
        self.clock = clock
        self._later = clock.later  # later(delay, fn, *args): a call on the clock
        self.cfg = cfg
        self.rng = rng
        # two independent streams: the MAC's backoffs, and what happens at receivers (loss,
        # shadowing), so that e.g. injecting loss does not reshuffle the backoffs
        mac_rng, rx_rng = rng.spawn(2)
        self._mac_draws = Draws(mac_rng)
        self._rx_draws = Draws(rx_rng)
        self.stations: dict[int, Station] = {}
        self.stats = RadioStats()
        self._air: list[_Tx] = []  # transmissions that may still overlap something
        self._queues: dict[int, list[Frame]] = {}  # per station: frames waiting for the MAC
        self.drop_filter: Callable[[Frame], bool] | None = None  # fault injection (tests)
        self.trace: RadioTrace | None = None  # the experimenter's trace hook (module docstring)
        self._range2 = cfg.range_m**2
        # RSSI distance estimate d * 10^(σ·z / (10 n)), z ~ N(0, 1)
        self._shadow_k = cfg.rssi_shadowing_db / (10.0 * cfg.path_loss_exponent)
        # the values read for every frame, as plain attributes (a field of the pydantic config
        # costs several times an attribute to read)
        self._overhead_bytes, self._bitrate_bps = cfg.frame_overhead_bytes, cfg.bitrate_bps
        self._latency_s, self._turnaround_s = cfg.latency_s, cfg.turnaround_s
        self._min_be, self._backoff_slot_s = cfg.min_be, cfg.backoff_slot_s
        self._loss_prob = cfg.loss_prob

    def attach(self, station: Station) -> None:
        self.stations[station.node_id] = station
        self._queues[station.node_id] = []

    def airtime_s(self, frame: Frame) -> float:
        return (self._overhead_bytes + frame.size_bytes) * 8.0 / self._bitrate_bps

    # -- sending --------------------------------------------------------------------------------
    def send(self, station: Station, frame: Frame) -> None:
        """Queue ``frame`` from ``station``; its MAC sends one frame at a time, in order:
        latency, then CSMA-CA, then airtime."""
        queue = self._queues[station.node_id]
        queue.append(frame)
        if len(queue) == 1:
            self._start(station, frame)

    def _start(self, station: Station, frame: Frame) -> None:
        """The MAC takes the first frame of the station's queue: driver latency, first backoff."""
        be = self._min_be
        self._later(self._latency_s + self._backoff(be), self._cca, station, frame, 0, be)

    def _done(self, station: Station) -> None:
        queue = self._queues[station.node_id]
        queue.pop(0)
        if queue:
            self._start(station, queue[0])

    def _backoff(self, be: int) -> float:
        """Random backoff of 0 … 2^BE − 1 unit periods."""
        return int(self._mac_draws.uniform() * (1 << be)) * self._backoff_slot_s

    def _cca(self, station: Station, frame: Frame, nb: int, be: int) -> None:
        now = self.clock.now
        x, y = station.position()
        r2 = self._range2
        for tx in self._air:
            if tx.start <= now < tx.end and (tx.x - x) ** 2 + (tx.y - y) ** 2 <= r2:  # busy
                if nb >= self.cfg.max_backoffs:
                    self.stats.frames_dropped_busy += 1
                    if self.trace is not None:
                        self.trace.busy(now, station.node_id, frame)
                    self._done(station)
                    return
                be = min(be + 1, self.cfg.max_be)
                self._later(self._backoff(be), self._cca, station, frame, nb + 1, be)
                return
        # clear: on the air after the RX-to-TX turnaround, which the CCA of others cannot sense
        start = now + self._turnaround_s
        tx = _Tx(frame, start, start + self.airtime_s(frame), x, y)
        self._air.append(tx)
        self.stats.frames_sent += 1
        if self.trace is not None:
            self.trace.on_air(now, station.node_id, frame, start, tx.end)
        self._later(tx.end - now, self._deliver, tx, station)

    # -- receiving ------------------------------------------------------------------------------
    def _deliver(self, tx: _Tx, sender: Station) -> None:
        """The frame has left the air: every station in range gets it now, unless it collided."""
        self._done(sender)
        now = self.clock.now
        frame = tx.frame
        air = self._air
        # one pass: the transmissions that overlap this one, and the start of the oldest one still
        # on the air (this one included, so never later than now)
        oldest_live = now
        overlapping = []
        start, end = tx.start, tx.end
        for t in air:
            if t.end >= now and t.start < oldest_live:
                oldest_live = t.start
            if t is not tx and t.start < end and t.end > start:
                overlapping.append(t)
        # forget transmissions that can no longer overlap anything still on the air (none of them
        # overlaps this one: they ended before the oldest live start, at most this one's start)
        if air[0].end < oldest_live:
            self._air = [t for t in air if t.end >= oldest_live or t is tx]
        if self.drop_filter is not None and self.drop_filter(frame):
            return
        if frame.dst == BROADCAST:
            targets = self.stations.values()
        else:
            st = self.stations.get(frame.dst)
            targets = () if st is None else (st,)
        stats = self.stats
        r2 = self._range2
        loss = self._loss_prob
        shadow_k = self._shadow_k
        uniform, normal = self._rx_draws.uniform, self._rx_draws.normal
        sqrt = math.sqrt
        kind, src, dst, pan, payload, size = frame.kind, frame.src, frame.dst, frame.pan, frame.payload, frame.size_bytes
        tx_x, tx_y = tx.x, tx.y
        trace = self.trace
        for st in targets:
            node_id = st.node_id
            if node_id == src:
                continue
            rx, ry = st.position()
            d2 = (rx - tx_x) ** 2 + (ry - tx_y) ** 2
            if d2 > r2:
                continue
            if pan not in st.pans:
                stats.foreign_pan_dropped += 1
                if trace is not None:
                    trace.reception(now, frame, node_id, FILTERED, math.nan)
                continue
            stats.receptions += 1
            collided = False
            for t in overlapping:  # another transmission in range, or it was transmitting (half duplex)
                if t.frame.src == node_id or (t.x - rx) ** 2 + (t.y - ry) ** 2 <= r2:
                    collided = True
                    break
            if collided:
                stats.frames_collided += 1
                if trace is not None:
                    trace.reception(now, frame, node_id, COLLIDED, math.nan)
                continue
            if loss > 0 and uniform() < loss:
                stats.frames_lost += 1
                if trace is not None:
                    trace.reception(now, frame, node_id, LOST, math.nan)
                continue
            # RSSI-based distance estimate: log-distance path loss with log-normal shadowing
            d = sqrt(d2)
            if d < 0.1:  # max(d, 0.1)
                d = 0.1
            est = d * 10.0 ** (shadow_k * normal()) if shadow_k > 0 else d
            if trace is not None:
                trace.reception(now, frame, node_id, DELIVERED, est)
            st.receive(Frame(kind, src, dst, pan, payload, size, est))
