"""The documentation stays true to the code."""

import re
from pathlib import Path

from petswarm_env.config import load_config
from petswarm_env import state
from petswarm_env.observe import ObservationLayout, markdown_table, observation_bounds

ROOT = Path(__file__).resolve().parents[2]


def test_observation_doc_matches_the_layout():
    cfg = load_config()
    layout = ObservationLayout(cfg.robot.ultrasonic.count)
    doc = (ROOT / "docs" / "observation.md").read_text()
    table = markdown_table(layout, observation_bounds(layout, cfg))
    assert table in doc, "regenerate with: python -m petswarm_env.observation_page > docs/observation.md"
    assert f"{layout.size} values" in doc


def test_the_observation_page_command_the_doc_names_writes_the_doc():
    """The page's own command runs with the compiled core (``python -m`` of a compiled module cannot) and prints
    the page as it is."""
    import subprocess
    import sys

    doc = (ROOT / "docs" / "observation.md").read_text()
    assert "`python -m petswarm_env.observation_page`" in doc
    out = subprocess.run([sys.executable, "-m", "petswarm_env.observation_page"], cwd=ROOT, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout == doc


def test_state_doc_matches_the_state_layout():
    doc = (ROOT / "docs" / "state.md").read_text()
    assert doc == state.markdown(load_config()), "regenerate with: python -m petswarm_env.state > docs/state.md"


README = ROOT / "README.md"
USAGE = ROOT / "docs" / "usage.md"
RUN_CMD = "bash scripts/setup.sh && .venv/bin/petswarm run --episodes 5"
TEST_CMD = "bash scripts/setup.sh test && .venv/bin/python -m pytest"


def test_readme_states_the_observation_size_and_the_ci_command():
    readme = README.read_text()
    layout = ObservationLayout(load_config().robot.ultrasonic.count)
    assert f"({layout.size},)" in readme
    ci = (ROOT / ".ci" / "run").read_text()
    assert TEST_CMD in readme and TEST_CMD in ci
    assert RUN_CMD in readme


def test_readme_is_a_door_short_with_the_quickstart_early():
    lines = README.read_text().splitlines()
    assert len(lines) <= 350, f"README.md has {len(lines)} lines; the limit is 350 (move detail under docs/)"
    first = next(i for i, ln in enumerate(lines) if ln.startswith("```python"))
    end = next(i for i in range(first + 1, len(lines)) if lines[i].startswith("```"))
    assert end < 120, f"the Python quickstart ends on line {end + 1}; it must sit within the first 120"
    assert "parallel_env" in "\n".join(lines[first:end]) and "env.step" in "\n".join(lines[first:end])


def test_readme_quickstart_runs(capsys):
    """The README's first Python block, on a shortened episode (``max_cycles`` added)."""
    code = _block(README, "## Python quickstart")
    short = code.replace('"swarm.num_slaves": 3,', '"swarm.num_slaves": 3, "max_cycles": 40,')
    assert short != code
    exec(compile(short, "README.md", "exec"), {})
    assert "formation RMSE" in capsys.readouterr().out


def test_usage_python_api_example_runs(capsys):
    """docs/usage.md's first Python block (the API tour), on a shortened episode."""
    code = _block(USAGE, "## The Python API")
    short = code.replace('"swarm.num_slaves": 3,', '"swarm.num_slaves": 3, "max_cycles": 40,')
    assert short != code
    exec(compile(short, "docs/usage.md", "exec"), {})
    assert "formation_rmse_m" in capsys.readouterr().out


def test_readme_headline_table_is_the_results_pages():
    """The README's headline rows are docs/results.md's, figure for figure, with the same commands."""
    readme, results = README.read_text(), (ROOT / "docs" / "results.md").read_text()
    rows = [ln for ln in readme.splitlines() if ln.startswith("| scripted, ") or ln.startswith("| random |")]
    assert len(rows) == 5 and all(row in results for row in rows)  # the default's three, 1 + 9 and 1 + 16
    commands = [ln for ln in readme.splitlines() if ln.startswith("petswarm run ")]
    assert len(commands) == 3 and all(c in results for c in commands)


def test_readme_env_card_names_the_versions_spaces_and_every_top_level_key():
    from petswarm_env import ENV_NAME, parallel_env
    from petswarm_env.observe import OBS_VERSION

    readme = README.read_text()
    card = readme[readme.index("## Environment card"):readme.index("## Documentation")]
    env = parallel_env()
    assert ENV_NAME in card and env.metadata["name"] == ENV_NAME
    assert f"observation layout version {OBS_VERSION}" in card
    assert f"{env.state_space.shape[0]} values for the default config, state version {state.STATE_VERSION}" in card
    assert f"Box(-1, 1, {env.action_space(env.possible_agents[0]).shape}" in card
    for mode in env.metadata["render_modes"]:
        assert f'"{mode}"' in card
    for key in load_config().to_dict():
        assert f"`{key}`" in card, f"the env card does not name the top-level config key {key}"
    for name in ("config", "render_mode", "**overrides"):
        assert name in card
    w = load_config().reward
    assert f"weights in `reward:` ({w.formation}, {w.heading}, {w.collision}, {w.smoothness})" in card
    assert f"{env.metadata['render_fps']} fps" in card and f"({load_config().max_cycles} = " in card


def test_readme_and_docs_links_resolve():
    pages = [README, *sorted((ROOT / "docs").glob("*.md"))]
    for page in pages:
        text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            assert (page.parent / path).exists(), f"{page.relative_to(ROOT)} links to {target}, which does not exist"
            if anchor and (not path or path.endswith(".md")):
                heading_of = _anchors(page.parent / (path or page.name))
                assert anchor in heading_of, f"{page.relative_to(ROOT)} links to {target}: no such heading"
    readme = README.read_text()
    for doc in ("architecture", "observation", "state", "faults", "training", "benchmarks", "results", "reproduce",
                "pcap", "usage", "configuration"):
        assert f"(docs/{doc}.md)" in readme, f"the README's table of contents lacks docs/{doc}.md"


def _anchors(page: Path) -> set[str]:
    """GitHub's heading anchors of a markdown page (lower case, punctuation dropped, spaces → -)."""
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
    return {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-") for h in re.findall(r"^#+ (.*)$", text, re.M)}


def test_no_issue_numbers_in_readme_docs_and_configs():
    """Cite papers, not process: no issue numbers in what a user reads."""
    pages = [README, *(ROOT / "docs").glob("*.md"), *(ROOT / "configs").rglob("*.yaml")]
    for page in pages:
        hits = re.findall(r".{0,30}\bissues?\s?#?\d+.{0,30}", page.read_text(), flags=re.I)
        assert not hits, f"{page.relative_to(ROOT)} cites an issue number: {hits[0]!r}"


def _block(page: Path, after: str) -> str:
    text = page.read_text()
    start = text.index("```python", text.index(after)) + len("```python")
    return text[start:text.index("```", start)]


def test_usage_sb3_vector_snippet_runs():
    """docs/usage.md's SB3 snippet over the batched vector env, with a seed, a tiny run in place of its numbers."""
    import pytest

    pytest.importorskip("stable_baselines3")
    code = _block(USAGE, "Stable-Baselines3 over the batched vector env (what")
    small = (code.replace('"max_cycles": 300', '"max_cycles": 10').replace("num_envs=4", "num_envs=1")
             .replace('PPO("MlpPolicy", vec, seed=0)', 'PPO("MlpPolicy", vec, seed=0, n_steps=16, batch_size=32, n_epochs=1)')
             .replace("learn(100_000)", "learn(16)"))
    assert small.count("n_steps=16") == 1 and "learn(16)" in small and "num_envs=1" in small
    exec(compile(small, "docs/usage.md", "exec"), {})


# -- docs/training.md: every command, flag, key, extra and file it names exists ---------------------

TRAINING_DOC = ROOT / "docs" / "training.md"


def _doc_commands(text: str, program: str) -> list[list[str]]:
    """Each ``program …`` command of a markdown text, from its code blocks (one a line) and its
    inline code spans (which may wrap over lines), as shell words."""
    import shlex

    blocks = [body for lang, body in re.findall(r"```(\w*)\n(.*?)```", text, re.S) if lang in ("", "bash")]
    lines = [ln.split(" # ")[0] for b in blocks for ln in b.splitlines()]
    spans = [" ".join(s.split()) for s in re.findall(r"(?<!`)`([^`]+)`(?!`)", re.sub(r"```.*?```", "", text, flags=re.S))]
    out = []
    for line in [*lines, *spans]:
        for part in re.split(r"&&|;", line):
            try:
                words = shlex.split(part.replace("<", "").replace(">", ""), posix=True)
            except ValueError:  # an apostrophe in prose ("the grid's")
                words = part.split()
            for i, w in enumerate(words):
                if w.endswith(program) and i + 1 < len(words):
                    out.append(words[i + 1:])
    return out


def _flags_of(parser) -> set[str]:
    return {s for action in parser._actions for s in action.option_strings}


def test_training_doc_petswarm_commands_use_real_subcommands_flags_and_config_keys():
    from petswarm.cli.main import build_parser
    from petswarm.training.config import load_train_config

    import argparse

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)).choices
    train_keys = set(_flatten(load_train_config().model_dump(mode="json")))
    env_keys = set(_flatten(load_config().to_dict()))
    commands = _doc_commands(TRAINING_DOC.read_text(), "petswarm")
    assert len(commands) >= 8 and {c[0] for c in commands} >= {"train", "eval"}
    for words in commands:
        assert words[0] in sub, f"no subcommand petswarm {words[0]}"
        flags = _flags_of(sub[words[0]])
        for i, w in enumerate(words):
            if w.startswith("--"):
                assert w.split("=")[0] in flags, f"petswarm {words[0]} has no flag {w}"
            if i and words[i - 1] == "--set":
                key = w.split("=")[0]
                ok = key in train_keys or (key.startswith("env.") and key[4:] in env_keys)
                assert ok, f"--set {key}: not a key of the training config"
            if i and words[i - 1] == "--backend":
                assert w in sub["train"]._option_string_actions["--backend"].choices
    spans = re.findall(r"`(--[\w-]+)[^`]*`", TRAINING_DOC.read_text())  # a flag on its own: petswarm train's
    assert len(spans) >= 5 and all(f in _flags_of(sub["train"]) for f in spans), set(spans) - _flags_of(sub["train"])


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict) and v:
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def test_training_doc_scripts_extras_files_and_config_keys_exist():
    import tomllib

    from petswarm.training.config import RESUMABLE, load_train_config

    text = TRAINING_DOC.read_text()
    flat = " ".join(text.split())
    setup = (ROOT / "scripts" / "setup.sh").read_text()
    targets = set(re.findall(r"^\s+(\w+)\)", setup, re.M))
    for target in re.findall(r"scripts/setup\.sh (\w+)", text):
        assert target in targets, f"scripts/setup.sh has no target {target}"
    extras = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"])
    named = [e for group in re.findall(r"(?:petswarm|\.)\[([a-z0-9_,]+)\]", text) for e in group.split(",")]
    assert {"train", "rllib", "torchrl", "benchmarl"} <= set(named)
    assert set(named) <= extras, f"extras the doc names but pyproject lacks: {set(named) - extras}"
    for path in set(re.findall(r"\b((?:training|examples|tests|bench|configs|baselines)/[\w/]+\.(?:py|yaml))", text)):
        assert (ROOT / path).is_file(), f"{path} does not exist"
    for path, test in re.findall(r"(tests/[\w/]+\.py)::(\w+)", text):
        assert f"def {test}(" in (ROOT / path).read_text(), f"{path} has no {test}"
    for module, script, args in re.findall(r"python (?:-m ([\w.]+)|([\w/]+\.py))((?: --[\w-]+(?: [^\s`-]\S*)?)*)", flat):
        module = module.removeprefix("petswarm.")  # petswarm.X.Y is the repository's X/Y.py
        path = ROOT / (script or module.replace(".", "/") + ".py")
        if module and not path.is_file() and module.split(".")[0] not in ("bench", "experiments", "petswarm_env", "tests"):
            continue  # another program's module (python -m venv)
        source = path.read_text()
        for flag in re.findall(r"--[\w-]+", args):
            assert f'"{flag}"' in source, f"{script or module} has no flag {flag}"
    keys = set(_flatten(load_train_config().model_dump(mode="json")))
    for key in re.findall(r"`((?:ppo|rllib|eval|checkpoint|pretrain)\.[a-z_]+)`", text):
        assert key in keys, f"{key} is not a training config key"
    resume = flat[flat.index("`--resume` continues"):]
    resume = resume[:resume.index("RESUMABLE")]
    assert all(f"`{k}`" in resume for k in RESUMABLE), "the resume paragraph lists petswarm.training.config.RESUMABLE"


