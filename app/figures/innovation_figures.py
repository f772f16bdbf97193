"""Plotly figures of the aiding sources' innovations: for each source, every method's innovations
per measurement row with the filter's 3-sigma envelope and the rows the gate rejected.

A consistent filter keeps about 99.7 % of its innovations inside its band; innovations that wander
out of it, or a run of rejections, show a filter that no longer knows its error or a sensor that
went wrong. Each panel holds one quantity (:data:`INNOVATION_ROWS`): the DVL's body axes and TC's
beams are never drawn on a shared panel.

A long run's updates reduced to time bins (tauvcore.eval.envelope.DecimatedUpdates) are drawn as
the innovation of each bin's last update over a band from the bin's smallest to its largest
innovation, the 3-sigma band at the bin's largest ``3 sqrt(S_ii)``, and a cross at the last
rejected innovation of each bin with a rejection.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import plotly.graph_objects as go

from app.figures.shared import (
    BAND_ALPHA_MAX,
    TICK_LABELS_PX,
    TITLE_PX,
    band_alpha,
    bin_label,
    decimate,
    envelope_traces,
    hex_to_rgba,
    make_figure,
    merge_bins,
    merged_envelope,
    method_color,
    stacked_layout,
)
from tauvcore.aiding.sources import FUSED
from tauvcore.engine.results import MethodResult
from tauvcore.eval.envelope import DecimatedUpdates, is_decimated

INNOVATION_ROWS = {
    "dvl": {3: ("surge", "sway", "heave"), 4: ("beam 1", "beam 2", "beam 3", "beam 4")},
    # the DVL's water-track beams, fused against the current states (tauvcore.engine.dvl_fusion)
    "water": {4: ("beam 1", "beam 2", "beam 3", "beam 4")},
}
INNOVATION_ROWS.update({name: {len(s.row_labels): s.row_labels} for name, s in FUSED.items()})
"""What a source's innovation rows are, by their number (DVL: body axes, TC: beams; a plug-in: its own)."""
BAND_SUFFIX = " 3-sigma"
PANEL_PX = 120  # each panel's height on a card app.figures.shared.CARD_WIDTH_PX wide (None: height_px)
REJECTED_SUFFIX = " rejected"


def innovation_sources(results: Mapping[str, MethodResult]) -> tuple[str, ...]:
    """The aiding sources any method of ``results`` updated with, in order of appearance."""
    return tuple(dict.fromkeys(s for res in results.values() for s in res.updates))


