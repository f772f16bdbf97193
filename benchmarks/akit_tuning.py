"""Calibrated and tuned on some real segments, judged on the others: the A-KIT table of docs/tuning.md.

    python benchmarks/akit_tuning.py [--data ../shared/data/akit] [--train 1-6] [--params P,Q,...]
        [--imu PROFILE] [--fragment akit_tuning]

Each segment of the A-KIT dataset (Snapir AUV; its NOTES.md) is converted to a log
(scripts/akit_to_log.py: re-timed, Y axis flipped, clock offsets estimated, the DVL's lever arm
and the reference's own 1-sigma in the log's log.toml). Then, as an engineer with these logs
would:

1. **before**: every segment replayed as ``tauv replay`` does by default (Table 2's tuning, the
   log's own file), LC with four beams and TC;
2. **calibrate** on the training segments only (``tauv calibrate``: the DVL's mounting and scale
   factor, the IMU-to-reference boresight; tauvcore.eval.calibration);
3. **tune** on the training segments only, calibrated (``tauv tune --method lc``: the IMU's white
   noises and the DVL's noise by the likelihood of the innovations; tauvcore.eval.tuning);
4. **after**: every segment replayed with the calibration and the tuning; the held-out segments
   (the others) are the judgement.

Columns per segment and method, before -> after: the DVL's NIS per degree of freedom, the
velocity, tilt and heading NEES per dimension against the reference with its stated sigma, the
position error at the end [m] and the divergence monitor's first flag. Then the held-out
segments together against the bands the tuning must meet.

Writes its tables to docs/results/akit_tuning.md (``--fragment NAME``: NAME.md; benchmarks/fragment.py);
exits quietly when the data are absent. docs/tuning.md shows three: akit_tuning.md (the defaults),
akit_tuning_walks.md (``--params gyro_noise,accel_noise,dvl_noise,gyro_bias_walk,accel_bias_walk,gyro_bias
--fragment akit_tuning_walks``) and akit_tuning_phins.md (``--imu phins --params dvl_noise,dvl_bias_walk
--fragment akit_tuning_phins``).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from tauvcore.config import Config, from_dict, merge
from tauvcore.engine.results import MethodResult
from tauvcore.eval.calibration import calibrate
from tauvcore.eval.consistency import nees_series
from tauvcore.eval.replay import log_config, replay
from tauvcore.eval.tuning import (
    DEFAULT_PARAMETERS,
    PARAMETERS,
    PreparedLog,
    TuningLog,
    start_values,
    tune,
    tuned_sections,
)
from tauvcore.geo.rotations import C_nb_from_euler
from tauvcore.logs import Log, read_log
from tauvcore.sensors.imu import IMU_PROFILES

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("akit_to_log", ROOT / "scripts" / "akit_to_log.py")
akit = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(akit)

METHODS = ("lc", "tc")
"""The methods judged: loosely and tightly coupled DVL, four beams."""
NIS_BAND_TOGETHER = (0.7, 1.4)
NIS_BAND_EACH = (0.3, 3.0)
NEES_BAND_TOGETHER = (0.3, 3.0)
"""The bands the held-out segments must meet (DVL NIS/dof over them together and on each; velocity
and tilt NEES/dim over them together)."""
FLAG_WITHIN_M = 10.0
"""A divergence flag is false where LC's position error stays within this [m]."""


def _segments(spec: str, available: list[int]) -> list[int]:
    lo, _, hi = spec.partition("-")
    wanted = range(int(lo), int(hi or lo) + 1)
    return [n for n in available if n in wanted]


