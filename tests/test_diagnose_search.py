"""The subset search off the stepwise path: one two-fault case (the 10-seed campaigns are
``benchmarks/diagnosis_two_faults.py``, figures in benchmarks/README.md).

Hexapod, struts 2 and 5 at k_s = 3e7 N/m (a third of the default), 0.5 % noise, 54 rows: forward
selection starts with a leg that stands for both and ends on the wrong pair; the search finds
a series compliance on legs 2 and 5 (strut, joints and actuator loss are one model on a leg:
equal frequencies everywhere, so either name is right), the data explained, and the answer
says the search changed the stepwise result.
"""

from __future__ import annotations

import pytest

import eigentwist
from eigentwist.diagnose.answer import answer
from tests import diagnosis_cases as cases

pytestmark = [pytest.mark.slow, pytest.mark.compiled]


def test_two_softer_struts_are_found_off_the_greedy_path():
    ev = eigentwist.load("hexapod", backend="c")
    d, ok, why = cases.hexapod_struts(ev, 0)
    assert ok, why
    assert d.search is not None and d.search.changed and set(d.search.greedy) != set(d.selected)
    assert not d.implausible  # every fitted value inside its plausible range
    lines = answer(d, ev)["lines"]
    assert sum(line.startswith("Search:") for line in lines) == 1, lines
    assert lines[0].startswith("Explained")
