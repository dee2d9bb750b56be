"""The subset search's rules on a table of fits (no model evaluated: cheap).

The fitter and the scope are replaced by a table: each subset of single effects has a chi2
(n = 30 rows, one parameter per effect, AICc = chi2 + 2 k here) and fitted values. Every
expectation follows from the module's rules written out: the beam of ``BEAM`` plausible
subsets, at most ``MAX_SIZE`` effects, the stop when a size's best counted subset explains the
data, the forward rule for each member (``scipy.stats.f`` here), ties within ``DELTA_AICC``,
the warm start from the members' single fits.
"""

from __future__ import annotations

import itertools
import math
from types import SimpleNamespace as NS

import numpy as np
import pytest
from scipy import stats

from eigentwist.diagnose import search
from eigentwist.diagnose.stats import DELTA_AICC

N, ALPHA = 30, 0.01
BASE_VALUE, SINGLE_VALUE, JOINT_VALUE = 2.0, 4.0, 5.0  # all inside the plausible range (1, 10)


class World:
    """Fits looked up by the set of effects on top of the baseline ``base``."""

    def __init__(self, chi2, preds=None, conflicts=(), at_bound=None, values=None):
        self.chi2, self.preds = chi2, preds or {}
        self.conflicts = {frozenset(c) for c in conflicts}
        self.at_bound, self.values = at_bound or {}, values or {}
        self.calls = []

    def result(self, members, value):
        key = frozenset(members)
        names = ("k_base",) + tuple(f"k_{e}" for e in members)
        values = {n: (BASE_VALUE if n == "k_base" else value) for n in names}
        values.update(self.values.get(key, {}))
        chi2 = self.chi2(key) if callable(self.chi2) else self.chi2[key]
        k = len(names)
        pred = np.asarray(self.preds.get(key, (0.0, 0.0, 0.0)), float)
        return NS(
            effects=("base",) + tuple(members),
            names=names,
            values=values,
            std={n: 0.1 for n in names},
            fixed={"k_fixed": 7.0},
            comparison=NS(predicted=pred),
            chi2=chi2,
            n=N,
            k=k,
            aicc=chi2 + 2 * k,
            at_bound=tuple(self.at_bound.get(key, ())),
        )

    def candidates(self, ev, effects, *, per_leg):
        assert ev is self.ev and per_leg is True
        return [e for e in "abcdefgh" if e not in effects and not any({e, x} in self.conflicts for x in effects)]

    def order(self, ev, effects):
        assert ev is self.ev
        return ("ordered",) + tuple(effects)

    def fit(self, meas, effects, ev, names, *, start, fixed, explore, max_nfev):
        assert effects[:2] == ("ordered", "base") and meas is self.meas and ev is self.ev
        members = effects[2:]
        self.calls.append(
            NS(members=members, names=names, start=dict(start), fixed=fixed, explore=explore, nfev=max_nfev)
        )
        return self.result(members, JOINT_VALUE)

    def single(self, e, i, plausible=True):
        return NS(effect=e, plausible=plausible, fit=self.result((e,), SINGLE_VALUE), names=(f"k_{e}",), order=i)


def _parameter(name):
    assert name.startswith("k_"), name
    return NS(plausible_range=(1.0, 10.0))


@pytest.fixture
def ev():
    return NS(parameter=_parameter)


def _run(monkeypatch, world, ev, singles, greedy, m=1, alpha=ALPHA):
    monkeypatch.setattr(search, "fit", world.fit)
    monkeypatch.setattr(search, "scope", world)
    world.ev, world.meas = ev, NS(sigma_hz=np.ones(3))
    base = world.result((), BASE_VALUE)
    return search.search_subsets(world.meas, ev, base, singles, world.result(greedy, JOINT_VALUE), greedy, m, alpha)


def _p(chi2_0, chi2_1, k_1):
    """The F test of one more parameter, from its definition."""
    return stats.f.sf((chi2_0 - chi2_1) / (chi2_1 / (N - k_1)), 1, N - k_1)


