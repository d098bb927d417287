"""The house rules (docs/architecture.md), read from the source: sizes of files and functions.

No module outside ``tests/`` is over ``MAX_FILE_LINES`` lines, and no function is over
``MAX_FUNCTION_LINES`` lines unless its docstring says why it is one function ("on purpose").
"""

import ast
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 80


def _project_sources() -> list[Path]:
    out = subprocess.run(["git", "ls-files", "*.py"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    files = [ROOT / line for line in out.split() if not line.startswith("tests/")]
    assert len(files) > 50, "the project's sources were not found"
    return files


def test_no_module_is_over_the_file_limit():
    long = [f"{p.relative_to(ROOT)}: {n} lines" for p in _project_sources()
            if (n := len(p.read_text().splitlines())) > MAX_FILE_LINES]
    assert not long, f"modules over {MAX_FILE_LINES} lines (split them by idea):\n" + "\n".join(long)


def test_a_long_function_says_why_it_is_one():
    long = []
    for path in _project_sources():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES and "on purpose" not in (ast.get_docstring(node) or ""):
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name}: {n} lines")
    assert not long, (f"functions over {MAX_FUNCTION_LINES} lines whose docstring does not say why they are one "
                      "function ('... on purpose ...'):\n" + "\n".join(long))


def test_the_rules_can_fail(tmp_path):
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES + 1))
    tree = ast.parse(f"def f():\n{body}\n")
    fn = tree.body[0]
    assert fn.end_lineno - fn.lineno + 1 > MAX_FUNCTION_LINES and ast.get_docstring(fn) is None
