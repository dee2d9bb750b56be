"""Stand-ins for a diagnosis and its fits, for the tests of the text it is rendered to
(``tests/test_verdict_text.py``, ``tests/test_answer_rules.py``): plain namespaces with the
fields :mod:`eigentwist.diagnose.verdict` and :mod:`eigentwist.diagnose.answer` read, each
test setting the ones it is about. No evaluator, no fit."""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np

from eigentwist.diagnose.select import Step


def fit_of(
    effects=(),
    chi2=20.0,
    n=30,
    k=1,
    values=None,
    std=None,
    at_bound=(),
    rms=1.5,
    mx=3.0,
    aicc=10.0,
    fixed=None,
    names=None,
):
    """A fit of ``effects``: chi^2 over n rows with k parameters, fitted ``values`` and their
    ``std``, RMS and largest error (%), AICc."""
    values = dict(values or {})
    return NS(
        effects=tuple(effects),
        chi2=chi2,
        n=n,
        k=k,
        dof=n - k,
        reduced_chi2=chi2 / (n - k) if n > k else math.nan,
        values=values,
        std=dict(std or {}),
        at_bound=tuple(at_bound),
        rms_pct=rms,
        max_pct=mx,
        aicc=aicc,
        fixed=dict(fixed or {}),
        names=tuple(values) if names is None else tuple(names),
        comparison=NS(predicted=np.zeros(3), meas=NS(sigma_hz=np.ones(3)), where_it_fails=lambda: []),
    )


class Rows(NS):
    """Measurements with a length: ``n`` rows, or as many as ``freq_hz`` has."""

    def __len__(self):
        return self.n if hasattr(self, "n") else len(self.freq_hz)


def diag(**kw):
    """A diagnosis of the Heli4 that explains its 30 rows with nothing added; ``kw`` replaces
    any field."""
    base = dict(
        robot="heli4",
        baseline=fit_of(rms=4.56),
        final=fit_of(),
        explained=True,
        alpha=0.01,
        implausible={},
        manual=False,
        uncertainty=None,
        steps=[Step(fit_of(), ranking=[])],
        alternatives=[],
        untestable={},
        next_measurement=None,
        outliers=[],
        all_rows=None,
        removed=[],
        meas=Rows(n=30, k_a_unit="N m/rad", sigma_hz=np.ones(3)),
        ranking=[],
        selected=[],
        setting_anomalies=[],
        notes=[],
        search=None,
    )
    base.update(kw)
    return NS(**base)
