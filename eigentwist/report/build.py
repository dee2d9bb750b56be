"""Build the report: compute (``build_report``), render (``render_html``), write.

The HTML is one file with every figure embedded as a base64 PNG (the animated mode
shapes as a base64 SVG animated by SMIL, :mod:`eigentwist.plots.animate`), so a colleague
can open it anywhere, offline. It opens with the diagnosis's answer (JSON ``answer``,
:mod:`eigentwist.diagnose.answer`) and ends with the provenance (:mod:`.provenance`).
Sections: the model and its parameters with the robot and its lowest
mode shapes at the measured pose, the paper reproduction (Heli4), the comparison with
the measurements (Fig. 6 style), the diagnosis (ranking, the error falling step by step,
the final model's fitted values) and the suggested next measurement.

The diagnosis is read from :meth:`Diagnosis.to_json` only, so keys the diagnosis gains
(``alternatives``, ``outliers``, ``uncertainty``) are shown when present. Everything that
reaches the HTML from the user (file names, CSV cells, parameter names) is escaped by
Jinja's autoescape; no template marks anything as safe.
"""

from __future__ import annotations

import base64
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import jinja2
import numpy as np

from ..errors import InputError
from ..diagnose.answer import uncertainty_sentence
from ..outputs import write_atomic
from ..text import format_estimate
from .provenance import provenance

__all__ = ["ReportData", "build_report", "render_html", "write_report", "SECTIONS"]

TEMPLATES = Path(__file__).parent / "templates"
SECTIONS = ("model", "reproduction", "comparison", "diagnosis", "next-measurement")


@dataclass
class ReportData:
    """Everything the template shows (numbers, tables and PNG figures as bytes)."""

    robot: str
    title: str
    source: str
    data_source: str
    model: tuple
    baseline: tuple
    parameters: list
    reproduction: dict | None
    comparison: dict
    diagnosis: dict
    figures: dict = field(default_factory=dict)
    command: str = "eigentwist report"
    final: dict = field(default_factory=dict)
    next_measurement: dict = field(default_factory=dict)
    modes: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)
    campaign_html: str = ""  # section of a modal-test campaign (eigentwist.modal.report)
    answer: dict = field(default_factory=dict)  # the answer first (diagnosis JSON ``answer``)
    provenance: dict = field(default_factory=dict)  # version, date, command line, SHA-256 of the inputs
    animation_svg: str = ""  # the final model's three lowest modes, animated (SMIL)
    mac: dict | None = None  # MAC matrix of measured vs model shapes (campaigns)
    lowest_map: dict = field(default_factory=dict)  # where the workspace map of f1 is drawn
    uncertainty_text: str = ""  # the verdict on the stated uncertainty, a sentence


def _png(plot, *args) -> bytes:
    buf = io.BytesIO()
    plot(*args[:1], buf, *args[1:])
    return buf.getvalue()


def _comparison_rows(cmp) -> list[dict]:
    m = cmp.meas
    rows = []
    for i in range(len(m)):
        rows.append(
            dict(
                line=m.where(i),
                pose=[float(v) for v in m.poses[i]],
                k_a=float(m.k_a[i]),
                mode=m.mode[i],
                measured=float(m.freq_hz[i]),
                sigma=float(m.sigma_hz[i]),
                predicted=float(cmp.predicted[i]),
                error_pct=float(cmp.error_pct[i]),
                error_sigma=float(cmp.error_sigma[i]),
                failing=bool(cmp.failing[i]),
                kind=m.kind[i],
                zeta=None if cmp.zeta is None else float(cmp.zeta[i]),
            )
        )
    return rows