def judge(result: MethodResult) -> dict[str, float]:
    """One method on one segment: the DVL's NIS and dof summed, the NEES/dim of the velocity,
    tilt and heading (mean over the epochs), the position error at the end and over the segment,
    and the monitor's first flag [s] (NaN: none)."""
    dvl = result.updates["dvl"]
    dof = dvl.nis_dof[:, 0]
    used = (dof > 0) & np.isfinite(dvl.nis[:, 0])
    out = {
        "nis_sum": float(np.sum(dvl.nis[used, 0])),
        "dof_sum": float(np.sum(dof[used])),
        "pos_end_m": float(result.pos_err_m[-1, 0]),
        "pos_max_m": float(np.nanmax(result.pos_err_m[:, 0])),
        "flag_s": float(result.diverged_at_s[0]),
    }
    for block, dim in (("vel", 3), ("tilt", 2), ("heading", 1)):
        out[f"nees_{block}"] = float(np.nanmean(nees_series(result, block)[:, 0]) / dim)
    at = np.isfinite(nees_series(result, "tilt")[:, 0])  # the reference's own epochs (tauvcore.eval.judging)
    out["tilt_rms_deg"] = float(np.sqrt(np.mean(result.tilt_err_deg[at, 0] ** 2)))
    out["tilt_sigma_deg"] = float(np.nanmedian(result.tilt_sigma_deg[:, 0]))
    out["innovation_lag1"] = innovation_lag1(dvl)
    return out


def innovation_lag1(dvl) -> float:
    """The lag-1 autocorrelation of the DVL's normalised innovations (each row over its own
    sqrt(S), successive pings that both fused it, the rows pooled): about 0 when the innovations
    are white, as the filter's model says they are; towards 1 when an error the filter does not
    model lasts over several pings (a latency, a misalignment, a time-varying bias)."""
    nu = dvl.innovation[:, 0, :] / np.sqrt(dvl.innovation_var[:, 0, :])
    ok = dvl.fused_rows[:, 0, :] & np.isfinite(nu)
    a, b = nu[:-1], nu[1:]
    both = ok[:-1] & ok[1:]
    if both.sum() < 10:
        return float("nan")
    x, y = a[both], b[both]
    return float(np.corrcoef(x, y)[0, 1])


def fitted_lever_arm(log: Log) -> tuple[np.ndarray, np.ndarray]:
    """The DVL's lever arm against the reference [m] (body FRD) and its 1-sigma: least squares of the
    DVL's body velocity on the reference's (its attitude and NED velocity interpolated to the ping)
    plus ``omega x l`` (the IMU's rate over the ten samples around the ping) and a constant bias,
    the residuals' spread as the noise. What the reference says the DVL's lever arm is, whatever
    the IMU's own position."""
    assert log.ref_t_s is not None and log.ref_euler is not None and log.ref_vel_n is not None
    assert log.dvl_t_s is not None and log.dvl_body_mps is not None
    rows, rhs = [], []
    yaw = np.unwrap(log.ref_euler[:, 2])
    for t, v in zip(log.dvl_t_s, log.dvl_body_mps, strict=True):
        k = int(np.searchsorted(log.imu_t_s, t))
        if (
            not np.isfinite(v).all()
            or not log.ref_t_s[0] < t < log.ref_t_s[-1]
            or not 5 <= k < len(log.imu_t_s) - 5
        ):
            continue
        w = log.dtheta_b[k - 5 : k + 5].sum(axis=0) / (10 * log.dt_s)
        euler = [
            np.interp(t, log.ref_t_s, log.ref_euler[:, 0]),
            np.interp(t, log.ref_t_s, log.ref_euler[:, 1]),
        ]
        vel_n = [np.interp(t, log.ref_t_s, log.ref_vel_n[:, j]) for j in range(3)]
        vel_b = C_nb_from_euler(np.array([*euler, np.interp(t, log.ref_t_s, yaw)])).T @ np.array(vel_n)
        wx = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        rows.append(np.hstack([wx, np.eye(3)]))  # v_dvl - v_b = omega x l + bias
        rhs.append(v - vel_b)
    a, b = np.concatenate(rows), np.concatenate(rhs)
    x, *_ = np.linalg.lstsq(a, b, rcond=None)
    cov = np.linalg.inv(a.T @ a) * float(np.var(b - a @ x))
    return x[:3], np.sqrt(np.diag(cov)[:3])


def free_ins_drift(log: Log, config: Config) -> dict[str, float]:
    """The standalone INS from the reference's first row: its tilt and heading error at the end
    [deg]. A navigation-grade IMU's own integration stays within hundredths of a degree over 400 s;
    more says the IMU's record and the reference disagree beyond any sensor noise."""
    _, results = replay(config.replace("run", methods=("ins",), seed=0), log, np.random.default_rng(0))
    r = results["ins"]
    return {"tilt_end_deg": float(r.tilt_err_deg[-1, 0]), "heading_end_deg": float(r.heading_err_deg[-1, 0])}