def innovation_figure(
    results: Mapping[str, MethodResult],
    source: str = "dvl",
    run: int = 0,
    height_px: int | None = None,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """Innovations of aiding ``source`` against time for run ``run`` of each method that has such
    updates, one panel per measurement row (the DVL's body axes, or TC's beams), with the
    filter's 3-sigma envelope ``+-3 sqrt(S_ii)`` (``UpdateRecord.innovation_var``) as a shaded
    band (trace "<METHOD> 3-sigma") and the rows the gate rejected marked with a cross (trace
    "<METHOD> rejected", at every rejected row, never decimated). Epochs where the source gave
    no measurement are gaps. A consistent filter keeps about 99.7 % of its innovations in its band.
    Each panel holds one quantity: methods whose rows mean different things (LC's body axes, TC's
    beams) get panels of their own, one per row name (:data:`INNOVATION_ROWS`), never a shared one.
    """
    records = {
        m: r.updates[source] for m, r in results.items() if source in r.updates and len(r.updates[source].t_s)
    }
    named = INNOVATION_ROWS.get(source, {})
    row_names = {
        m: named.get(d, tuple(f"row {k + 1}" for k in range(d)))
        for m, d in ((m, rec.innovation.shape[2]) for m, rec in records.items())
    }
    names = list(dict.fromkeys(name for labels in row_names.values() for name in labels)) or ["row 1"]
    data: list[dict[str, Any]] = []
    bins_s = [float(r.bin_s) for m, r in results.items() if m in records and is_decimated(r)]
    for method, rec in records.items():
        if not 0 <= run < rec.innovation.shape[1]:
            raise ValueError(f"run must be within [0, {rec.innovation.shape[1] - 1}], got {run}")
        color = method_color(method)
        binned = results[method]
        if isinstance(rec, DecimatedUpdates) and is_decimated(binned):
            bin_s = float(binned.bin_s)
            data += _binned_traces(rec, method, run, row_names[method], names, color, bin_s, max_points)
            continue
        keep = decimate(len(rec.t_s), max_points)
        t = rec.t_s[keep]
        valid = rec.valid[:, run]
        for k in range(rec.innovation.shape[2]):
            panel = names.index(row_names[method][k])
            suffix = "" if panel == 0 else str(panel + 1)
            axes = {"xaxis": f"x{suffix}", "yaxis": f"y{suffix}"}
            # a row is drawn where it was measured: a beam that did not return has no variance
            # (its innovation is a placeholder 0), so it is a gap, not a perfect innovation
            var = rec.innovation_var[:, run, k]
            row_ok = valid & np.isfinite(var)
            nu = np.where(row_ok, rec.innovation[:, run, k], np.nan)
            with np.errstate(invalid="ignore"):
                env = np.where(row_ok, 3.0 * np.sqrt(var), np.nan)
            data.append(_sigma3_band(t, env[keep], method, color, axes))
            data.append(
                {
                    "type": "scatter",
                    "x": t,
                    "y": nu[keep],
                    "name": method.upper(),
                    "mode": "lines+markers",
                    "marker": {"size": 3},
                    "line": {"color": color, "width": 1},
                    "legendgroup": method,
                    "showlegend": k == 0,
                    **axes,
                }
            )
            hit = rec.rejected_rows[:, run, k] & row_ok
            if hit.any():
                data.append(
                    _rejected_trace(method, color, rec.t_s[hit], rec.innovation[hit, run, k], data, axes)
                )
    runs_text = f", run {run + 1}" if any(rec.innovation.shape[1] > 1 for rec in records.values()) else ""
    shaded = f", shaded: {bin_label(max(bins_s))}" if bins_s else ""
    title = f"{source.upper()} innovations with their 3-sigma (x: rejected){runs_text}{shaded}"
    alpha = band_alpha(len(records))  # one band per method on each panel
    for trace in data:
        if trace["name"].endswith(BAND_SUFFIX):
            trace["fillcolor"] = hex_to_rgba(trace["line"]["color"], alpha)
    height_px = height_px or PANEL_PX * len(names) + TITLE_PX + TICK_LABELS_PX
    return make_figure(data, stacked_layout(title, names, height_px, data), validate)


def _binned_traces(
    rec: DecimatedUpdates,
    method: str,
    run: int,
    rows: tuple[str, ...],
    names: list[str],
    color: str,
    bin_s: float,
    max_points: int | None,
) -> list[dict[str, Any]]:
    """The traces of one method's binned updates (module docstring), run ``run``, one panel per row."""
    assert rec.innovation_low is not None and rec.innovation_high is not None
    assert rec.sigma3_high is not None and rec.rejected_innovation is not None
    keep, starts = merge_bins(len(rec.t_s), max_points)
    t = rec.t_s[keep]
    data: list[dict[str, Any]] = []
    for k in range(rec.innovation.shape[2]):
        panel = names.index(rows[k])
        suffix = "" if panel == 0 else str(panel + 1)
        axes = {"xaxis": f"x{suffix}", "yaxis": f"y{suffix}"}
        lo, hi = merged_envelope(rec.innovation_low[:, run, k], rec.innovation_high[:, run, k], starts)
        _, env = merged_envelope(rec.sigma3_high[:, run, k], rec.sigma3_high[:, run, k], starts)
        measured = rec.valid[:, run] & np.isfinite(rec.innovation_var[:, run, k])
        nu = np.where(measured, rec.innovation[:, run, k], np.nan)[keep]
        data.append(_sigma3_band(t, env, method, color, axes))
        data += envelope_traces(t, lo, hi, method.upper(), color, bin_s, method, **axes)
        data.append(
            {
                "type": "scatter",
                "x": t,
                "y": nu,
                "name": method.upper(),
                "mode": "lines",
                "line": {"color": color, "width": 1},
                "legendgroup": method,
                "showlegend": k == 0,
                **axes,
            }
        )
        rejected = rec.rejected_innovation[:, run, k]
        hit = np.isfinite(rejected)
        if hit.any():
            data.append(_rejected_trace(method, color, rec.t_s[hit], rejected[hit], data, axes))
    return data


def _sigma3_band(
    t: np.ndarray, sigma3: np.ndarray, method: str, color: str, axes: dict[str, str]
) -> dict[str, Any]:
    """The filled +-3 sqrt(S_ii) band of one method's innovations of one row: ``sigma3`` (n,) at
    times ``t`` (n,) [s], on the panel's ``axes``."""
    return {
        "type": "scatter",
        "x": np.r_[t, t[::-1]],
        "y": np.r_[sigma3, -sigma3[::-1]],
        "name": method.upper() + BAND_SUFFIX,
        "mode": "lines",
        "fill": "toself",
        "fillcolor": hex_to_rgba(color, BAND_ALPHA_MAX),
        "line": {"width": 0, "color": color},
        "hoverinfo": "skip",
        "legendgroup": method,
        "showlegend": False,
        **axes,
    }


def _rejected_trace(
    method: str, color: str, t: np.ndarray, nu: np.ndarray, data: list[dict[str, Any]], axes: dict[str, str]
) -> dict[str, Any]:
    """The crosses of ``method``'s innovations ``nu`` the gate rejected, at ``t`` [s], on the panel
    ``axes``; in the legend once, unless ``data`` (the traces drawn before it) already has them."""
    name = method.upper() + REJECTED_SUFFIX
    return {
        "type": "scatter",
        "x": t,
        "y": nu,
        "name": name,
        "mode": "markers",
        "marker": {"color": color, "size": 8, "symbol": "x"},
        "legendgroup": method,
        "showlegend": not any(d["name"] == name for d in data),
        **axes,
    }
