"""Results as strict JSON: the document ``tauv run --json`` and ``tauv replay --json`` write and
the dashboard's JSON download is (app.dashboard.export), per method the per-epoch series of one run, its
divergence verdict, its NIS per aiding source, its consistency summary and the counts of its
updates; non-finite numbers are null."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from tauvcore.config import Config, to_dict
from tauvcore.engine.results import BLOCK_DIMS
from tauvcore.eval.consistency import MethodConsistency, method_consistency, nees_series
from tauvcore.eval.counts import method_counts
from tauvcore.eval.envelope import is_decimated

if TYPE_CHECKING:
    from tauvcore.engine.results import MethodResult, UpdateRecord


def _finite(values: np.ndarray) -> list[float | None]:
    """Plain list with every non-finite number (NaN, +-inf) as None (JSON null)."""
    values = np.asarray(values, dtype=float)
    plain = values.astype(object)
    plain[~np.isfinite(values)] = None
    return plain.tolist()


def _number(value: float) -> float | None:
    """A float for JSON, None (null) if not finite."""
    value = float(value)
    return value if np.isfinite(value) else None


def result_to_json(
    result: MethodResult,
    run_index: int = 0,
    origin_rad: tuple[float, float] | None = None,
    smoothed: bool = False,
) -> dict[str, Any]:
    """Per-epoch series of one run, its divergence verdict and the method's consistency, as in the
    CLI contract (strict JSON: non-finite numbers are null).

    The estimate itself: ``est_north_m``, ``est_east_m``, ``est_down_m`` from the sea-surface point
    above the start (on WGS-84 in that point's tangent frame), with ``origin_rad`` (its latitude,
    longitude) also ``est_lat_deg``, ``est_lon_deg``, ``est_depth_m``; ``est_vel_north_mps``,
    ``est_vel_east_mps``, ``est_vel_down_mps``; ``est_roll_deg``, ``est_pitch_deg``, ``est_yaw_deg``.

    Series (length of ``t``, run ``run_index``): errors and the filter's own 1-sigma of velocity,
    attitude (the norm, and apart: ``tilt`` = roll/pitch levelling, ``heading``) and position;
    ``nees`` (the full state: 20 states, 12 for Yoo 2014's methods) and ``nees_<block>`` for the
    blocks pos, vel, tilt, heading, sensor, and those the sources' states add (``nees_current``
    with the DVL's current states: ``MethodResult.block_dims``).

    ``nis``: per aiding source the method used, ``{"t", "nis", "dof"}`` at every update time of
    that source (the length of its own ``t``, not of the output epochs). ``nis`` is null where the
    source produced no measurement (outage, no beam, nothing active: ``dof`` 0) or NIS is not
    finite, so the non-null entries are exactly those that ``consistency.nis.<source>.count``
    counts; NIS is taken before the gate, so a rejected update keeps its value.

    ``counts``: per aiding source the updates fused, rejected and unused over all runs of
    ``result``, and the DVL's pings and those coasted on (:func:`tauvcore.eval.counts.method_counts`,
    the DVL's bottom-track, water-track and the RPM's velocity apart): ``{"sources": {source:
    {"fused", "rejected", "unused"}}, "pings", "coasted"}`` (``coasted`` null without DVL pings).

    ``consistency``: :func:`tauvcore.eval.consistency.method_consistency` over all runs of
    ``result`` (the CLI runs one): ``{"nees": {block: {"dim", "per_dim", "in_band",
    "band_per_dim"}}, "nis": {source: {"per_dof", "in_band", "count"}}}``; NEES/dim and NIS/dof
    are 1 for a consistent filter, ``in_band`` is the fraction inside the two-sided 99 % band.

    A run reduced to time bins (tauvcore.eval.envelope.DecimatedResult: the dashboard's long
    missions) gives its series and NIS at each bin's last epoch and update, its consistency from
    every epoch (its summary), and adds ``"bin_s"`` and ``"epochs_per_bin"``.

    ``smoothed`` (after ``nis``): the fixed-interval smoother's results (``result.smoothed``), by
    :func:`smoothed_to_json`; present whenever ``result`` has them, and null for a method without
    them when ``smoothed`` is True (a run that smoothed).
    """
    i = run_index
    binned = result if is_decimated(result) else None
    summary = binned.summary if binned is not None else None
    consistency = summary.consistency if summary is not None else method_consistency(result)
    counts = summary.counts if summary is not None else method_counts(result)
    diverged_at = float(result.diverged_at_s[i])
    by_smoother = getattr(result, "smoothed", None)
    smoothed_item: dict[str, Any] = (
        {"smoothed": smoothed_to_json(by_smoother, i, origin_rad)}
        if by_smoother is not None
        else {"smoothed": None}
        if smoothed
        else {}
    )
    return {
        **{name: _finite(values) for name, values in result_series(result, i, origin_rad).items()},
        "nis": {source: _nis_to_json(record, i) for source, record in result.updates.items()},
        **smoothed_item,
        "consistency": consistency_to_json(consistency),
        "counts": counts.to_json(),
        "diverged": bool(result.diverged[i]),
        "diverged_at_s": diverged_at if np.isfinite(diverged_at) else None,
        "p_floor_count": int(result.p_floor_count[i]),
        **(
            {"bin_s": float(binned.bin_s), "epochs_per_bin": int(binned.epochs_per_bin)}
            if binned is not None
            else {}
        ),
    }


def smoothed_to_json(
    smoothed: MethodResult, run_index: int = 0, origin_rad: tuple[float, float] | None = None
) -> dict[str, Any]:
    """A method's smoothed results (``MethodResult.smoothed``) as :func:`result_to_json`'s
    ``smoothed``: the same series over the smoothed estimate (:func:`result_series`), its NEES
    consistency against truth (no NIS: the smoother makes no updates; a run in bins: the
    summary of every epoch) and ``smoother_cuts``.

    Parameters
    ----------
    smoothed : MethodResult
        The smoothed results (tauvcore.engine.mission.run with ``smooth``).
    run_index : int
        The run written.
    origin_rad : tuple of float or None
        Latitude and longitude [rad] of the estimate's origin, for ``est_lat_deg`` etc.

    Returns
    -------
    dict[str, Any]
        Strict-JSON data: the series, ``consistency`` and ``smoother_cuts`` (steps where the
        backward pass started afresh).
    """
    i = run_index
    summary = smoothed.summary if is_decimated(smoothed) else None  # a run in bins: of every epoch
    consistency = summary.consistency if summary is not None else method_consistency(smoothed)
    cuts = getattr(smoothed, "smoother_cuts", None)
    return {
        **{name: _finite(values) for name, values in result_series(smoothed, i, origin_rad).items()},
        "consistency": consistency_to_json(consistency),
        "smoother_cuts": int(cuts[i]) if cuts is not None else 0,
    }


def result_series(
    result: MethodResult, run_index: int = 0, origin_rad: tuple[float, float] | None = None
) -> dict[str, np.ndarray]:
    """The per-epoch series of :func:`result_to_json`, in its order, as float arrays (T,) (the
    JSON writes their non-finite values as null); of any stretch of output epochs, so that a
    long run's document can be written chunk by chunk (app.commands.json_stream)."""
    i = run_index
    estimate: dict[str, np.ndarray] = {}
    pos = result.est_pos_n[:, i]
    for k, axis in enumerate(("north", "east", "down")):
        estimate[f"est_{axis}_m"] = pos[:, k]
    if origin_rad is not None and len(pos):
        from tauvcore.geo.earth import geodetic_from_ned

        lat, lon, h = geodetic_from_ned(pos, (origin_rad[0], origin_rad[1], 0.0))
        estimate.update(est_lat_deg=np.degrees(lat), est_lon_deg=np.degrees(lon), est_depth_m=-h)
    if result.est_vel_n is not None:
        for k, axis in enumerate(("north", "east", "down")):
            estimate[f"est_vel_{axis}_mps"] = result.est_vel_n[:, i, k]
    if result.est_euler_rad is not None:
        for k, angle in enumerate(("roll", "pitch", "yaw")):
            estimate[f"est_{angle}_deg"] = np.degrees(result.est_euler_rad[:, i, k])
    return {
        "t": result.t_s,
        **estimate,
        "vel_err_mps": result.vel_err_mps[:, i],
        "att_err_deg": result.att_err_deg[:, i],
        "tilt_err_deg": result.tilt_err_deg[:, i],
        "heading_err_deg": result.heading_err_deg[:, i],
        "pos_err_m": result.pos_err_m[:, i],
        "vel_sigma_mps": result.vel_sigma_mps[:, i],
        "att_sigma_deg": result.att_sigma_deg[:, i],
        "tilt_sigma_deg": result.tilt_sigma_deg[:, i],
        "heading_sigma_deg": result.heading_sigma_deg[:, i],
        "pos_sigma_m": result.pos_sigma_m[:, i],
        "nees": result.nees[:, i],
        **{
            f"nees_{block}": nees_series(result, block)[:, i]
            for block in (result.block_dims or BLOCK_DIMS)
            if block != "full"
        },
    }


