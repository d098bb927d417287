"""The radio trace's encoding (evaluation/pcap.py): payloads, MAC frames, FCS, and the generated docs."""

import binascii
import struct
from pathlib import Path

import pytest

from petswarm.evaluation import pcap
from petswarm.evaluation.pcap_docs import with_lua_tables, with_table
from petswarm_env.comms.radio import BROADCAST, Frame
from petswarm_env.middleware import messages as msg

ROOT = Path(__file__).resolve().parents[2]

EXAMPLES = {
    msg.SCAN: {"known": [1, 3]},
    msg.JOIN_QUERY: {"candidates": [2, 4, 300]},
    msg.JOIN_ANSWER: {"available": False},
    msg.STATUS_QUERY: {"candidates": [2, 5]},
    msg.STATUS_ANSWER: {"available": True, "type": "petbot", "battery_mah": 2500.0, "slip_pct": 1.0,
                        "rate_servo_ma": 320.0, "rate_act_ma": -1.0, "rate_sens_ma": 65.0, "sensors": 7, "distance_m": 1.5},
    msg.SLOT_ANNOUNCE: {"seq": 3, "attempt": 1, "slots": [(1, 1.0, 1, 0.5), (3, 2.0, 2, 0.5)], "bidders": [2, 4]},
    msg.BID: {"seq": 3, "utilities": [(1, 0.25), (3, 0.5)]},
    msg.JOIN_NOTIFY: {"new_pan": 0x1001, "member": 2, "total": 5, "members": {0: 0, 1: 3, 2: 4}, "shape": "wedge",
                      "mode": "following", "links": {1: [(0, (-1.0, 0.5))], 2: [(0, (-1.0, -0.5))]}},
    msg.TX_START: {"seq": 1999},
    msg.TOKEN: {"seq": 2000, "next": 3},
    msg.SYNC: {"seq": 2000},
    msg.HEADING: {"bearing": -1.25},
    msg.STATUS: {"velocity": (0.5, -0.25, 0.125), "activity": "walk", "mode": "leading", "turn_rate": 0.5,
                 "rotating": True, "user": (1.0, -0.5)},
    msg.MODE_CHANGE: {"seq": 3, "mode": "leading", "members": {0: 4, 1: 0}, "shape": "wedge",
                      "links": {1: [(0, (-1.0, 0.5))], 2: [(0, (-1.0, -0.5)), (1, (0.0, -1.0))]}},
    msg.HANDOVER: {"seq": 3, "user": None, "previous": "following"},
    msg.MEMBER_UPDATE: {"seq": 21500, "members": {0: 0, 1: 4, 2: 2}, "shape": "wedge", "links": {1: [(0, (-1.0, 0.5))],
                        2: [(0, (-1.0, -0.5))]}, "mode": "following"},
    msg.MEMBER_UPDATE_ACK: {"seq": 21500},
}


def test_every_message_of_the_middleware_has_an_encoding():
    assert set(pcap.MESSAGES) == set(msg.SIZE_BYTES)
    codes = [code for code, _ in pcap.MESSAGES.values()]
    assert len(set(codes)) == len(codes) and all(1 <= c <= 255 for c in codes)
    assert {t for _, fields in pcap.MESSAGES.values() for _, t in fields} <= set(pcap.FIELD_TYPES)


@pytest.mark.parametrize("kind", list(pcap.MESSAGES))
def test_payloads_round_trip(kind):
    payload = EXAMPLES.get(kind, {})
    assert set(payload) == {name for name, _ in pcap.MESSAGES[kind][1]}, "give the test an example of every field"
    data = pcap.encode_payload(kind, payload)
    assert data[0] == pcap.MESSAGES[kind][0]
    assert pcap.decode_payload(data) == (kind, payload)  # the examples' floats are exact in f32


def test_a_payload_that_does_not_match_the_table_is_an_error_naming_it():
    with pytest.raises(ValueError, match="'scan' frame has fields"):
        pcap.encode_payload(msg.SCAN, {"known": [], "extra": 1})
    with pytest.raises(ValueError, match="'teleport' has no encoding"):
        pcap.encode_payload("teleport", {})


def _reflect(x: int, bits: int) -> int:
    return int(f"{x:0{bits}b}"[::-1], 2)


def test_fcs_is_the_itu_t_crc16_of_802_15_4():
    assert pcap.fcs16(b"123456789") == 0x2189  # CRC-16/KERMIT check value
    data = bytes(range(40))
    # the same CRC from the standard library: the non-reflected CCITT CRC of the bit-reversed bytes, reversed
    oracle = _reflect(binascii.crc_hqx(bytes(_reflect(b, 8) for b in data), 0), 16)
    assert pcap.fcs16(data) == oracle


def test_mac_frame_carries_the_radio_models_header():
    frame = Frame(msg.JOIN_ANSWER, src=3, dst=0, pan=0x0000, payload={"available": True})
    raw = pcap.mac_frame(frame, dsn=258)
    fc, seq, dpan, dst, span, src = struct.unpack_from("<HBHHHH", raw)
    assert fc & 0x7 == 1 and (fc >> 10) & 3 == 2 and (fc >> 14) & 3 == 2 and (fc >> 12) & 3 == 1  # data, short, 2006
    assert not fc & (1 << 5) and not fc & (1 << 6)  # no ack request, PAN IDs both present
    assert (seq, dpan, dst, span, src) == (2, 0x0000, 0, 0x0000, 3)
    assert raw[11:-2] == pcap.encode_payload(msg.JOIN_ANSWER, {"available": True})
    assert struct.unpack("<H", raw[-2:])[0] == pcap.fcs16(raw[:-2])
    bcast = pcap.mac_frame(Frame(msg.SCAN, src=0, dst=BROADCAST, pan=0x1001, payload={"known": []}), 0)
    assert struct.unpack_from("<HH", bcast, 3) == (0x1001, 0xFFFF)


def test_tap_header_is_version_0_with_its_length():
    head = pcap.tap_header(1.5, 1.500672)
    assert head[:2] == b"\0\0" and struct.unpack_from("<H", head, 2)[0] == len(head) == 36
    assert struct.unpack_from("<HHQ", head, 12) == (5, 8, 1_500_000_000)
    assert struct.unpack_from("<HHQ", head, 24) == (6, 8, 1_500_672_000)


def test_the_docs_and_the_dissector_are_generated_from_the_tables():
    doc = (ROOT / "docs" / "pcap.md").read_text(encoding="utf-8")
    assert with_table(doc) == doc, "regenerate: python -m petswarm.evaluation.pcap_docs --md docs/pcap.md --lua docs/examples/petswarm.lua"
    lua = (ROOT / "docs" / "examples" / "petswarm.lua").read_text(encoding="utf-8")
    assert with_lua_tables(lua) == lua
