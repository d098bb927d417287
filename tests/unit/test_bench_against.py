"""bench/against.py's pure parts: its argument errors (one line each) and its ratio arithmetic."""

import sys

import pytest

from petswarm.bench.against import parse, ratio


def test_the_ratio_is_of_the_totals_and_the_spread_of_the_rounds():
    a = [{"steps": 100, "cpu": 1.0, "wall": 2.0}, {"steps": 300, "cpu": 1.0, "wall": 1.0}]
    b = [{"steps": 50, "cpu": 1.0, "wall": 1.0}, {"steps": 50, "cpu": 2.0, "wall": 1.0}]
    r = ratio(a, b)  # per CPU: a 400 / 2 s = 200/s, b 100 / 3 s; rounds 100/50 = 2, 300/25 = 12
    assert r["total"] == pytest.approx(6.0) and r["min"] == pytest.approx(2.0) and r["max"] == pytest.approx(12.0)
    w = ratio(a, b, "wall")  # a 400 / 3 s, b 100 / 2 s; rounds 50/50 = 1, 300/50 = 6
    assert w["total"] == pytest.approx(400 / 3 / 50) and (w["min"], w["max"]) == pytest.approx((1.0, 6.0))
    with pytest.raises(ValueError, match="two equal, non-empty lists"):
        ratio(a, b[:1])


def _error(capsys, argv):
    with pytest.raises(SystemExit):
        parse(argv)
    lines = [x for x in capsys.readouterr().err.splitlines() if x and not x.startswith(("usage", " "))]
    assert len(lines) == 1, lines
    return lines[0]


def test_bad_arguments_are_one_line_naming_the_fix(capsys, tmp_path):
    root = tmp_path / "other"
    assert "holds no petswarm_env package" in _error(capsys, ["--other-python", sys.executable, "--other-root", str(root)])
    (root / "petswarm_env").mkdir(parents=True)
    (root / "petswarm_env" / "__init__.py").write_text("")
    assert "is not an executable file" in _error(capsys, ["--other-python", str(root / "py"), "--other-root", str(root)])
    assert "--burst-s > 0" in _error(capsys, ["--other-python", sys.executable, "--other-root", str(root), "--burst-s", "0"])
    assert parse(["--other-python", sys.executable, "--other-root", str(root)]).rounds == 6
