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

A module of the compiled core (``petswarm_env/_core.py``): Cython's pure-Python mode (typed
classes for frames, transmissions and the medium), the same file runs under the interpreter.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Optional, Protocol

import cython
import numpy as np
from cython.cimports.libc.math import sqrt as _c_sqrt

from petswarm_env.config import RadioConfig
from petswarm_env.sim.draws import Draws

if cython.compiled:  # the clock's C methods (sim/clock.pxd): the medium schedules by a C call; a body's position as a C read (sim/body.pxd)
    from cython.cimports.petswarm_env.sim.body import Body, _cp_get_position, cpVect
    from cython.cimports.petswarm_env.sim.clock import Clock, Due
    from cython.cimports.petswarm_env.sim.draws import Stream  # a draw by a C call (sim/draws.pxd)
else:
    from petswarm_env.sim.body import Body
    from petswarm_env.sim.clock import Clock, Due
    from petswarm_env.sim.draws import Stream

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

_READ_POSITION = Body.read_position  # a body's own position reader (a station's antenna: its robot's)

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


@cython.dataclasses.dataclass
@cython.cclass
class Frame:
    kind: str
    src: cython.long
    dst: object  # BROADCAST or a node id (None: a node id not known, which no station is)
    pan: object  # None: a robot's "own swarm" when it is in none (no MAC accepts it)
    payload: dict = cython.dataclasses.field(default_factory=dict)
    size_bytes: cython.long = 12
    rx_distance_est_m: cython.double = math.nan  # filled per reception


_NAN = cython.declare(cython.double, math.nan)


@cython.cfunc
def _received(frame: Frame, est: cython.double) -> Frame:
    """The copy of ``frame`` a receiver gets, with its RSSI distance estimate (the fields set
    directly: a frame is copied for every reception)."""
    out: Frame = Frame.__new__(Frame)
    out.kind, out.src, out.dst, out.pan = frame.kind, frame.src, frame.dst, frame.pan
    out.payload, out.size_bytes, out.rx_distance_est_m = frame.payload, frame.size_bytes, est
    return out


class Station(Protocol):
    node_id: int
    pans: frozenset[int]  # PAN IDs its MAC accepts

    def position(self) -> tuple[float, float]: ...

    def receive(self, frame: Frame) -> None: ...


@cython.cclass
class RadioStats:
    """The medium's counters (typed: the medium adds to them for every frame and reception)."""

    # its typed attributes are declared in ``radio.pxd``

    def __init__(self, frames_sent: int = 0, frames_dropped_busy: int = 0, receptions: int = 0, frames_lost: int = 0,
                 frames_collided: int = 0, foreign_pan_dropped: int = 0):
        self.frames_sent = frames_sent
        self.frames_dropped_busy = frames_dropped_busy
        self.receptions = receptions
        self.frames_lost = frames_lost
        self.frames_collided = frames_collided
        self.foreign_pan_dropped = foreign_pan_dropped

    def as_dict(self) -> dict[str, int]:
        return {k: getattr(self, k) for k in _STATS_FIELDS}

    def __repr__(self) -> str:
        return "RadioStats(" + ", ".join(f"{k}={v}" for k, v in self.as_dict().items()) + ")"

    def __eq__(self, other) -> bool:
        return isinstance(other, RadioStats) and self.as_dict() == other.as_dict()


_STATS_FIELDS = ("frames_sent", "frames_dropped_busy", "receptions", "frames_lost", "frames_collided",
                 "foreign_pan_dropped")


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


@cython.final
@cython.freelist(64)  # one for every frame event: reused, not allocated
@cython.cclass
class _Tx(Due):
    """One transmission: its frame, its time on the air, the sender's antenna position; on the
    clock, its delivery when it has left the air (:meth:`RadioMedium._deliver`, ``run``)."""

    # its typed attributes are declared in ``radio.pxd``

    def __init__(self, frame: Frame, start: cython.double, end: cython.double, x: cython.double, y: cython.double):
        self.frame, self.start, self.end, self.x, self.y = frame, start, end, x, y

    @cython.cfunc
    def run(self) -> cython.void:
        medium: RadioMedium = self.medium
        medium._deliver(self, self.sender)


@cython.final
@cython.freelist(64)  # one for every frame event: reused, not allocated
@cython.cclass
class _Cca(Due):
    """A frame's clear-channel assessment after its backoff, on the clock (``run``:
    :meth:`RadioMedium._cca`); a busy channel schedules the same object again with its counts raised."""

    # its typed attributes are declared in ``radio.pxd``

    @cython.cfunc
    def run(self) -> cython.void:
        medium: RadioMedium = self.medium
        medium._cca(self)


@cython.cfunc
def _on_air(frame: Frame, start: cython.double, end: cython.double, x: cython.double, y: cython.double) -> _Tx:
    """A :class:`_Tx`, its fields set directly (one for every frame on the air)."""
    tx: _Tx = _Tx.__new__(_Tx)
    tx.frame, tx.start, tx.end, tx.x, tx.y = frame, start, end, x, y
    return tx


