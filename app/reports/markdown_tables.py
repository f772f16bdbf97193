"""The Results tab's tables, as Markdown a person and a test can read: each method's errors and
consistency (:func:`summary_markdown`), its RMS errors (:func:`rms_markdown`) and what it did with
each aiding source's updates (:func:`counts_markdown`),
runs kept side by side (:func:`compare_markdown`), the settings that differ between them
(:func:`config_diff_markdown`), and the note on methods whose results are identical
(:func:`identical_note`). The numbers are :func:`summary_rows`', one row per method.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, TypedDict

import numpy as np

from app.reports.settings_text import setting_name, setting_value
from tauvcore.engine.results import MethodResult
from tauvcore.eval.consistency import method_consistency
from tauvcore.eval.counts import PING_SOURCES, SOURCE_LABELS, MethodCounts, SourceCounts, method_counts
from tauvcore.eval.envelope import is_decimated, run_curve
from tauvcore.eval.metrics import rms
from tauvcore.eval.study_statistics import FINAL_STATISTICS, final_statistics


class SummaryRow(TypedDict):
    """One method's line of :func:`summary_rows`."""

    method: str  # upper case
    vel_final_mps: float
    vel_rms_mps: float
    att_final_deg: float
    att_rms_deg: float
    tilt_rms_deg: float
    heading_rms_deg: float
    pos_final_m: float
    pos_rms_m: float
    nees_dim: int
    nees_per_dim: float
    nees_in_band: float
    vel_nees_per_dim: float
    dvl_nis_per_dof: float
    runs: int
    diverged_runs: int
    diverged_first_s: float
    p_floor_count: int
    counts: MethodCounts  # per aiding source its updates fused, rejected and unused, and the DVL
    # pings coasted on, summed over the runs (tauvcore.eval.counts)
    dvl_resets: int | None  # velocity resets to the DVL after a lock-out (tauvcore.engine.lockout) over
    # the runs; None: the method has no DVL updates


def summary_rows(results: Mapping[str, MethodResult]) -> list[SummaryRow]:
    """Per method: final and RMS-over-time errors (RMS over runs first when there are several),
    tilt and heading apart; consistency (tauvcore.eval.consistency.method_consistency, each
    method with its own NEES dimensions): the full state's dimension, its mean
    NEES/dim and the fraction of epochs inside its 99 % band, velocity
    NEES/dim, DVL NIS per degree of freedom (NaN without DVL updates); and the filter's health:
    how many runs the divergence monitor flagged, the earliest flag [s] (NaN if none) and the P
    eigenvalue-floor repairs summed over runs.

    A long run reduced to time bins (tauvcore.eval.envelope.DecimatedResult) takes its RMS figures,
    consistency and counts of updates from the summary reduced over every epoch and update as the run
    streamed (``DecimatedResult.summary``: tauvcore.eval.running), not from the bins; its final
    errors are its last bin's, the mission's last epoch."""
    rows: list[SummaryRow] = []
    for method, res in results.items():
        vel, att, pos = run_curve(res.vel_err_mps), run_curve(res.att_err_deg), run_curve(res.pos_err_m)
        summary = res.summary if is_decimated(res) else None
        if summary is not None:
            consistency = summary.consistency
            whole = dict(summary.rms_all_runs)
        else:
            consistency = method_consistency(res)
            whole = {
                "vel_err_mps": float(rms(vel)),
                "att_err_deg": float(rms(att)),
                "tilt_err_deg": float(rms(run_curve(res.tilt_err_deg))),
                "heading_err_deg": float(rms(run_curve(res.heading_err_deg))),
                "pos_err_m": float(rms(pos)),
            }
        dvl_nis = consistency.nis.get("dvl")
        rows.append(
            {
                "method": method.upper(),
                "vel_final_mps": float(vel[-1]),
                "vel_rms_mps": whole["vel_err_mps"],
                "att_final_deg": float(att[-1]),
                "att_rms_deg": whole["att_err_deg"],
                "tilt_rms_deg": whole["tilt_err_deg"],
                "heading_rms_deg": whole["heading_err_deg"],
                "pos_final_m": float(pos[-1]),
                "pos_rms_m": whole["pos_err_m"],
                "nees_dim": consistency.nees["full"].dim,
                "nees_per_dim": consistency.nees["full"].per_dim,
                "nees_in_band": consistency.nees["full"].in_band,
                "vel_nees_per_dim": consistency.nees["vel"].per_dim,
                "dvl_nis_per_dof": dvl_nis.per_dof if dvl_nis is not None else float("nan"),
                "runs": int(res.diverged.size),
                "diverged_runs": int(np.count_nonzero(res.diverged)),
                "diverged_first_s": _first_time(res.diverged_at_s),
                "p_floor_count": int(np.sum(res.p_floor_count)),
                "counts": result_counts(res),
                "dvl_resets": dvl_resets(res),
            }
        )
    return rows