def _explained_pair_world():
    chi2 = {
        frozenset(): 500.0,
        **{frozenset(e): c for e, c in zip("abcdefgh", (300, 320, 340, 400, 405, 498, 350, math.nan))},
        frozenset("ab"): 25.0 + DELTA_AICC,  # explained, AICc exactly DELTA_AICC from bc's: no tie
        frozenset("ac"): 25.0 + DELTA_AICC * 1.01,  # explained, AICc just outside a tie with bc
        frozenset("ad"): 280.0,  # not needed beside a
        frozenset("bc"): 25.0,  # explained: the best
        frozenset("bd"): 25.0 + DELTA_AICC * 0.99,  # a tie
    }
    preds = {frozenset(e): p for e, p in zip("abcdef", np.eye(3).tolist() + [[0, 0, 1], [0, 0, 1.05], [1, 1, 1]])}
    preds[frozenset("a")] = [0.0, 0.0, 0.0]
    preds[frozenset("b")], preds[frozenset("c")] = [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]
    return World(chi2, preds, conflicts=["cd"])


def test_an_explained_pair_replaces_the_stepwise_path_and_stops_the_search(monkeypatch, ev):
    w = _explained_pair_world()
    # ranked by AICc; an implausible single or one without an AICc may come first
    singles = [w.single("g", 6, plausible=False), w.single("h", 7)] + [w.single(e, i) for i, e in enumerate("abcdef")]
    r = _run(monkeypatch, w, ev, singles, ("a", "d"), m=4)

    # e repeats d's predictions (within SAME): one entry; f's AICc is the baseline's (it must
    # be lower), g implausible, h without an AICc: none searched
    assert r.same == {"d": ["e"]}
    fitted = {frozenset(c.members) for c in w.calls}
    assert fitted == {frozenset(p) for p in ("ab", "ac", "ad", "bc", "bd")}  # cd shares a part; no triple
    assert r.fitted == len(w.calls) == 5
    assert r.best.effects == ("b", "c") and r.best.counts
    # each member against the subset without it
    assert r.best.p_values == pytest.approx({"b": _p(340, 25, 3), "c": _p(320, 25, 3)}, rel=1e-9, abs=0)
    assert r.changed and r.greedy == ("a", "d") and r.greedy_aicc == 280.0 + 6
    assert [t.effects for t in r.ties] == [("b", "d")]
    assert r.to_json() == {
        "greedy": ["a", "d"],
        "best": ["b", "c"],
        "changed": True,
        "ties": [["b", "d"]],
        "equivalent": {"d": ["e"]},
        "subsets_fitted": 5,
        "aicc": 31.0,
    }
    assert r.sentence == "Search: b + c fits better than the stepwise path's a + d (dAICc = -255)."
    # each joint fit warm-started from the baseline's and the members' single values, members
    # in the order of their single AICc, no start grid, the search's solver budget
    bc = next(c for c in w.calls if set(c.members) == {"b", "c"})
    assert bc.members == ("b", "c") and bc.names == ("k_base", "k_b", "k_c")
    assert bc.start == {"k_base": BASE_VALUE, "k_b": SINGLE_VALUE, "k_c": SINGLE_VALUE}
    assert all(c.explore == () and c.nfev == search.SEARCH_NFEV and c.fixed == {"k_fixed": 7.0} for c in w.calls)


def test_the_stepwise_result_kept_when_it_is_the_best(monkeypatch, ev):
    w = _explained_pair_world()
    singles = [w.single(e, i) for i, e in enumerate("abcd")]
    r = _run(monkeypatch, w, ev, singles, ("c", "b"), m=4)
    assert not r.changed and r.best.effects == ("b", "c") and r.sentence is None
    assert [t.effects for t in r.ties] == [("b", "d")]  # within DELTA_AICC of the stepwise AICc
    assert r.to_json()["best"] == ["b", "c"] and r.to_json()["greedy"] == ["c", "b"]


