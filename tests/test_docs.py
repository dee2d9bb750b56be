"""The README stays in step with the interfaces it documents."""

from __future__ import annotations

from pathlib import Path

from eigentwist.description.effects import EFFECTS, PRESETS
from eigentwist.robots import NAMES

README = (Path(__file__).resolve().parent.parent / "README.md").read_text()


def test_readme_starts_with_the_two_commands():
    first_block = README.split("```")[1]
    lines = [ln.split("#")[0].strip() for ln in first_block.splitlines() if ln.strip() and not ln.startswith("sh")]
    assert lines[:2] == ["make run", "make test"]


def test_readme_lists_every_effect_preset_and_robot():
    for name in list(EFFECTS) + list(PRESETS) + list(NAMES):
        assert f"`{name}`" in README or f'"{name}"' in README, name


def test_readme_cites_the_paper_by_doi():
    assert "10.1016/j.mechmachtheory.2019.103775" in README
