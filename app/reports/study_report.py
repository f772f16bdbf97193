"""``report.html`` of a Monte Carlo study: one self-contained page (plotly.js embedded, nothing
fetched) with, per trajectory, the paper's Figures 9-14 layout (velocity RMS and attitude RMS
against time, every method) plus tilt, heading and NEES/dim beside them, a table of the final
values and the consistency per method, and one of its updates per aiding source."""

from __future__ import annotations

import html
from typing import Any

import numpy as np
import plotly.graph_objects as go
from plotly.subplots import make_subplots

from app.figures.shared import make_figure, method_color
from app.reports.tables import mission_rms
from tauvcore.engine.results import BLOCK_DIMS
from tauvcore.eval.consistency import nees_band
from tauvcore.eval.counts import PING_SOURCES, SOURCE_LABELS, MethodCounts
from tauvcore.eval.study_statistics import FINAL_STATISTICS

PANELS = (
    ("vel_err_mps", "Velocity error RMS [m/s]", True),
    ("att_err_deg", "Attitude error RMS [deg]", False),
    ("tilt_err_deg", "Tilt (roll, pitch) error RMS [deg]", True),
    ("heading_err_deg", "Heading error RMS [deg]", False),
)


def _finite_or_none(x: np.ndarray) -> list[float | None]:
    plain = x.astype(object)
    plain[~np.isfinite(x)] = None
    return plain.tolist()


def _axes(row: int, col: int) -> tuple[str, str]:
    """The x and y axes of the panel at ``row``, ``col`` (from 1) of the two-column grid."""
    n = (row - 1) * 2 + col
    return ("x", "y") if n == 1 else (f"x{n}", f"y{n}")


def _line(x: Any, y: Any, method: str, showlegend: bool, row: int, col: int) -> dict[str, Any]:
    """``method``'s curve, in its colour, in the panel at ``row``, ``col`` of the grid."""
    xa, ya = _axes(row, col)
    return {
        "type": "scatter",
        "x": x,
        "y": y,
        "mode": "lines",
        "name": method.upper(),
        "legendgroup": method,
        "showlegend": showlegend,
        "line": {"color": method_color(method), "width": 1.5},
        "xaxis": xa,
        "yaxis": ya,
    }


def trajectory_figure(trajectory: str, summary: dict[str, Any], validate: bool = False) -> go.Figure:
    """Five panels for one trajectory: velocity, attitude, tilt, heading RMS and NEES/dim.

    The grid comes from ``make_subplots``; the traces are plain dicts placed on its axes and the
    figure is wrapped without plotly's per-property validation (app.figures.shared.make_figure): validating
    the 123 traces of ``tauv reproduce``'s report took 2.7 s of the study's main process, which
    shares the machine with the workers. ``validate`` True builds the validated figure (the tests
    check both are equal)."""
    t = np.asarray(summary["t_s"], dtype=float)
    grid = make_subplots(
        rows=3,
        cols=2,
        vertical_spacing=0.09,
        horizontal_spacing=0.08,
        subplot_titles=[p[1] for p in PANELS] + ["NEES/dim, full state (1 = consistent)"],
    )
    layout = grid.layout.to_plotly_json()
    layout.pop("template", None)
    data: list[dict[str, Any]] = []
    for i, (name, _, log) in enumerate(PANELS):
        row, col = divmod(i, 2)
        for method, m in summary["methods"].items():
            rms = _finite_or_none(np.asarray(m["rms"][name], dtype=float))
            data.append(_line(t, rms, method, i == 0, row + 1, col + 1))
        if log:
            layout[f"yaxis{'' if i == 0 else i + 1}"]["type"] = "log"
    lo, hi = nees_band(20, summary["num_runs"])
    xa, ya = _axes(3, 1)
    data.append(
        {
            "type": "scatter",
            "x": [t[0], t[-1], t[-1], t[0]],
            "y": [lo, lo, hi, hi],
            "fill": "toself",
            "mode": "none",
            "fillcolor": "rgba(128,128,128,0.2)",
            "name": "99 % band",
            "showlegend": True,
            "xaxis": xa,
            "yaxis": ya,
        }
    )
    for method, m in summary["methods"].items():
        nees = _finite_or_none(np.asarray(m["mean_nees"]["nees"], dtype=float) / 20.0)
        data.append(_line(t, nees, method, False, 3, 1))
    layout[f"yaxis{ya[1:]}"]["type"] = "log"
    for key in list(layout):
        if key.startswith("xaxis"):
            layout[key]["title"] = {"text": "time [s]"}
    layout.update(
        height=900,
        title={"text": f"{trajectory}: RMS over {summary['num_runs']} runs"},
        margin={"l": 60, "r": 20, "t": 70, "b": 40},
        template="plotly_white",
    )
    return make_figure(data, layout, validate=validate)