def result_counts(result: MethodResult) -> MethodCounts:
    """Per aiding source the updates of ``result`` fused, rejected and unused, and the DVL pings it
    coasted on, summed over its runs, as the CLI counts them (tauvcore.eval.counts.method_counts,
    app.reports.tables.counts_table). A run reduced to time bins counts every update (its summary,
    tauvcore.eval.running), not the bins'."""
    summary = result.summary if is_decimated(result) else None
    return summary.counts if summary is not None else method_counts(result)


def dvl_resets(result: MethodResult) -> int | None:
    """The velocity resets to the DVL after a lock-out over the runs of ``result``
    (tauvcore.engine.lockout); None for a method without DVL updates. A run reduced to time bins
    counts every update (its summary)."""
    summary = result.summary if is_decimated(result) else None
    dvl = result.updates.get("dvl")
    if summary is not None:
        return summary.dvl_resets if summary.counts.coasted is not None else None
    if dvl is None:
        return None
    return 0 if dvl.reset is None else int(np.sum(dvl.reset))


def _health_cell(row: SummaryRow) -> str:
    """ "ok", or when the divergence monitor flagged runs, when (and how many of the runs); and how
    often the velocity was reset to the DVL after a lock-out."""
    resets = row["dvl_resets"] or 0
    reset = f"{resets} velocity reset{'s' if resets > 1 else ''} after a lock-out" if resets else ""
    if not row["diverged_runs"]:
        return f"ok, {reset}" if reset else "ok"
    at = f"diverged at {row['diverged_first_s']:.1f} s"
    health = at if row["runs"] == 1 else f"{row['diverged_runs']} of {row['runs']} runs, first {at}"
    return f"{health}; {reset}" if reset else health


def _fixed(x: float, decimals: int) -> str:
    """``x`` with ``decimals`` decimals, "-" if it is not finite."""
    return f"{x:.{decimals}f}" if np.isfinite(x) else "-"


def _ratio(x: float) -> str:
    """A NEES or NIS ratio (1 = consistent, up to thousands): two decimals near 1, "-" if not finite."""
    if not np.isfinite(x):
        return "-"
    if x >= 100.0:
        return f"{x:.0f}"
    return f"{x:.2f}" if x >= 0.1 else f"{x:.2g}"


def _in_band_cell(per_dim: float, in_band: float) -> str:
    if not np.isfinite(per_dim):
        return "-"
    return _ratio(per_dim) + (f" ({in_band:.0%})".replace("%", " %") if np.isfinite(in_band) else "")


ERROR_COLUMNS = (
    "method",
    "vel final [m/s]",
    "vel RMS [m/s]",
    "att final [deg]",
    "pos final [m]",
    "tilt RMS [deg]",
    "heading RMS [deg]",
)
CONSISTENCY_COLUMNS = (
    "method",
    "states",
    "NEES/dim (in 99 % band)",
    "vel NEES/dim",
    "DVL NIS/dof",
    "monitor",
)
"""The results' two tables (a "P floors" column ends the second when some method needed a repair):
one table of eleven columns is wider than the dashboard's panel, which cut off its right end."""
CONSISTENCY_HEADING = "**Consistency** (1 = the method knows its error; above 1 it is over-confident)"
RMS_COLUMNS = (
    "method",
    "vel RMS [m/s]",
    "att RMS [deg]",
    "tilt RMS [deg]",
    "heading RMS [deg]",
    "pos RMS [m]",
)
RMS_HEADING = "**RMS over time** (over the runs and the whole mission)"
"""The results' third table: every RMS figure the CLI prints; :data:`COUNTS_HEADING`'s below it."""
COUNTS_HEADING = (
    "**Updates per source** (fused / rejected / unused, summed over the runs; rejected: a measurement "
    "the filter took none of; unused: no measurement of that source for the method there; coasted: "
    "DVL pings on which no velocity was fused: no bottom-track, water-track or RPM)"
)
"""The heading of :func:`counts_markdown`: the DVL's bottom-track, its water-track and the RPM's
velocity each a column of its own (tauvcore.eval.counts)."""


def _table(columns: tuple[str, ...], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)] + [
        "| " + " | ".join(cells) + " |" for cells in rows
    ]