def test_a_member_not_needed_at_alpha_over_m_is_no_count(monkeypatch, ev):
    w = _explained_pair_world()
    singles = [w.single(e, i) for i, e in enumerate("abcd")]
    # with m = 1e20 no improvement is significant (p > 1e-22): nothing counts, nothing replaces the path
    assert _p(320, 25, 3) > ALPHA / 1e20
    r = _run(monkeypatch, w, ev, singles, ("a", "d"), m=1e20)
    assert r.best is None and not r.changed and r.ties == [] and r.sentence is None
    assert r.to_json()["best"] is None and r.to_json()["aicc"] is None
    assert len(w.calls) > 0 and all(len(c.members) == 2 for c in w.calls)  # no pair counted: no triple


def test_m_below_one_divides_alpha_by_one(monkeypatch, ev):
    w = _explained_pair_world()
    singles = [w.single(e, i) for i, e in enumerate("abcd")]
    assert _run(monkeypatch, w, ev, singles, ("a", "d"), m=0).best.effects == ("b", "c")


def test_the_sentence_names_nothing_for_an_empty_stepwise_path(monkeypatch, ev):
    w = _explained_pair_world()
    singles = [w.single(e, i) for i, e in enumerate("abcd")]
    r = _run(monkeypatch, w, ev, singles, (), m=4)
    assert r.sentence.startswith("Search: b + c fits better than the stepwise path's nothing (")


FACTOR = dict(zip("abcdefg", (0.6, 0.62, 0.64, 0.66, 0.7, 0.75, 0.8)))


def _product(key):
    return 500.0 * math.prod(FACTOR[e] for e in key)  # never explained (n = 30)


def test_the_beam_extends_the_best_plausible_subsets_up_to_max_size(monkeypatch, ev):
    assert search.BEAM == 5 and search.MAX_SIZE == 3
    preds = {frozenset(e): [10.0 * i, 0.0, 0.0] for i, e in enumerate("abcdefg")}
    w = World(_product, preds, at_bound={frozenset("ab"): ("k_a",)})
    singles = [w.single(e, i) for i, e in enumerate("abcdefg")]
    r = _run(monkeypatch, w, ev, singles, ("a",))

    # the five best single seeds (a..e) reach every pair but fg; the pair ab ends at a bound: out of the beam
    pairs = [frozenset(p) for p in itertools.combinations("abcdefg", 2) if p != ("f", "g")]
    beam = sorted((p for p in pairs if p != frozenset("ab")), key=_product)[:5]
    triples = {p | {s} for p in beam for s in "abcdefg" if s not in p}
    fitted = [frozenset(c.members) for c in w.calls]
    assert sorted(fitted, key=sorted) == sorted(set(pairs) | triples, key=sorted)  # each once, none of 4
    best = min(triples, key=_product)
    assert set(r.best.effects) == best and r.best.effects == tuple(sorted(best, key=FACTOR.get))


def test_a_subset_with_a_member_sharing_a_part_is_never_judged(monkeypatch, ev):
    w = World(_product, {frozenset(e): [10.0 * i, 0.0, 0.0] for i, e in enumerate("abc")}, conflicts=["ab"])
    singles = [w.single(e, i) for i, e in enumerate("abc")]
    r = _run(monkeypatch, w, ev, singles, ("a",))
    assert {frozenset(c.members) for c in w.calls} == {frozenset("ac"), frozenset("bc")}  # abc needs ab
    assert r.best.effects == ("a", "c")


def test_a_joint_fit_is_plausible_only_with_every_value_plausible(ev):
    def f(values, std, at_bound=()):
        return NS(values=values, std=std, at_bound=at_bound)

    assert search._plausible_fit(ev, f({"k_x": 5.0, "k_y": 10.0}, {"k_x": 0.1, "k_y": 0.1}))
    assert not search._plausible_fit(ev, f({"k_x": 5.0, "k_y": 20.0}, {"k_x": 0.1, "k_y": 0.1}))
    assert search._plausible_fit(ev, f({"k_x": 5.0, "k_y": 10.5}, {"k_x": 0.1, "k_y": 1.0}))  # within 3 sigma
    assert not search._plausible_fit(ev, f({"k_x": 5.0, "k_y": 10.5}, {"k_x": 0.1}))  # no std: infinite
    assert not search._plausible_fit(ev, f({"k_x": 5.0}, {"k_x": 0.1}, ("k_x",)))  # at a bound


