"""Modal-test data: UFF files in, identified modes and mode shapes out.

Modules, one job each: :mod:`.uff_io` (UFF datasets 58, 55, 15/2411 through pyuff),
:mod:`.layout` (measured DOFs on the platform and the model's shape there),
:mod:`.frf` (a model's FRFs from M, K and modal damping), :mod:`.identify` (LSCF poles,
automatic stabilisation, LSFD shapes for one setting), :mod:`.campaign` (the manifest and
the identification of a campaign into a measurement CSV), :mod:`.synth` (synthetic
campaigns), :mod:`.plots` (stabilisation diagrams, measured vs re-synthesised FRFs),
:mod:`.report` (the report section). Shapes, MAC and matching by shape live in
:mod:`eigentwist.diagnose.shapes`. Needs the ``modal`` extra (pyuff, sdypy-EMA).
"""

from .campaign import Campaign, CampaignResult, identify_campaign, read_manifest, write_manifest
from .frf import modal_frf
from .identify import IdentifiedMode, SettingModes, identify_frfs, modes_from_set
from .synth import synth_campaign
from .uff_io import FrfSet, ModeSet, UffError, read_uff, write_frf_uff, write_modes_uff

__all__ = [
    "Campaign",
    "CampaignResult",
    "identify_campaign",
    "read_manifest",
    "write_manifest",
    "modal_frf",
    "IdentifiedMode",
    "SettingModes",
    "identify_frfs",
    "modes_from_set",
    "synth_campaign",
    "FrfSet",
    "ModeSet",
    "UffError",
    "read_uff",
    "write_frf_uff",
    "write_modes_uff",
]
