"""The diagnosis cases as data: synthetic measurements per seed and what a right diagnosis says.

Shared by ``tests/test_diagnose_seeds.py`` and ``benchmarks/diagnosis_seeds.py`` (the
figures of the closing note). Every case draws its truth's nuisance parameters (eta_a
and l2, +-1 %, in the truth only; never the masses: m_e and m_p are exactly confounded)
and its noise from the seed.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from eigentwist.diagnose import diagnose, synth

KA = (250, 500, 1000, 2000, 4000)
POSES = ((0.0, 0.0, -0.625), (0.06, -0.04, -0.6))
XYZ = ("x", "y", "z")
NOISE = 0.005
NUISANCE = 0.01


def nuisance(ev, seed: int) -> str:
    """``eta_a=...,l2=...`` drawn uniformly within +-1 % of the defaults."""
    rng = np.random.default_rng(10_000 + seed)
    u = rng.uniform(-NUISANCE, NUISANCE, 2)
    return f"eta_a={ev.parameters['eta_a'].default * (1 + u[0]):.6g},l2={ev.parameters['l2'].default * (1 + u[1]):.6g}"


def _truth(ev, seed, hidden: str = "") -> str:
    return f"paper:{nuisance(ev, seed)}" + (f"+{hidden}" if hidden else "")


def _with(meas, **arrays):
    return dataclasses.replace(meas, **arrays)


# each case: seed -> (diagnosis, ok: bool, why: str)


def spring(ev, seed):
    """A hose pulling the end-effector (150 N/m in x and y): not explained, nothing implausible selected."""
    meas = synth(_truth(ev, seed), KA, POSES, XYZ, NOISE, seed=seed, ev=ev, extra_stiffness={"x": 150.0, "y": 150.0})
    d = diagnose(meas, "paper", ev=ev)
    chosen = [c for s, c in _added(d)]
    ok = not d.explained and all(c.plausible for c in chosen)
    return d, ok, f"explained={d.explained} selected={d.selected}"


def _added(d):
    """(step, candidate) of every effect the selection added."""
    out = []
    for k, s in enumerate(d.steps[1:], start=1):
        if not s.added:
            continue  # a removal (backward elimination)
        out.append((s, next(c for c in d.steps[k - 1].ranking if c.effect == s.added)))
    return out


def two_effects(ev, seed):
    """Payload 0.3 kg and k_t = 8000 N m/rad: both found, or the second's equal named at its step."""
    meas = synth(
        _truth(ev, seed, "payload_mass:m_p=0.3+transmission_compliance:k_t=8000"),
        KA,
        POSES,
        XYZ,
        NOISE,
        seed=seed,
        ev=ev,
    )
    d = diagnose(meas, "paper", ev=ev)
    found = set(d.selected) | {a for s in d.steps for a in s.alternatives}
    ok = {"payload_mass", "transmission_compliance"} <= found
    return d, ok, f"selected={d.selected} alternatives={[s.alternatives for s in d.steps]}"


BAD_ROW = 7  # index of the row made 20 % high (CSV line 9)


def bad_row(ev, seed):
    """One row 20 % off: flagged by its line; m_p within 3 std or 3 % of the truth (0.35 kg)."""
    meas = synth(_truth(ev, seed, "payload_mass:m_p=0.35"), KA, POSES, XYZ, NOISE, seed=seed, ev=ev)
    f = meas.freq_hz.copy()
    f[BAD_ROW] *= 1.2
    meas = _with(meas, freq_hz=f)
    d = diagnose(meas, "paper", ev=ev)
    line = int(meas.lines[BAD_ROW])
    m_p, std = d.final.values.get("m_p", math.nan), d.final.std.get("m_p", math.nan)
    ok = (
        [o.line for o in d.outliers] == [line]
        and "payload_mass" in d.selected
        and (abs(m_p - 0.35) <= 3 * std or abs(m_p - 0.35) <= 0.03 * 0.35)
    )
    return d, ok, f"outliers={[o.line for o in d.outliers]} (bad {line}) m_p={m_p:.4g}+-{std:.2g}"


def sigma_understated(ev, seed):
    """3 % scatter, 1 % stated: ``understated``."""
    meas = synth(_truth(ev, seed), KA, POSES, XYZ, 0.03, seed=seed, ev=ev)
    meas = _with(meas, sigma_hz=0.01 * meas.freq_hz)
    d = diagnose(meas, "paper", ev=ev)
    return d, d.uncertainty.verdict == "understated", f"verdict={d.uncertainty.verdict} selected={d.selected}"


def sigma_overstated(ev, seed):
    """0.5 % scatter, 5 % stated: ``overstated``."""
    meas = synth(_truth(ev, seed), KA, POSES, XYZ, NOISE, seed=seed, ev=ev)
    meas = _with(meas, sigma_hz=0.05 * meas.freq_hz)
    d = diagnose(meas, "paper", ev=ev)
    return d, d.uncertainty.verdict == "overstated", f"verdict={d.uncertainty.verdict} selected={d.selected}"


def four_rows(ev, seed):
    """A hidden rotor inertia on 4 rows: its equals named, no single confident answer."""
    meas = synth(
        _truth(ev, seed, "rotor_inertia:I_add=3e-3"), (500, 2000), POSES[:1], ("x", "y"), NOISE, seed=seed, ev=ev
    )
    d = diagnose(meas, "paper", ev=ev)
    named = bool(
        d.alternatives or any(s.alternatives for s in d.steps) or (d.ranking and d.ranking[0].indistinguishable_from)
    )
    confident = bool(d.selected) and not d.alternatives and d.uncertainty.verdict != "too few rows"
    ok = named and not confident
    return (
        d,
        ok,
        (
            f"selected={d.selected} final alternatives={[a.effects for a in d.alternatives]} "
            f"verdict={d.uncertainty.verdict}"
        ),
    )