def build_report(
    data=None,
    robot: str = "heli4",
    model="paper",
    baseline="rigid",
    backend: str = "numpy",
    progress=None,
    values: dict | None = None,
    command: str = "eigentwist report",
) -> ReportData:
    """Compute every section of the report.

    data : path of a measurement CSV (see the README), or None for the robot's embedded
        measurements (the paper's Tables E.1/E.2 for the Heli4).
    model : the model compared with the data (preset or effects).
    baseline : where the diagnosis starts.
    values : parameter values of the run (SI, e.g. ``--set``) instead of the robot's
        defaults, for the comparison and the diagnosis; the parameter table shows the
        values used (a data column wins over these).
    command : the command line, for the provenance (with the SHA-256 of every input file).
    """
    from ..description.effects import resolve_model
    from ..diagnose import compare, diagnose, load_measurements
    from ..diagnose.measurements import paper_csv, parse_csv
    from ..diagnose.values import used_parameters
    from ..diagnose.verdict import failing_text
    from ..plots import plot_comparison, plot_diagnosis
    from ..runtime import load

    ev = load(robot, backend=backend)
    campaign_html = ""
    if data is None:
        if robot != "heli4":
            raise InputError(f"no embedded measurements for robot {robot!r}: pass a measurement CSV")
        meas = parse_csv(paper_csv(robot), "heli4_paper.csv", ev, values=values)
        data_source = "the paper's measurements (Tables E.1/E.2, 'Meas.'), embedded"
    else:
        from ..modal.report import campaign_section, is_manifest

        if is_manifest(data):  # a modal-test campaign: identify it first
            meas, campaign_html = campaign_section(data, ev)
        else:
            meas = load_measurements(data, robot, ev, values)
        data_source = str(data)
    effects = resolve_model(model, ev.robot)
    cmp = compare(meas, effects, ev, values)
    diag = diagnose(meas, baseline=baseline, ev=ev, progress=progress, values=values)
    params = used_parameters(ev, effects, values, meas)
    repro = _reproduction(ev) if robot == "heli4" else None
    modes = {**_modes_view(meas, effects), "values": dict(values or {})}  # the picture with the used values
    figures = {
        "comparison": _png(plot_comparison, cmp, ev),
        "diagnosis": _png(plot_diagnosis, diag, ev),
        "modes": _modes_png(ev, modes),
    }
    diag_json = diag.to_json()
    shown = _shown(ev, diag, meas, values)
    figures["lowest_map"] = shown.pop("png")
    return ReportData(
        robot=robot,
        title=ev.robot.title,
        source=ev.robot.source,
        data_source=data_source,
        model=effects,
        baseline=tuple(diag.baseline.effects),
        parameters=params,
        reproduction=repro,
        comparison=dict(summary=cmp.summary(), rows=_comparison_rows(cmp), failing=failing_text(cmp)),
        diagnosis=diag_json,
        figures=figures,
        final=final_parameters(diag_json, ev),
        next_measurement=next_measurement_text(diag_json),
        modes=modes,
        units={p.name: p.unit for p in ev.robot.parameters},
        campaign_html=campaign_html,
        answer=diag_json.get("answer") or {},
        command=command,
        provenance=provenance(command, data, robot if str(robot).endswith(".py") else None),
        uncertainty_text=uncertainty_sentence(diag_json.get("uncertainty"), bool(diag_json["final"]["explained"])),
        **shown,
    )


def _shown(ev, diag, meas, values) -> dict:
    """What the report shows of the final model: its three lowest modes animated at the most
    measured pose, the MAC matrix (data with shapes), the map of f1 over the workspace."""
    from ..plots.animate import modes_svg
    from .figures import final_values, lowest_frequency_png, mac_matrix

    view = _modes_view(meas, diag.final.effects)
    used = final_values(diag, values)
    unit = ev.parameter("k_a").unit
    model = " + ".join(diag.final.effects) or "(no effect)"
    svg = modes_svg(ev, view["pose"], ",".join(diag.final.effects), **{**used, "k_a": view["k_a"]})
    png = lowest_frequency_png(
        ev,
        ",".join(diag.final.effects),
        view["pose"],
        view["k_a"],
        used,
        meas.poses,
        f"final model {model}, k_a = {view['k_a']:g} {unit}",
    )
    return dict(
        animation_svg=svg,
        mac=mac_matrix(meas, ev, ",".join(diag.final.effects), used),
        lowest_map={**view, "model": model, "k_a_unit": unit},
        png=png,
    )


def _reproduction(ev) -> dict:
    from ..paper import reproduce, summary

    res = reproduce(ev)
    rows = [
        dict(
            source=v.source,
            label=v.label,
            printed=v.printed,
            model=v.model,
            dev=v.deviation,
            status=v.status,
            note=v.note,
        )
        for v in res["values"]
        if not (v.paper == 0 and abs(v.model) < v.half_unit)
    ]
    return dict(
        printed=res["printed"],
        within=res["within_rounding"],
        nonzero=res["nonzero"],
        nonzero_within=res["nonzero_within"],
        calibration=res["calibration"],
        tested=res["tested"],
        tested_within=res["tested_within"],
        required=res["required"],
        required_ok=res["required_ok"],
        summary=summary(res),
        rows=rows,
    )


