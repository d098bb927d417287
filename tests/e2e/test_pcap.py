"""`petswarm run --pcap`: the trace read back by tshark (Debian's tshark) and by dpkt (PyPI, the
test extra), each where installed: the join protocol in order on the right PANs, valid MAC frames,
and the frame counts of the episode summary."""

import binascii
import json
import re
import shutil
import struct
import subprocess
from pathlib import Path

import pytest

from petswarm.cli.main import main
from petswarm.evaluation.pcap import KIND_OF_CODE, decode_payload

ROOT = Path(__file__).resolve().parents[2]
LUA = ROOT / "docs" / "examples" / "petswarm.lua"
SWARM_PAN, WAITING_PAN = 0x1001, 0x0000
JOIN = ("scan", "scan_response", "join_query", "join_answer", "join_notify", "notify_ack")
FIELDS = ("frame.number", "frame.interface_id", "frame.packet_flags_direction", "wpan.seq_no", "wpan.dst_pan", "wpan.src_pan",
          "wpan.dst16", "wpan.src16", "wpan.fcs_ok", "petswarm.kind", "petswarm.new_pan", "frame.comment")


@pytest.fixture(scope="module")
def episode(tmp_path_factory):
    d = tmp_path_factory.mktemp("pcap")
    path, out = d / "trace.pcapng", d / "run.json"
    assert main(["run", "--set", "max_cycles=60", "--set", "radio.loss_prob=0.05", "--seed", "4", "--pcap", str(path),
                 "--json", str(out), "--quiet"]) == 0
    return path, json.loads(out.read_text())["episodes"][0]


def _hexint(text):
    return int(text, 0) if text else None


def read_tshark(path):
    """Records (one dict each, in file order) and the section comment, as tshark and capinfos see them."""
    rows = subprocess.run(["tshark", "-X", f"lua_script:{LUA}", "-r", str(path), "-T", "fields", "-E", "separator=\t",
                           "-E", "occurrence=f", *[a for f in FIELDS for a in ("-e", f)]],
                          capture_output=True, text=True, check=True, timeout=120).stdout
    records = []
    for line in rows.splitlines():
        v = dict(zip(FIELDS, line.split("\t")))
        records.append({"number": int(v["frame.number"]), "iface": int(v["frame.interface_id"]),
                        "out": _hexint(v["frame.packet_flags_direction"]) == 2, "dsn": int(v["wpan.seq_no"]),
                        "dst_pan": _hexint(v["wpan.dst_pan"]), "src_pan": _hexint(v["wpan.src_pan"]),
                        "dst": _hexint(v["wpan.dst16"]), "src": _hexint(v["wpan.src16"]),
                        "fcs_ok": v["wpan.fcs_ok"] in ("1", "True"), "kind": v["petswarm.kind"],
                        "new_pan": _hexint(v["petswarm.new_pan"]), "comment": v["frame.comment"]})
    info = subprocess.run(["capinfos", "-k", str(path)], capture_output=True, text=True, check=True).stdout
    return records, info


def _reflect(x, bits):
    return int(f"{x:0{bits}b}"[::-1], 2)


def read_dpkt(path):
    """The same records through dpkt's pcapng blocks and a plain parse of the TAP and MAC headers."""
    pcapng = pytest.importorskip("dpkt.pcapng")
    data, i, records, comment = path.read_bytes(), 0, [], ""
    while i < len(data):
        btype, blen = struct.unpack_from("<II", data, i)
        block = data[i:i + blen]
        i += blen
        if btype == pcapng.PCAPNG_BT_SHB:
            comment = next(o.text for o in pcapng.SectionHeaderBlockLE(block).opts if o.code == pcapng.PCAPNG_OPT_COMMENT)
            continue
        if btype != pcapng.PCAPNG_BT_EPB:
            continue
        epb = pcapng.EnhancedPacketBlockLE(block)
        opts = {o.code: o for o in epb.opts}
        flags = struct.unpack("<I", opts[2].data)[0]
        raw = epb.pkt_data
        tap_len = struct.unpack_from("<H", raw, 2)[0]
        mac = raw[tap_len:]
        _, dsn, dst_pan, dst, src_pan, src = struct.unpack_from("<HBHHHH", mac)
        body, fcs = mac[:-2], struct.unpack("<H", mac[-2:])[0]
        crc = _reflect(binascii.crc_hqx(bytes(_reflect(b, 8) for b in body), 0), 16)
        kind, fields = decode_payload(body[11:])
        assert KIND_OF_CODE[body[11]] == kind
        records.append({"number": len(records) + 1, "iface": epb.iface_id, "out": flags & 3 == 2, "dsn": dsn,
                        "dst_pan": dst_pan, "src_pan": src_pan, "dst": dst, "src": src, "fcs_ok": crc == fcs, "kind": kind,
                        "new_pan": fields.get("new_pan"), "comment": opts[1].text})
    return records, comment