def nis_series(record: UpdateRecord, run_index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One source's update times [s], NIS (NaN where it did not measure) and dof of run
    ``run_index``, as :func:`result_to_json`'s ``nis`` holds them."""
    nis, dof = record.nis[:, run_index], record.nis_dof[:, run_index]
    used = record.valid[:, run_index] & (dof > 0)
    return record.t_s, np.where(used, nis, np.nan), dof


def _nis_to_json(record: UpdateRecord, run_index: int) -> dict[str, list]:
    t, nis, dof = nis_series(record, run_index)
    return {"t": _finite(t), "nis": _finite(nis), "dof": [int(d) for d in dof]}


def consistency_to_json(c: MethodConsistency) -> dict[str, Any]:
    """:class:`~tauvcore.eval.consistency.MethodConsistency` as strict-JSON data (NaN -> null)."""
    return {
        "nees": {
            block: {
                "dim": s.dim,
                "per_dim": _number(s.per_dim),
                "in_band": _number(s.in_band),
                "band_per_dim": [_number(b) for b in s.band_per_dim],
            }
            for block, s in c.nees.items()
        },
        "nis": {
            source: {"per_dof": _number(s.per_dof), "in_band": _number(s.in_band), "count": s.count}
            for source, s in c.nis.items()
        },
    }


def config_to_json(config: Config) -> dict[str, Any]:
    """The configuration as ``tauv config`` prints it, plus the value NSV's epsilon resolved to
    (``partial.nsv_epsilon_value_m2_per_s2``: derived, not a key a --config file may set)."""
    data = to_dict(config)
    data["partial"]["nsv_epsilon_value_m2_per_s2"] = config.nsv_epsilon_value_m2_per_s2()
    return data


def run_payload(
    config: Config, results: dict[str, MethodResult], log: str | dict[str, Any] | None = None
) -> dict[str, Any]:
    """The document ``tauv run --json`` writes (with ``log``, ``tauv replay --json``; the
    dashboard's JSON download, app.dashboard.export, is the same): ``{"config": ..., ["log": ...,]
    "results": {method: ...}}``: the configuration by :func:`config_to_json` and each method's run
    0 by :func:`result_to_json`, the estimate's origin the configured latitude and longitude. A
    replay's ``log`` holds its directory, its own configuration file, what configured the run,
    where the filters started and the reader's notes. Results that carry the smoother's
    (``MethodResult.smoothed``) get ``smoothed`` per method (null for a method without)."""
    origin = (config.earth.latitude_rad, config.earth.longitude_rad)
    payload: dict[str, Any] = {"config": config_to_json(config)}
    if log is not None:
        payload["log"] = log
    smoothed = any(getattr(r, "smoothed", None) is not None for r in results.values())
    payload["results"] = {
        m: result_to_json(r, origin_rad=origin, smoothed=smoothed) for m, r in results.items()
    }
    return payload
