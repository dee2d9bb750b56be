"""CI runs every tier: with EIGENTWIST_REQUIRE_TIERS=1 (set by .ci/run) a tier that cannot
run fails instead of skipping."""

from __future__ import annotations

from pathlib import Path

import pytest

from .conftest import REQUIRE_TIERS_ENV, skip_tier


def test_missing_tool_skips_outside_ci(monkeypatch):
    monkeypatch.delenv(REQUIRE_TIERS_ENV, raising=False)
    with pytest.raises(pytest.skip.Exception, match="compiled tier skipped: no C compiler"):
        skip_tier("compiled", "no C compiler")


@pytest.mark.parametrize("tier", ["compiled", "browser"])
def test_missing_tool_fails_where_tiers_are_required(monkeypatch, tier):
    monkeypatch.setenv(REQUIRE_TIERS_ENV, "1")
    with pytest.raises(pytest.fail.Exception, match=f"the {tier} tier cannot run here but {REQUIRE_TIERS_ENV}=1"):
        skip_tier(tier, "tool missing")


def test_ci_script_requires_the_tiers():
    text = (Path(__file__).resolve().parent.parent / ".ci" / "run").read_text()
    assert f"export {REQUIRE_TIERS_ENV}=1" in text
    assert text.index(f"export {REQUIRE_TIERS_ENV}=1") < text.rindex("\nmake test")