@cython.final
@cython.cclass
class _Port:
    """An attached station as the medium reads it: its id, its station, its antenna's position reader
    (``station.position``, read for every frame it sends or hears), its MAC's queue of frames."""

    # its typed attributes are declared in ``radio.pxd``

    def __init__(self, node_id: cython.long, station: object):
        self.node_id = node_id
        self.station = station
        self.read_by(station.position)
        self.queue = []

    def read_by(self, position) -> None:
        """The antenna's position reader: ``position()`` gives ``(x, y)``."""
        self.position = position
        owner = getattr(position, "__self__", None)
        own = isinstance(owner, Body) and getattr(position, "__func__", None) is _READ_POSITION
        self.body = owner if own else None

    @cython.cfunc
    def xy(self) -> tuple[cython.double, cython.double]:
        """``position()``: Chipmunk's position of the body by a C call when it is the body's own reader."""
        if cython.compiled and self.body is not None:
            p: cpVect = _cp_get_position(cython.cast(cython.p_void, self.body._cp))
            return p.x, p.y
        return self.position()


@cython.cclass
class RadioMedium:
    """One shared channel; stations attach, then send frames."""

    # its typed attributes are declared in ``radio.pxd``

    def __init__(self, clock: Clock, cfg: RadioConfig, rng: np.random.Generator):
        self.clock = clock
        self._clock = clock  # _clock.call_later(delay, fn, args): a call on the clock
        self.cfg = cfg
        self.rng = rng
        # two independent streams: the MAC's backoffs, and what happens at receivers (loss,
        # shadowing), so that e.g. injecting loss does not reshuffle the backoffs
        mac_rng, rx_rng = rng.spawn(2)
        mac_draws, rx_draws = Draws(mac_rng), Draws(rx_rng)
        self._mac_uniform = mac_draws.uniform
        self._rx_uniform, self._rx_normal = rx_draws.uniform, rx_draws.normal
        self.stations = {}
        self.stats = RadioStats()
        self._air = []
        self._ports = {}
        self._port_list = []
        self.drop_filter = None
        self.trace = None
        self._range2 = cfg.range_m**2
        # RSSI distance estimate d * 10^(σ·z / (10 n)), z ~ N(0, 1)
        self._shadow_k = cfg.rssi_shadowing_db / (10.0 * cfg.path_loss_exponent)
        # the values read for every frame, typed (a field of the pydantic config costs several
        # times an attribute to read)
        self._overhead_bytes, self._bitrate_bps = cfg.frame_overhead_bytes, cfg.bitrate_bps
        self._latency_s, self._turnaround_s = cfg.latency_s, cfg.turnaround_s
        self._min_be, self._max_be, self._max_backoffs = cfg.min_be, cfg.max_be, cfg.max_backoffs
        self._backoff_slot_s = cfg.backoff_slot_s
        self._loss_prob = cfg.loss_prob

    def attach(self, station: Station) -> None:
        node_id = station.node_id
        if node_id in self._ports:  # attached again: the new station replaces the old one in place
            port: _Port = self._ports[node_id]
            port.station = station
            port.read_by(station.position)
            port.queue = []
        else:
            port = _Port(node_id, station)
            self._ports[node_id] = port
            self._port_list.append(port)
        self.stations[node_id] = station

    @cython.ccall
    def airtime_s(self, frame: Frame) -> cython.double:
        return (self._overhead_bytes + frame.size_bytes) * 8.0 / self._bitrate_bps

    # -- sending --------------------------------------------------------------------------------
    def send(self, station: Station, frame: Frame) -> None:
        """Queue ``frame`` from ``station``; its MAC sends one frame at a time, in order:
        latency, then CSMA-CA, then airtime."""
        self._enqueue(self._ports[station.node_id], frame)

    @cython.ccall
    def transmit(self, kind: str, src: cython.long, dst: object, pan: object, payload: dict, size: cython.long):
        """:meth:`send` of the frame ``Frame(kind, src, dst, pan, payload, size)`` from the station
        ``src``, built here (a station's ``send``: one call, the frame's fields set directly)."""
        frame: Frame = Frame.__new__(Frame)
        frame.kind, frame.src, frame.dst, frame.pan = kind, src, dst, pan
        frame.payload, frame.size_bytes, frame.rx_distance_est_m = payload, size, _NAN
        self._enqueue(self._ports[src], frame)

    @cython.cfunc
    def _enqueue(self, port: _Port, frame: Frame) -> cython.void:
        port.queue.append(frame)
        if len(port.queue) == 1:
            self._start(port, frame)

    @cython.cfunc
    def _start(self, port: _Port, frame: Frame) -> cython.void:
        """The MAC takes the first frame of the station's queue: driver latency, first backoff."""
        cca: _Cca = _Cca.__new__(_Cca)
        cca.medium, cca.port, cca.frame, cca.nb, cca.be = self, port, frame, 0, self._min_be
        self._clock.call_due(self._latency_s + self._backoff(cca.be), cca)

    @cython.cfunc
    def _done(self, port: _Port) -> cython.void:
        queue: list = port.queue
        del queue[0]  # the frame just sent or given up
        if queue:
            self._start(port, queue[0])

    @cython.cfunc
    def _backoff(self, be: cython.int) -> cython.double:
        """Random backoff of 0 … 2^BE − 1 unit periods."""
        u: cython.double = self._mac_uniform.next()
        return cython.cast(cython.long, u * (1 << be)) * self._backoff_slot_s

    @cython.cfunc
    def _cca(self, cca: _Cca) -> cython.void:
        """The clear-channel assessment of ``cca.frame`` (module docstring): busy, back off again or
        give up; clear, on the air."""
        port: _Port = cca.port
        frame: Frame = cca.frame
        nb: cython.int = cca.nb
        now: cython.double = self._clock.now
        x: cython.double
        y: cython.double
        x, y = port.xy()
        r2: cython.double = self._range2
        tx: _Tx
        for tx in self._air:
            if tx.start <= now < tx.end and (tx.x - x) ** 2 + (tx.y - y) ** 2 <= r2:  # busy
                if nb >= self._max_backoffs:
                    self.stats.frames_dropped_busy += 1
                    if self.trace is not None:
                        self.trace.busy(now, port.node_id, frame)
                    self._done(port)
                    return
                cca.be = min(cca.be + 1, self._max_be)
                cca.nb = nb + 1
                self._clock.call_due(self._backoff(cca.be), cca)
                return
        # clear: on the air after the RX-to-TX turnaround, which the CCA of others cannot sense
        start: cython.double = now + self._turnaround_s
        tx = _on_air(frame, start, start + self.airtime_s(frame), x, y)
        self._air.append(tx)
        self.stats.frames_sent += 1
        if self.trace is not None:
            self.trace.on_air(now, port.node_id, frame, start, tx.end)
        tx.medium, tx.sender = self, port
        self._clock.call_due(tx.end - now, tx)

    # -- receiving ------------------------------------------------------------------------------
    @cython.cfunc
    def _deliver(self, tx: _Tx, sender: _Port) -> cython.void:
        """The frame has left the air: every station in range gets it now, unless it collided.
        One function on purpose: the loop over the receivers runs on typed locals for every frame."""
        self._done(sender)
        now: cython.double = self._clock.now
        frame: Frame = tx.frame
        air: list = self._air
        # one pass: the transmissions that overlap this one, and the start of the oldest one still
        # on the air (this one included, so never later than now)
        oldest_live: cython.double = now
        overlapping: list = []
        start: cython.double = tx.start
        end: cython.double = tx.end
        t: _Tx
        for t in air:
            if t.end >= now and t.start < oldest_live:
                oldest_live = t.start
            if t is not tx and t.start < end and t.end > start:
                overlapping.append(t)
        # forget transmissions that can no longer overlap anything still on the air (none of them
        # overlaps this one: they ended before the oldest live start, at most this one's start)
        t = air[0]
        if t.end < oldest_live:
            self._air = [t for t in air if t.end >= oldest_live or t is tx]
        if self.drop_filter is not None and self.drop_filter(frame):
            return
        targets: list
        if frame.dst == BROADCAST:
            targets = self._port_list
        else:
            port = self._ports.get(frame.dst)
            targets = [] if port is None else [port]
        stats: RadioStats = self.stats
        r2: cython.double = self._range2
        loss: cython.double = self._loss_prob
        shadow_k: cython.double = self._shadow_k
        src: cython.long = frame.src
        pan = frame.pan
        tx_x: cython.double = tx.x
        tx_y: cython.double = tx.y
        trace = self.trace
        rx: cython.double
        ry: cython.double
        d2: cython.double
        d: cython.double
        est: cython.double
        u: cython.double  # a receiver's loss draw
        z: cython.double  # a receiver's shadowing draw
        node_id: cython.long
        collided: cython.bint
        p: _Port
        for p in targets:
            node_id = p.node_id
            if node_id == src:
                continue
            st = p.station
            rx, ry = p.xy()
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
            if loss > 0:
                u = self._rx_uniform.next()
                if u < loss:
                    stats.frames_lost += 1
                    if trace is not None:
                        trace.reception(now, frame, node_id, LOST, math.nan)
                    continue
            # RSSI-based distance estimate: log-distance path loss with log-normal shadowing
            d = _c_sqrt(d2)
            if d < 0.1:  # max(d, 0.1)
                d = 0.1
            if shadow_k > 0:
                z = self._rx_normal.next()
                est = d * 10.0 ** (shadow_k * z)
            else:
                est = d
            if trace is not None:
                trace.reception(now, frame, node_id, DELIVERED, est)
            st.receive(_received(frame, est))