def _cell(x: Any, fmt: str) -> str:
    return "-" if x is None or not np.isfinite(x) else format(x, fmt)


def summary_table_html(summary: dict[str, Any]) -> str:
    """Per method the final errors over the runs (RMS, median, 95th percentile), the consistency and
    the runs the monitor flagged and those whose velocity was reset after a DVL lock-out; a method
    with flagged runs gets a second row without them."""

    def triple(stats: dict[str, Any], suffix: str, fmt: str) -> str:
        return " / ".join(_cell(stats[f"{k}{suffix}"], fmt) for k in FINAL_STATISTICS)

    rows = []
    for method, m in summary["methods"].items():
        st, c = m["final_stats"], m["consistency"]
        for suffix, label in (("", method.upper()), ("_unflagged", f"{method.upper()} without flagged runs")):
            if suffix and not m["runs_flagged_by_monitor"]:
                continue
            nees = (
                f"<td>{_cell(c['full']['per_dim'], '.3g')} ({_cell(c['full']['in_band'], '.2f')})</td>"
                f"<td>{_cell(c['vel']['per_dim'], '.3g')} ({_cell(c['vel']['in_band'], '.2f')})</td>"
                if not suffix
                else "<td>-</td><td>-</td>"
            )
            flagged = (
                str(m["runs_flagged_by_monitor"])
                if not suffix
                else "left out: runs " + ", ".join(map(str, m["flagged_runs"]))
            )
            resets = m.get("lockout_resets", 0)
            if resets and not suffix:
                flagged += (
                    f"; {resets} lock-out reset{'s' if resets > 1 else ''} (runs "
                    + ", ".join(map(str, m["reset_runs"]))
                    + ")"
                )
            rows.append(
                f"<tr><td>{html.escape(label)}</td><td>{triple(st['vel_err_mps'], suffix, '.3g')}</td>"
                f"<td>{triple(st['tilt_err_deg'], suffix, '.3f')}</td>"
                f"<td>{triple(st['heading_err_deg'], suffix, '.3f')}</td>"
                f"<td>{triple(st['pos_err_m'], suffix, '.3g')}</td>{nees}<td>{html.escape(flagged)}</td></tr>"
            )
    return (
        "<table><tr><th>method</th><th>vel [m/s]</th><th>tilt [deg]</th><th>heading [deg]</th><th>pos [m]</th>"
        "<th>NEES/dim full (in band)</th><th>NEES/dim vel (in band)</th><th>runs flagged</th></tr>"
        + "".join(rows)
        + "</table>"
    )


def counts_table_html(summary: dict[str, Any]) -> str:
    """Per method each aiding source's updates fused / rejected / unused over every run of the
    study, and the DVL pings it coasted on (the summary's ``counts``, tauvcore.eval.counts: the
    DVL's bottom-track, its water-track and the RPM's velocity apart); empty when no method has a
    record of any source.

    Parameters
    ----------
    summary : dict[str, Any]
        A study's summary (tauvcore.eval.study.StudyAccumulator.summary).

    Returns
    -------
    str
        A sentence and the HTML table, or "".
    """
    counts = {
        method: MethodCounts.from_json(m["counts"])
        for method, m in summary["methods"].items()
        if "counts" in m
    }
    order = list(dict.fromkeys(src for c in counts.values() for src in c.sources))
    sources = [*(x for x in PING_SOURCES if x in order), *(x for x in order if x not in PING_SOURCES)]
    if not sources:
        return ""
    rows = []
    for method, c in counts.items():
        cells = [
            f"{c.sources[x].fused} / {c.sources[x].rejected} / {c.sources[x].unused}"
            if x in c.sources
            else "-"
            for x in sources
        ]
        cells.append("-" if c.coasted is None else f"{c.coasted} of {c.pings}")
        rows.append(
            f"<tr><td>{html.escape(method.upper())}</td>" + "".join(f"<td>{x}</td>" for x in cells) + "</tr>"
        )
    head = "".join(f"<th>{html.escape(SOURCE_LABELS.get(x, x))}</th>" for x in [*sources, "coasted"])
    return (
        "<p>Updates per source over every run: fused / rejected / unused (rejected: a measurement the "
        "filter took none of; unused: none of that source for the method there); coasted: DVL pings on "
        "which no velocity was fused (no bottom-track, water-track or RPM).</p>"
        f"<table><tr><th>method</th>{head}</tr>" + "".join(rows) + "</table>"
    )