def _modes_view(meas, effects) -> dict:
    """Where the mode-shape picture is drawn: the most measured pose, its median k_a."""
    poses, counts = np.unique(np.round(meas.poses, 9), axis=0, return_counts=True)
    pose = poses[int(np.argmax(counts))]
    at = np.all(np.isclose(meas.poses, pose, atol=1e-9), axis=1)
    measured = np.sort(meas.k_a[at])
    k_a = float(measured[(len(measured) - 1) // 2])  # a measured value near the median
    return dict(pose=[float(v) for v in pose], k_a=k_a, model=",".join(effects), n=int(at.sum()))


def _modes_png(ev, view: dict) -> bytes:
    from ..plots import plot_modes

    buf = io.BytesIO()
    plot_modes(ev, view["pose"], buf, model=view["model"], **{**view.get("values", {}), "k_a": view["k_a"]})
    return buf.getvalue()


def final_parameters(diagnosis: dict, ev) -> dict:
    """The final model's fitted values with standard errors and units, for sentences and a table.

    Reads ``diagnosis`` as :meth:`Diagnosis.to_json` gives it (``final.params``,
    ``final.param_std``).
    """
    final = diagnosis.get("final", {})
    std = final.get("param_std") or {}
    marks = {q["name"]: q for e in (diagnosis.get("answer") or {}).get("effects", []) for q in e.get("params", [])}
    rows = []
    for name, value in (final.get("params") or {}).items():
        p = ev.parameters.get(name)
        unit = p.unit if p is not None else ""
        default = p.default if p is not None else None
        s = std.get(name)
        rows.append(
            dict(
                name=name,
                value=value,
                std=s,
                unit="" if unit == "-" else unit,
                text=f"{name} = {format_estimate(value, s if s is not None else math.inf, unit)}",
                default=None if default is None else format_estimate(default, None, unit),
                effect=(p.effect or "") if p is not None else "",
                doc=p.doc if p is not None else "",
                relative=(None if s is None or not value else abs(s / value)),
                plausible=marks.get(name, {}).get("plausible"),
                plausible_range=marks.get(name, {}).get("plausible_range"),
            )
        )
    return dict(effects=list(final.get("effects", [])), rows=rows, sentence=_and([r["text"] for r in rows]))


def _and(items: list) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1] if items else ""


def next_measurement_text(diagnosis: dict) -> dict:
    """What section 5 says, consistent with the diagnosis.

    A separating measurement is proposed only when the diagnosis found the best effect
    indistinguishable from its rival on these data; when the data already tell them
    apart, the section says so (with the ΔAICc) and proposes nothing to separate them.
    When the final model does not explain the data, it points at where it still fails.
    """
    nm = diagnosis.get("next_measurement") or None
    ranking = diagnosis.get("ranking") or []
    top = ranking[0] if ranking else None
    out = dict(
        kind="none",
        top=top["effect"] if top else None,
        rival=None,
        delta_aicc=None,
        rows=[],
        alternative=None,
        explained=bool(diagnosis.get("final", {}).get("explained")),
        failing=diagnosis.get("final", {}).get("failing") or [],
    )
    if nm:
        a, b = (nm.get("between") or [None, None])[:2]
        tied = nm.get("indistinguishable")
        if tied is None and top:
            tied = b in (top.get("indistinguishable_from") or [])
        rival = next((c for c in ranking if c.get("effect") == b), None)
        out.update(rival=b, delta_aicc=None if rival is None else rival.get("delta_aicc"))
        if tied:
            out.update(kind="separate", rows=_measurement_rows(nm, a, b))
            alt = nm.get("with_measured_modes")
            if alt and alt.get("mode") != nm.get("mode"):
                out["alternative"] = _measurement_rows(alt, a, b)
        else:
            out["kind"] = "told_apart"
    elif top and len(ranking) >= 2:
        out.update(kind="told_apart", rival=ranking[1].get("effect"), delta_aicc=ranking[1].get("delta_aicc"))
    return out


def _measurement_rows(nm: dict, a: str, b: str) -> list:
    pred = nm.get("predicted_hz") or {}
    pose = ", ".join(f"{v:g}" for v in np.round(nm.get("pose", []), 4))
    rows = [
        ("pose", f"[{pose}] {'m' if len(nm.get('pose', [])) in (0, 3) else 'm, rad'}"),
        ("actuator stiffness k_a", f"{nm.get('k_a', float('nan')):.4g} {nm.get('k_a_unit', 'N m/rad')}"),
        ("mode", str(nm.get("mode"))),
    ]
    for name in (a, b):
        if name in pred and pred[name] is not None:
            rows.append((f"{name} predicts", f"{pred[name]:.4g} Hz"))
    if nm.get("separation_sigma") is not None:
        sigma = f" (σ = {nm['sigma_hz']:.3g} Hz)" if nm.get("sigma_hz") is not None else ""
        rows.append(("separation", f"{nm['separation_sigma']:.1f} σ{sigma}"))
    return rows


def _env() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TEMPLATES)),
        undefined=jinja2.StrictUndefined,
        autoescape=True,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )
    env.filters["b64"] = lambda b: base64.b64encode(b).decode("ascii")
    env.filters["g"] = lambda v, fmt=".4g": "" if v is None else format(float(v), fmt)
    env.filters["est"] = lambda v, std=None, unit="": format_estimate(v, math.inf if std is None else std, unit)
    env.filters["num"] = lambda v: "" if v is None else format_estimate(v)
    env.filters["plain"] = plain_text
    return env


def plain_text(value) -> str:
    """Any JSON value as readable text (never a Python repr): keys the template does not know yet."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return format(value, ".4g")
    if isinstance(value, dict):
        return "; ".join(f"{k}: {plain_text(v)}" for k, v in value.items())
    if isinstance(value, (list, tuple)):
        return ", ".join(plain_text(v) for v in value)
    return str(value)


def render_html(report: ReportData) -> str:
    """The report as one self-contained HTML string (pure: no I/O)."""
    return _env().get_template("report.html.jinja").render(r=report, sections=SECTIONS)


def write_report(path, report: ReportData) -> Path:
    """Write the HTML of ``report`` to ``path``; return the path."""
    path = Path(path)
    write_atomic(path, render_html(report))
    return path
