"""The methods on real AUV data: position error at the end of each A-KIT segment (about 400 s).

    python benchmarks/akit_table.py [--data ../shared/data/akit] [--imu-errors table2]

Each segment is converted to a log (scripts/akit_to_log.py: re-timed, Y axis flipped, clock
offsets estimated, the DVL's lever arm in the log's own log.toml) and replayed as ``tauv replay
OUT`` does by default (tauvcore.eval.replay: the log's configuration applied, the filters
starting on the reference's first row), tuned with Table 2 (or, with ``--imu-errors``, the log's
IMU degraded by that IMU's errors). Columns: the standalone INS; LC with four (synthetic) beams
projected from the DVL's body velocity; TC, NSV and ELC with beams 3 and 4 dropped for the whole
segment. Errors against the reference, itself an INS/DVL smoother (not independent of the DVL).
A second table gives LC's verdicts per segment under two tunings: Table 2's MEMS IMU and the
PHINS class of the data's own IMU (the ``phins`` profile as the ``[imu]`` section).

Writes its tables to docs/results/akit_table.md (with ``--imu-errors P``, akit_table_P.md) (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import sys
import tempfile
from pathlib import Path

import numpy as np

from tauvcore.config import from_dict
from tauvcore.eval.replay import log_config, replay
from tauvcore.logs import read_log
from tauvcore.sensors.imu import IMU_PROFILES

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("akit_to_log", ROOT / "scripts" / "akit_to_log.py")
akit = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(akit)


TUNINGS = ("table2", "phins")
"""The filters' IMU tuning of the second table: Table 2's MEMS IMU (the lab's default) and the PHINS
class the data were recorded with (tauvcore.sensors.imu.IMU_PROFILES)."""


def _lc_diagnosis(r) -> dict[str, float]:
    """LC's verdicts on a segment: the monitor's first flag, the lock-out resets, the DVL's NIS per
    degree of freedom, the tilt and velocity errors against the reference and their NEES/dim, at
    the reference's own epochs (where the NEES is finite: tauvcore.eval.judging)."""
    dvl = r.updates["dvl"]
    dof = dvl.nis_dof[:, 0]
    used = dof > 0
    at = np.isfinite(r.nees_block[:, 0, 1])
    return {
        "flag_s": float(r.diverged_at_s[0]),
        "resets": int(dvl.reset[:, 0].sum()) if dvl.reset is not None else 0,
        "nis": float(np.mean(dvl.nis[used, 0] / dof[used])),
        "tilt_deg": float(np.sqrt(np.mean(r.tilt_err_deg[at, 0] ** 2))),
        "vel_mps": float(np.sqrt(np.mean(r.vel_err_mps[at, 0] ** 2))),
        "nees_tilt": float(np.mean(r.nees_block[at, 0, 2]) / 2.0),
        "nees_vel": float(np.mean(r.nees_block[at, 0, 1]) / 3.0),
        "pos_m": float(r.pos_err_m[-1, 0]),
    }


def segment_row(segment: Path, imu_errors: str | None, seed: int = 0) -> dict[str, float]:
    with tempfile.TemporaryDirectory() as tmp:
        offsets = akit.convert(segment, Path(tmp))
        log = read_log(tmp)
        base = from_dict(log_config(tmp)[0]).replace("run", seed=seed)   # the log's own configuration
        errors = IMU_PROFILES[imu_errors] if imu_errors else None
        four = base.replace("run", methods=("ins", "lc"))
        two = base.replace("run", methods=("tc", "nsv", "elc")).replace("dvl", beams=(1, 2))
        out: dict[str, float] = {"imu_shift_s": offsets["imu_shift_s"], "dvl_shift_s": offsets["dvl_shift_s"],
                                 "duration_s": log.duration_s}
        for config in (four, two):
            _, results = replay(config, log, np.random.default_rng(seed), imu_errors=errors)
            for method, r in results.items():
                out[method] = float(r.pos_err_m[-1, 0])
                if method == "lc":
                    out["lc_table2"] = _lc_diagnosis(r)
        # LC tuned for the IMU the data come from (the log's rate kept)
        profile = {k: v for k, v in dataclasses.asdict(IMU_PROFILES["phins"]).items() if k != "rate_hz"}
        phins = base.replace("run", methods=("lc",)).replace("imu", **profile)
        _, results = replay(phins, log, np.random.default_rng(seed), imu_errors=errors)
        out["lc_phins"] = _lc_diagnosis(results["lc"])
        return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "akit"))
    parser.add_argument("--imu-errors", choices=tuple(IMU_PROFILES), default=None)
    args = parser.parse_args()
    data = Path(args.data)
    segments = sorted((p for p in data.glob("Trajectory*") if p.is_dir()), key=lambda p: int(p.name[10:]))
    if not segments:
        raise SystemExit(f"no A-KIT segments under {data}")
    methods = ("ins", "lc", "tc", "nsv", "elc")
    with fragment.capture() as shown:
        print(f"Position error [m] at the end of each segment (IMU errors added: {args.imu_errors or 'none'})\n")
        print("| segment | length [s] | IMU / DVL clock [s] | INS | LC, 4 beams | TC, beams 1-2 | NSV, beams 1-2 "
              "| ELC, beams 1-2 |")
        print("|---|---|---|---|---|---|---|---|")
        rows = []
        for segment in segments:
            row = segment_row(segment, args.imu_errors)
            rows.append(row)
            cells = " | ".join(f"{row[m]:.1f}" for m in methods)
            print(f"| {segment.name} | {row['duration_s']:.0f} | {row['imu_shift_s']:+.2f} / {row['dvl_shift_s']:+.2f} "
                  f"| {cells} |", flush=True)
        medians = " | ".join(f"{np.median([r[m] for r in rows]):.1f}" for m in methods)
        print(f"| median | | | {medians} |")
        print("\nLC with four beams, tuned for Table 2's MEMS IMU (the columns above) and for the PHINS-class IMU "
              "the data were recorded with (the `phins` IMU profile as the `[imu]` section): position error at the end [m]; the divergence monitor's "
              "first flag [s] (from the DVL's innovations, as a real filter could judge itself); velocity resets "
              "after a lock-out; the DVL's NIS per degree of freedom (1 for a filter whose DVL noise is right); "
              "RMS tilt [deg] and velocity [m/s] errors against the reference and their NEES/dim, at the "
              "reference's own 1 Hz epochs\n")
        print("| segment | tuning | position [m] | flagged at [s] | resets | DVL NIS/dof | tilt [deg] | velocity [m/s] "
              "| NEES/dim tilt | NEES/dim velocity |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for segment, row in zip(segments, rows, strict=True):
            for tuning in TUNINGS:
                d = row[f"lc_{tuning}"]
                flag = "never" if np.isnan(d["flag_s"]) else f"{d['flag_s']:.0f}"
                print(f"| {segment.name} | {tuning} | {d['pos_m']:.1f} | {flag} | {d['resets']} | {d['nis']:.2f} | "
                      f"{d['tilt_deg']:.3f} | {d['vel_mps']:.3f} | {d['nees_tilt']:,.1f} | {d['nees_vel']:,.1f} |")
    name = "akit_table" + (f"_{args.imu_errors}" if args.imu_errors else "")
    print(f"written to {fragment.write(name, shown.getvalue())}")


if __name__ == "__main__":
    main()