def smoothed_table_html(summary: dict[str, Any]) -> str:
    """Of a study with the smoother: per method filtered and smoothed, the RMS over the runs and the
    whole mission (app.reports.tables.mission_rms) and NEES/dim of every block (in brackets the fraction of
    epochs inside the 99 % band); a method the smoother does not run one row saying so. Empty for a
    study without the smoother."""
    methods = summary["methods"]
    if not any("smoothed" in m for m in methods.values()):
        return ""
    blocks = list(BLOCK_DIMS)
    rows = []
    for method, m in methods.items():
        if m.get("smoothed") is None:
            rows.append(
                f"<tr><td>{html.escape(method.upper())}</td><td colspan='{5 + len(blocks)}'>"
                "not smoothed</td></tr>"
            )
            continue
        for label, part in (("filtered", m), ("smoothed", m["smoothed"])):
            r, c = part["rms"], part["consistency"]
            errors = "".join(
                f"<td>{_cell(mission_rms(r[n]), fmt)}</td>"
                for n, fmt in (
                    ("vel_err_mps", ".3g"),
                    ("tilt_err_deg", ".3f"),
                    ("heading_err_deg", ".3f"),
                    ("pos_err_m", ".3g"),
                )
            )
            nees = "".join(
                f"<td>{_cell(c[b]['per_dim'], '.3g')} ({_cell(c[b]['in_band'], '.2f')})</td>" for b in blocks
            )
            rows.append(f"<tr><td>{html.escape(method.upper())}</td><td>{label}</td>{errors}{nees}</tr>")
    head = "".join(f"<th>NEES/dim {html.escape(b)}</th>" for b in blocks)
    return (
        "<p>Fixed-interval smoother: RMS over the runs and the whole mission and NEES/dim against truth "
        "per block, filtered and smoothed.</p><table><tr><th>method</th><th></th><th>vel [m/s]</th><th>tilt [deg]</th>"
        f"<th>heading [deg]</th><th>pos [m]</th>{head}</tr>" + "".join(rows) + "</table>"
    )


def markdown_table_html(markdown: str) -> str:
    """A Markdown pipe table (header, rule, rows) as an HTML table, every cell escaped."""
    rows = [
        [c.strip() for c in line.strip().strip("|").split("|")]
        for line in markdown.strip().splitlines()
        if line.strip().startswith("|")
    ]
    if len(rows) < 2:
        return ""
    head, body = rows[0], rows[2:]
    th = "".join(f"<th>{html.escape(c)}</th>" for c in head)
    trs = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in body)
    return f"<table class='comparison'><tr>{th}</tr>{trs}</table>"


def report_html(
    title: str, description: str, summaries: dict[str, dict[str, Any]], comparison_md: str | None = None
) -> str:
    """The whole page; ``summaries`` maps trajectory to its StudyAccumulator.summary(), and
    ``comparison_md`` (``tauv reproduce``) is the paper comparison shown after the description."""
    parts = [
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>",
        (
            "<style>body{font-family:sans-serif;margin:2em;max-width:1200px}table{border-collapse:collapse}"
            "td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}table.comparison td{text-align:left}</style></head><body>"
        ),
        f"<h1>{html.escape(title)}</h1><p>{html.escape(description)}</p>",
    ]
    if comparison_md:
        parts.append("<h2>Beside the paper</h2>" + markdown_table_html(comparison_md))
    first = True
    for trajectory, summary in summaries.items():
        parts.append(
            f"<h2>{html.escape(trajectory)}</h2><p>Final values over the runs at the last epoch: RMS / median / "
            "95th percentile; a method whose runs the divergence monitor flagged has a second row without "
            "them.</p>"
        )
        parts.append(summary_table_html(summary))
        parts.append(counts_table_html(summary))
        parts.append(smoothed_table_html(summary))
        parts.append(
            trajectory_figure(trajectory, summary).to_html(
                full_html=False, include_plotlyjs=first, include_mathjax=False
            )
        )
        first = False
    parts.append("</body></html>")
    return "".join(parts)