def payload_offset(ev, seed):
    """A hidden 0.5 kg payload at p_z = 0.05 m, rotational modes measured: p_z within 3 std."""
    meas = synth(
        _truth(ev, seed, "payload_mass:m_p=0.5,p_z=0.05"), KA, POSES, XYZ + ("rx", "ry", "rz"), NOISE, seed=seed, ev=ev
    )
    d = diagnose(meas, "paper", ev=ev)
    p_z, std = d.final.values.get("p_z", math.nan), d.final.std.get("p_z", math.nan)
    ok = "payload_mass" in d.selected and abs(p_z - 0.05) <= 3 * std
    return d, ok, f"selected={d.selected} p_z={p_z:.4g}+-{std:.2g}"


def baseline_truth(ev, seed, noise):
    """Truth = baseline (no nuisance): nothing added."""
    meas = synth("paper", KA, POSES, XYZ, noise, seed=seed, ev=ev)
    d = diagnose(meas, "paper", ev=ev)
    return d, d.selected == [], f"selected={d.selected}"


CASES = {
    "spring": spring,
    "two_effects": two_effects,
    "bad_row": bad_row,
    "sigma_understated": sigma_understated,
    "sigma_overstated": sigma_overstated,
    "four_rows": four_rows,
    "payload_offset": payload_offset,
}


def run(case, ev, seeds, allowed_wrong: int | None = None) -> list[tuple[int, bool, str]]:
    """(seed, right, why) per seed. With ``allowed_wrong``, the seeds stop as soon as the
    verdict "at most ``allowed_wrong`` wrong" is decided: more wrong ones than that, or so
    few seeds left that even all of them wrong would keep it (the same verdict as running
    every seed; the benchmark counts every seed)."""
    out = []
    seeds = list(seeds)
    for k, seed in enumerate(seeds):
        _, ok, why = case(ev, seed)
        out.append((seed, ok, why))
        if allowed_wrong is not None:
            wrong = sum(not r for _, r, _ in out)
            if wrong > allowed_wrong or wrong + len(seeds) - (k + 1) <= allowed_wrong:
                break
    return out


# ------------------------------------------------------------------ two faults at once

HEXAPOD_POSES = ((0, 0, 0.8, 0, 0, 0), (0.05, 0, 0.78, 0, 0.05, 0.1), (-0.04, 0.05, 0.82, 0.05, 0, -0.1))
HELI4_POSES = POSES + ((-0.05, 0.05, -0.58),)


def _series_pair(d, legs) -> bool:
    """Whether the final model holds one series compliance (strut, joints or actuator: one model
    on a hexapod leg) on each of ``legs`` and nothing else, selected or stated as its equal."""
    named = set(d.selected) | {a for s in d.steps for a in s.alternatives}
    chosen = {int(e.partition("@")[2] or 0) for e in d.selected}
    return (
        chosen == set(legs)
        and len(d.selected) == len(legs)
        and all(any(e.endswith(f"@{k}") for e in named) for k in legs)
    )


def hexapod_struts(ev, seed, progress=None):
    """Hexapod, struts 2 and 5 at k_s = 3e7 N/m (0.5 % noise, 54 rows): a series compliance on legs
    2 and 5 (strut, joints and actuator loss are one model on a leg), the data explained."""
    meas = synth(
        "paper+strut_compliance@2:k_s@2=3e7+strut_compliance@5:k_s@5=3e7",
        (1e7, 2e7, 4e7),
        HEXAPOD_POSES,
        [str(k) for k in range(1, 7)],
        NOISE,
        seed=seed,
        ev=ev,
    )
    d = diagnose(meas, "paper", ev=ev, progress=progress)
    ok = _series_pair(d, (2, 5)) and d.explained
    return (
        d,
        ok,
        f"selected={d.selected} explained={d.explained} "
        f"search changed={bool(getattr(d, 'search', None) and d.search.changed)}",
    )


def heli4_actuator_transmission(ev, seed):
    """Heli4, leg 3's actuator at eta_a = 0.5 and leg 1's transmission at k_t = 4000 N m/rad (0.5 %
    noise, 45 rows): actuator_loss@3 and transmission_compliance@1 (or a stated equal), explained."""
    meas = synth(
        _truth(ev, seed, "actuator_loss@3:eta_a@3=0.5+transmission_compliance@1:k_t@1=4000"),
        KA,
        HELI4_POSES,
        XYZ,
        NOISE,
        seed=seed,
        ev=ev,
    )
    d = diagnose(meas, "paper", ev=ev)
    named = (
        set(d.selected) | {a for s in d.steps for a in s.alternatives} | {e for a in d.alternatives for e in a.effects}
    )
    ok = {"actuator_loss@3", "transmission_compliance@1"} <= named and len(d.selected) == 2 and d.explained
    return (
        d,
        ok,
        f"selected={d.selected} explained={d.explained} "
        f"search changed={bool(getattr(d, 'search', None) and d.search.changed)}",
    )


TWO_FAULTS = {
    "hexapod_struts": ("hexapod", hexapod_struts),
    "heli4_actuator_transmission": ("heli4", heli4_actuator_transmission),
}
