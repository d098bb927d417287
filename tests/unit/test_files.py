"""The one atomic writer and the one JSON sanitiser (petswarm_env/files.py)."""

import json
import math
import os

import numpy as np
import pytest

from petswarm_env.files import jsonable, write_atomic, write_json_atomic, write_text_atomic


def test_writes_into_new_folders_with_ordinary_permissions(tmp_path):
    old = os.umask(0o027)
    try:
        path = write_text_atomic(tmp_path / "a" / "b" / "page.html", "<p>hi</p>")
    finally:
        os.umask(old)
    assert path.read_text() == "<p>hi</p>"
    assert path.stat().st_mode & 0o777 == 0o640  # 0o666 less the umask, as open() would create it
    assert sorted(p.name for p in path.parent.iterdir()) == ["page.html"]


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temp_file(tmp_path):
    path = tmp_path / "r.json"
    path.write_text("old")

    def fail(tmp):
        with open(tmp, "w") as f:
            f.write("half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        write_atomic(path, fail)
    assert path.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_the_temp_file_has_the_suffix_writers_expect(tmp_path):
    seen = []
    write_atomic(tmp_path / "policy.npz", lambda tmp: seen.append(tmp) or np.savez(tmp, a=np.zeros(2)))
    assert seen[0].endswith(".npz") and os.path.basename(seen[0]).startswith(".policy.npz.")
    assert np.load(tmp_path / "policy.npz")["a"].tolist() == [0.0, 0.0]
    write_atomic(tmp_path / "policy", lambda tmp: np.savez(tmp, a=np.ones(1)), suffix=".npz")  # a name without it
    assert np.load(tmp_path / "policy")["a"].tolist() == [1.0]


def test_json_is_indented_with_a_final_newline_and_keeps_nan(tmp_path):
    path = write_json_atomic(tmp_path / "x.json", {"a": [1, 2], "b": math.nan})
    text = path.read_text()
    assert text.endswith("}\n") and '\n  "a": [' in text and "NaN" in text


def test_jsonable_gives_plain_strict_json():
    data = {1: (np.int64(3), np.float32(0.5)), "arr": np.arange(3), "flag": np.bool_(True), "bad": [math.inf, np.nan],
            "nested": {"x": np.float64(2.0)}, "s": "text", "none": None}
    out = jsonable(data)
    assert out == {"1": [3, 0.5], "arr": [0, 1, 2], "flag": True, "bad": [None, None], "nested": {"x": 2.0}, "s": "text",
                   "none": None}
    assert type(out["1"][0]) is int and type(out["flag"]) is bool
    json.dumps(out, allow_nan=False)  # strict JSON


# -- temporary files: every exit path, and leftovers of a killed process -----------------------
def _dead_pid() -> int:
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_the_temp_name_says_whose_it_is(tmp_path):
    from petswarm_env.files import TEMP_PATTERN

    seen = []
    write_atomic(tmp_path / "out.json", lambda tmp: seen.append(os.path.basename(tmp)) or open(tmp, "w").close())
    m = TEMP_PATTERN.match(seen[0])
    assert m and m["target"] == "out.json" and int(m["pid"]) == os.getpid() and seen[0].endswith(".json")


def test_stale_temps_of_a_killed_process_go_at_the_next_write_and_nothing_else(tmp_path):
    import petswarm_env.files as files

    dead = _dead_pid()
    stale = [tmp_path / f".out.json.petswarm-tmp-{dead}-abcd1234.json", tmp_path / f".policy.npz.petswarm-tmp-{dead}-x_y0z9qq.npz",
             tmp_path / f".ep.gif.petswarm-tmp-{dead}-00000000.gif"]
    alive = tmp_path / f".out.json.petswarm-tmp-{os.getppid()}-abcd1234.json"  # a writer still running
    users = [tmp_path / ".out.json.backup", tmp_path / f"out.json.petswarm-tmp-{dead}-abcd1234.json",  # no leading dot
             tmp_path / f".out.json.petswarm-tmp-{dead}-abc.json", tmp_path / "notes.txt",
             tmp_path / f".x.petswarm-tmp-{dead}-abcd1234.json.old"]
    for p in stale + [alive] + users:
        p.write_text("x")
    (tmp_path / f".d.petswarm-tmp-{dead}-abcd1234").mkdir()  # a folder of that name is not ours
    files._cleaned_folders.discard(os.path.abspath(tmp_path))
    write_text_atomic(tmp_path / "other.txt", "new")
    left = {p.name for p in tmp_path.iterdir()}
    assert not any(p.name in left for p in stale)
    assert {alive.name, *(p.name for p in users), "other.txt", f".d.petswarm-tmp-{dead}-abcd1234"} == left


def test_sigterm_during_a_write_removes_the_temp_and_keeps_the_old_file(tmp_path):
    import signal

    from petswarm_env.files import Terminated, exit_cleanly_on_signals

    path = tmp_path / "r.json"
    path.write_text("old")

    def killed(tmp):
        with open(tmp, "w") as f:
            f.write("half")
        os.kill(os.getpid(), signal.SIGTERM)

    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(Terminated) as info, exit_cleanly_on_signals():
        write_atomic(path, killed)
    assert info.value.code == 128 + signal.SIGTERM and "SIGTERM" in str(info.value)
    assert path.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]
    assert signal.getsignal(signal.SIGTERM) is before  # handlers restored after the command


