"""README.md is for users: at most 800 words, what fitlab is in its first lines, the two set-up commands at the
top, and the "which model for which job" table as tools/readme_table.py prints it from the report's CSV."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
COMMANDS = ['pip install -e ".[dev]" && fitlab refit --target H0',
            'sh tools/install-system-packages.sh; pip install -e ".[dev]" && pytest']  # fmt: skip


def _script():
    spec = importlib.util.spec_from_file_location("readme_table", ROOT / "tools" / "readme_table.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_readme_is_short_and_opens_with_what_fitlab_is():
    words = len(README.split())
    assert words <= 800, f"README.md has {words} words; at most 800 (move the rest to docs/ or CONTRIBUTING.md)"
    lines = README.splitlines()
    assert lines[0] == "# fitlab"
    assert "fitlab fits, measures and generates code for analytic BRDFs" in " ".join(lines[1:4])


def test_the_two_commands_come_first():
    block = README.split("```")[1].strip().splitlines()
    assert block == COMMANDS
    assert README.index(COMMANDS[0]) < README.index("## ")


def test_the_model_table_is_what_the_script_prints():
    script = _script()
    assert script.with_table(README, script.use_table()) == README, \
        "README.md's table is not the report's: run python tools/readme_table.py --write"  # fmt: skip


def test_every_link_of_the_readme_names_a_file():
    import re

    links = re.findall(r"\]\(([^)#]+)\)", README)
    local = [link for link in links if "://" not in link]
    assert len(local) > 10
    missing = [link for link in local if not (ROOT / link).exists()]
    assert not missing, f"README.md links to files that do not exist: {missing}"
