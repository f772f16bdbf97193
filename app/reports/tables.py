"""The tables ``tauv`` prints: a run's errors and consistency per method, and a study's summary."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from tauvcore.aiding.sources import FUSED
from tauvcore.config import Config
from tauvcore.engine import yoo_sources
from tauvcore.engine.results import BLOCK_DIMS, MethodResult
from tauvcore.eval.counts import PING_SOURCES, SOURCE_LABELS, MethodCounts
from tauvcore.eval.envelope import DecimatedResult
from tauvcore.eval.running import MethodSummary, summarise
from tauvcore.eval.study_statistics import FINAL_STATISTICS
from tauvcore.filter.families import FAMILIES, FIRST, family_of


def summary_table(
    results: Mapping[str, MethodResult | MethodSummary],
    config: Config,
    elapsed_s: float,
    source: str | None = None,
    preamble: Sequence[str] = (),
    smoothed: Mapping[str, MethodSummary] | None = None,
) -> str:
    """The errors of run 0 per method (attitude as the norm and apart: tilt, heading), then
    :func:`counts_table` and :func:`consistency_table`. ``results``: each method's whole results, or its summary reduced
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
            f"{'head RMS':>9} {'pos final':>10} {'pos RMS':>9} {'vel 1-sig':>10}"
        ),
        (
            f"{'':<7} {'[m/s]':>10} {'[m/s]':>9} {'[deg]':>10} {'[deg]':>9} {'[deg]':>9} {'[deg]':>9} {'[m]':>10} "
            f"{'[m]':>9} {'[m/s]':>10}"
        ),
    ]
    for name, s in summaries.items():
        marker = ""
        if s.diverged:
            marker = "  diverged" + (f" at {s.diverged_at_s:g} s" if np.isfinite(s.diverged_at_s) else "")
        if s.reset_times_s:
            when = cut_list([f"{t:g}" for t in s.reset_times_s], RESET_TIMES_SHOWN, " s")
            marker += f"  velocity reset to the DVL after a lock-out at {when}"
        f, r = s.final, s.rms
        lines.append(
            f"{name.upper():<7} {_fixed(f['vel_err_mps'], 10, 4)} {_fixed(r['vel_err_mps'], 9, 4)} "
            f"{_fixed(f['att_err_deg'], 10, 4)} {_fixed(r['att_err_deg'], 9, 4)} "
            f"{_fixed(r['tilt_err_deg'], 9, 4)} {_fixed(r['heading_err_deg'], 9, 4)} "
            f"{_fixed(f['pos_err_m'], 10, 3)} {_fixed(r['pos_err_m'], 9, 3)} "
            f"{_fixed(f['vel_sigma_mps'], 10, 4)}" + marker
        )
    recorded = {src for s in summaries.values() for src in s.consistency.nis}
    extra = [s for s in ("water",) if s in recorded]  # the DVL's water-track, beside its bottom-track
    tables = [counts_table(summaries), consistency_table(summaries, (*config.run.aiding, *extra))]
    if smoothed is not None:
        tables.append(smoothing_table(summaries, smoothed))
    return "\n".join(lines + ["", "\n\n".join(tables)])


RESET_TIMES_SHOWN = 5
"""The lock-out reset times a method's row of :func:`summary_table` names; the rest are counted."""


def cut_list(items: Sequence[str], shown: int, unit: str = "") -> str:
    """The first ``shown`` of ``items`` joined by commas, ``unit`` after them, and how many more
    were left out: ``"10, 20, 30 s ... and 12 more"``.

    Parameters
    ----------
    items : Sequence[str]
        The entries, already formatted.
    shown : int
        How many to name (at least one).
    unit : str
        Appended to the named entries (e.g. ``" s"``).

    Returns
    -------
    str
        The list, "... and N more" when ``items`` has more than ``shown``.
    """
    more = len(items) - shown
    return ", ".join(items[:shown]) + unit + (f" ... and {more} more" if more > 0 else "")


