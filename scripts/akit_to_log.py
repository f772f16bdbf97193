"""Convert a segment of the A-KIT dataset (Snapir AUV) to the log format of tauvcore.logs.

    python scripts/akit_to_log.py ../shared/data/akit/Trajectory1 /tmp/akit1

OUT_DIR follows the rule of every writer (tauvcore.logs.writer.output_dir): a new directory in an
existing one, or an empty one; a bad argument is one line and exit status 2.

The dataset (Cohen & Klein 2025, public repository ``ansfl/A-KIT``; see its NOTES.md, not part
of this repository) has per segment ``IMU.csv`` (100 Hz specific force and rate), ``DVL.csv``
(1 Hz body velocity) and ``GT.csv`` (1 Hz post-processed reference: longitude, latitude [rad],
altitude [m], NED velocity, roll, pitch, yaw [rad]). What the conversion fixes, as the notes
describe and this script measures per segment:

1. time: every column's time is spread evenly over 0-400 s; the true spacing is 0.01 s (IMU) and
   1 s (DVL, reference), so the time axes are rebuilt from the sample index;
2. the IMU's Y axis has the wrong sign (gyro and accelerometer): flipped;
3. clock offsets: the IMU's against the reference (about +-0.4 to 0.5 s, varying by segment)
   and the DVL's (about 1 s), each estimated by cross-correlating a rate that both see (the
   IMU's yaw rate against the reference's; the DVL's body velocity against the reference's,
   resolved in the body) over shifts of +-2 s in 0.01 s steps;
4. the DVL sits about (-1.86, -0.03, +0.18) m from the INS reference point: a lever arm for the
   configuration (:data:`DVL_LEVER_ARM_M`, written to the log's own configuration file,
   ``log.toml`` beside the tables, which ``tauv replay`` and the dashboard apply);
5. the reference is not exact: its 1-sigma (:data:`REFERENCE_SIGMA`, the same for every segment)
   goes to the same file's ``[reference]``, so that the NEES is taken against it with it.

The IMU is written as rates, the DVL as a body velocity (the replay projects it onto the
configured Janus beams, so beams can be dropped), the reference as geodetic position (depth =
-altitude) with NED velocity and attitude in radians. IMU samples outside the reference's span
are left out.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import NoReturn

import numpy as np
import tomli_w

from tauvcore.config import from_dict
from tauvcore.geo.rotations import C_nb_from_euler
from tauvcore.logs.writer import output_dir, write_log
from tauvcore.validation import OutputDirError, one_line, show_path

IMU_DT_S = 0.01
REF_DT_S = 1.0
DVL_LEVER_ARM_M = (-1.86, -0.03, 0.18)
REFERENCE_SIGMA = {"roll_pitch_deg": 0.01, "yaw_deg": 0.01}
"""The reference's 1-sigma (``[reference]`` of tauvcore.config), the same for every segment.

