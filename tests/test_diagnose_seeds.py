"""The diagnosis cases over seeds: the diagnosis says the right thing in >= 3 of the first 4 seeds.

Each case (``tests/diagnosis_cases.py``) draws its noise and the truth's nuisance
parameters (eta_a and l2 +-1 %, in the truth only) from the seed. In-process calls on the
C backend where a compiler exists (NumPy otherwise; same numbers). The full campaigns (10
seeds per case, >= 9 right; 20 clean seeds per noise level) are a study:
``benchmarks/diagnosis_campaigns.py``, figures in ``benchmarks/README.md``.
"""

from __future__ import annotations

import pytest

import eigentwist

from .diagnosis_cases import CASES, baseline_truth, run

pytestmark = pytest.mark.slow

SEEDS = range(4)
CLEAN_SEEDS = 6


@pytest.fixture(scope="module")
def ev_fast():
    return eigentwist.load("heli4", backend="auto")


@pytest.mark.parametrize("case", list(CASES))
def test_right_in_three_of_four_seeds(ev_fast, case):
    # the seeds stop once the verdict is decided (e.g. after 3 right ones: the fourth cannot fail it)
    results = run(CASES[case], ev_fast, SEEDS, allowed_wrong=1)
    wrong = [(seed, why) for seed, ok, why in results if not ok]
    assert len(wrong) <= 1, f"{case}: wrong in {len(wrong)} of the first {len(results)} of {len(SEEDS)} seeds: {wrong}"


@pytest.mark.parametrize("noise", [0.005, 0.02])
def test_nothing_added_when_the_truth_is_the_baseline(ev_fast, noise):
    # independent noise draws per level: the seeds of the two levels differ
    offset = {0.005: 0, 0.02: 1000}[noise]
    results = run(
        lambda ev, seed: baseline_truth(ev, offset + seed, noise), ev_fast, range(CLEAN_SEEDS), allowed_wrong=1
    )
    wrong = [why for _, ok, why in results if not ok]
    assert len(wrong) <= 1, wrong