def replayed(log: Log, config: Config, seed: int = 0) -> dict[str, dict[str, float]]:
    """Every method of :data:`METHODS` on the log under ``config``, judged."""
    _, results = replay(config.replace("run", methods=METHODS, seed=seed), log, np.random.default_rng(seed))
    return {m: judge(results[m]) | velocity_timing(results[m], log) for m in METHODS}


def velocity_timing(result: MethodResult, log: Log) -> dict[str, float]:
    """The filter's horizontal NED velocity against the reference's at the reference's own epochs:
    its RMS error [m/s], the time offset [s] that best explains that error as the reference's
    acceleration times a delay (least squares), and the RMS left after it. A filter whose velocity
    follows a DVL timed differently from the reference shows an offset and a large reduction."""
    at = np.flatnonzero(np.isfinite(nees_series(result, "vel")[:, 0]))
    if result.est_vel_n is None or log.ref_t_s is None or log.ref_vel_n is None or len(at) < 10:
        return {
            "vel_h_rms_mps": float("nan"),
            "vel_offset_s": float("nan"),
            "vel_h_rms_after_mps": float("nan"),
        }
    j = np.clip(np.searchsorted(log.ref_t_s, result.t_s[at]), 0, len(log.ref_t_s) - 1)
    prev = np.clip(j - 1, 0, None)
    j = np.where(
        np.abs(log.ref_t_s[prev] - result.t_s[at]) < np.abs(log.ref_t_s[j] - result.t_s[at]), prev, j
    )
    accel = np.gradient(log.ref_vel_n, log.ref_t_s, axis=0)[j, :2].ravel()
    err = (result.est_vel_n[at, 0, :2] - log.ref_vel_n[j, :2]).ravel()
    offset = float(accel @ err / (accel @ accel))
    return {
        "vel_h_rms_mps": float(np.sqrt(np.mean(err**2) * 2)),
        "vel_offset_s": offset,
        "vel_h_rms_after_mps": float(np.sqrt(np.mean((err - accel * offset) ** 2) * 2)),
    }


def _band(value: float, band: tuple[float, float]) -> str:
    return "in" if band[0] <= value <= band[1] else "**out**"


