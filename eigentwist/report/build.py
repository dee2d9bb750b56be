"""Build the report: compute (``build_report``), render (``render_html``), write.

The HTML is one file with every figure embedded as a base64 PNG, so a colleague can
open it anywhere. Sections: the model and its parameters, the paper reproduction (Heli4),
the comparison with the measurements (Fig. 6 style), the diagnosis (ranking, the error
falling step by step) and the suggested next measurement.
"""
from __future__ import annotations

import base64
import io
from dataclasses import dataclass, field
from pathlib import Path

import jinja2

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


def _png(plot, *args) -> bytes:
    buf = io.BytesIO()
    plot(*args[:1], buf, *args[1:])
    return buf.getvalue()


def _comparison_rows(cmp) -> list[dict]:
    m = cmp.meas
    rows = []
    for i in range(len(m)):
        rows.append(dict(line=m.where(i), pose=[float(v) for v in m.poses[i]], k_a=float(m.k_a[i]), mode=m.mode[i],
                         measured=float(m.freq_hz[i]), sigma=float(m.sigma_hz[i]),
                         predicted=float(cmp.predicted[i]), error_pct=float(cmp.error_pct[i]),
                         error_sigma=float(cmp.error_sigma[i]), failing=bool(cmp.failing[i])))
    return rows


def build_report(data=None, robot: str = "heli4", model="paper", baseline="rigid", backend: str = "numpy",
                 progress=None) -> ReportData:
    """Compute every section of the report.

    data : path of a measurement CSV (see the README), or None for the robot's embedded
        measurements (the paper's Tables E.1/E.2 for the Heli4).
    model : the model compared with the data (preset or effects).
    baseline : where the diagnosis starts.
    """
    from ..description.effects import resolve_model
    from ..diagnose import compare, diagnose, load_measurements, paper_measurements
    from ..diagnose.plots import plot_comparison, plot_diagnosis
    from ..diagnose.report import failing_text
    from ..paper import reproduce
    from ..runtime import load

    ev = load(robot, backend=backend)
    if data is None:
        if robot != "heli4":
            raise ValueError(f"no embedded measurements for robot {robot!r}: pass a measurement CSV")
        meas = paper_measurements(ev)
        data_source = "the paper's measurements (Tables E.1/E.2, 'Meas.'), embedded"
    else:
        meas = load_measurements(data, robot, ev)
        data_source = str(data)
    effects = resolve_model(model, ev.robot)
    cmp = compare(meas, effects, ev)
    diag = diagnose(meas, baseline=baseline, ev=ev, progress=progress)
    params = [dict(name=p.name, value=p.default, unit=p.unit, effect=p.effect or "", doc=p.doc,
                   active=p.effect is None or p.effect in effects) for p in ev.robot.parameters]
    repro = None
    if robot == "heli4":
        res = reproduce(ev)
        repro = dict(printed=res["printed"], within=res["within_rounding"], required=res["required"],
                     required_ok=res["required_ok"],
                     rows=[dict(source=v.source, label=v.label, printed=v.printed, model=v.model, dev=v.deviation,
                                within=v.within_rounding, ok=v.ok, required=v.required, note=v.note)
                           for v in res["values"] if not (v.paper == 0 and abs(v.model) < v.half_unit)])
    figures = {
        "comparison": _png(plot_comparison, cmp, ev),
        "diagnosis": _png(plot_diagnosis, diag, ev),
    }
    return ReportData(
        robot=robot, title=ev.robot.title, source=ev.robot.source, data_source=data_source,
        model=effects, baseline=tuple(diag.baseline.effects), parameters=params, reproduction=repro,
        comparison=dict(summary=cmp.summary(), rows=_comparison_rows(cmp), failing=failing_text(cmp)),
        diagnosis=diag.to_json(), figures=figures,
    )


def _env() -> jinja2.Environment:
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(str(TEMPLATES)), undefined=jinja2.StrictUndefined,
                             autoescape=True, trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True)
    env.filters["b64"] = lambda b: base64.b64encode(b).decode("ascii")
    env.filters["g"] = lambda v, fmt=".4g": "" if v is None else format(float(v), fmt)
    return env


def render_html(report: ReportData) -> str:
    """The report as one self-contained HTML string (pure: no I/O)."""
    return _env().get_template("report.html.jinja").render(r=report, sections=SECTIONS)


def write_report(path, report: ReportData) -> Path:
    """Write the HTML of ``report`` to ``path``; return the path."""
    path = Path(path)
    path.write_text(render_html(report), encoding="utf-8")
    return path