def _reader(name):
    if name == "tshark" and (shutil.which("tshark") is None or shutil.which("capinfos") is None):
        pytest.skip("tshark is not installed (bash scripts/setup.sh test installs Debian's tshark)")
    return read_tshark if name == "tshark" else read_dpkt


@pytest.mark.parametrize("reader", ["tshark", "dpkt"])
def test_the_trace_reads_back_with_the_organize_in_order_and_the_summarys_counts(episode, reader):
    path, summary = episode
    records, info = _reader(reader)(path)
    first = int(re.search(r"from frame\.number (\d+) on", info).group(1))
    assert all(r["fcs_ok"] for r in records)
    sent = [r for r in records if r["out"]]
    # every robot's radio: its own frames outbound, with one DSN after the other but for the frames its MAC
    # numbered and never sent (the channel busy at every clear-channel assessment, counted in the comment); others'
    # frames inbound
    assert all(r["iface"] == r["src"] for r in sent) and all(r["iface"] != r["src"] for r in records if not r["out"])
    never_sent = int(re.search(r"(\d+) frames were numbered by their MAC and never went on the air", info).group(1))
    skipped = 0
    for robot in {r["iface"] for r in sent}:
        dsns = [r["dsn"] for r in sent if r["iface"] == robot]
        steps = [(b - a) % 256 for a, b in zip(dsns, dsns[1:])]
        assert all(1 <= d <= 1 + never_sent for d in steps) and dsns[0] <= never_sent
        skipped += sum(d - 1 for d in steps) + dsns[0]
    assert skipped <= never_sent  # (a robot's last numbers, never sent, leave no gap)
    assert all(r["dst_pan"] == r["src_pan"] for r in records)
    # the join protocol, in order, on the common PAN (seed 000 Fig. 8)
    join = [r for r in sent if r["kind"] in JOIN]
    assert join[0]["kind"] == "scan" and join[0]["src"] == 0 and join[0]["dst"] == 0xFFFF
    assert all(r["dst_pan"] == WAITING_PAN for r in join)
    order = [r["kind"] for r in join]
    slaves = sorted({r["dst"] for r in join if r["kind"] == "join_notify"})
    assert len(slaves) == summary["slaves"] == 4
    for s in slaves:  # each slave: a scan, its response, a query, its answer, its notification, its acknowledgement
        mine = [(r["kind"], r["src"]) for r in join if r["src"] == s or r["dst"] == s]
        response = next(k for k, r in enumerate(join) if r["src"] == s and r["kind"] == "scan_response")
        assert "scan" in order[:response] and "join_query" in order[response:], mine
        answer = next(k for k, r in enumerate(join) if r["src"] == s and r["kind"] == "join_answer")
        notify = next(k for k, r in enumerate(join) if r["dst"] == s and r["kind"] == "join_notify")
        ack = next(k for k, r in enumerate(join) if r["src"] == s and r["kind"] == "notify_ack" and k > notify)
        assert response < answer < notify < ack and "join_query" in order[response:answer], mine
        assert join[notify]["new_pan"] == SWARM_PAN
    last_ack = max(k for k, r in enumerate(sent) if r["kind"] == "notify_ack")
    swarm = [r for r in sent[last_ack + 1:] if r["kind"] in ("status", "tx_start", "token", "sync", "heading")]
    assert swarm and all(r["dst_pan"] == SWARM_PAN for r in swarm)
    assert {r["kind"] for r in swarm} >= {"status", "tx_start", "token"}
    # the episode summary's frames: the records from the episode's first one on
    episode_records = [r for r in records if r["number"] >= first]
    counts = {"sent": sum(r["out"] for r in episode_records),
              "lost": sum(r["comment"].startswith("lost ") for r in episode_records),
              "collided": sum(r["comment"].startswith("collided ") for r in episode_records)}
    assert counts == summary["frames"] and counts["lost"] > 0 and counts["collided"] > 0
    assert first > 1 and any(not r["out"] and r["comment"].startswith("delivered ") for r in episode_records)


def test_pcap_must_be_named_pcapng(tmp_path, capsys):
    assert main(["run", "--set", "max_cycles=1", "--pcap", str(tmp_path / "trace.pcap")]) == 2
    assert "--pcap must name a .pcapng file" in capsys.readouterr().err
    assert not (tmp_path / "trace.pcap").exists()
