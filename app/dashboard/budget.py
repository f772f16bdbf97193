"""How much memory a dashboard run takes, estimated before it starts, and the budget it must fit.

A run of ``duration_s`` at the IMU rate f has K = duration_s * f + 1 samples and T output epochs
(:func:`output_epochs`); with R Monte Carlo runs and M methods, the worker process
(app.dashboard.worker.run_worker) streams the mission (tauvcore.engine.mission.run_streaming): truth and
sensors exist one chunk at a time (``STREAM_CHUNK_S``, K_c samples). A mission of at most
``tauvcore.eval.envelope.SCREEN_BINS`` output epochs keeps its results at every epoch; a longer
one reduces them to at most that many time bins as it streams (tauvcore.eval.envelope), so its
results are bounded by the bins, not the duration (:func:`kept_epochs`). Counted from the arrays
the engine allocates (8-byte floats; "d" is one double):

- one chunk: the truth being built (tauvcore.truth.kinematic: the record and the motion at 4
  Gauss-Legendre nodes per interval, ``TRUTH_BUILD_DOUBLES`` = 169 d per sample, as tracemalloc
  measured), and the chunk's IMU record with its coning/sculling compensation and temporaries
  (``COMPENSATION_DOUBLES`` = 37 d per sample and run);
- P and one covariance step's scratch per method and run (8 x 400 d), and ``UPDATE_ROW_BYTES`` of
  numpy object overhead per update row of one chunk (rows are stacked at the end of every chunk).

Results kept at every output epoch (T within SCREEN_BINS):

- per output epoch, method and run the eleven error/sigma/NEES series, the five block NEES and
  the estimated position (``OUTPUT_DOUBLES`` = 19 d), held four times at the end (the bank's
  chunks, their concatenation, the result handed to the queue and its pickle);
- the sensor errors' estimate, sigma and truth where the worker asks for them
  (tauvcore.engine.results.SENSOR_STATES: ``SENSOR_DOUBLES`` = 3 x 11 d), held three times;
- the thinned live copy (at most ``app.dashboard.worker.PROGRESS_MAX_EPOCHS`` epochs, copy and pickle);
- per update (DVL ping per DVL method, depth and magnetometer sample and a plug-in source's epoch,
  at its ``rate_hz``, per aided method) ~20 d per run (``UPDATE_DOUBLES``), four times as well.

Results reduced to B bins (T beyond SCREEN_BINS, B <= SCREEN_BINS):

- per bin, method and run the series at the bin's last epoch (``OUTPUT_DOUBLES``) and the sensor
  errors with their minimum and maximum (``BIN_SENSOR_COPIES`` x ``SENSOR_DOUBLES``), and per bin
  and method the minimum and maximum of the plotted curves (``BIN_CURVE_DOUBLES``), four times
  (the bins, the live and the final message and its pickle);
- per bin with updates, aided method and run the last update and the innovations' envelope
  (``BIN_UPDATE_DOUBLES``), four times;
- one chunk's results and updates as the banks hand them out, four times;
- what grows with the mission, a few bytes per update: the divergence monitor's columns of every
  update and run (``MONITOR_BYTES``); and the Sensors tab's view (app.figures.sensor_view), counted as
  ``SOURCE_VIEW_DOUBLES`` per DVL ping and fused source's epoch, a bound: it is thinned as it
  comes to at most twice ``app.figures.sensor_view.MAX_SOURCE_EPOCHS`` epochs per source.

The smoother (``smooth_mb``: tauvcore.engine.smoothing) adds, for the M methods (Yoo 2014's
12-state filters counted as the 20-state filter's, a bound), its tape of the forward pass: per output epoch, method and run the transition
since the last mark, P and the error against truth and the filtered estimates
(``TAPE_OUTPUT_DOUBLES``), per aiding epoch (a DVL ping, a fused source's epoch) the transition, P
before and after and the correction (``TAPE_AIDING_DOUBLES``), held in memory up to half of
``smooth_mb`` (the rest in a temporary file); the smoothed stores of its backward pass
(``OUTPUT_DOUBLES`` and the estimates per epoch, up to the other half); and the smoothed results, the size of the
filtered series (``OUTPUT_DOUBLES``; in bins the same bins), as many times as those. A run kept at
every epoch lets its tape go before it gathers the smoothed results, so it counts the larger of
the two; a run in bins holds its bins, the tape and the stores at once.

The sensor errors are recorded only where their records (per kept epoch) stay within
``SENSOR_RECORDS_MAX_BYTES`` and the run fits the budget with them
(:func:`records_sensor_errors`); the budget refuses a run that does not fit even without them.

The estimate is the sum, plus ``SLACK`` (15 %) for the allocator's pages, plus ``FIXED_BYTES`` for
what a run loads once: the compiled kernels of the filter bank (tauvcore.filter.kernels,
tauvcore.engine.loop: numba's machine code and its LLVM context, 62-64 MiB measured for a 10 s
run once the fused stretch kernel ``run_stops`` joined them; 14-16 MiB more since the geodetic
path, its truth integrator included), and lazily imported modules. The dynamic truth
(tauvcore.truth.dynamic) adds its compiled vehicle and autopilot and its mission
(``DYNAMIC_FIXED_BYTES``, 12 MiB measured for a streamed 20 min mission) and, for a mission short
enough to keep, its knots (``KNOT_DOUBLES`` per sample). tests/unit/app/dashboard/test_budget.py checks it
against the measured peak resident memory of real runs, a 3 h mission in bins among them
(estimate >= measured, within 1.5x). The server holds one more unpickled copy of the results per
tab and one pickled copy is in transit through the worker's pipe: :func:`estimate_run` reports
them apart (``results_bytes``), and the budget applies to the sum (``RunEstimate.total_bytes``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from tauvcore.aiding.sources import FUSED
from tauvcore.config import Config
from tauvcore.eval.envelope import epochs_per_bin

DOUBLE = 8
TRUTH_BUILD_DOUBLES = 169
COMPENSATION_DOUBLES = 12 + 6 + 6 + 13
OUTPUT_DOUBLES = 11 + 5 + 3
SENSOR_DOUBLES = 3 * 11
SENSOR_COPIES = 3
SENSOR_RECORDS_MAX_BYTES = 64 * 2**20
"""The sensor errors are recorded only for runs whose records are at most this large (20 runs of
five methods over 250 s: 63 MiB; a longer mission's per bin: 10 runs of them over 1 h, 9 over 10 h)."""
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
LIVE_EPOCHS = (
    1200  # app.dashboard.worker.PROGRESS_MAX_EPOCHS (not imported: app.dashboard.worker starts processes)
)

BIN_CURVE_DOUBLES = 2 * (10 + 6)  # minimum and maximum per bin of the ten run curves and six NEES
# curves (tauvcore.eval.envelope.RUN_CURVES, curve_key), whatever the runs
BIN_SENSOR_COPIES = 3  # the sensor errors per bin: the last epoch's, their minimum and maximum
BIN_UPDATE_DOUBLES = UPDATE_DOUBLES + 4 * 4  # an update bin: the last update's fields, and per row
# (TC: 4) the innovation's minimum and maximum, the largest 3-sigma, the last rejected innovation
MONITOR_BYTES = 2 * (3 * 8 + 3)  # per update and run the divergence monitor keeps for the whole
# mission (time, NIS, dof; fused, valid, reset), its arrays grown by doubling
SOURCE_VIEW_DOUBLES = 16  # per aiding-source epoch the Sensors tab's view keeps (columns, truth)

TAPE_OUTPUT_DOUBLES = 9 * 15 + 20 * 20 + 20 + 9  # the smoother's output mark: transition (9 x 15),
# P, the error against truth, the filtered estimates (tauvcore.engine.tape.OUTPUT_TAPE, ESTIMATES)
TAPE_AIDING_DOUBLES = 9 * 15 + 2 * 20 * 20 + 20  # an aiding mark: transition, P before and after,
# the correction
SMOOTHED_STORE_DOUBLES = OUTPUT_DOUBLES + 6  # a smoothed store's epoch: the series, velocity and
# attitude estimates

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


def estimate_run(
    config: Config, num_runs: int, sensor_errors: bool = True, smooth_mb: float | None = None
) -> RunEstimate:
    """Estimated memory of ``num_runs`` Monte Carlo runs of ``config`` (see the module docstring).

    Parameters
    ----------
    config : Config
        The run's configuration.
    num_runs : int
        Monte Carlo runs R.
    sensor_errors : bool
        Whether the sensor errors are recorded.
    smooth_mb : float or None
        The smoother's tape held in memory [MB] (tauvcore.engine.smoothing.SmoothOptions.budget_mb);
        None: no smoother.

    Returns
    -------
    RunEstimate
        The estimate [bytes].
    """
    n = _Counts(config, num_runs)
    sensor_doubles = SENSOR_DOUBLES if sensor_errors else 0
    chunk = TRUTH_BUILD_DOUBLES * DOUBLE * n.K_c + COMPENSATION_DOUBLES * DOUBLE * n.K_c * n.R
    k = epochs_per_bin(n.T)
    if k == 1:
        outputs, sensors, update_data, end = _kept_every_epoch(n, sensor_doubles)
    else:
        outputs, sensors, update_data, end = _kept_in_bins(n, k, sensor_doubles)
    end += int(UPDATE_ROW_BYTES * (n.dvl_rows + n.other_rows) * n.chunk_fraction)  # the update rows' objects
    end += COVARIANCE_DOUBLES * DOUBLE * n.M * n.R
    smoothed = 0
    if smooth_mb is not None and n.M:
        smoothed, smoother_end = _smoother(n, smooth_mb, sensor_doubles, k > 1, outputs, sensors)
        end += smoother_end
    fixed = FIXED_BYTES
    if config.trajectory.truth == "dynamic":
        fixed += DYNAMIC_FIXED_BYTES
        chunk += KNOT_DOUBLES * DOUBLE * ((n.K + 1) if n.K + 1 <= CACHE_MAX_KNOTS else n.K_c)
    return RunEstimate(
        chunk_bytes=chunk,
        end_bytes=end,
        results_bytes=outputs + sensors + update_data + smoothed,
        worker_peak_bytes=int(SLACK * (chunk + end)) + fixed,
    )


class _Counts:
    """What the memory of ``num_runs`` Monte Carlo runs of ``config`` grows with (the module
    docstring's K, K_c, T, R and M)."""

    def __init__(self, config: Config, num_runs: int) -> None:
        rate_hz, duration_s = config.imu.rate_hz, config.trajectory.duration_s
        step = max(1, round(rate_hz / config.filter.output_rate_hz))
        self.K = round(duration_s * rate_hz) + 1  # IMU samples of the mission, and of one chunk:
        self.K_c = min(self.K, round(max(STREAM_CHUNK_S, 1.0 / config.dvl.rate_hz) * rate_hz) + 1)
        self.T, self.T_c = math.ceil(self.K / step), math.ceil(self.K_c / step)  # output epochs (of a chunk)
        self.R, self.M = int(num_runs), len(config.run.methods)
        aiding = set(config.run.aiding)
        self.dvl_methods = sum(1 for m in config.run.methods if m != "ins")  # the methods aided
        self.pings = math.ceil(duration_s * config.dvl.rate_hz + 1) if "dvl" in aiding else 0  # DVL pings
        self.source_updates = [  # epochs of each plug-in source fused (none without an aided method)
            math.ceil(duration_s * source.rate_hz(config.section(source.section_name)) + 1)
            for name, source in FUSED.items()
            if self.dvl_methods and name in aiding
        ]
        self.other_updates = sum(self.source_updates)
        self.dvl_rows = self.pings * self.dvl_methods  # update rows of the DVL
        self.other_rows = self.other_updates * self.dvl_methods  # ... and of the plug-in sources
        self.chunk_fraction = min(1.0, self.K_c / self.K)  # the share of the mission in one chunk


def _kept_every_epoch(n: _Counts, sensor_doubles: int) -> tuple[int, int, int, int]:
    """A run kept at every output epoch: its results' series, sensor errors and updates (one copy
    each) and what they take at the end, copies and the live copy included [bytes]."""
    outputs = OUTPUT_DOUBLES * DOUBLE * n.T * n.M * n.R
    sensors = sensor_doubles * DOUBLE * n.T * n.M * n.R
    live = 2 * (OUTPUT_DOUBLES + sensor_doubles) * DOUBLE * min(n.T, LIVE_EPOCHS) * n.M * n.R
    update_data = UPDATE_DOUBLES * DOUBLE * n.R * (n.dvl_rows + n.M * n.other_updates)
    end = OUTPUT_COPIES * (outputs + update_data) + SENSOR_COPIES * sensors + live
    return outputs, sensors, update_data, end


def _kept_in_bins(n: _Counts, k: int, sensor_doubles: int) -> tuple[int, int, int, int]:
    """A run reduced to bins of ``k`` output epochs: as :func:`_kept_every_epoch` (its sensor
    errors in the bins), with one chunk's results, the divergence monitor and the Sensors tab's
    view at the end [bytes]."""
    B = math.ceil(n.T / k)
    outputs = (
        ((OUTPUT_DOUBLES + sensor_doubles * BIN_SENSOR_COPIES) * n.R + BIN_CURVE_DOUBLES) * DOUBLE * B * n.M
    )
    binned_rows = (min(B, n.pings) + sum(min(B, u) for u in n.source_updates)) * n.dvl_methods
    update_data = BIN_UPDATE_DOUBLES * DOUBLE * n.R * binned_rows
    rows = n.dvl_rows + n.other_rows
    chunk_results = (OUTPUT_DOUBLES + sensor_doubles) * DOUBLE * n.T_c * n.M * n.R
    chunk_results += UPDATE_DOUBLES * DOUBLE * n.R * int(rows * n.chunk_fraction)
    monitor = MONITOR_BYTES * n.R * rows
    sensor_view = SOURCE_VIEW_DOUBLES * DOUBLE * (n.pings + n.other_updates)
    end = OUTPUT_COPIES * (outputs + update_data) + OUTPUT_COPIES * chunk_results + monitor + sensor_view
    return outputs, 0, update_data, end


def _smoother(
    n: _Counts, smooth_mb: float, sensor_doubles: int, binned: bool, outputs: int, sensors: int
) -> tuple[int, int]:
    """The smoother's results (one copy, as large as the filtered ``outputs`` and ``sensors``)
    and what the smoother adds at the end: its tape and stores, each held in memory up to half
    of ``smooth_mb``, and its results' copies [bytes]."""
    held = int(smooth_mb * 1e6) // 2  # each of the tapes (marks, smoothed stores) holds half of it
    # per method and run a mark at every output epoch (the sensor errors' rows too) and aiding epoch
    marks = n.T * (TAPE_OUTPUT_DOUBLES + sensor_doubles) + (n.pings + n.other_updates) * TAPE_AIDING_DOUBLES
    tape = DOUBLE * n.M * n.R * marks
    stores = DOUBLE * n.M * n.R * n.T * (SMOOTHED_STORE_DOUBLES + sensor_doubles)
    if not binned:
        smoothed = outputs + sensors
        # the tape is let go before the smoothed results are gathered: whichever is larger
        return smoothed, max(min(tape, held) + min(stores, held), OUTPUT_COPIES * smoothed)
    # one segment and its smoothing's scratch (the pass's covariances)
    segment = DOUBLE * n.M * n.R * n.T_c * (TAPE_OUTPUT_DOUBLES + 2 * 20 * 20)
    # the smoothed bins and their pickle (no live copy: they come with the final message)
    return outputs, min(tape, held) + min(stores, held) + segment + 2 * outputs


def records_sensor_errors(
    config: Config, num_runs: int, limit_bytes: int, smooth_mb: float | None = None
) -> bool:
    """Whether a dashboard run of ``config`` records the sensor errors (the Sensors tab's lower
    figure): only when, with them, it fits ``limit_bytes`` and their records stay within
    ``SENSOR_RECORDS_MAX_BYTES`` (they travel from the worker with every result).

    Parameters
    ----------
    config : Config
        The run's configuration.
    num_runs : int
        Monte Carlo runs R.
    limit_bytes : int
        The run's memory budget [bytes].
    smooth_mb : float or None
        The smoother's tape held in memory [MB] (:func:`estimate_run`); None: no smoother.

    Returns
    -------
    bool
        Whether the run records them.
    """
    T, M, R = kept_epochs(config), len(config.run.methods), int(num_runs)
    if SENSOR_DOUBLES * DOUBLE * T * M * R > SENSOR_RECORDS_MAX_BYTES:
        return False
    return estimate_run(config, num_runs, sensor_errors=True, smooth_mb=smooth_mb).total_bytes <= limit_bytes


def output_epochs(config: Config) -> int:
    """Output epochs T of ``config``'s mission (the first at 0 s, every ``filter.output_rate_hz``
    as the IMU's samples allow)."""
    rate_hz = config.imu.rate_hz
    K = round(config.trajectory.duration_s * rate_hz) + 1
    return math.ceil(K / max(1, round(rate_hz / config.filter.output_rate_hz)))


def kept_epochs(config: Config) -> int:
    """Epochs a dashboard run of ``config`` keeps: its output epochs, or of a long mission its
    bins (tauvcore.eval.envelope.epochs_per_bin: at most SCREEN_BINS)."""
    T = output_epochs(config)
    return math.ceil(T / epochs_per_bin(T))


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