def test_equal_single_aiccs_are_ordered_by_the_catalogue(monkeypatch, ev):
    chi2 = {frozenset(): 500.0, frozenset("a"): 300.0, frozenset("b"): 300.0, frozenset("ab"): 25.0}
    w = World(chi2, {frozenset("a"): [0, 0, 0], frozenset("b"): [1, 0, 0]})
    singles = [w.single("a", 2), w.single("b", 1)]
    assert _run(monkeypatch, w, ev, singles, ("a",)).best.effects == ("b", "a")


def test_joint_fits_take_members_in_the_order_of_their_single_aicc(monkeypatch, ev):
    chi2 = {frozenset(): 500.0, frozenset("a"): 300.0, frozenset("b"): 200.0, frozenset("ab"): 25.0}
    w = World(chi2, {frozenset("a"): [0, 0, 0], frozenset("b"): [1, 0, 0]})
    _run(monkeypatch, w, ev, [w.single("b", 0), w.single("a", 1)], ("b",))
    assert [c.members for c in w.calls] == [("b", "a")] and w.calls[0].names == ("k_base", "k_b", "k_a")


@pytest.mark.parametrize("factor, triples", [(0.99, False), (1.01, True)])
def test_the_search_stops_at_a_size_whose_best_subset_explains_the_data(monkeypatch, ev, factor, triples):
    """Both sides of the goodness-of-fit test of the best pair (N - 3 degrees of freedom, alpha = 0.05)."""
    alpha = 0.05
    edge = stats.chi2.isf(alpha, N - 3)
    chi2 = {frozenset(): 500.0, **{frozenset(e): c for e, c in zip("abc", (300.0, 320.0, 340.0))}}
    chi2.update({frozenset(p): edge * factor + i for i, p in enumerate(("ab", "ac", "bc"))})
    chi2[frozenset("abc")] = 10.0
    w = World(chi2, {frozenset(e): [10.0 * i, 0, 0] for i, e in enumerate("abc")})
    _run(monkeypatch, w, ev, [w.single(e, i) for i, e in enumerate("abc")], ("a",), alpha=alpha)
    assert any(len(c.members) == 3 for c in w.calls) == triples


def test_a_member_needed_at_alpha_when_m_is_one():
    n = 30
    smaller = NS(chi2=100.0, k=1, n=n, aicc=0.0)
    chi2 = 100.0 / (1 + stats.f.isf(0.75 * ALPHA, 1, n - 2) / (n - 2))  # p = 0.75 alpha
    ok, p = search._needed(NS(chi2=chi2, k=2, n=n, aicc=-1.0), smaller, 1, ALPHA)
    assert ok and p == pytest.approx(0.75 * ALPHA, rel=1e-6)


def test_boundaries_of_better_and_same_are_outside():
    sub = search.Subset(("a",), NS(aicc=0.99), True, True)
    assert 1.0 - search.BETTER == 0.99 and not search.replaces(sub, ("b",), 1.0)
    meas = NS(sigma_hz=np.ones(3))
    ranking = [
        NS(effect=e, plausible=True, fit=NS(aicc=1.0, comparison=NS(predicted=np.array(p))))
        for e, p in (("a", [0.0, 0, 0]), ("b", [search.SAME, 0, 0]))
    ]
    assert search._distinct(meas, ranking) == (ranking, {})  # exactly SAME apart: two entries


class RefitWorld(World):
    """A world whose joint fits from the members' single values end at ``chi2``; fitted again
    with a member's parameters screened (``explore``), at ``refit``."""

    def __init__(self, chi2, refit):
        super().__init__(chi2, {frozenset("a"): [1.0, 0.0, 0.0], frozenset("b"): [0.0, 1.0, 0.0]})
        self.refit, self.returned = refit, []

    def fit(self, meas, effects, ev, names, *, start, fixed, explore, max_nfev):
        out = super().fit(meas, effects, ev, names, start=start, fixed=fixed, explore=explore, max_nfev=max_nfev)
        if explore:
            out.chi2 = self.refit[frozenset(effects[2:])]
            out.aicc = out.chi2 + 2 * out.k
        self.returned.append(out)
        return out