The reference is a Delph INS post-processed solution of the iXblue Phins Subsea with the DVL
(the dataset's NOTES.md). Attitude: 0.01 deg in heading, roll and pitch, the PHINS's published
accuracy (IXSEA's release on the PHINS for the National Oceanography Centre's Autosub6000,
rovworld.com, 1 November 2007: "heading, roll and pitch ... with an accuracy of 0.01 degrees");
a post-processed solution of the same sensors is taken as no better. Position and velocity are
left exact (0): no published PHINS figure for them was found (searched), and these data give no
estimate independent of the filters under test (the reference is the INS/DVL solution of the
same DVL; its own position increments and velocities disagree by 1 to 7 cm per 1 s row, in a
heavy-tailed, time-correlated way that one sigma does not describe). A replay starts on the
reference's first row, so only what the reference gets wrong after its start could enter the
NEES: the position and velocity NEES are therefore upper bounds."""
SHIFTS_S = np.arange(-2.0, 2.0 + 1e-9, 0.01)


def _read(path: Path) -> np.ndarray:
    return np.loadtxt(path, delimiter=",", skiprows=1)


def _best_shift(t_ref: np.ndarray, ref: np.ndarray, t_sig: np.ndarray, sig: np.ndarray) -> float:
    """The shift s maximising the correlation of ``sig(t + s)`` with ``ref(t)`` (columns summed)."""
    ref = ref - ref.mean(axis=0)
    best, best_s = -np.inf, 0.0
    inside = (t_ref > t_sig[0] + 2.5) & (t_ref < t_sig[-1] - 2.5)
    for s in SHIFTS_S:
        moved = np.column_stack([np.interp(t_ref[inside] + s, t_sig, sig[:, i]) for i in range(sig.shape[1])])
        moved -= moved.mean(axis=0)
        score = float(np.sum(moved * ref[inside]) / np.sqrt(np.sum(moved**2) * np.sum(ref[inside] ** 2)))
        if score > best:
            best, best_s = score, float(s)
    return best_s


def convert(segment: Path, out: Path, fmt: str = "csv") -> dict[str, float]:
    """Write the log of one segment to ``out``; returns the offsets found [s]."""
    imu, dvl, gt = _read(segment / "IMU.csv"), _read(segment / "DVL.csv"), _read(segment / "GT.csv")
    t_imu = np.arange(imu.shape[0]) * IMU_DT_S
    t_ref = np.arange(gt.shape[0]) * REF_DT_S
    t_dvl = np.arange(dvl.shape[0]) * REF_DT_S
    acc, gyro = imu[:, 1:4].copy(), imu[:, 4:7].copy()
    acc[:, 1] *= -1.0
    gyro[:, 1] *= -1.0
    lon, lat, alt = gt[:, 1], gt[:, 2], gt[:, 3]
    vel_n = gt[:, 4:7]
    euler = gt[:, 7:10]
    # the IMU's yaw rate against the reference's (central differences of the unwrapped yaw)
    yaw = np.unwrap(euler[:, 2])
    yaw_rate = np.gradient(yaw, t_ref)
    C = C_nb_from_euler(euler)
    yaw_rate_imu = gyro[:, 2]      # level vehicle: the yaw rate is the body z rate to within 1 %
    # a 1 s moving average of the IMU rate, to compare with the reference's 1 s differences
    kernel = np.ones(100) / 100.0
    smooth = np.convolve(yaw_rate_imu, kernel, mode="same")
    imu_shift = _best_shift(t_ref, yaw_rate[:, None], t_imu, smooth[:, None])
    # the DVL's body velocity against the reference's resolved in the body
    vel_b_ref = np.einsum("kji,kj->ki", C, vel_n)
    dvl_shift = _best_shift(t_ref, vel_b_ref, t_dvl, dvl[:, 1:4])
    # IMU samples on the reference's clock (the shift is a whole number of IMU steps: rounded to
    # the grid, so that the IMU has a sample at every reference time), from the first reference
    # time on: the filters start there, and their 10 Hz records fall on the reference's rows
    t_imu_ref = np.round((t_imu - imu_shift) / IMU_DT_S) * IMU_DT_S
    first_ref = t_ref[np.searchsorted(t_ref, t_imu_ref[0] - 1e-9)]
    keep = (t_imu_ref >= first_ref - 1e-9) & (t_imu_ref <= t_ref[-1] + 1e-9)
    t_dvl_ref = t_dvl - dvl_shift
    keep_dvl = (t_dvl_ref >= t_imu_ref[keep][0]) & (t_dvl_ref <= t_imu_ref[keep][-1])
    tables = {
        "imu": {"t_s": t_imu_ref[keep], "gyro_x_rps": gyro[keep, 0], "gyro_y_rps": gyro[keep, 1],
                "gyro_z_rps": gyro[keep, 2], "accel_x_mps2": acc[keep, 0], "accel_y_mps2": acc[keep, 1],
                "accel_z_mps2": acc[keep, 2]},
        "dvl": {"t_s": t_dvl_ref[keep_dvl], "vel_x_mps": dvl[keep_dvl, 1], "vel_y_mps": dvl[keep_dvl, 2],
                "vel_z_mps": dvl[keep_dvl, 3]},
        "reference": {"t_s": t_ref, "lat_rad": lat, "lon_rad": lon, "depth_m": -alt, "roll_rad": euler[:, 0],
                      "pitch_rad": euler[:, 1], "yaw_rad": euler[:, 2], "vel_north_mps": vel_n[:, 0],
                      "vel_east_mps": vel_n[:, 1], "vel_down_mps": vel_n[:, 2]},
    }
    ref_keep = t_ref >= first_ref - 1e-9
    tables["reference"] = {k: v[ref_keep] for k, v in tables["reference"].items()}
    own = {"dvl": {"lever_arm_m": list(DVL_LEVER_ARM_M)}, "reference": dict(REFERENCE_SIGMA)}
    from_dict(own)  # the configuration the replay will read: checked before anything is written
    write_log(out, tables, fmt, config_toml=tomli_w.dumps(own))
    return {"imu_shift_s": imu_shift, "dvl_shift_s": dvl_shift}


SEGMENT_FILES = ("IMU.csv", "DVL.csv", "GT.csv")
"""The files of one segment of the dataset."""


def _fail(message: str) -> NoReturn:
    """One line on stderr and exit status 2 (bad input)."""
    print(f"akit_to_log.py: error: {one_line(message)}", file=sys.stderr)
    raise SystemExit(2)


def _check_segment(segment: Path) -> None:
    """One line and exit 2 unless ``segment`` is one segment's folder (it holds :data:`SEGMENT_FILES`);
    given the dataset's root (or any folder of segments), the line lists the segments found."""
    if not segment.is_dir():
        _fail(f"SEGMENT_DIR: {show_path(str(segment))} is not a directory (one segment folder, e.g. Trajectory1)")
    missing = [name for name in SEGMENT_FILES if not (segment / name).is_file()]
    if not missing:
        return
    try:
        found = sorted(
            (d.name for d in segment.iterdir() if d.is_dir() and all((d / n).is_file() for n in SEGMENT_FILES)),
            key=lambda name: (len(name), name),
        )
    except OSError:
        found = []
    if found:
        listing = ", ".join(found[:4]) + (f", ... ({len(found)} segments)" if len(found) > 4 else "")
        _fail(
            f"SEGMENT_DIR: {show_path(str(segment))} holds segments, not one: give one segment folder, "
            f"e.g. {show_path(str(segment / found[0]))} (found {listing})"
        )
    _fail(f"SEGMENT_DIR: {show_path(str(segment))} is not an A-KIT segment: no {', '.join(missing)}")


def main() -> None:
    if len(sys.argv) != 3:
        _fail("usage: python scripts/akit_to_log.py SEGMENT_DIR OUT_DIR")
    segment, out = Path(sys.argv[1]), sys.argv[2]
    _check_segment(segment)
    try:
        output_dir(out, "OUT_DIR", inputs=[("the segment", str(segment))])
    except OutputDirError as exc:
        _fail(str(exc))
    try:
        offsets = convert(segment, Path(out))
    except (OSError, ValueError, IndexError) as exc:  # a segment's file that is not the dataset's
        _fail(f"{show_path(str(segment))}: cannot be converted: {exc}")
    print(f"written {sys.argv[2]}: IMU clock {offsets['imu_shift_s']:+.2f} s, DVL {offsets['dvl_shift_s']:+.2f} s")


if __name__ == "__main__":
    main()
