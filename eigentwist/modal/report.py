"""The report's section on a modal-test campaign (rendered here, shown by the report).

:func:`is_manifest` tells a campaign manifest (a ``file`` column) from a measurement
CSV; :func:`campaign_section` identifies the campaign and returns the measurements and
an HTML fragment (identified modes per setting with damping, shape (over the DOFs
listed below the table), complexity and stable orders, the campaign's notes, the time
per setting, and each setting's stabilisation diagram), which
the report inserts after its comparison section.
"""

from __future__ import annotations

import base64
import csv
from pathlib import Path

import jinja2

__all__ = ["is_manifest", "campaign_section", "render_section"]

TEMPLATE = """<section id="campaign">
<h2>Modal-test campaign</h2>
<p>Identified from {{ n }} settings listed in <code>{{ source }}</code>: LSCF poles and LSFD shapes (sdypy-EMA),
stable poles selected automatically (see <code>eigentwist identify --help</code>); {{ seconds }} per setting.</p>
<table>
<tr><th class="l">file</th><th>k_a [N m/rad]</th><th>pose [m]</th><th class="l">mode</th><th>f [Hz]</th>\
<th>&sigma; [Hz]</th>
<th>&zeta; [%]</th><th>shape</th><th>complexity</th><th>stable orders</th></tr>
{% for row in rows %}
<tr><td class="l">{{ row.file }}</td><td>{{ row.k_a }}</td><td>{{ row.pose }}</td><td class="l">{{ row.mode }}</td>
<td>{{ row.f }}</td><td>{{ row.sigma }}</td><td>{{ row.zeta }}</td><td>{{ row.shape }}</td><td>{{ row.mcf }}</td>
<td>{{ row.orders }}</td></tr>
{% endfor %}
</table>
{% for dofs in dof_lists %}
<p>shape over {{ dofs }}</p>
{% endfor %}
{% for note in notes %}
<p>note: {{ note }}</p>
{% endfor %}
{% for name, png in figures %}
<details><summary>{{ name }}: stabilisation diagram</summary>
<img alt="stabilisation diagram of {{ name }}" src="data:image/png;base64,{{ png }}"></details>
{% endfor %}
</section>
"""


def is_manifest(path) -> bool:
    """True when ``path`` is a CSV whose header has a ``file`` column (a campaign manifest)."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            for cells in csv.reader(fh):
                if cells and not cells[0].lstrip().startswith("#") and any(c.strip() for c in cells):
                    return "file" in [c.strip() for c in cells]
    except (OSError, UnicodeDecodeError):
        return False
    return False


def render_section(result, figures: bool = True) -> str:
    """HTML fragment of an identified :class:`~eigentwist.modal.campaign.CampaignResult`."""
    rows = []
    for s, res in zip(result.campaign.settings, result.results):
        for m in sorted(res.modes, key=lambda m: m.freq_hz):
            rows.append(
                dict(
                    file=s.file.name,
                    k_a=f"{s.k_a:g}",
                    pose=", ".join(f"{v:.4g}" for v in s.pose),
                    mode=m.label,
                    f=f"{m.freq_hz:.4f}",
                    sigma=f"{m.sigma_hz:.3g}",
                    zeta=f"{100 * m.damping_ratio:.2f}",
                    shape=", ".join(f"{v:+.3f}" for v in m.shape),
                    mcf=f"{m.complexity:.3f}",
                    orders=m.orders or "-",
                )
            )
    pngs = []
    if figures:
        from .plots import figure_bytes, plot_stabilisation

        pngs = [
            (s.file.name, base64.b64encode(figure_bytes(plot_stabilisation, r)).decode("ascii"))
            for s, r in zip(result.campaign.settings, result.results)
            if r.stabilisation is not None
        ]
    secs = [r.seconds for r in result.results if r.seconds]
    dof_lists = list(dict.fromkeys(", ".join(m.dofs) for r in result.results for m in r.modes if m.dofs))
    env = jinja2.Environment(undefined=jinja2.StrictUndefined, autoescape=True, trim_blocks=True, lstrip_blocks=True)
    return env.from_string(TEMPLATE).render(
        n=len(result.results),
        source=Path(result.campaign.source).name,
        rows=rows,
        figures=pngs,
        dof_lists=dof_lists,
        notes=result.notes,
        seconds=f"{sum(secs) / len(secs):.2f} s" if secs else "no FRF identification",
    )


def campaign_section(manifest, ev, figures: bool = True):
    """(measurements, HTML fragment) of the campaign ``manifest``."""
    from .campaign import identify_campaign

    result = identify_campaign(manifest, ev)
    return result.measurements, render_section(result, figures)
