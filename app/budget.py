"""How much memory a dashboard run takes, estimated before it starts, and the budget it must fit.

A run of ``duration_s`` at the IMU rate f has K = duration_s * f + 1 samples; with R Monte Carlo
runs and M methods, the worker process (app.worker.run_worker) goes through three peaks, counted
from the arrays the engine allocates (8-byte floats; "d" is one double):

1. Truth generation (tauvcore.truth.kinematic.generate_from_profile), per IMU sample: the truth
   record, 37 d (t, pos, vel_n, vel_b, C_nb 9, euler, omega_nb, omega_ib, f_b, dtheta, dv), and
   while it is built the motion at 4 Gauss-Legendre nodes per interval, 27 d each (euler, C_nb 9,
   omega_nb, omega_ib, vel_b, vel_n, f_b) plus 9 d of expression temporaries (acc_n, cross
   products): at most 37 + 4 x 36 = 181 d; tracemalloc measures 169 d, which
   ``TRUTH_BUILD_DOUBLES`` takes. The nodes are freed afterwards.
2. Compensation (tauvcore.ins.strapdown.body_increments), per IMU sample and run: the IMU record
   (dtheta, dv and the true biases, 12 d), the shifted previous-sample copies (6 d), the
   coning/sculling compensated increments (6 d) and 13 d of cross-product temporaries (five
   np.cross results of 3 d and their per-component products, as tracemalloc measures):
   ``COMPENSATION_DOUBLES`` = 37 d, on top of the truth record.
3. End of the run: the truth, the IMU record and the compensated increments (18 d per sample
   and run); per output epoch, method and run the eleven error/sigma/NEES series (norms, tilt and
   heading, full NEES), the five block NEES and the estimated position (19 d) twice (the run's arrays and the pickled result queued for the
   dashboard), plus the thinned live copy (at most ``app.worker.PROGRESS_MAX_EPOCHS`` epochs,
   twice: copy and pickle); P and one covariance step's F, G, Phi, Qd and products per method and
   run (8 x 400 d); per update record row (DVL ping per DVL method, depth and magnetometer
   sample per aided method) ``UPDATE_ROW_BYTES`` of numpy object overhead, and ~20 d of data
   per run three times (rows, stacked record, pickle). The rows of one depth or magnetometer
   update are views of one batched (M, R, ...) outcome, which they keep alive whole: M x 20 d
   per run and update, shared by the M rows.

The estimate is the largest of the three, plus ``SLACK`` (15 %) for the allocator's pages, plus
``FIXED_BYTES`` for what a run loads once (lazily imported modules: 3 MB measured for a 10 s
run). tests/unit/test_budget.py checks it against the measured peak resident memory of real runs
(estimate >= measured, within 1.5x). The server holds one more unpickled copy of the results
per tab and one pickled copy is in transit through the worker's pipe: :func:`estimate_run` reports them
apart (``results_bytes``), and the budget applies to the sum (``RunEstimate.total_bytes``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from tauvcore.config import Config

DOUBLE = 8
TRUTH_DOUBLES = 37
TRUTH_BUILD_DOUBLES = 169
COMPENSATION_DOUBLES = 12 + 6 + 6 + 13
IMU_KEPT_DOUBLES = 12 + 6
OUTPUT_DOUBLES = 11 + 5 + 3
COVARIANCE_DOUBLES = 8 * 20 * 20
UPDATE_ROW_BYTES = 3000
UPDATE_DOUBLES = 20
FIXED_BYTES = 14 * 2**20
SLACK = 1.15
LIVE_EPOCHS = 1200          # app.worker.PROGRESS_MAX_EPOCHS (not imported: app.worker starts processes)

DEFAULT_BUDGET_BYTES = int(1.5 * 2**30)
"""Default memory a single dashboard run may take (1.5 GiB): two runs at once and the server fit
in 4 GiB. Set ``TAUV_RUN_BUDGET_MB`` to change it."""
BUDGET_ENV = "TAUV_RUN_BUDGET_MB"


@dataclass(frozen=True)
class RunEstimate:
    """Estimated memory of one dashboard run [bytes]."""

    truth_build_bytes: int      # peak 1: truth generation (Gauss nodes)
    compensation_bytes: int     # peak 2: IMU record and its compensated copies
    end_bytes: int              # peak 3: results, records and the queued pickle at the end
    results_bytes: int          # one copy of the results (the server's; the pipe's in transit)
    worker_peak_bytes: int      # SLACK x the largest of the three + FIXED_BYTES: the worker's own peak

    @property
    def total_bytes(self) -> int:
        """The worker's peak plus the results in transit and held by the server."""
        return self.worker_peak_bytes + 2 * self.results_bytes


