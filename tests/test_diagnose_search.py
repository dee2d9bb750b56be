"""The subset search off the stepwise path: one two-fault case (the 10-seed campaigns are
``benchmarks/diagnosis_campaigns.py``, figures in benchmarks/README.md).

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
    shown = []

    def progress(items, desc, **kw):  # stands in for tqdm: records each bar
        shown.append((desc, len(items)))
        return items

    d, ok, why = cases.hexapod_struts(ev, 0, progress)
    assert ok, why
    # the search's pairs are shown as progress, like the stepwise candidates
    assert any(desc == "searching subsets of 2" and n > 0 for desc, n in shown), shown
    assert any(desc == "fitting effects" for desc, _ in shown), shown
    assert d.search is not None and d.search.changed and set(d.search.greedy) != set(d.selected)
    assert not d.implausible  # every fitted value inside its plausible range
    lines = answer(d, ev)["lines"]
    assert sum(line.startswith("Search:") for line in lines) == 1, lines
    assert lines[0].startswith("Explained")
