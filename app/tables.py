"""The tables ``tauv`` prints: a run's errors and consistency per method, and a study's summary."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from tauvcore.aiding.sources import FUSED
from tauvcore.config import YOO_METHODS, Config
from tauvcore.engine import yoo_sources
from tauvcore.engine.results import BLOCK_DIMS, MethodResult
from tauvcore.eval.envelope import DecimatedResult
from tauvcore.eval.running import MethodSummary, summarise
from tauvcore.eval.study_statistics import FINAL_STATISTICS


def summary_table(
    results: Mapping[str, MethodResult | MethodSummary],
    config: Config,
    elapsed_s: float,
    source: str | None = None,
    preamble: Sequence[str] = (),
    smoothed: Mapping[str, MethodSummary] | None = None,
) -> str:
    """The errors of run 0 per method (attitude as the norm and apart: tilt, heading), then
    :func:`consistency_table`. ``results``: each method's whole results, or its summary reduced
    chunk by chunk (tauvcore.eval.running); ``source``: what was run, when not the configured
    trajectory (a log); ``preamble``: lines after the first (a log: what configured it, where it
    started); ``smoothed``: the smoothed methods' summaries of a run that smoothed, then
    :func:`smoothing_table` last."""
    summaries = _summaries(results)
    tr = config.trajectory
    what = source if source is not None else f"trajectory {tr.name} ({tr.truth} truth)"
    ideal = config.run.ideal and source is None  # a replay's sensors are the log's: it has no ideal mode
    lines = [
        f"{what}, {tr.duration_s:g} s, earth {config.earth.model}, seed {config.run.seed}, "
        f"aiding {','.join(config.run.aiding) or 'none'}"
        + (", IDEAL sensors" if ideal else "")
        + f"  ({elapsed_s:.1f} s wall)",
        *preamble,
        "",
        (
            f"{'method':<7} {'vel final':>10} {'vel RMS':>9} {'att final':>10} {'att RMS':>9} {'tilt RMS':>9} "
            f"{'head RMS':>9} {'pos final':>10} {'pos RMS':>9} {'vel 1-sig':>10} {'DVL fused/rej/coast':>20}"
        ),
        (
            f"{'':<7} {'[m/s]':>10} {'[m/s]':>9} {'[deg]':>10} {'[deg]':>9} {'[deg]':>9} {'[deg]':>9} {'[m]':>10} "
            f"{'[m]':>9} {'[m/s]':>10}"
        ),
    ]
    for name, s in summaries.items():
        fused = "-" if s.dvl_counts is None else "/".join(str(n) for n in s.dvl_counts)
        marker = ""
        if s.diverged:
            marker = "  diverged" + (f" at {s.diverged_at_s:g} s" if np.isfinite(s.diverged_at_s) else "")
        if s.reset_times_s:
            when = ", ".join(f"{t:g}" for t in s.reset_times_s[:5])
            marker += f"  velocity reset to the DVL after a lock-out at {when} s"
        f, r = s.final, s.rms
        lines.append(
            f"{name.upper():<7} {_fixed(f['vel_err_mps'], 10, 4)} {_fixed(r['vel_err_mps'], 9, 4)} "
            f"{_fixed(f['att_err_deg'], 10, 4)} {_fixed(r['att_err_deg'], 9, 4)} "
            f"{_fixed(r['tilt_err_deg'], 9, 4)} {_fixed(r['heading_err_deg'], 9, 4)} "
            f"{_fixed(f['pos_err_m'], 10, 3)} {_fixed(r['pos_err_m'], 9, 3)} "
            f"{_fixed(f['vel_sigma_mps'], 10, 4)} {fused:>20}" + marker
        )
    recorded = {src for s in summaries.values() for src in s.consistency.nis}
    extra = [s for s in ("water",) if s in recorded]  # the DVL's water-track, beside its bottom-track
    tables = [consistency_table(summaries, (*config.run.aiding, *extra))]
    if smoothed is not None:
        tables.append(smoothing_table(summaries, smoothed))
    return "\n".join(lines + ["", "\n\n".join(tables)])


SMOOTHED_RMS = (("vel_err_mps", "vel RMS", "[m/s]", 4), ("tilt_err_deg", "tilt RMS", "[deg]", 4))
SMOOTHED_RMS += (("heading_err_deg", "head RMS", "[deg]", 4), ("pos_err_m", "pos RMS", "[m]", 3))
"""The RMS of run 0 :func:`smoothing_table` gives filtered and smoothed: series, heading, unit, decimals."""


def _block_dims(summaries: Mapping[str, MethodSummary]) -> dict[str, int]:
    """The NEES columns of a table of ``summaries``: the 20-state filter's blocks, and those its
    sources add (tauvcore.filter.layout.Layout), each with its dimension; the full state's is the
    20-state methods' (Yoo 2014's are in a note)."""
    dims = dict(BLOCK_DIMS)
    for name, summary in summaries.items():
        for block, n in (summary.block_dims or {}).items():
            dims.setdefault(block, n)
            if block == "full" and name not in YOO_METHODS:
                dims["full"] = max(dims["full"], n)
    return dims


def smoothing_table(filtered: Mapping[str, MethodSummary], smoothed: Mapping[str, MethodSummary]) -> str:
    """Per method two rows, filtered then smoothed: the RMS of run 0 (velocity, tilt, heading,
    position) and NEES/dim of the full state and each block against truth, with the fraction of
    epochs inside the 99 % band; a method the smoother does not run (Yoo 2014's) one row saying so.

    Parameters
    ----------
    filtered : Mapping[str, MethodSummary]
        Every method's summary (tauvcore.eval.running).
    smoothed : Mapping[str, MethodSummary]
        The smoothed methods' summaries over the same epochs.

    Returns
    -------
    str
        The table, its title first.
    """
    dims = _block_dims(filtered)
    blocks = list(dims)
    head = ["method", *(h for _, h, _, _ in SMOOTHED_RMS), *blocks]
    units = ["", *(u for _, _, u, _ in SMOOTHED_RMS), *(f"NEES/{dims[b]}" for b in blocks)]
    rows = []
    for name, summary in filtered.items():
        if name not in smoothed:
            rows.append([f"{name.upper()} not smoothed"])
            continue
        for label, s in (("filtered", summary), ("smoothed", smoothed[name])):
            c = s.consistency.nees
            rows.append(
                [
                    f"{name.upper()} {label}",
                    *(_fixed(s.rms[n], 0, d).strip() for n, _, _, d in SMOOTHED_RMS),
                    *(_cell(c[b].per_dim, c[b].in_band) if b in c else "-" for b in blocks),
                ]
            )
    full = [r for r in rows if len(r) > 1]
    widths = [max(len(row[k]) for row in [head, units, *full]) for k in range(len(head))]

    def line(cells: list[str]) -> str:
        if len(cells) == 1:
            return cells[0]
        return " ".join(
            [cells[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(cells[1:], widths[1:])]
        ).rstrip()

    title = (
        "Smoothed beside filtered (fixed-interval smoother over the whole run): RMS of run 0, NEES/dim "
        "against truth (in brackets the fraction inside the 99 % band)"
    )
    return "\n".join([title, line(head), line(units), *(line(row) for row in rows)])


def _summaries(results: Mapping[str, MethodResult | MethodSummary]) -> dict[str, MethodSummary]:
    """Each method's summary: as given, the one a run reduced to time bins carries
    (tauvcore.eval.envelope.DecimatedResult.summary), or of its whole results
    (tauvcore.eval.running.summarise)."""
    results = {
        m: r.summary if isinstance(r, DecimatedResult) and r.summary is not None else r
        for m, r in results.items()
    }
    whole = {m: r for m, r in results.items() if isinstance(r, MethodResult)}
    done = summarise(whole) if whole else {}
    return {m: done[m] if isinstance(r, MethodResult) else r for m, r in results.items()}


def _fixed(value: float | np.ndarray, width: int, digits: int) -> str:
    """``value`` (a number, or a 0-d array) right-aligned in ``width`` with ``digits`` decimals;
    "-" if unknown (NaN: a log without a reference has no errors)."""
    number = float(value)
    return f"{number:>{width}.{digits}f}" if np.isfinite(number) else f"{'-':>{width}}"


def _ratio(value: float) -> str:
    """NEES/dim or NIS/dof in at most 7 characters; "-" if not finite."""
    if not np.isfinite(value):
        return "-"
    if abs(value) < 10:
        return f"{value:.2f}"
    if abs(value) < 100:
        return f"{value:.1f}"
    return f"{value:.0f}" if abs(value) < 1e5 else f"{value:.1e}"


def _cell(ratio: float, in_band: float) -> str:
    """``1.03 (0.98)``: the ratio and, in brackets, the fraction inside the band; "-" for neither."""
    if not (np.isfinite(ratio) or np.isfinite(in_band)):
        return "-"
    return f"{_ratio(ratio)} ({f'{in_band:.2f}' if np.isfinite(in_band) else '-'})"


def consistency_table(results: Mapping[str, MethodResult | MethodSummary], sources: Sequence[str]) -> str:
    """Per method: NEES/dim of the full state and each block, NIS/dof of each aiding source in
    ``sources``, each with the fraction of epochs (NIS: updates) inside its two-sided 99 %
    chi-square band (:func:`tauvcore.eval.consistency.method_consistency`; with one run, the
    single-run band)."""
    summaries = _summaries(results)
    dims = _block_dims(summaries)
    blocks = list(dims)
    head = ["method", *blocks, *sources]
    units = ["", *(f"NEES/{dims[b]}" for b in blocks), *("NIS/dof" for _ in sources)]
    rows = []
    for name, summary in summaries.items():
        c = summary.consistency
        nis = [c.nis.get(s) for s in sources]
        rows.append(
            [
                name.upper(),
                *(_cell(c.nees[b].per_dim, c.nees[b].in_band) if b in c.nees else "-" for b in blocks),
                *(_cell(n.per_dof, n.in_band) if n is not None else "-" for n in nis),
            ]
        )
    widths = [max(len(row[k]) for row in [head, units, *rows]) for k in range(len(head))]
    widths[0] = max(widths[0], 7)

    def line(cells: list[str]) -> str:
        return " ".join(
            [cells[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(cells[1:], widths[1:])]
        ).rstrip()

    title = (
        "Consistency (1 = consistent, above 1 over-confident, below 1 cautious; in brackets the fraction "
        "inside the 99 % band)"
    )
    notes = []
    yoo_full = [(s.block_dims or {}).get("full", 12) for name, s in summaries.items() if name in YOO_METHODS]
    if yoo_full:
        left_out = [s for s in sources if s in FUSED and not yoo_sources.takes(FUSED[s])]
        notes = [
            f"INS-DVL and VKF are Yoo 2014's 12-state filter: their full NEES is over {max(yoo_full)} states, "
            "their sensor NEES over 6, and they have no position state"
            + (f"; they do not fuse {', '.join(left_out)} (no position state)" if left_out else "")
        ]
    return "\n".join([title, line(head), line(units), *(line(row) for row in rows), *notes])


def study_table(summary: dict[str, Any], trajectory: str, num_runs: int, elapsed_s: float) -> str:
    """The study's final errors per method: RMS, median and 95th percentile over the runs, the
    consistency, the runs the monitor flagged; a method with flagged runs gets a second row, its
    statistics without them (marked "w/o flagged"); a study with the smoother then
    :func:`smoothed_study_lines`."""
    lines = [
        (
            f"trajectory {trajectory}, {num_runs} runs  ({elapsed_s:.1f} s wall); errors at the end over the "
            "runs: RMS / median / 95th percentile"
        ),
        "",
        (
            f"{'method':<16} {'vel [m/s]':>26} {'tilt [deg]':>11} {'head [deg]':>11} {'pos [m]':>30} "
            f"{'NEES/dim':>14} {'vel NEES/dim':>14} {'flagged':>8} {'resets':>7}"
        ),
    ]

    def triple(stats: dict[str, Any], suffix: str) -> str:
        return " / ".join(_g(stats[f"{k}{suffix}"]) for k in FINAL_STATISTICS)

    for method, m in summary["methods"].items():
        f, c, st = m["final_rms"], m["consistency"], m["final_stats"]
        lines.append(
            f"{method.upper():<16} {triple(st['vel_err_mps'], ''):>26} {f['tilt_err_deg']:>11.4f} "
            f"{f['heading_err_deg']:>11.4f} {triple(st['pos_err_m'], ''):>30} "
            f"{_cell(c['full']['per_dim'], c['full']['in_band']):>14} "
            f"{_cell(c['vel']['per_dim'], c['vel']['in_band']):>14} {m['runs_flagged_by_monitor']:>8} "
            f"{m['lockout_resets']:>7}"
        )
        if m["runs_flagged_by_monitor"]:
            tilt, head = st["tilt_err_deg"]["rms_unflagged"], st["heading_err_deg"]["rms_unflagged"]
            lines.append(
                f"{(method.upper() + ' w/o flagged'):<16} {triple(st['vel_err_mps'], '_unflagged'):>26} "
                f"{_g(tilt, '.4f'):>11} {_g(head, '.4f'):>11} {triple(st['pos_err_m'], '_unflagged'):>30} "
                f"{'-':>14} {'-':>14} {'runs ' + ','.join(map(str, m['flagged_runs'][:6])):>8}"
                + (" ..." if len(m["flagged_runs"]) > 6 else "")
            )
    if any("smoothed" in m for m in summary["methods"].values()):
        lines += ["", *smoothed_study_lines(summary)]
    return "\n".join(lines)


def mission_rms(rms_s: Any) -> float:
    """The RMS over the whole mission of a per-epoch RMS over the runs (the RMS over every run and
    epoch): ``sqrt(mean_t(rms_t^2))`` over the epochs where it is known; NaN if none.

    Parameters
    ----------
    rms_s : array_like
        (T,) the RMS over the runs at each epoch (a study summary's ``rms``), None or NaN unknown.

    Returns
    -------
    float
        In the series' unit.
    """
    x = np.array([np.nan if v is None else v for v in rms_s], dtype=float)
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2))) if x.size else float("nan")


def smoothed_study_lines(summary: dict[str, Any]) -> list[str]:
    """A study with the smoother: per method a row filtered and a row smoothed, the RMS over the
    runs and the whole mission (:func:`mission_rms`; not at the last epoch, where the smoothed
    estimate is the filtered) of velocity, tilt, heading and position, and NEES/dim of the full
    state and each block over every run and epoch (in brackets the fraction of epochs inside the
    99 % band); a method the smoother does not run (Yoo 2014's) one row saying so.

    Parameters
    ----------
    summary : dict[str, Any]
        A study's summary (tauvcore.eval.study.StudyAccumulator.summary) with ``smoothed``.

    Returns
    -------
    list[str]
        The lines: a title, a head, then the rows.
    """
    blocks = list(BLOCK_DIMS)
    lines = [
        (
            "Filtered and smoothed: RMS over the runs and the whole mission, NEES/dim per block against truth "
            "(in brackets the fraction inside the 99 % band)"
        ),
        f"{'method':<16} "
        + " ".join(f"{h:>10}" for h in ("vel [m/s]", "tilt [deg]", "head [deg]", "pos [m]"))
        + " "
        + " ".join(f"{b:>11}" for b in blocks),
    ]
    for method, m in summary["methods"].items():
        if m.get("smoothed") is None:
            lines.append(f"{method.upper():<16} not smoothed")
            continue
        for label, part in (("filtered", m), ("smoothed", m["smoothed"])):
            r, c = part["rms"], part["consistency"]
            errors = " ".join(
                f"{_g(mission_rms(r[n]), fmt):>10}"
                for n, fmt in (
                    ("vel_err_mps", ".4f"),
                    ("tilt_err_deg", ".4f"),
                    ("heading_err_deg", ".4f"),
                    ("pos_err_m", ".3f"),
                )
            )
            cells = " ".join(f"{_cell(c[b]['per_dim'], c[b]['in_band']):>11}" for b in blocks)
            lines.append(f"{(method.upper() + ' ' + label):<16} {errors} {cells}")
    return lines


def _g(x: Any, fmt: str = ".3g") -> str:
    return "-" if x is None or not np.isfinite(x) else format(x, fmt)