def estimate_run(config: Config, num_runs: int) -> RunEstimate:
    """Estimated memory of ``num_runs`` Monte Carlo runs of ``config`` (see the module docstring)."""
    rate_hz = config.imu.rate_hz
    duration_s = config.trajectory.duration_s
    K = int(round(duration_s * rate_hz)) + 1
    R = int(num_runs)
    M = len(config.run.methods)
    T = math.ceil(K / max(1, int(round(rate_hz / config.filter.output_rate_hz))))
    aiding = set(config.run.aiding)
    dvl_methods = sum(1 for m in config.run.methods if m != "ins")
    dvl_rows = math.ceil(duration_s * config.dvl.rate_hz + 1) * dvl_methods if "dvl" in aiding else 0
    other_updates = 0
    if dvl_methods:
        other_updates += math.ceil(duration_s * config.pressure.rate_hz + 1) if "depth" in aiding else 0
        other_updates += math.ceil(duration_s * config.magnetometer.rate_hz + 1) if "mag" in aiding else 0
    other_rows = other_updates * dvl_methods

    truth = TRUTH_DOUBLES * DOUBLE * K
    outputs = OUTPUT_DOUBLES * DOUBLE * T * M * R
    live = 2 * OUTPUT_DOUBLES * DOUBLE * min(T, LIVE_EPOCHS) * M * R
    update_data = UPDATE_DOUBLES * DOUBLE * R * (dvl_rows + M * other_updates)
    update_objects = UPDATE_ROW_BYTES * (dvl_rows + other_rows)
    covariance = COVARIANCE_DOUBLES * DOUBLE * M * R
    truth_build = TRUTH_BUILD_DOUBLES * DOUBLE * K
    compensation = truth + COMPENSATION_DOUBLES * DOUBLE * K * R
    end = (truth + IMU_KEPT_DOUBLES * DOUBLE * K * R + 2 * outputs + live + 3 * update_data
           + update_objects + covariance)
    return RunEstimate(truth_build_bytes=truth_build, compensation_bytes=compensation, end_bytes=end,
                       results_bytes=outputs + update_data + update_objects,
                       worker_peak_bytes=int(SLACK * max(truth_build, compensation, end)) + FIXED_BYTES)


def budget_bytes() -> int:
    """The per-run memory budget: ``TAUV_RUN_BUDGET_MB`` if set, else :data:`DEFAULT_BUDGET_BYTES`.

    Raises ValueError naming the variable and its value if it is set but not a positive number.
    """
    raw = os.environ.get(BUDGET_ENV)
    if raw is None or not raw.strip():
        return DEFAULT_BUDGET_BYTES
    try:
        mb = float(raw)
    except ValueError:
        mb = math.nan
    if not math.isfinite(mb) or mb <= 0:
        raise ValueError(f"{BUDGET_ENV} must be a positive number of MB, got {raw[:40]!r}")
    return int(mb * 2**20)


def over_budget_message(estimate: RunEstimate, budget: int) -> str | None:
    """None if the run fits ``budget`` [bytes], else one line saying by how much and what to shrink."""
    need = estimate.total_bytes
    if need <= budget:
        return None
    return (f"this run would need about {need / 2**30:.2f} GB of memory, more than the "
            f"{budget / 2**30:.2f} GB a run may take ({BUDGET_ENV}); shorten Duration or lower Runs")