def summary_markdown(results: Mapping[str, MethodResult]) -> str:
    """The results as two Markdown tables (the dashboard shows them as text a person and a test
    can read): errors, then consistency below the line CONSISTENCY_HEADING.

    Errors: final and RMS velocity, the attitude norm, position, and tilt and heading RMS apart.
    Consistency: the number of error states (the full NEES's dimension: 20, Yoo 2014's 12), the
    NEES/dim of the full state with the fraction of epochs inside its two-sided 99 %
    band, velocity NEES/dim and DVL NIS per degree of freedom (1 = the method knows its error; "-"
    where there is nothing to measure, as for DVL NIS without DVL updates, or a value is NaN).
    The "monitor" column is the divergence monitor's verdict (tauvcore.engine: state or P
    not finite, an estimated sensor error far beyond its prior, innovations inconsistent, or the
    gate locked out). It sees only what the measurements reveal: "ok" is not a proof of
    consistency (VB at n_f = 2 on beams 1-2 was "ok" with a velocity error of 50 sigma); the
    NEES columns beside it are. A "P floors" column (repairs of P summed over runs) appears
    only when some method needed one. The RMS figures and the counts of updates are
    :func:`rms_markdown`.
    """
    rows = summary_rows(results)
    floors = any(r["p_floor_count"] for r in rows)
    errors = [
        [
            str(r["method"]),
            _fixed(r["vel_final_mps"], 4),
            _fixed(r["vel_rms_mps"], 4),
            _fixed(r["att_final_deg"], 3),
            _fixed(r["pos_final_m"], 2),
            _fixed(r["tilt_rms_deg"], 3),
            _fixed(r["heading_rms_deg"], 3),
        ]
        for r in rows
    ]
    consistency = [
        [
            str(r["method"]),
            str(r["nees_dim"]),
            _in_band_cell(r["nees_per_dim"], r["nees_in_band"]),
            _ratio(r["vel_nees_per_dim"]),
            _ratio(r["dvl_nis_per_dof"]),
            _health_cell(r),
        ]
        + ([str(r["p_floor_count"])] if floors else [])
        for r in rows
    ]
    columns = CONSISTENCY_COLUMNS + (("P floors",) if floors else ())
    lines = _table(ERROR_COLUMNS, errors) + ["", CONSISTENCY_HEADING, ""] + _table(columns, consistency)
    spread = runs_markdown(results)
    return "\n".join(lines + (["", spread] if spread else []))


RUNS_COLUMNS = (
    "method",
    "vel final [m/s]: RMS / median / p95",
    "pos final [m]: RMS / median / p95",
    "runs flagged",
    "without them: vel / pos RMS",
)


def runs_markdown(results: Mapping[str, MethodResult]) -> str:
    """For a Monte Carlo (more than one run), the final errors over the runs: RMS, median and 95th
    percentile (tauvcore.eval.study_statistics.final_statistics), how many runs the divergence monitor
    flagged, and the RMS without them, so that one locked-out run cannot hide behind the RMS;
    "" for a single run."""
    if not results or all(r.diverged.size <= 1 for r in results.values()):
        return ""
    rows = []
    for method, res in results.items():
        flagged = np.asarray(res.diverged, dtype=bool)
        vel = final_statistics(res.vel_err_mps[-1], flagged)
        pos = final_statistics(res.pos_err_m[-1], flagged)

        def triple(st: dict[str, float | int], decimals: int) -> str:
            return " / ".join(_fixed(float(st[k]), decimals) for k in FINAL_STATISTICS)

        rows.append(
            [
                method.upper(),
                triple(vel, 4),
                triple(pos, 2),
                f"{int(flagged.sum())} of {flagged.size}",
                f"{_fixed(float(vel['rms_unflagged']), 4)} / {_fixed(float(pos['rms_unflagged']), 2)}"
                if flagged.any()
                else "-",
            ]
        )
    runs = max(r.diverged.size for r in results.values())
    heading = (
        f"**Over the {runs} runs** (final errors; the divergence monitor's flagged runs, and the RMS "
        "without them)"
    )
    return "\n".join([heading, "", *_table(RUNS_COLUMNS, rows)])


def rms_markdown(results: Mapping[str, MethodResult]) -> str:
    """The Results tab's third table, below RMS_HEADING: every RMS over time the CLI prints
    (velocity, attitude norm, tilt, heading, position); then :func:`counts_markdown`."""
    rows = [[str(r["method"]), *_rms_cells(r)] for r in summary_rows(results)]
    return "\n".join([RMS_HEADING, ""] + _table(RMS_COLUMNS, rows) + ["", counts_markdown(results)])