COUNTS_TITLE = (
    "Updates per source, summed over the runs: fused/rejected/unused (rejected: a measurement the filter\n"
    "took none of; unused: none of that source for the method there); coasted: DVL pings on which no\n"
    "velocity was fused (no bottom-track, water-track or RPM)"
)
"""The title of :func:`counts_table` (its lines within 110 columns; tauvcore.eval.counts defines each
count)."""


def counts_table(results: Mapping[str, MethodResult | MethodSummary]) -> str:
    """Per method, each aiding source's updates fused, rejected and unused, and the DVL pings on
    which it coasted (tauvcore.eval.counts: the DVL's bottom-track, its water-track and the RPM's
    velocity counted apart, every other source over its own epochs), summed over the runs.

    Parameters
    ----------
    results : Mapping[str, MethodResult | MethodSummary]
        Each method's results or summary (tauvcore.eval.running).

    Returns
    -------
    str
        :data:`COUNTS_TITLE`, a head naming every source some method has a record of, then a row
        per method ("-" for a source it does not take); "coasted" as "N of P pings" ("-" for a
        method without DVL pings). One line when no method took any source.
    """
    return "\n".join(counts_lines({name: s.counts for name, s in _summaries(results).items()}))


def counts_lines(counts: Mapping[str, MethodCounts]) -> list[str]:
    """:func:`counts_table`'s lines from each method's counts (tauvcore.eval.counts.MethodCounts).

    Parameters
    ----------
    counts : Mapping[str, MethodCounts]
        Method name -> its counts.

    Returns
    -------
    list[str]
        :data:`COUNTS_TITLE`'s lines, the head, a row per method; one line when no method took a
        source.
    """
    order = list(dict.fromkeys(src for c in counts.values() for src in c.sources))
    sources = [*(x for x in PING_SOURCES if x in order), *(x for x in order if x not in PING_SOURCES)]
    if not sources:
        return ["Updates per source: none (no method took an aiding source)"]
    head = ["method", *(SOURCE_LABELS.get(x, x) for x in sources), "coasted"]
    rows = []
    for name, c in counts.items():
        coasted = "-" if c.coasted is None else f"{c.coasted} of {c.pings}"
        rows.append(
            [name.upper(), *(c.sources[x].cell() if x in c.sources else "-" for x in sources), coasted]
        )
    widths = [max(len(row[k]) for row in [head, *rows]) for k in range(len(head))]
    widths[0] = max(widths[0], 7)
    lines = [
        " ".join([cells[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(cells[1:], widths[1:])])
        for cells in [head, *rows]
    ]
    return [*COUNTS_TITLE.splitlines(), *lines]


SMOOTHED_RMS = (("vel_err_mps", "vel RMS", "[m/s]", 4), ("tilt_err_deg", "tilt RMS", "[deg]", 4))
SMOOTHED_RMS += (("heading_err_deg", "head RMS", "[deg]", 4), ("pos_err_m", "pos RMS", "[m]", 3))
"""The RMS of run 0 :func:`smoothing_table` gives filtered and smoothed: series, heading, unit, decimals."""


def _nees_groups(summaries: Mapping[str, MethodSummary]) -> list[tuple[dict[str, int], list[str]]]:
    """The methods of a table of ``summaries`` by the error state of their filter family
    (tauvcore.filter.families: the families on one error state share its NEES blocks), each group
    with its NEES blocks and their dimensions (the error state's, with the blocks their sources add,
    tauvcore.filter.layout.Layout; without the position a family has no state for); a group only
    when it has methods, in the families' order, each in ``summaries``' order."""
    groups = []
    for state in dict.fromkeys(family.error_state for family in FAMILIES.values()):
        names = [name for name in summaries if family_of(name).error_state == state]
        if names:
            family = family_of(names[0])
            dims = dict(family.block_dims)
            for name in names:
                dims.update(summaries[name].block_dims or {})
            if not family.position_state:
                dims.pop("pos")  # its position NEES is NaN throughout
            groups.append((dims, names))
    return groups


def _nees_layout(
    summaries: Mapping[str, MethodSummary],
) -> tuple[list[str], list[tuple[list[str], list[str]]]]:
    """The NEES columns of a table of ``summaries`` (every group's blocks, in order) and per group
    (:func:`_nees_groups`) the unit cells of those columns (``NEES/<dim>``, "" where the group has
    no such block) and its methods."""
    groups = _nees_groups(summaries)
    blocks = list(dict.fromkeys(b for dims, _ in groups for b in dims))
    return blocks, [
        ([f"NEES/{dims[b]}" if b in dims else "" for b in blocks], names) for dims, names in groups
    ]


def _unit_label(units: list[str], several: bool) -> str:
    """The first cell of a group's unit line: its state count when the table has several groups."""
    return units[0].removeprefix("NEES/") + " states" if several and units and units[0] else ""


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
    blocks, groups = _nees_layout(filtered)
    head = ["method", *(h for _, h, _, _ in SMOOTHED_RMS), *blocks]
    plain = ["", *(u for _, _, u, _ in SMOOTHED_RMS)]
    several = len(groups) > 1
    units, rows = [], []
    for nees_units, names in groups:
        unit_row = [_unit_label(nees_units, several), *plain[1:], *nees_units]
        units.append(unit_row)
        if several:
            rows.append(unit_row)
        for name in names:
            summary = filtered[name]
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
    widths = [max(len(row[k]) for row in [head, *units, *full]) for k in range(len(head))]

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
    top = [line(head)] if several else [line(head), line(units[0])]
    return "\n".join([title, *top, *(line(row) for row in rows)])


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
    blocks, groups = _nees_layout(summaries)
    head = ["method", *blocks, *sources]
    several = len(groups) > 1
    units, rows = [], []
    for nees_units, names in groups:
        unit_row = [_unit_label(nees_units, several), *nees_units, *("NIS/dof" for _ in sources)]
        units.append(unit_row)
        if several:
            rows.append(unit_row)
        for name in names:
            c = summaries[name].consistency
            nis = [c.nis.get(s) for s in sources]
            rows.append(
                [
                    name.upper(),
                    *(_cell(c.nees[b].per_dim, c.nees[b].in_band) if b in c.nees else "-" for b in blocks),
                    *(_cell(n.per_dof, n.in_band) if n is not None else "-" for n in nis),
                ]
            )
    widths = [max(len(row[k]) for row in [head, *units, *rows]) for k in range(len(head))]
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
    for family in FAMILIES.values():
        names = [name.upper() for name in summaries if family_of(name) is family]
        if not names or family.error_state == FIRST.error_state:
            continue
        verb = "is" if len(names) == 1 else "are"
        note = f"{' and '.join(names)} {verb} {family.title}, headed with its own dimensions"
        if not family.position_state:
            left_out = [s for s in sources if s in FUSED and not yoo_sources.takes(FUSED[s])]
            note += "; they have no position state" + (
                f"; they do not fuse {', '.join(left_out)} (no position state)" if left_out else ""
            )
        notes.append(note)
    top = [line(head)] if several else [line(head), line(units[0])]
    return "\n".join([title, *top, *(line(row) for row in rows), *notes])


FLAGGED_RUNS_SHOWN = 6
"""The flagged runs a study's "w/o flagged" row of :func:`study_table` names; the rest are counted."""


def study_table(summary: dict[str, Any], trajectory: str, num_runs: int, elapsed_s: float) -> str:
    """The study's final errors per method: RMS, median and 95th percentile over the runs, the
    consistency, the runs the monitor flagged; a method with flagged runs gets a second row, its
    statistics without them (marked "w/o flagged"); then the updates per source over every run
    (:func:`counts_lines`); a study with the smoother then :func:`smoothed_study_lines`."""
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
                f"{'-':>14} {'-':>14} runs {cut_list([str(r) for r in m['flagged_runs']], FLAGGED_RUNS_SHOWN)}"
            )
    counts = {
        method: MethodCounts.from_json(m["counts"])
        for method, m in summary["methods"].items()
        if "counts" in m
    }
    if any(c.sources for c in counts.values()):
        lines += ["", *counts_lines(counts)]
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
