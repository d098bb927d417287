"""Radio traces for Wireshark: every frame the simulated 802.15.4 medium carried, as a pcapng file.

    petswarm run --pcap organize.pcapng           # the first episode (like --video)
    petswarm eval --pcap-dir traces/              # one file per episode

The file format is documented in ``docs/pcap.md`` (generated from this module's tables by
``python -m petswarm.evaluation.pcap --doc docs/pcap.md``). In short:

* **pcapng, one interface per robot** (``robot_0``, ``robot_1``, …; link type
  ``LINKTYPE_IEEE802_15_4_TAP`` = 283, nanosecond timestamps from the simulation clock). Each robot's
  radio is a sniffer: an *outbound* record when its clear CCA put a frame on the air (where the
  medium counts ``frames_sent``), and an *inbound* record on every station the frame reached, at the
  instant it left the air, with how the reception ended in the record's comment and flags
  (``delivered``, ``lost``, ``collided``, ``filtered``). Per-receiver records were chosen over one
  record per frame with the outcome in the TAP header because the TAP header has no field for a
  reception's outcome, and one frame has a different outcome at each receiver.
* **TAP header**: FCS type (16-bit), the start and end of the frame on the air (ns).
* **MAC header** as the radio model has it: a data frame, 2006 format, no MAC acknowledgement
  requested (the model has none), destination and source PAN IDs (one PAN per frame in the model,
  so both are the frame's PAN, written uncompressed), short addresses (a robot's node id; 0xffff
  broadcast), and a per-station data sequence number (DSN) counted by this recorder for every frame a
  station's MAC took, including those CSMA-CA gave up on; then the payload and a real FCS.
* **Payload**: the middleware message type (one byte, :data:`MESSAGES`) and its fields in a compact
  little-endian encoding (:data:`FIELD_TYPES`); airtime in the model comes from
  ``middleware/messages.py:SIZE_BYTES``, not from this encoding's length.

This is the experimenter's tool (it hooks :attr:`petswarm_env.comms.radio.RadioMedium.trace` through
``env.radio_trace``); it lives in ``evaluation/`` because it encodes the middleware's messages, which
the radio (``comms/``) must not import.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path
from typing import Any

from petswarm_env.comms.radio import BROADCAST, DELIVERED, FILTERED, OUTCOMES, Frame
from petswarm_env.files import write_atomic
from petswarm_env.middleware import messages as msg

LINKTYPE_IEEE802_15_4_TAP = 283
BROADCAST_ADDR = 0xFFFF
# frame control: data frame (1), no security, no frame pending, no ack request, no PAN ID
# compression, short destination address (2 << 10), frame version 2006 (1 << 12), short source (2 << 14)
FRAME_CONTROL = 0x0001 | (2 << 10) | (1 << 12) | (2 << 14)
TAP_FCS_TYPE, TAP_SOF_TS, TAP_EOF_TS = 0, 5, 6  # TLV types of the IEEE 802.15.4 TAP header
FLAG_INBOUND, FLAG_OUTBOUND = 1, 2  # epb_flags bits 0-1
FLAG_UNICAST, FLAG_BROADCAST = 1 << 2, 3 << 2  # bits 2-4, reception type
FLAG_FCS_2 = 2 << 5  # bits 5-8: FCS length in octets
FLAG_CRC_ERROR = 1 << 24  # link-layer error: the receiver got a corrupted frame (lost, collided)

# the middleware's messages: type code, then its fields (name, type) in payload order
MESSAGES: dict[str, tuple[int, tuple[tuple[str, str], ...]]] = {
    msg.SCAN: (1, (("known", "ids"),)),
    msg.SCAN_RESPONSE: (2, ()),
    msg.JOIN_QUERY: (3, (("candidates", "ids"),)),
    msg.JOIN_ANSWER: (4, (("available", "bool"), ("lf", "bool"))),
    msg.JOIN_NOTIFY: (5, (("new_pan", "u16"), ("member", "u8"), ("total", "u8"), ("members", "members"),
                          ("shape", "str"), ("mode", "str"), ("links", "links"), ("lf", "ids"))),
    msg.NON_PARTICIPATE: (6, ()),
    msg.NOTIFY_ACK: (7, ()),
    msg.TX_START: (8, (("seq", "u32"),)),
    msg.TX_START_ACK: (9, ()),
    msg.TOKEN: (10, (("seq", "u32"), ("next", "u8"))),
    msg.TOKEN_ACK: (11, ()),
    msg.SYNC: (12, (("seq", "u32"),)),
    msg.HEADING: (13, (("bearing", "f32"),)),
    msg.STATUS: (14, (("velocity", "f32x3"), ("activity", "str"), ("mode", "str"), ("turn_rate", "f32"),
                      ("rotating", "bool"), ("user", "f32x2"))),
    msg.DISPERSE: (15, ()),
    msg.DISPERSE_ACK: (16, ()),
    msg.MODE_CHANGE: (17, (("seq", "u32"), ("mode", "str"), ("members", "members"), ("shape", "str"), ("links", "links"),
                           ("lf", "ids"))),
    msg.MODE_CHANGE_ACK: (18, ()),
    msg.HANDOVER: (19, (("seq", "u32"), ("user", "user"), ("previous", "str"))),
    msg.HANDOVER_ACK: (20, ()),
    msg.STATUS_ANSWER: (21, (("available", "bool"), ("type", "str"), ("battery_mah", "f32"), ("slip_pct", "f32"),
                             ("rate_servo_ma", "f32"), ("rate_act_ma", "f32"), ("rate_sens_ma", "f32"),
                             ("sensors", "u8"), ("distance_m", "f32"))),
    msg.STATUS_QUERY: (24, (("candidates", "ids"),)),
    msg.SLOT_ANNOUNCE: (22, (("seq", "u32"), ("attempt", "u8"), ("slots", "slots"), ("bidders", "ids"))),
    msg.BID: (23, (("seq", "u32"), ("utilities", "bids"))),
    msg.MEMBER_UPDATE: (25, (("seq", "u32"), ("members", "members"), ("shape", "str"), ("links", "links"), ("mode", "str"))),
    msg.MEMBER_UPDATE_ACK: (26, (("seq", "u32"),)),
    msg.BID_REQUEST: (27, (("seq", "u32"), ("member", "u8"), ("sensors", "u8"))),
    msg.BID_REQUEST_ACK: (28, (("seq", "u32"),)),
    msg.CANDIDACY: (29, (("lost", "u16"), ("claim", "i16"), ("member", "u8"), ("mode", "str"), ("lf", "bool"))),
    msg.TAKEOVER: (30, (("seq", "u32"), ("lost", "u16"), ("claim", "i16"), ("member", "u8"), ("members", "members"),
                        ("shape", "str"), ("links", "links"), ("mode", "str"), ("lf", "ids"))),
    msg.TAKEOVER_ACK: (31, (("seq", "u32"),)),
}
KIND_OF_CODE = {code: kind for kind, (code, _) in MESSAGES.items()}

FIELD_TYPES = {  # type: what it is on the wire (little-endian), for docs/pcap.md
    "u8": "unsigned 8-bit integer",
    "u16": "unsigned 16-bit integer",
    "u32": "unsigned 32-bit integer",
    "i16": "signed 16-bit integer",
    "bool": "one byte, 0 or 1",
    "f32": "IEEE 754 single-precision float",
    "f32x2": "two f32 (x, y)",
    "f32x3": "three f32 (vx, vy, ω)",
    "str": "u8 length, then that many bytes of UTF-8",
    "ids": "u8 count, then that many u16 node ids",
    "user": "signed 16-bit user id, -1 for none",
    "members": "u8 count, then per member: u8 member number, u16 node id",
    "links": "u8 count, then per member: u8 member number, u8 link count, then per link: u8 neighbour member, f32 x, f32 y (offset, m)",
    "slots": "u8 count, then per open slot: u8 member number, f32 distance from the master (m), u8 exposed sides (of 4), f32 age (s)",
    "bids": "u8 count, then per entry: u8 member number, f32 utility",
}
_SCALARS = {"u8": "B", "u16": "H", "u32": "I", "i16": "h", "bool": "?", "f32": "f", "f32x2": "2f", "f32x3": "3f", "user": "h"}


# -- payload ---------------------------------------------------------------------------------------
def _encode_field(ftype: str, value: Any, out: bytearray) -> None:
    if ftype in _SCALARS:
        if ftype == "user":
            value = -1 if value is None else value
        vals = tuple(value) if ftype.startswith("f32x") else (value,)
        out += struct.pack("<" + _SCALARS[ftype], *vals)
    elif ftype == "str":
        raw = str(value).encode("utf-8")
        out += struct.pack("<B", len(raw)) + raw
    elif ftype == "ids":
        out += struct.pack(f"<B{len(value)}H", len(value), *value)
    elif ftype == "members":
        out += struct.pack("<B", len(value))
        for m, node in sorted((int(m), n) for m, n in value.items()):
            out += struct.pack("<BH", m, node)
    elif ftype == "slots":
        out += struct.pack("<B", len(value))
        for m, dist, sides, age in value:
            out += struct.pack("<BfBf", m, dist, sides, age)
    elif ftype == "bids":
        out += struct.pack("<B", len(value))
        for m, u in value:
            out += struct.pack("<Bf", m, u)
    elif ftype == "links":
        out += struct.pack("<B", len(value))
        for m, links in sorted((int(m), lks) for m, lks in value.items()):
            out += struct.pack("<BB", m, len(links))
            for nb, (ox, oy) in links:
                out += struct.pack("<Bff", nb, ox, oy)
    else:  # pragma: no cover - the table above names only these
        raise ValueError(f"unknown field type {ftype}")


def encode_payload(kind: str, payload: dict[str, Any]) -> bytes:
    """The frame's payload on the wire: the type code, then its fields (:data:`MESSAGES`). A kind
    or a field the table does not know is an error naming it (the table must follow the middleware)."""
    entry = MESSAGES.get(kind)
    if entry is None:
        raise ValueError(f"pcap: message type '{kind}' has no encoding in evaluation/pcap.py MESSAGES")
    code, fields = entry
    names = [name for name, _ in fields]
    if set(payload) != set(names):
        raise ValueError(f"pcap: '{kind}' frame has fields {sorted(payload)}, MESSAGES encodes {sorted(names)}")
    out = bytearray([code])
    for name, ftype in fields:
        _encode_field(ftype, payload[name], out)
    return bytes(out)


def _decode_field(ftype: str, data: bytes, i: int) -> tuple[Any, int]:
    if ftype in _SCALARS:
        fmt = "<" + _SCALARS[ftype]
        vals = struct.unpack_from(fmt, data, i)
        i += struct.calcsize(fmt)
        if ftype == "user":
            return (None if vals[0] == -1 else vals[0]), i
        return (vals if ftype.startswith("f32x") else vals[0]), i
    n = data[i]
    i += 1
    if ftype == "str":
        return data[i:i + n].decode("utf-8"), i + n
    if ftype == "ids":
        return list(struct.unpack_from(f"<{n}H", data, i)), i + 2 * n
    if ftype in ("slots", "bids"):
        fmt = "<BfBf" if ftype == "slots" else "<Bf"
        size = struct.calcsize(fmt)
        return [struct.unpack_from(fmt, data, i + k * size) for k in range(n)], i + n * size
    out: dict[int, Any] = {}
    for _ in range(n):
        if ftype == "members":
            m, node = struct.unpack_from("<BH", data, i)
            out[m], i = node, i + 3
        else:
            m, count = struct.unpack_from("<BB", data, i)
            i += 2
            links = []
            for _ in range(count):
                nb, ox, oy = struct.unpack_from("<Bff", data, i)
                links.append((nb, (ox, oy)))
                i += 9
            out[m] = links
    return out, i


def decode_payload(data: bytes) -> tuple[str, dict[str, Any]]:
    """The message type and fields of a payload written by :func:`encode_payload`."""
    kind = KIND_OF_CODE.get(data[0]) if data else None
    if kind is None:
        raise ValueError(f"pcap: unknown message type code {data[0] if data else 'none'}")
    fields, i = {}, 1
    for name, ftype in MESSAGES[kind][1]:
        fields[name], i = _decode_field(ftype, data, i)
    return kind, fields


# -- MAC frame ---------------------------------------------------------------------------------------
def _crc_table() -> list[int]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
        table.append(crc)
    return table


_CRC_TABLE = _crc_table()


def fcs16(data: bytes) -> int:
    """The 802.15.4 FCS: ITU-T CRC-16 (x^16 + x^12 + x^5 + 1), LSB first, initial value 0."""
    crc = 0
    for b in data:
        crc = (crc >> 8) ^ _CRC_TABLE[(crc ^ b) & 0xFF]
    return crc


def mac_frame(frame: Frame, dsn: int) -> bytes:
    """The frame as an 802.15.4 MAC data frame: header, payload, FCS."""
    dst = BROADCAST_ADDR if frame.dst == BROADCAST else frame.dst
    mhr = struct.pack("<HBHHHH", FRAME_CONTROL, dsn & 0xFF, frame.pan, dst, frame.pan, frame.src)
    body = mhr + encode_payload(frame.kind, frame.payload)
    return body + struct.pack("<H", fcs16(body))


def tap_header(start_s: float, end_s: float) -> bytes:
    """The IEEE 802.15.4 TAP header: FCS type (16-bit), start and end of the frame on the air (ns)."""
    tlvs = struct.pack("<HHB3x", TAP_FCS_TYPE, 1, 1) + struct.pack("<HHQ", TAP_SOF_TS, 8, _ns(start_s)) + \
        struct.pack("<HHQ", TAP_EOF_TS, 8, _ns(end_s))
    return struct.pack("<BBH", 0, 0, 4 + len(tlvs)) + tlvs


def _ns(t_s: float) -> int:
    return int(round(t_s * 1e9))


# -- pcapng blocks -------------------------------------------------------------------------------------
def _option(code: int, value: bytes) -> bytes:
    return struct.pack("<HH", code, len(value)) + value + b"\0" * (-len(value) % 4)


def _block(block_type: int, body: bytes) -> bytes:
    length = 12 + len(body)
    return struct.pack("<II", block_type, length) + body + struct.pack("<I", length)


def section_header(comment: str) -> bytes:
    options = _option(1, comment.encode()) + _option(4, b"petswarm (evaluation/pcap.py)") + _option(0, b"")
    return _block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1) + options)


def interface(name: str, description: str, bitrate_bps: float) -> bytes:
    options = (_option(2, name.encode()) + _option(3, description.encode()) + _option(8, struct.pack("<Q", int(bitrate_bps)))
               + _option(9, bytes([9])) + _option(0, b""))
    return _block(1, struct.pack("<HHI", LINKTYPE_IEEE802_15_4_TAP, 0, 0) + options)


def packet(iface: int, t_s: float, data: bytes, flags: int, comment: str) -> bytes:
    ts = _ns(t_s)
    body = struct.pack("<IIIII", iface, ts >> 32, ts & 0xFFFFFFFF, len(data), len(data)) + data + b"\0" * (-len(data) % 4)
    body += _option(1, comment.encode()) + _option(2, struct.pack("<I", flags)) + _option(0, b"")
    return _block(6, body)


# -- the recorder -----------------------------------------------------------------------------------------
class PcapRecorder:
    """Records every frame of an env's radio medium from the next ``reset`` on (a
    :class:`~petswarm_env.comms.radio.RadioTrace`), and writes them as pcapng (:meth:`close`).

    Use it like :class:`petswarm.evaluation.runner.VideoRecorder`: build it before the episode's reset (it sets
    ``env.radio_trace``), call it after the reset and after every step (its first call marks the
    episode's start, where the episode summary's ``frames`` start counting), then :meth:`close`."""

    def __init__(self, env, path: str | Path):
        self.env = env
        self.path = Path(path)
        attach_trace(env, self)
        self.records: list[bytes] = []
        self._dsn: dict[int, int] = {}
        self._on_air: dict[int, tuple[Frame, bytes, int, float]] = {}  # id(frame) -> frame, packet, flags, end
        self.episode_start_s: float | None = None
        self.counts = {"sent": 0, "busy": 0, **{o: 0 for o in OUTCOMES}}  # records from the episode's start
        self.never_sent = 0  # frames a MAC numbered that never went on the air, the whole recording

    def _next_dsn(self, station: int) -> int:
        dsn = self._dsn.get(station, -1) + 1
        self._dsn[station] = dsn
        return dsn

    def on_air(self, now: float, station: int, frame: Frame, start_s: float, end_s: float) -> None:
        data = tap_header(start_s, end_s) + mac_frame(frame, self._next_dsn(station))
        cast = FLAG_BROADCAST if frame.dst == BROADCAST else FLAG_UNICAST
        self._on_air[id(frame)] = (frame, data, cast, end_s)
        self.records.append(packet(station, now, data, FLAG_OUTBOUND | cast | FLAG_FCS_2, f"sent {frame.kind}"))
        if self.episode_start_s is not None:
            self.counts["sent"] += 1

    def reception(self, now: float, frame: Frame, receiver: int, outcome: str, distance_est_m: float) -> None:
        _, data, cast, _ = self._on_air[id(frame)]
        flags = FLAG_INBOUND | cast | FLAG_FCS_2
        if outcome in ("lost", "collided"):
            flags |= FLAG_CRC_ERROR
        comment = f"{outcome} {frame.kind}"
        if outcome == DELIVERED:
            comment += f" (rssi distance {distance_est_m:.2f} m)"
        elif outcome == FILTERED:
            comment += f" (PAN 0x{frame.pan:04x})"
        self.records.append(packet(receiver, now, data, flags, comment))
        if self.episode_start_s is not None:
            self.counts[outcome] += 1

    def busy(self, now: float, station: int, frame: Frame) -> None:
        self._next_dsn(station)  # the MAC numbered it; it never went on the air
        self.never_sent += 1
        if self.episode_start_s is not None:
            self.counts["busy"] += 1

    def __call__(self) -> None:
        now = self.env.truth.now
        if self.episode_start_s is None:
            self.episode_start_s = now
            self.first_episode_record = len(self.records) + 1  # Wireshark's frame.number
        # forget the frames that left the air (every reception of a frame comes when it ends)
        self._on_air = {k: v for k, v in self._on_air.items() if v[3] >= now}

    def close(self) -> str:
        """Stop recording and write the file (atomically); returns its path."""
        detach_trace(self.env, self)
        env = self.env
        t0 = self.episode_start_s if self.episode_start_s is not None else math.nan
        n_robots = len(env.truth.robots) if env.episode is not None else 1 + max(self._dsn, default=0)
        first = getattr(self, "first_episode_record", len(self.records) + 1)
        comment = (f"petswarm radio trace: scenario {env.scenario if env.episode is not None else '?'}, {n_robots} robots. The episode starts at "
                   f"t = {t0:.9f} s (the end of reset: pairing and organize come before it), with record {first}: "
                   f"the episode summary's frames count the records from frame.number {first} on: sent = outbound "
                   "records, lost / collided = inbound records whose comment starts with 'lost ' / 'collided '. "
                   f"{self.never_sent} frames were numbered by their MAC and never went on the air (the channel busy at "
                   "every clear-channel assessment): their sequence numbers are missing from their robot's outbound records.")
        bitrate = env.cfg.radio.bitrate_bps
        head = section_header(comment) + b"".join(
            interface(f"robot_{i}", f"robot {i}'s 802.15.4 radio, short address 0x{i:04x}", bitrate) for i in range(n_robots))
        records = self.records

        def write(tmp: str) -> None:
            with open(tmp, "wb") as f:
                f.write(head)
                f.writelines(records)

        write_atomic(self.path, write)
        return str(self.path)


# -- the env's one trace hook, shared by several recorders --------------------------------------------------
class TraceTee:
    """Several :class:`~petswarm_env.comms.radio.RadioTrace` on one medium (the pcap and the replay)."""

    def __init__(self, traces: list):
        self.traces = traces

    def on_air(self, *args) -> None:
        for t in self.traces:
            t.on_air(*args)

    def reception(self, *args) -> None:
        for t in self.traces:
            t.reception(*args)

    def busy(self, *args) -> None:
        for t in self.traces:
            t.busy(*args)


def attach_trace(env, trace) -> None:
    """Add ``trace`` to the env's radio trace (from its next reset on)."""
    current = env.radio_trace
    if current is None:
        env.radio_trace = trace
    elif isinstance(current, TraceTee):
        current.traces.append(trace)
    else:
        env.radio_trace = TraceTee([current, trace])


def detach_trace(env, trace) -> None:
    """Remove ``trace`` from the env's radio trace (and from its current medium)."""
    current = env.radio_trace
    if current is trace:
        env.radio_trace = None
    elif isinstance(current, TraceTee) and trace in current.traces:
        current.traces.remove(trace)
        if len(current.traces) == 1:
            env.radio_trace = current.traces[0]
    radio = getattr(env, "radio", None)
    if radio is not None:
        radio.trace = env.radio_trace

