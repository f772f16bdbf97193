"""How much memory a dashboard run takes, estimated before it starts, and the budget it must fit.

A run of ``duration_s`` at the IMU rate f has K = duration_s * f + 1 samples; with R Monte Carlo
runs and M methods, the worker process (app.worker.run_worker) streams the mission
(tauvcore.engine.mission.run_streaming): truth and sensors exist one chunk at a time
(``STREAM_CHUNK_S``, K_c samples), the results grow with the output epochs. Counted from the
arrays the engine allocates (8-byte floats; "d" is one double):

- one chunk: the truth being built (tauvcore.truth.kinematic: the record and the motion at 4
  Gauss-Legendre nodes per interval, ``TRUTH_BUILD_DOUBLES`` = 169 d per sample, as tracemalloc
  measured), and the chunk's IMU record with its coning/sculling compensation and temporaries
  (``COMPENSATION_DOUBLES`` = 37 d per sample and run);
- the results: per output epoch, method and run the eleven error/sigma/NEES series, the five
  block NEES and the estimated position (``OUTPUT_DOUBLES`` = 19 d), held four times at the end,
  and the sensor errors' estimate, sigma and truth (the worker asks for them,
  tauvcore.engine.results.SENSOR_STATES: ``SENSOR_DOUBLES`` = 3 x 11 d), held three times (the
  bank's chunks, their concatenation, the pickle: counted four times, the estimate of 12 runs
  of 250 s was 1.5x the measured peak). A run that fits the budget only without them, or whose
  records would exceed ``SENSOR_RECORDS_MAX_BYTES``, runs without them
  (:func:`records_sensor_errors`); the budget refuses a run that does not fit even so.
  (the bank's chunks, their concatenation, the result handed to the queue and its pickle); the
  thinned live copy (at most ``app.worker.PROGRESS_MAX_EPOCHS`` epochs, copy and pickle); per
  update (DVL ping per DVL method, depth and magnetometer sample and a plug-in source's epoch,
  at its ``rate_hz``, per aided method) ~20 d per run,
  four times as well, and ``UPDATE_ROW_BYTES`` of numpy object overhead per row of one chunk
  (rows are stacked at the end of every chunk); P and one covariance step's scratch per method
  and run (8 x 400 d).

The estimate is the sum, plus ``SLACK`` (15 %) for the allocator's pages, plus ``FIXED_BYTES`` for
what a run loads once: the compiled kernels of the filter bank (tauvcore.filter.kernels, tauvcore.engine.loop: numba's machine code and its
LLVM context, 62-64 MiB measured for a 10 s run once the fused stretch kernel
``run_stops`` joined them; 14-16 MiB more since the geodetic path, its truth integrator included,
and lazily imported modules. The dynamic truth (tauvcore.truth.dynamic) adds its
compiled vehicle and autopilot and its mission (``DYNAMIC_FIXED_BYTES``, 12 MiB measured for a
streamed 20 min mission) and, for a mission short enough to keep, its knots (``KNOT_DOUBLES`` per
sample).
tests/unit/test_budget.py checks it against the measured peak resident memory of real runs
(estimate >= measured, within 1.5x). The server holds one more unpickled copy of the results
per tab and one pickled copy is in transit through the worker's pipe: :func:`estimate_run` reports them
apart (``results_bytes``), and the budget applies to the sum (``RunEstimate.total_bytes``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from tauvcore.aiding.sources import FUSED
from tauvcore.config import Config

DOUBLE = 8
TRUTH_BUILD_DOUBLES = 169
COMPENSATION_DOUBLES = 12 + 6 + 6 + 13
OUTPUT_DOUBLES = 11 + 5 + 3
SENSOR_DOUBLES = 3 * 11
SENSOR_COPIES = 3
SENSOR_RECORDS_MAX_BYTES = 64 * 2**20
"""The sensor errors are recorded only for runs whose records are at most this large (20 runs of
five methods over 250 s: 63 MiB; one run of them over 5,000 s)."""
OUTPUT_COPIES = 4
COVARIANCE_DOUBLES = 8 * 20 * 20
UPDATE_ROW_BYTES = 3000
UPDATE_DOUBLES = 20
FIXED_BYTES = 84 * 2**20
SLACK = 1.15
DYNAMIC_FIXED_BYTES = 13 * 2**20
KNOT_DOUBLES = 24  # tauvcore.truth.dynamic.KNOT_COLUMNS (not imported: it loads numba)
CACHE_MAX_KNOTS = 100_000  # tauvcore.truth.dynamic.CACHE_MAX_KNOTS
STREAM_CHUNK_S = 10.0  # tauvcore.engine.mission.STREAM_CHUNK_S (not imported: it loads the engine)
LIVE_EPOCHS = 1200  # app.worker.PROGRESS_MAX_EPOCHS (not imported: app.worker starts processes)

DEFAULT_BUDGET_BYTES = int(1.5 * 2**30)
"""Default memory a single dashboard run may take (1.5 GiB): two runs at once and the server fit
in 4 GiB. Set ``TAUV_RUN_BUDGET_MB`` to change it."""
BUDGET_ENV = "TAUV_RUN_BUDGET_MB"


@dataclass(frozen=True)
class RunEstimate:
    """Estimated memory of one dashboard run [bytes]."""

    chunk_bytes: int  # one chunk of truth (being built) and IMU record with its compensation
    end_bytes: int  # results, records and the queued pickle at the end
    results_bytes: int  # one copy of the results (the server's; the pipe's in transit)
    worker_peak_bytes: int  # SLACK x (chunk + end) + FIXED_BYTES: the worker's own peak

    @property
    def total_bytes(self) -> int:
        """The worker's peak plus the results in transit and held by the server."""
        return self.worker_peak_bytes + 2 * self.results_bytes


