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