def _rms_cells(row: SummaryRow) -> list[str]:
    """The RMS errors of ``row`` as :data:`RMS_COLUMNS` shows them: velocity, attitude norm, tilt,
    heading, position."""
    return [
        _fixed(row["vel_rms_mps"], 4),
        _fixed(row["att_rms_deg"], 3),
        _fixed(row["tilt_rms_deg"], 3),
        _fixed(row["heading_rms_deg"], 3),
        _fixed(row["pos_rms_m"], 2),
    ]


def _counts_cell(c: SourceCounts) -> str:
    return f"{c.fused} / {c.rejected} / {c.unused}"


def counts_markdown(results: Mapping[str, MethodResult]) -> str:
    """Below COUNTS_HEADING, per method each aiding source's updates "fused / rejected / unused"
    and the DVL pings it coasted on, "N of P" (:func:`result_counts`; "-" for a source the method
    does not take, or without DVL pings). A column per source some method has a record of: the
    DVL's bottom-track, its water-track and the RPM's velocity apart, then the others by name.

    Parameters
    ----------
    results : Mapping[str, MethodResult]
        Method name -> its results.

    Returns
    -------
    str
        The heading and the Markdown table; the heading and one sentence when no method took a
        source.
    """
    counts = {m.upper(): result_counts(r) for m, r in results.items()}
    order = list(dict.fromkeys(src for c in counts.values() for src in c.sources))
    sources = [*(x for x in PING_SOURCES if x in order), *(x for x in order if x not in PING_SOURCES)]
    if not sources:
        return f"{COUNTS_HEADING}\n\nNo method took an aiding source."
    rows = [
        [
            method,
            *(_counts_cell(c.sources[x]) if x in c.sources else "-" for x in sources),
            "-" if c.coasted is None else f"{c.coasted} of {c.pings}",
        ]
        for method, c in counts.items()
    ]
    columns = ("method", *(SOURCE_LABELS.get(x, x) for x in sources), "coasted")
    return "\n".join([COUNTS_HEADING, ""] + _table(columns, rows))


SMOOTHED_COLUMNS = (
    "method",
    "vel RMS [m/s]",
    "tilt RMS [deg]",
    "heading RMS [deg]",
    "pos RMS [m]",
    "NEES/dim (in 99 % band)",
    "vel NEES/dim",
)
SMOOTHED_HEADING = (
    "**Smoothed** (the fixed-interval smoother over the whole run; each cell: filtered / smoothed, "
    "the NEES against the same truth)"
)


def smoothed_markdown(results: Mapping[str, MethodResult]) -> str:
    """The smoother's RMS errors and consistency beside the filter's, below SMOOTHED_HEADING: per
    method with smoothed results (``MethodResult.smoothed``), each cell "filtered / smoothed"
    (:func:`summary_rows` of both; a run in bins from its summaries of every epoch); "" when no
    method has them.

    Parameters
    ----------
    results : Mapping[str, MethodResult]
        Method name -> its results.

    Returns
    -------
    str
        The Markdown table, or "".
    """
    pairs = {m: (r, r.smoothed) for m, r in results.items() if r.smoothed is not None and len(r.smoothed.t_s)}
    if not pairs:
        return ""
    filtered = summary_rows({m: r for m, (r, _) in pairs.items()})
    smoothed = summary_rows({m: sm for m, (_, sm) in pairs.items()})
    rows = []
    for f, sm in zip(filtered, smoothed):
        rows.append(
            [
                str(f["method"]),
                f"{_fixed(f['vel_rms_mps'], 4)} / {_fixed(sm['vel_rms_mps'], 4)}",
                f"{_fixed(f['tilt_rms_deg'], 3)} / {_fixed(sm['tilt_rms_deg'], 3)}",
                f"{_fixed(f['heading_rms_deg'], 3)} / {_fixed(sm['heading_rms_deg'], 3)}",
                f"{_fixed(f['pos_rms_m'], 2)} / {_fixed(sm['pos_rms_m'], 2)}",
                " / ".join(_in_band_cell(r["nees_per_dim"], r["nees_in_band"]) for r in (f, sm)),
                f"{_ratio(f['vel_nees_per_dim'])} / {_ratio(sm['vel_nees_per_dim'])}",
            ]
        )
    return "\n".join([SMOOTHED_HEADING, ""] + _table(SMOOTHED_COLUMNS, rows))