@pytest.mark.parametrize(
    "above, refits",
    [(DELTA_AICC, False), (DELTA_AICC * 1.01, True)],  # above the single a's chi2
)
def test_a_joint_fit_ending_above_a_subset_it_contains_is_fitted_again_from_it(monkeypatch, ev, above, refits):
    chi2 = {frozenset(): 500.0, frozenset("a"): 300.0, frozenset("b"): 320.0, frozenset("ab"): 300.0 + above}
    w = RefitWorld(chi2, {frozenset("ab"): 25.0})
    r = _run(monkeypatch, w, ev, [w.single("a", 0), w.single("b", 1)], ("a",), m=2)
    again = [c for c in w.calls if c.explore]
    assert r.fitted == 1  # one subset, however many times it is fitted
    if not refits:
        assert again == [] and r.best.effects == ("a",)  # b not needed beside a: the pair does not count
        return
    # from the lower subset it contains (a: b's removal), b's parameter screened from its single
    # value, the search's solver budget; the lower end kept: the pair explains the data
    (c,) = again
    assert c.members == ("a", "b") and c.explore == ("k_b",) and c.nfev == search.SEARCH_NFEV
    assert c.start == {"k_base": BASE_VALUE, "k_a": SINGLE_VALUE, "k_b": SINGLE_VALUE}
    assert c.names == ("k_base", "k_a", "k_b") and c.fixed == {"k_fixed": 7.0}
    assert r.best.effects == ("a", "b") and r.best.fit.chi2 == 25.0 and r.best.counts


@pytest.mark.parametrize("refit, kept", [(311.0, 310.0), (310.0, 310.0), (305.0, 305.0)])
def test_of_a_joint_fit_and_its_refit_the_lower_end_is_kept(monkeypatch, ev, refit, kept):
    chi2 = {frozenset(): 500.0, frozenset("a"): 300.0, frozenset("b"): 320.0, frozenset("ab"): 310.0}
    w = RefitWorld(chi2, {frozenset("ab"): refit})
    monkeypatch.setattr(search, "fit", w.fit)
    monkeypatch.setattr(search, "scope", w)
    w.ev, w.meas = ev, NS(sigma_hz=np.ones(3))
    fits = search._Fits(w.meas, ev, w.result((), BASE_VALUE), [w.single("a", 0), w.single("b", 1)])
    assert fits(("b", "a")).chi2 == kept and len(w.calls) == 2 and fits.fitted == 1
    assert fits(("a", "b")) is w.returned[1 if refit < 310.0 else 0]  # an equal end: the first fit kept
    assert fits(("a", "b")).chi2 == kept and len(w.calls) == 2  # fitted once


@pytest.mark.parametrize("a, b, screened", [(301.0, 300.0, "k_a"), (300.0, 301.0, "k_b"), (300.0, 300.0, "k_a")])
def test_the_refit_starts_from_the_lowest_subset_it_ends_above(monkeypatch, ev, a, b, screened):
    chi2 = {frozenset(): 500.0, frozenset("a"): a, frozenset("b"): b, frozenset("ab"): 310.0}
    w = RefitWorld(chi2, {frozenset("ab"): 25.0})
    monkeypatch.setattr(search, "fit", w.fit)
    monkeypatch.setattr(search, "scope", w)
    w.ev, w.meas = ev, NS(sigma_hz=np.ones(3))
    fits = search._Fits(w.meas, ev, w.result((), BASE_VALUE), [w.single("a", 0), w.single("b", 1)])
    assert fits(("a", "b")).chi2 == 25.0
    # above both singles: from the lower one, the other member's parameter screened (equal
    # singles: a, the first by name, is the member dropped)
    assert [c.explore for c in w.calls] == [(), (screened,)]