def test_every_petswarm_command_of_the_readme_and_moved_pages_is_real():
    """The commands that moved out of the README keep naming real subcommands, flags and keys."""
    from petswarm.cli.main import build_parser

    import argparse

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)).choices
    env_keys = set(_flatten(load_config().to_dict()))
    for page in (README, USAGE, *(ROOT / "docs" / f"{n}.md" for n in ("results", "reproduce", "configuration", "faults"))):
        commands = _doc_commands(page.read_text(), "petswarm")
        assert commands or page.name in ("configuration.md", "faults.md"), f"{page.name} names no petswarm command"
        for words in commands:
            if words[0] in ("[--config", "RESULT.json", "..."):
                continue  # the usage synopsis of docs/usage.md's command line
            assert words[0] in sub, f"{page.name}: no subcommand petswarm {words[0]}"
            flags = _flags_of(sub[words[0]])
            for i, w in enumerate(words):
                if w.startswith("--"):
                    assert w.split("=")[0] in flags, f"{page.name}: petswarm {words[0]} has no flag {w}"
                if i and words[i - 1] == "--set" and "=" in w:
                    key = w.split("=")[0]
                    known = key in env_keys or any(k.startswith(f"{key}.") for k in env_keys)
                    assert known, f"{page.name}: --set {key} is no config key"