def estimate_run(config: Config, num_runs: int, sensor_errors: bool = True) -> RunEstimate:
    """Estimated memory of ``num_runs`` Monte Carlo runs of ``config`` (see the module docstring),
    with the sensor errors recorded (``sensor_errors``) or not."""
    rate_hz = config.imu.rate_hz
    duration_s = config.trajectory.duration_s
    K = round(duration_s * rate_hz) + 1
    R = int(num_runs)
    M = len(config.run.methods)
    T = math.ceil(K / max(1, round(rate_hz / config.filter.output_rate_hz)))
    aiding = set(config.run.aiding)
    dvl_methods = sum(1 for m in config.run.methods if m != "ins")
    dvl_rows = math.ceil(duration_s * config.dvl.rate_hz + 1) * dvl_methods if "dvl" in aiding else 0
    other_updates = 0
    if dvl_methods:
        for name, source in FUSED.items():
            if name in aiding:
                other_updates += math.ceil(
                    duration_s * source.rate_hz(config.section(source.section_name)) + 1
                )
    other_rows = other_updates * dvl_methods

    K_c = min(K, round(max(STREAM_CHUNK_S, 1.0 / config.dvl.rate_hz) * rate_hz) + 1)
    chunk = TRUTH_BUILD_DOUBLES * DOUBLE * K_c + COMPENSATION_DOUBLES * DOUBLE * K_c * R
    outputs = OUTPUT_DOUBLES * DOUBLE * T * M * R
    sensor_doubles = SENSOR_DOUBLES if sensor_errors else 0
    sensors = sensor_doubles * DOUBLE * T * M * R
    live = 2 * (OUTPUT_DOUBLES + sensor_doubles) * DOUBLE * min(T, LIVE_EPOCHS) * M * R
    update_data = UPDATE_DOUBLES * DOUBLE * R * (dvl_rows + M * other_updates)
    chunk_fraction = min(1.0, K_c / K)
    update_objects = int(UPDATE_ROW_BYTES * (dvl_rows + other_rows) * chunk_fraction)
    covariance = COVARIANCE_DOUBLES * DOUBLE * M * R
    end = (
        OUTPUT_COPIES * (outputs + update_data) + SENSOR_COPIES * sensors + live + update_objects + covariance
    )
    fixed = FIXED_BYTES
    if config.trajectory.truth == "dynamic":
        fixed += DYNAMIC_FIXED_BYTES
        chunk += KNOT_DOUBLES * DOUBLE * ((K + 1) if K + 1 <= CACHE_MAX_KNOTS else K_c)
    return RunEstimate(
        chunk_bytes=chunk,
        end_bytes=end,
        results_bytes=outputs + sensors + update_data,
        worker_peak_bytes=int(SLACK * (chunk + end)) + fixed,
    )


def records_sensor_errors(config: Config, num_runs: int, limit_bytes: int) -> bool:
    """Whether a dashboard run of ``config`` records the sensor errors (the Sensors tab's lower
    figure): only when, with them, it fits ``limit_bytes`` and their records stay within
    ``SENSOR_RECORDS_MAX_BYTES`` (they travel from the worker with every result)."""
    T, M, R = _epochs(config), len(config.run.methods), int(num_runs)
    if SENSOR_DOUBLES * DOUBLE * T * M * R > SENSOR_RECORDS_MAX_BYTES:
        return False
    return estimate_run(config, num_runs, sensor_errors=True).total_bytes <= limit_bytes


def _epochs(config: Config) -> int:
    """Output epochs T of ``config``'s mission."""
    rate_hz = config.imu.rate_hz
    K = round(config.trajectory.duration_s * rate_hz) + 1
    return math.ceil(K / max(1, round(rate_hz / config.filter.output_rate_hz)))


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
    return (
        f"this run would need about {need / 2**30:.2f} GB of memory, more than the "
        f"{budget / 2**30:.2f} GB a run may take ({BUDGET_ENV}); shorten Duration or lower Runs"
    )
