"""Compare a model with measured natural frequencies, find the missing physical effect.

Typical use::

    from eigentwist.diagnose import diagnose, paper_measurements
    d = diagnose(paper_measurements(), baseline="rigid")
    print(d.to_json()["selected"])          # ['ee_compliance']

Modules, one job each: :mod:`.measurements` (CSV loading/validation, the paper's data),
:mod:`.matching` (which model mode a label names), :mod:`.predict` (batched
predictions), :mod:`.compare` (errors, where a model fails), :mod:`.patterns` (what the
residual shape suggests), :mod:`.fit` (weighted least squares), :mod:`.stats` (the
criteria), :mod:`.identifiable` (which parameters the data can fit), :mod:`.select` (ranking,
forward selection, ties), :mod:`.misfit` (too few rows, the stated uncertainty, outliers),
:mod:`.separate` (the next measurement), :mod:`.synth` (synthetic data), :mod:`.verdict`
(text), :mod:`.render_json` (JSON), :mod:`.plots`.
"""

from .compare import Comparison, compare
from .fit import FitResult, fit
from .matching import ModeMatchError, match_modes, parse_mode
from .measurements import Measurements, MeasurementError, load_measurements, paper_csv, paper_measurements
from .select import Candidate, Diagnosis, diagnose
from .synth import parse_truth, synth

__all__ = [
    "Comparison",
    "compare",
    "FitResult",
    "fit",
    "ModeMatchError",
    "match_modes",
    "parse_mode",
    "Measurements",
    "MeasurementError",
    "load_measurements",
    "paper_csv",
    "paper_measurements",
    "Candidate",
    "Diagnosis",
    "diagnose",
    "parse_truth",
    "synth",
]