def identical_methods(results: Mapping[str, MethodResult]) -> dict[str, str]:
    """Methods whose results equal an earlier method's, each mapped to that method (the first
    in ``results``' order): every error series, its sigma and NEES equal element for element (NaN
    equal to NaN). ELC, NSV, VB, ... with all four beams returning are LC: the same numbers."""
    fields = ("vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "pos_sigma_m", "nees")
    same: dict[str, str] = {}
    seen: list[str] = []
    for method, res in results.items():
        for other in seen:
            ref = results[other]
            if ref.t_s.shape == res.t_s.shape and all(
                getattr(ref, f).shape == getattr(res, f).shape
                and np.array_equal(getattr(ref, f), getattr(res, f), equal_nan=True)
                for f in fields
            ):
                same[method] = other
                break
        else:
            seen.append(method)
    return same


PARTIAL_BEAM_METHODS = frozenset({"VB", "NSV", "PLCF", "VHV", "ELC"})


def _identical_reason(ref: str, names: list[str]) -> str:
    """Why ``names`` give exactly ``ref``'s results, where the cause is known ("" otherwise)."""
    if ref == "INS":
        if names == ["LC"]:
            return "LC coasts: fewer than three beams give it no velocity, so it fuses nothing"
        return "nothing they fuse reached the filter: with fewer than three beams LC coasts"
    if ref == "LC" and set(names) <= PARTIAL_BEAM_METHODS:
        return "with 3-4 beams returning, the partial-beam methods fuse as LC"
    if names == ["ELC"] and ref in PARTIAL_BEAM_METHODS:
        return f"the ELC selector took {ref}'s axes on every ping"
    return ""


def identical_note(same: Mapping[str, str]) -> str:
    """One sentence per group of identical methods (:func:`identical_methods`), each with its
    reason where it is known (:func:`_identical_reason`), "" if none."""
    groups: dict[str, list[str]] = {}
    for method, ref in same.items():
        groups.setdefault(ref.upper(), []).append(method.upper())
    parts = []
    for ref, names in groups.items():
        reason = _identical_reason(ref, names)
        parts.append(
            f"{' and '.join(names)} {'give' if len(names) > 1 else 'gives'} exactly the results of {ref}"
            + (f" ({reason})" if reason else "")
        )
    if not parts:
        return ""
    return (
        "**Identical methods:** "
        + "; ".join(parts)
        + ". Their curves lie on one another: the one drawn last "
        "hides the others."
    )


COMPARE_COLUMNS = (
    "method",
    "run",
    "vel RMS [m/s]",
    "att RMS [deg]",
    "tilt RMS [deg]",
    "heading RMS [deg]",
    "pos RMS [m]",
    "pos final [m]",
    "NEES/dim",
)


def compare_markdown(runs: Sequence[tuple[str, Mapping[str, MethodResult]]]) -> str:
    """The runs' results side by side: one Markdown table, a line per method and run, the runs
    of one method together (methods in order of first appearance; :func:`summary_rows`' numbers)."""
    rows: dict[str, list[list[str]]] = {}
    for label, results in runs:
        for r in summary_rows(results):
            rows.setdefault(str(r["method"]), []).append(
                [
                    str(r["method"]),
                    label,
                    *_rms_cells(r),
                    _fixed(r["pos_final_m"], 2),
                    _ratio(r["nees_per_dim"]),
                ]
            )
    return "\n".join(_table(COMPARE_COLUMNS, [line for lines in rows.values() for line in lines]))


def config_differences(configs: Sequence[Mapping[str, Any]]) -> dict[str, list[Any]]:
    """The settings (keys of :func:`~app.reports.settings_text.flat_config`) whose values are not all equal across
    ``configs``, each with its value in every config (None where one lacks it), in key order."""
    keys = sorted(set().union(*configs)) if configs else []
    out = {}
    for key in keys:
        values = [c.get(key) for c in configs]
        if any(v != values[0] for v in values[1:]):
            out[key] = values
    return out


def _cell(key: str, value: Any) -> str:
    """Setting ``key``'s ``value`` in plain words (app.reports.settings_text.setting_value), for a table cell."""
    return setting_value(key, value).replace("|", "/")


def config_diff_markdown(labels: Sequence[str], configs: Sequence[Mapping[str, Any]]) -> str:
    """A Markdown table of the settings that differ between the runs (:func:`config_differences`),
    one column per run; a sentence when they all ran the same configuration."""
    diff = config_differences(configs)
    if not diff:
        return "**Configuration:** the same for " + ", ".join(labels) + "."
    return "\n".join(
        ["**Configuration differences**", ""]
        + _table(
            ("setting", *labels),
            [[setting_name(key), *(_cell(key, v) for v in values)] for key, values in diff.items()],
        )
    )


def _first_time(times_s: np.ndarray) -> float:
    """The earliest of ``times_s`` [s] that is a time (NaN: a run flagged without one); NaN if none."""
    known = times_s[np.isfinite(times_s)]
    return float(known.min()) if known.size else float("nan")
