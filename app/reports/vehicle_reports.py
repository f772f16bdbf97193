"""The reports of a calibration and a tuning as ``tauv calibrate`` and ``tauv tune`` print them and
the dashboard's "Your vehicle" folder shows them (app.dashboard.vehicle_tasks), and the configuration
sections they found."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from app.reports.tables import consistency_table
from tauvcore.config import Config

if TYPE_CHECKING:
    from tauvcore.eval.calibration import Calibration, Estimate


def calibration_sections(result: Calibration) -> dict[str, dict[str, Any]]:
    """The ``[calibration]`` section of ``result`` (section -> key -> value, plain TOML values)."""
    c = result.config
    return {
        "calibration": {
            "dvl_misalignment_deg": [float(v) for v in c.dvl_misalignment_deg],
            "dvl_scale_factor_pct": float(c.dvl_scale_factor_pct),
            "imu_boresight_deg": [float(v) for v in c.imu_boresight_deg],
        }
    }


def number_to_sigma(value: float, sigma: float) -> str:
    """``value`` to the digits its sigma warrants (two significant digits of the sigma)."""
    if not np.isfinite(sigma) or sigma <= 0.0:
        return f"{value:.4g}"
    digits = max(0, 1 - int(np.floor(np.log10(sigma))))
    return f"{value:.{min(digits, 6)}f}"


def _own_estimate(est: Estimate | None, width: int) -> str:
    """A log's own estimate ``est`` as "value ± 1-sigma" cells of ``width`` characters, "" for
    none (too few pings or intervals in the log)."""
    if est is None:
        return ""
    return "".join(
        f"{number_to_sigma(v, s) + ' ± ' + f'{s:.2g}':>{width}}"
        for v, s in zip(est.value, est.sigma, strict=True)
    )


def calibration_table(result: Calibration) -> str:
    """The estimates of all logs (value, 1-sigma and the sigma of each of its parts), then per log
    its DVL and boresight residuals before and after, and its own estimates with their 1-sigma."""
    lines = [
        (
            f"calibration from {len(result.logs)} log{'s' if len(result.logs) != 1 else ''}: "
            f"{sum(f.pings for f in result.logs)} DVL pings, {sum(f.intervals for f in result.logs)} reference intervals"
        ),
        "",
    ]
    part_names = [*result.dvl.parts, *(p for p in result.boresight.parts if p not in result.dvl.parts)]
    head = f"{'quantity':<34}{'value':>10}{'1-sigma':>10}" + "".join(f"{'σ ' + p:>16}" for p in part_names)
    lines += [head, "-" * len(head)]
    for est in (result.dvl, result.boresight):
        for i, (name, unit) in enumerate(zip(est.names, est.units, strict=True)):
            sigma = est.sigma[i]
            row = f"{name + ' [' + unit + ']':<34}{number_to_sigma(est.value[i], sigma):>10}{sigma:>10.2g}"
            for p in part_names:
                row += f"{est.part_sigma(p)[i]:>16.2g}" if p in est.parts else f"{'':>16}"
            lines.append(row)
    lines += [
        "",
        (
            "σ noise: the residuals' (their correlation over pings or intervals included); σ beam biases: what not "
            "knowing the DVL beams' biases adds (confounded with the misalignment at constant speed); σ boresight, "
            "σ IMU biases: what their uncertainty adds (docs/calibration.md)"
        ),
        "",
    ]
    head = (
        f"{'log':<24}{'pings':>6}{'out':>5}{'DVL rms before':>16}{'after':>8}{'tau':>6}   "
        f"{'roll':>16}{'pitch':>16}{'yaw':>16}{'scale factor':>16}"
    )
    lines += [
        (
            "DVL per log: residuals [m/s] with no calibration and with the one above (less the beam biases that fit "
            "them best); the log's own estimate [deg, %]"
        ),
        head,
    ]
    for f in result.logs:
        own = _own_estimate(f.dvl, 16)
        if f.pings == 0:
            lines.append(f"{_short(f.name):<24}{'no DVL pings':>20}")
            continue
        lines.append(
            f"{_short(f.name):<24}{f.pings:>6}{f.dvl_outliers:>5}{f.dvl_rms_before_mps:>16.4f}"
            f"{f.dvl_rms_after_mps:>8.4f}{f.dvl_tau:>6.2f}   {own}"
        )
    head = (
        f"{'log':<24}{'intervals':>10}{'rate rms before':>17}{'after':>9}{'force rms before':>18}{'after':>9}   "
        f"{'roll':>18}{'pitch':>18}{'yaw':>18}"
    )
    lines += [
        "",
        (
            "boresight per log: residuals per axis (rate [deg/s], specific force [m/s^2]) with no calibration and with "
            "the one above; the log's own estimate [deg]"
        ),
        head,
    ]
    for f in result.logs:
        own = _own_estimate(f.boresight, 18)
        lines.append(
            f"{_short(f.name):<24}{f.intervals:>10}{f.rate_rms_before_dps:>17.4g}{f.rate_rms_after_dps:>9.4g}"
            f"{f.force_rms_before_mps2:>18.4g}{f.force_rms_after_mps2:>9.4g}   {own}"
        )
    return "\n".join(lines)


def _short(name: str, width: int = 23) -> str:
    return name if len(name) <= width else "…" + name[-(width - 1) :]


def report(
    result: Any,
    before: Mapping[str, float],
    tables: Sequence[tuple[Any, Any, Any]],
    still: bool,
    elapsed_s: float,
    dask: bool,
) -> str:
    """The printed report: the parameters before and after with their uncertainty, the
    likelihood, then per log (and for all together) the consistency before and after
    (app.reports.tables.consistency_table: NEES/dim per block against the log's reference, NIS/dof per
    source).

    Parameters
    ----------
    result : tauvcore.eval.tuning.TuningResult
        What the search found.
    before : Mapping[str, float]
        Each parameter's configured value (the first log's), in its key's unit.
    tables : Sequence[tuple[TuningLog, MethodResult, MethodResult]]
        Each log with the method's replay before (as configured) and after (tuned), the gate as
        configured.
    still : bool
        Whether a still stretch gave the IMU's white noise.
    elapsed_s : float
        Wall time of the whole [s].
    dask : bool
        Whether the search ran on Dask.

    Returns
    -------
    str
        The text.
    """
    from tauvcore.eval.running import RunningSummary, summarise
    from tauvcore.eval.tuning import PARAMETERS, UNDETERMINED_FACTOR

    method = tables[0][0].method
    state = "stopped" if result.stopped else ("converged" if result.converged else result.message)
    lines = [
        f"tuned {method.upper()} on {len(tables)} log{'s' if len(tables) > 1 else ''}: "
        f"{result.evaluations} evaluations ({state}), {elapsed_s:.1f} s wall" + (", on Dask" if dask else ""),
        (
            f"negative log-likelihood of the innovations (gate open): {result.nll_start:.2f} at the start, "
            f"{result.nll_tuned:.2f} tuned"
        ),
        "",
        (
            f"Parameters (1-sigma: the factor the likelihood's curvature allows; beyond x/ {UNDETERMINED_FACTOR:g} "
            "the logs do not determine it and the configured value holds it, a factor of 10 at 1 sigma)"
        ),
    ]
    rows = [("parameter", "unit", "before", "start", "after", "1-sigma", "")]
    notes = []
    for name in result.parameters:
        p = PARAMETERS[name]
        s = result.sigma_ln[name]
        sigma = f"x/ {math.exp(s):.3g}" if np.isfinite(s) and s < 50 else ("-" if np.isnan(s) else "inf")
        note = (
            "at a bound" if result.at_bound[name] else ("" if result.determined(name) else "not determined")
        )
        start = f"{result.start[name]:.4g}"
        if result.start_from[name] != "configuration":
            start += "*"
            notes.append(f"* {name}: {result.start_from[name]} (x/ {math.exp(result.priors[name][1]):.3g})")
        rows.append((name, p.unit, f"{before[name]:.4g}", start, f"{result.tuned[name]:.4g}", sigma, note))
    lines += _columns(rows) + notes
    if not result.minimum:
        lines.append(
            "the likelihood curves down along some direction there: not a minimum, the search stopped short "
            "(more --max-evaluations, or fewer --params)"
        )
    if not still and {"gyro_noise", "accel_noise"} & set(result.parameters):
        lines.append(
            "no still stretch (IMU constant for 60 s) in the logs: the IMU's white noise from the innovations alone"
        )
    sources = None
    together_before, together_after = RunningSummary(), RunningSummary()
    for case, before_result, after_result in tables:
        sources = _sources(case.config, before_result, after_result)
        summaries = summarise({"before": before_result, "after": after_result})
        lines += ["", f"{case.name}, {case.log.duration_s:g} s:", consistency_table(summaries, sources)]
        together_before.add({"before": before_result})
        together_after.add({"after": after_result})
    if len(tables) > 1 and sources is not None:
        summaries = {**together_before.summaries(), **together_after.summaries()}
        lines += ["", f"all {len(tables)} logs together:", consistency_table(summaries, sources)]
    return "\n".join(lines)


def _sources(config: Config, *results: Any) -> tuple[str, ...]:
    """The aiding sources of the consistency table: those configured, and the DVL's water-track
    when recorded."""
    recorded = {s for r in results for s in r.updates}
    return (*config.run.aiding, *(s for s in ("water",) if s in recorded))


def _columns(rows: Sequence[Sequence[str]]) -> list[str]:
    widths = [max(len(r[k]) for r in rows) for k in range(len(rows[0]))]
    return [
        " ".join(
            [r[0].ljust(widths[0]), r[1].ljust(widths[1])]
            + [c.rjust(w) for c, w in zip(r[2:-1], widths[2:-1])]
            + [r[-1]]
        ).rstrip()
        for r in rows
    ]