def _flag(row: dict[str, float]) -> str:
    return "-" if np.isnan(row["flag_s"]) else f"{row['flag_s']:.0f} s"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "akit"))
    parser.add_argument("--train", default="1-6", help="segments calibrated and tuned on (default 1-6)")
    parser.add_argument("--max-evaluations", type=int, default=200)
    parser.add_argument(
        "--params",
        default=",".join(DEFAULT_PARAMETERS),
        help="the parameters tuned (tauvcore.eval.tuning.PARAMETERS)",
    )
    parser.add_argument(
        "--imu",
        default=None,
        choices=sorted(IMU_PROFILES),
        help="the filters tuned for this IMU profile (tauv replay --imu) before the tuning",
    )
    parser.add_argument(
        "--fragment", default="akit_tuning", help="the page fragment written (docs/results/NAME.md)"
    )
    args = parser.parse_args()
    names = tuple(args.params.split(","))
    unknown = [n for n in names if n not in PARAMETERS]
    if unknown:
        parser.error(f"--params: unknown {unknown} (choose from {', '.join(PARAMETERS)})")
    data = Path(args.data)
    found = sorted(int(p.name[10:]) for p in data.glob("Trajectory*") if p.is_dir() and p.name[10:].isdigit())
    if not found:
        print(f"no A-KIT segments under {data}: nothing measured")
        return
    train = _segments(args.train, found)
    held_out = [n for n in found if n not in train]
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        logs: dict[int, Log] = {}
        own: dict[int, dict] = {}
        for n in found:
            out = Path(tmp) / str(n)
            akit.convert(data / f"Trajectory{n}", out)
            logs[n], own[n] = read_log(out), log_config(out)[0]
        before = {n: replayed(logs[n], from_dict(own[n])) for n in found}
        calibration = calibrate([(f"Trajectory{n}", logs[n], from_dict(own[n])) for n in train])
        c = calibration.config
        cal_sections = {
            "calibration": {
                "dvl_misalignment_deg": list(c.dvl_misalignment_deg),
                "dvl_scale_factor_pct": c.dvl_scale_factor_pct,
                "imu_boresight_deg": list(c.imu_boresight_deg),
            }
        }
        if args.imu is not None:
            cal_sections["imu"] = dict(IMU_PROFILES[args.imu].__dict__)
        cases = [
            TuningLog(
                f"Trajectory{n}",
                logs[n],
                from_dict(merge(own[n], cal_sections)).replace("run", methods=("lc",)),
            )
            for n in train
        ]
        prepared = [PreparedLog(c) for c in cases]
        start = start_values(cases, names)
        result = tune(prepared, names, start=start, max_evaluations=args.max_evaluations)
        found_sections = merge(cal_sections, tuned_sections(result))
        after = {n: replayed(logs[n], from_dict(merge(own[n], found_sections))) for n in found}
        drift = {n: free_ins_drift(logs[n], from_dict(merge(own[n], cal_sections))) for n in found}
        no_arm = {"dvl": {"lever_arm_m": [0.0, 0.0, 0.0]}}
        armless = {
            n: replayed(logs[n], from_dict(merge(merge(own[n], found_sections), no_arm))) for n in found
        }
        arms = {n: fitted_lever_arm(logs[n]) for n in found}
    elapsed_s = time.perf_counter() - started

    with fragment.capture() as shown:
        segs = ", ".join(str(n) for n in train)
        imu = f", the filters set for the {args.imu} IMU before tuning" if args.imu else ""
        print(
            f"Calibrated and tuned (LC) on segments {segs}{imu}; every segment replayed before (Table 2's tuning) "
            f"and after; the held-out segments are the judgement. {elapsed_s:.0f} s for the whole benchmark.\n"
        )
        print("What was found:\n")
        print("| quantity | value | 1-sigma |")
        print("|---|---|---|")
        for est in (calibration.dvl, calibration.boresight):
            for name, unit, value, sigma in zip(est.names, est.units, est.value, est.sigma, strict=True):
                print(f"| {name} | {value:+.3f} {unit} | {sigma:.3f} {unit} |")
        for name in result.parameters:
            s = result.sigma_ln[name]
            factor = f"x{np.exp(s):.2f}" if np.isfinite(s) else "not determined"
            print(f"| {name} | {result.start[name]:.4g} -> {result.tuned[name]:.4g} | {factor} |")
        print(
            "\nPer segment, before -> after (NIS/dof: the DVL's; NEES/dim against the reference with its stated "
            "1-sigma; position: error at the end; flag: the divergence monitor's first):\n"
        )
        print(
            "| segment | method | DVL NIS/dof | vel NEES/dim | tilt NEES/dim | heading NEES/dim | position [m] "
            "| flag |"
        )
        print("|---|---|---|---|---|---|---|---|")
        for n in found:
            role = "train" if n in train else "held out"
            for m in METHODS:
                b, a = before[n][m], after[n][m]
                nis_b, nis_a = b["nis_sum"] / b["dof_sum"], a["nis_sum"] / a["dof_sum"]
                print(
                    f"| {n} ({role}) | {m.upper()} | {nis_b:.2f} -> {nis_a:.2f} | {b['nees_vel']:.2f} -> "
                    f"{a['nees_vel']:.2f} | {b['nees_tilt']:.2f} -> {a['nees_tilt']:.2f} | {b['nees_heading']:.2f} "
                    f"-> {a['nees_heading']:.2f} | {b['pos_end_m']:.1f} -> {a['pos_end_m']:.1f} | {_flag(b)} -> "
                    f"{_flag(a)} |"
                )
        print(
            "\nEvidence per segment, LC after: the standalone INS's tilt and heading error at the end (the IMU's "
            "record against the reference), LC's tilt error (RMS at the reference's own epochs) against its own "
            "1-sigma (median), and the lag-1 "
            "autocorrelation of the DVL's normalised innovations (0: white, as the filter assumes); LC's horizontal "
            "velocity error at the reference's epochs, the time offset that best explains it as the reference's "
            "acceleration times a delay, and what is left without it; the DVL's lever arm (its forward component) "
            "fitted against the reference (its velocity and attitude, with the IMU's rate), and LC's DVL NIS/dof and "
            "horizontal velocity RMS after, with the log's lever arm and with none:\n"
        )
        print(
            "| segment | INS tilt at end [deg] | INS heading at end [deg] | LC tilt RMS [deg] | LC tilt 1-sigma [deg] "
            "| innovation lag-1 | LC horizontal velocity RMS [m/s] | its time offset [s] | RMS without it [m/s] "
            "| DVL lever arm x fitted [m] | LC NIS/dof: log's arm -> none | LC velocity RMS: log's arm -> none [m/s] |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for n in found:
            a, z = after[n]["lc"], armless[n]["lc"]
            arm, arm_sigma = arms[n]
            print(
                f"| {n} | {drift[n]['tilt_end_deg']:.3f} | {drift[n]['heading_end_deg']:.3f} | {a['tilt_rms_deg']:.3f} "
                f"| {a['tilt_sigma_deg']:.3f} | {a['innovation_lag1']:+.2f} | {a['vel_h_rms_mps']:.3f} "
                f"| {a['vel_offset_s']:+.2f} | {a['vel_h_rms_after_mps']:.3f} | {arm[0]:+.2f} +- {arm_sigma[0]:.2f} "
                f"| {a['nis_sum'] / a['dof_sum']:.2f} -> {z['nis_sum'] / z['dof_sum']:.2f} "
                f"| {a['vel_h_rms_mps']:.3f} -> {z['vel_h_rms_mps']:.3f} |"
            )
        if held_out:
            print(
                f"\nThe held-out segments ({', '.join(str(n) for n in held_out)}) together, LC, after, against "
                "the bands:\n"
            )
            print("| check | band | value | |")
            print("|---|---|---|---|")
            lc = [after[n]["lc"] for n in held_out]
            nis_all = sum(r["nis_sum"] for r in lc) / sum(r["dof_sum"] for r in lc)
            print(
                f"| DVL NIS/dof, together | {NIS_BAND_TOGETHER} | {nis_all:.2f} | {_band(nis_all, NIS_BAND_TOGETHER)} |"
            )
            each = [r["nis_sum"] / r["dof_sum"] for r in lc]
            worst = min(each, key=lambda v: min(v / NIS_BAND_EACH[0], NIS_BAND_EACH[1] / v))
            inside = sum(NIS_BAND_EACH[0] <= v <= NIS_BAND_EACH[1] for v in each)
            print(
                f"| DVL NIS/dof, each | {NIS_BAND_EACH} | {inside} of {len(each)} inside (worst {worst:.2f}) | "
                f"{'in' if inside == len(each) else '**out**'} |"
            )
            for block in ("vel", "tilt"):
                v = float(np.mean([r[f"nees_{block}"] for r in lc]))
                print(
                    f"| {block} NEES/dim, together | {NEES_BAND_TOGETHER} | {v:.2f} | {_band(v, NEES_BAND_TOGETHER)} |"
                )
            false_flags = [
                n
                for n in held_out
                if not np.isnan(after[n]["lc"]["flag_s"]) and after[n]["lc"]["pos_max_m"] <= FLAG_WITHIN_M
            ]
            print(
                f"| LC flagged while within {FLAG_WITHIN_M:g} m | none | "
                f"{', '.join(map(str, false_flags)) or 'none'} | {'in' if not false_flags else '**out**'} |"
            )
            for m in METHODS:
                mb = float(np.median([before[n][m]["pos_end_m"] for n in held_out]))
                ma = float(np.median([after[n][m]["pos_end_m"] for n in held_out]))
                print(
                    f"| {m.upper()} median end position [m] | no worse than before | {mb:.2f} -> {ma:.2f} | "
                    f"{'in' if ma <= mb else '**out**'} |"
                )
    print(f"written to {fragment.write(args.fragment, shown.getvalue())}")


if __name__ == "__main__":
    main()
