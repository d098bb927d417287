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
    assert table in doc, "regenerate with: python -m petswarm_env.observe > docs/observation.md"
    assert f"{layout.size} values" in doc


def test_state_doc_matches_the_state_layout():
    doc = (ROOT / "docs" / "state.md").read_text()
    assert doc == state.markdown(load_config()), "regenerate with: python -m petswarm_env.state > docs/state.md"


def test_readme_states_the_observation_size_and_the_ci_command():
    readme = (ROOT / "README.md").read_text()
    layout = ObservationLayout(load_config().robot.ultrasonic.count)
    assert f"({layout.size},)" in readme
    ci = (ROOT / ".ci" / "run").read_text()
    test_cmd = "bash scripts/setup.sh test && .venv/bin/python -m pytest"
    assert test_cmd in readme and test_cmd in ci


def test_configs_default_is_the_packaged_default():
    assert (ROOT / "configs" / "default.yaml").read_text() == (ROOT / "petswarm_env" / "default.yaml").read_text()


def test_configs_train_ppo_is_the_packaged_training_default():
    assert (ROOT / "configs" / "train" / "ppo.yaml").read_text() == (ROOT / "training" / "ppo.yaml").read_text()


def test_every_default_value_has_a_comment_or_a_commented_section():
    text = (ROOT / "petswarm_env" / "default.yaml").read_text()
    headers: dict[int, str] = {}  # indentation -> the section line above
    for line in text.splitlines():
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        indent = len(line) - len(line.lstrip())
        if line.rstrip().endswith(":") or re.match(r"^\s*\w+:\s+#", line):
            headers[indent] = line
            continue
        parents = [h for i, h in headers.items() if i < indent]
        assert "#" in line or any("#" in h for h in parents), f"undocumented default: {line.strip()}"


def _readme_block(after: str) -> str:
    text = (ROOT / "README.md").read_text()
    start = text.index("```python", text.index(after)) + len("```python")
    return text[start:text.index("```", start)]


def test_readme_supersuit_sb3_snippet_runs():
    """The README's FixedAgents + SuperSuit + SB3 snippet, with a tiny run in place of its numbers."""
    import pytest

    pytest.importorskip("stable_baselines3")
    pytest.importorskip("supersuit")
    code = _readme_block("SuperSuit + Stable-Baselines3 (what")
    small = (code.replace("max_cycles=300", "max_cycles=10").replace("4, num_cpus=2", "1, num_cpus=0")
             .replace('PPO("MlpPolicy", vec)', 'PPO("MlpPolicy", vec, n_steps=16, batch_size=32, n_epochs=1)')
             .replace("learn(100_000)", "learn(16)"))
    assert small != code
    exec(compile(small, "README.md", "exec"), {})