def test_ctrl_c_during_a_write_removes_the_temp(tmp_path):
    def interrupted(tmp):
        open(tmp, "w").close()
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_atomic(tmp_path / "r.json", interrupted)
    assert list(tmp_path.iterdir()) == []


def test_json_lines_open_at_the_first_record_and_flush_each(tmp_path):
    from petswarm_env.files import JsonLines, jsonl_path

    assert jsonl_path("a/OUT.json") == jsonl_path("a/OUT.json").with_name("OUT.jsonl")
    assert jsonl_path("res").name == "res.jsonl" and jsonl_path("x.txt").name == "x.txt.jsonl"
    old = tmp_path / "OUT.jsonl"
    old.write_text("old run\n")
    lines = JsonLines(old)
    assert old.read_text() == "old run\n"  # untouched until a record is finished
    lines.append({"seed": 0, "rmse": math.nan})
    assert old.read_text() == '{"seed": 0, "rmse": NaN}\n'  # flushed at once
    lines.append({"seed": 1})
    lines.close()
    assert [json.loads(line)["seed"] for line in old.read_text().splitlines()] == [0, 1]
    JsonLines(None).append({"dropped": True})


@pytest.mark.parametrize("make, words", [
    (lambda p: p.write_bytes(b"PK\x03\x04 truncated"), "not a zip"),
    (lambda p: p.write_bytes(b""), "not a zip"),
    (lambda p: np.savez(p, a=np.array([{"x": 1}], dtype=object)), "Python objects"),
    (lambda p: np.savez(p, a=np.array(["text"])), "not numbers"),
    (lambda p: np.savez(p, a=np.array([1 + 2j])), "not numbers"),
])
def test_read_npz_refuses_what_is_not_plain_numbers(tmp_path, make, words):
    from petswarm_env.files import read_npz

    path = tmp_path / "f.npz"
    make(path)
    with pytest.raises(ValueError, match=words):
        read_npz(path, 10**6)


def test_read_npz_refuses_declared_sizes_beyond_the_file_and_the_limit(tmp_path):
    import zipfile

    from petswarm_env.files import read_npz

    huge = tmp_path / "huge.npz"
    header = np.lib.format.header_data_from_array_1_0(np.zeros(1, np.float32))
    header["shape"] = (10**12,)
    with zipfile.ZipFile(huge, "w") as z:
        with z.open("w0.npy", "w") as f:
            np.lib.format.write_array_header_1_0(f, header)
            f.write(b"\x00" * 16)
    with pytest.raises(ValueError, match=r"declares shape \(1000000000000,\)"):
        read_npz(huge, 10**6)
    big = tmp_path / "big.npz"
    np.savez(big, a=np.zeros(1000))
    with pytest.raises(ValueError, match="more than"):
        read_npz(big, 1000)
    assert read_npz(big, 10**6)["a"].shape == (1000,)


def test_a_signal_swallowed_by_a_callback_is_raised_again_at_the_next_step():
    """pymunk frees a space through a cffi callback, which prints and drops an exception raised in
    it: a SIGTERM or Ctrl-C that lands there must still end the command (files.raise_pending_signal)."""
    import os
    import signal

    from petswarm_env.files import Terminated, exit_cleanly_on_signals, raise_pending_signal

    with exit_cleanly_on_signals():
        raise_pending_signal()  # nothing pending: a no-op
        try:  # the callback: the handler's exception is swallowed
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(1000):
                pass
        except Terminated:
            pass
        with pytest.raises(Terminated) as info:
            raise_pending_signal()
        assert info.value.code == 128 + signal.SIGTERM
    raise_pending_signal()  # the block's end forgets it


def test_a_signal_swallowed_by_a_callback_is_not_printed_and_other_errors_still_are(monkeypatch):
    """Python reports an exception that a callback swallows through sys.unraisablehook ("Exception ignored ...",
    with a traceback): for the pending signal's exception that report is left out, the command's one line comes when
    it is raised again (files.raise_pending_signal); any other swallowed exception reaches the hook that was there
    before. A ``__del__`` stands for the callback (its exceptions go the same way)."""
    import gc
    import os
    import signal
    import sys

    from petswarm_env.files import Terminated, exit_cleanly_on_signals

    reported = []

    def record(unraisable):
        reported.append(unraisable.exc_value)

    monkeypatch.setattr(sys, "unraisablehook", record)

    class Swallows:
        def __init__(self, exc):
            self.exc = exc

        def __del__(self):
            raise self.exc

    with exit_cleanly_on_signals():
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(1000):
                pass
        except Terminated as exc:
            pending = exc
        Swallows(pending)
        gc.collect()
        assert reported == []
        real = ValueError("a real error")
        Swallows(real)
        gc.collect()
        assert reported == [real]
    assert sys.unraisablehook is record  # the block's end puts the previous hook back
