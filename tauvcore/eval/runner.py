"""Run a scenario: simulate truth and sensors once, then every selected method side by side.

The nominal state runs at the IMU rate; the covariance is propagated at
``filter.covariance_rate_hz`` (and always up to an aiding or output epoch) with F evaluated at
the current nominal state and the mean rate over the interval, ``Phi = expm(F dt_c)`` to third
order. At 10 Hz the rotation over one interval is < 0.02 rad, so this costs nothing in accuracy
(the NEES test checks it) and a fifteenth of the work.

Methods and Monte Carlo runs are array dimensions of one filter bank (batch ``(M, R)``): the
IMU-rate loop (strapdown step and covariance propagation) runs once for all of them, and each
aiding epoch applies its update only to the methods that use it ("when" lives here, "how" in
tauvcore.aiding). Every update leaves an :class:`UpdateRecord`; every output epoch leaves the
error norms (attitude also split into tilt and heading), the filter's own 1-sigma, and the NEES
against truth of the full state and of each block of :data:`~tauvcore.filter.layout.NEES_BLOCKS`
(position, velocity, tilt, heading, sensor errors); every update record carries its NIS.

Numerical health (issue 7): after the corrections of every aiding epoch, and at least once per
second of propagation (:data:`CONDITION_CHECK_RATE_HZ`), P goes through
:func:`~tauvcore.filter.eskf.condition_covariance` (one batched Cholesky for all methods and
runs; an eigenvalue floor only where it fails, counted per run in ``MethodResult.p_floor_count``). The divergence
monitor flags a run's solution (``MethodResult.diverged``, ``diverged_at_s``) at the first of

- an output epoch where its state or P is not finite;
- an aiding epoch after which an estimated sensor error (IMU or DVL bias, DVL scale factor) lies far
  outside the filter's own prior (:func:`~tauvcore.eval.metrics.implausible_sensor_errors`);
- an innovation inconsistency of any of its aiding sources
  (:func:`~tauvcore.eval.metrics.innovation_divergence_s`: windowed NIS above its chi-square
  bound, or the source locked out by the gate).

It uses no truth, as a real filter could not; so it cannot see an error in a direction nothing
measures (heading on a straight line with the DVL alone, or VB's self-confirming virtual beam on
a fixed pair at a small n_f): the NEES against truth in the records shows those. The standalone
INS has no innovations and estimates no sensor error: it is flagged only if not finite.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from tauvcore import units
from tauvcore.aiding import Depth, MagAttitude, elc_select
from tauvcore.aiding.dvl_extended import (
    ELC_METHODS,
    MODE_COAST,
    MODE_LC,
    MODE_PARTIAL,
    MODE_TC,
    DvlExtended,
)
from tauvcore.aiding.noise_floors import dvl_beam_sigma_mps
from tauvcore.aiding.registry import REGISTRY
from tauvcore.config import Config
from tauvcore.eval.metrics import innovation_divergence_s, sensor_prior_bound
from tauvcore.filter import kernels
from tauvcore.filter.eskf import (
    Measurement,
    Nominal,
    UpdateOutcome,
    condition_covariance,
    fuse_in_place,
    make_outcome,
)
from tauvcore.filter.layout import NEES_BLOCKS, NOISE, STATE
from tauvcore.geo.rotations import (
    C_nb_from_euler,
    euler_from_misalignment_jacobian,
    exp_so3,
)
from tauvcore.ins.error_model import noise_psd
from tauvcore.ins.strapdown import NavState, Strapdown, body_increments, mv
from tauvcore.sensors import dvl as dvl_sensor
from tauvcore.sensors import echosounder as echo_sensor
from tauvcore.sensors import imu as imu_sensor
from tauvcore.sensors import magnetometer as mag_sensor
from tauvcore.sensors import pressure as pressure_sensor
from tauvcore.sensors import rpm as rpm_sensor
from tauvcore.sensors.stream import SensorStream, SensorStreams
from tauvcore.truth import Truth, generate, truth_stream
from tauvcore.truth.kinematic import bathymetry

CONDITION_CHECK_RATE_HZ = 1.0
"""P is checked (and repaired if need be) after the corrections of every aiding epoch, where
updates can lose definiteness to round-off, and at least this often in between (propagation
alone, e.g. the standalone INS or a DVL outage, only carries a positive definite P forward)."""

DVL_FUSION = {"ins": None, "lc": "lc", "tc": "tc", **{m: "elc" for m in ELC_METHODS}}
"""How each method fuses the DVL (None: not at all; a registered method, tauvcore.aiding.registry,
is not in it and takes no DVL)."""


@dataclass(frozen=True)
class Simulation:
    """Truth and every sensor's output for R Monte Carlo runs (run axis after time)."""

    truth: Truth
    imu: imu_sensor.ImuData
    dvl: dvl_sensor.DvlData
    pressure: pressure_sensor.PressureData
    mag: mag_sensor.MagnetometerData
    num_runs: int
    echo: echo_sensor.EchoSounderData | None = None  # echo sounder (None: a log without one)
    rpm: rpm_sensor.RpmData | None = None  # propeller RPM (None: a log without one)


def simulate(
    config: Config, rng: np.random.Generator, num_runs: int = 1, truth: Truth | None = None
) -> Simulation:
    """Generate the truth (unless given) and the sensor outputs (errors zeroed if ``config.run.ideal``)."""
    ideal = config.run.ideal
    if truth is None:
        truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    imu_cfg = config.imu.ideal() if ideal else config.imu
    dvl_cfg = config.dvl.ideal() if ideal else config.dvl
    p_cfg = config.pressure.ideal() if ideal else config.pressure
    m_cfg = config.magnetometer.ideal() if ideal else config.magnetometer
    seabed = bathymetry(config.trajectory)
    extra = rng.spawn(1)[0]
    return Simulation(
        truth=truth,
        imu=imu_sensor.simulate(truth, imu_cfg, rng, num_runs),
        dvl=dvl_sensor.simulate(truth, dvl_cfg, rng, num_runs, seabed),
        pressure=pressure_sensor.simulate(truth, p_cfg, rng, num_runs),
        mag=mag_sensor.simulate(truth, m_cfg, rng, num_runs),
        num_runs=num_runs,
        # from a child of rng (spawning draws nothing): what rng draws next, the filters'
        # initial errors, is what it drew before these sensors existed
        echo=echo_sensor.simulate(
            truth, config.echo_sounder.ideal() if ideal else config.echo_sounder, seabed, extra, num_runs
        ),
        rpm=rpm_sensor.simulate(truth, config.rpm.ideal() if ideal else config.rpm, extra, num_runs),
    )


@dataclass(frozen=True)
class UpdateRecord:
    """Every update of one aiding source for one method: U epochs x R runs."""

    t_s: np.ndarray  # (U,)
    z: np.ndarray  # (U, R, m) observation
    innovation: np.ndarray  # (U, R, m)
    innovation_var: np.ndarray  # (U, R, m) diagonal of S
    test_ratio: np.ndarray  # (U, R) max_i nu_i^2 / (gate^2 S_ii)
    fused: np.ndarray  # (U, R) bool
    rejected: np.ndarray  # (U, R) bool (failed the gate)
    valid: np.ndarray  # (U, R) bool (the source produced a measurement)
    fused_rows: np.ndarray  # (U, R, m) bool
    rejected_rows: np.ndarray  # (U, R, m) bool
    nis: np.ndarray  # (U, R) normalised innovation squared over the active rows, before the gate
    nis_dof: np.ndarray  # (U, R) int: its degrees of freedom (active rows)
    unusable: np.ndarray  # (U, R) bool: S not finite or not positive definite, nothing fused
    beams_available: np.ndarray | None = None  # (U, R, 4) DVL only: beams that returned
    mode: np.ndarray | None = None  # (U, R) DVL only: MODE_* code (coast, lc, partial, tc)
    measured_axes: np.ndarray | None = None  # (U, R, 3) DVL only: body axes the velocity carried
    elc_choice: np.ndarray | None = None  # (U, R, 3) ELC only: index into elc_select.CANDIDATES


@dataclass(frozen=True)
class MethodResult:
    """Per-epoch results of one method over R runs (time first)."""

    method: str
    t_s: np.ndarray  # (T,) output epochs [s]
    vel_err_mps: np.ndarray  # (T, R) |body velocity error|
    att_err_deg: np.ndarray  # (T, R) |misalignment| (tilt and heading together)
    pos_err_m: np.ndarray  # (T, R) |position error|
    vel_sigma_mps: np.ndarray  # (T, R) sqrt(trace P_vel), the filter's own 1-sigma of the norm
    att_sigma_deg: np.ndarray  # (T, R)
    pos_sigma_m: np.ndarray  # (T, R)
    nees: np.ndarray  # (T, R) full 20-state NEES against truth
    tilt_err_deg: np.ndarray  # (T, R) |(rho_N, rho_E)|: roll/pitch (levelling) error
    heading_err_deg: np.ndarray  # (T, R) |rho_D|: heading (azimuth) error
    tilt_sigma_deg: np.ndarray  # (T, R) sqrt(P_NN + P_EE) of the misalignment
    heading_sigma_deg: np.ndarray  # (T, R) sqrt(P_DD) of the misalignment
    nees_block: np.ndarray  # (T, R, B) NEES of each block of layout.NEES_BLOCKS (in its order)
    est_pos_n: np.ndarray  # (T, R, 3) estimated position, NED [m] from the sea-surface point above the start
    # (on WGS-84 in that point's tangent frame: tauvcore.geo.earth.geodetic_from_ned)
    diverged: np.ndarray  # (R,) bool: the divergence monitor flagged this run's solution
    diverged_at_s: np.ndarray  # (R,) time of the first flag [s], NaN if never
    p_floor_count: np.ndarray  # (R,) times an eigenvalue of P was raised to the floor
    updates: dict[str, UpdateRecord] = field(default_factory=dict)
    est_vel_n: np.ndarray | None = None  # (T, R, 3) estimated NED velocity [m/s]
    est_euler_rad: np.ndarray | None = None  # (T, R, 3) estimated roll, pitch, yaw [rad]
    block_dims: dict[str, int] | None = None  # NEES dimensions when not the 20-state filter's (Yoo 2014's
    # 12: tauvcore.eval.yoo_bank.BLOCK_DIMS); None: consistency.BLOCK_DIMS
    vkf_trace: dict[str, np.ndarray] | None = None  # the velocity Kalman filter at every ping (method vkf:
    # tauvcore.eval.yoo_bank.YooBank._vkf_series)


def _initial_draws(
    rng: np.random.Generator | Sequence[np.random.Generator], R: int
) -> tuple[np.ndarray, ...]:
    """Standard normals of the random initial errors (position, misalignment, velocity), (R, 3)
    each: from one generator for the whole batch, or one per run (a study's runs, each its own
    seeded unit: tauvcore.eval.study)."""
    if isinstance(rng, np.random.Generator):
        return rng.standard_normal((R, 3)), rng.standard_normal((R, 3)), rng.standard_normal((R, 3))
    if len(rng) != R:
        raise ValueError(f"one generator per run expected ({R}), got {len(rng)}")
    draws = [(g.standard_normal(3), g.standard_normal(3), g.standard_normal(3)) for g in rng]
    return tuple(np.stack([d[i] for d in draws]) for i in range(3))


def _initial_nominal(
    config: Config,
    truth: Truth,
    rng: np.random.Generator | Sequence[np.random.Generator],
    batch: tuple[int, int],
    P0_nav_att: np.ndarray,
) -> Nominal:
    """Estimate at t = 0: truth with the initial errors (fixed, or drawn per run), biases zero."""
    _, R = batch
    ie = config.initial_error.ideal() if config.run.ideal else config.initial_error
    assert truth.pos_nav is not None  # Truth.__post_init__ sets pos_n where it was not given
    pos_true, C_true, v_true_b = truth.pos_nav[0], truth.C_nb[0], truth.vel_b[0]

    def moved(offset_m: np.ndarray) -> np.ndarray:
        """The true position moved by (R, 3) north, east, down metres (on WGS-84: latitude,
        longitude and depth through the metric there)."""
        offset_m = np.ascontiguousarray(np.broadcast_to(offset_m, (R, 3)), dtype=float)
        if not truth.earth.geodetic:
            return pos_true + offset_m
        return kernels.add_position_batch(
            np.ascontiguousarray(np.broadcast_to(pos_true, (R, 3))), offset_m, True
        )

    if ie.mode == "fixed":
        pos = moved(np.asarray(ie.pos_m))
        C = np.broadcast_to(C_nb_from_euler(truth.euler[0] + np.asarray(ie.euler_rad)), (R, 3, 3))
        vel_b = np.broadcast_to(v_true_b + np.asarray(ie.vel_mps), (R, 3))
    else:
        n_pos, n_rho, n_vel = _initial_draws(rng, R)
        pos = moved(n_pos * np.asarray(ie.pos_m))
        rho = (np.linalg.cholesky(P0_nav_att) @ n_rho[..., None])[..., 0]
        C = exp_so3(-rho) @ C_true  # C_true = exp(rho) C_hat
        vel_b = v_true_b + n_vel * np.asarray(ie.vel_mps)
    vel_n = mv(C, vel_b)
    nav = NavState(
        pos_n=np.broadcast_to(pos, batch + (3,)).copy(),
        vel_n=np.broadcast_to(vel_n, batch + (3,)).copy(),
        C_nb=np.broadcast_to(C, batch + (3, 3)).copy(),
    )
    return Nominal(
        nav=nav,
        accel_bias=np.zeros(batch + (3,)),
        gyro_bias=np.zeros(batch + (3,)),
        dvl_bias=np.zeros(batch + (4,)),
        dvl_sf=np.zeros(batch),
    )


def initial_covariance(config: Config, euler0: np.ndarray) -> np.ndarray:
    """P0 (20, 20) from the initial-error and sensor sections (Table 2 values as 1-sigma).

    The attitude block maps the Euler-angle sigmas into the n-frame misalignment:
    ``P_rho = J^-1 diag(sigma_euler^2) J^-T``, ``J = d euler / d rho`` at the initial attitude.

    The filter has no states for the IMU's scale factors and misalignments (the paper's 20
    states). On a vehicle that cruises level they act on gravity alone, as a constant bias: the
    x and y accelerometers see ``m g`` of the axis leaning towards z, the z accelerometer ``s g``;
    so that part joins the accelerometer bias's initial sigma, and the filter's bias states take
    it in. What they do with turn rates and accelerations stays unmodelled (150 ppm of a 10 deg/s
    turn is 5 deg/h while it lasts).
    """
    ie, imu, dvl = config.initial_error, config.imu, config.dvl
    P0 = np.zeros((STATE.dim, STATE.dim))
    P0[STATE.pos, STATE.pos] = np.diag(np.square(ie.pos_m))
    J_inv = np.linalg.inv(euler_from_misalignment_jacobian(euler0))
    P0[STATE.att, STATE.att] = J_inv @ np.diag(np.square(ie.euler_rad)) @ J_inv.T
    P0[STATE.vel, STATE.vel] = np.diag(np.square(ie.vel_mps))
    g = float(np.linalg.norm(config.earth.g_n))
    axes_on_gravity = g * np.array(
        [imu.accel_misalignment_rad, imu.accel_misalignment_rad, imu.accel_scale_factor]
    )
    P0[STATE.ba, STATE.ba] = np.diag(imu.accel_bias_mps2**2 + axes_on_gravity**2)
    P0[STATE.bg, STATE.bg] = np.eye(3) * imu.gyro_bias_rps**2
    P0[STATE.b_dvl, STATE.b_dvl] = np.eye(4) * dvl.bias_mps**2
    P0[STATE.sf_dvl, STATE.sf_dvl] = dvl.scale_factor**2
    # a zero tuning value would make P0 singular; keep a floor far below any real error
    return P0 + np.eye(STATE.dim) * 1e-16


def _epoch_map(indices: np.ndarray) -> dict[int, int]:
    return {int(k): i for i, k in enumerate(indices)}


class _Recorder:
    """Collects the updates of one source for the whole bank (methods x runs, one row per update:
    the compiled correction's outcome as it comes, no per-method copies), and hands out each
    method's record (:meth:`build`).

    Rows are stacked into one array per field at the end of every chunk (:meth:`seal`), so a long
    mission holds a few arrays per chunk, not thousands of tiny ones; sealed chunks can be handed
    out and dropped (:meth:`drain`), while what the divergence monitor needs (times, NIS, dof,
    fused, valid: a few bytes per update and run) is kept for the whole mission.

    ``members`` (M,): the methods this source updates (they get a record); ``rows`` (M,): how many
    measurement rows each method's record has (the DVL's widest is tightly coupled's 4; the loosely
    coupled velocity's 3), None: all. ``shared``: fields of the ping, the same for every method
    (the beams that returned)."""

    MONITOR = ("nis", "nis_dof", "fused", "valid")
    ROW_FIELDS = ("z", "innovation", "innovation_var", "fused_rows", "rejected_rows")

    def __init__(self, members: npt.ArrayLike, rows: np.ndarray | None = None) -> None:
        self.members = np.asarray(members, dtype=bool)
        self.rows_of = rows
        self.t: list[float] = []
        self.rows: list[dict[str, np.ndarray]] = []
        self.chunks: list[tuple[np.ndarray, dict[str, np.ndarray]]] = []  # sealed (t, fields)
        self.monitor_t = np.zeros(0)  # the monitor's columns, grown by doubling
        self.monitor: dict[str, np.ndarray] = {}
        self.taken = 0  # sealed chunks already handed out (FilterBank.take with keep)
        self.count = 0  # updates recorded over the whole mission

    def add(
        self,
        t: float,
        outcome: UpdateOutcome,
        valid: np.ndarray,
        shared: dict[str, np.ndarray] | None = None,
        **extra: np.ndarray,
    ) -> None:
        """One update of every method and run: ``outcome`` and ``valid``, ``extra`` (M, R, ...);
        ``shared`` (R, ...)."""
        self.t.append(t)
        self.rows.append(
            {
                "z": outcome.z,
                "innovation": outcome.innovation,
                "innovation_var": outcome.innovation_var,
                "test_ratio": outcome.test_ratio,
                "fused": outcome.fused,
                "rejected": outcome.rejected,
                "valid": valid,
                "fused_rows": outcome.fused_rows,
                "rejected_rows": outcome.rejected_rows,
                "nis": outcome.nis,
                "nis_dof": outcome.nis_dof,
                "unusable": outcome.unusable,
                **extra,
                **{f"shared:{k}": v for k, v in (shared or {}).items()},
            }
        )
        self.count += 1

    def seal(self) -> None:
        if not self.rows:
            return
        fields = {k: np.stack([r[k] for r in self.rows]) for k in self.rows[0]}
        t = np.asarray(self.t)
        self.chunks.append((t, fields))
        self._monitor_append(t, fields)
        self.t, self.rows = [], []

    def _monitor_append(self, t: np.ndarray, fields: dict[str, np.ndarray]) -> None:
        """Copy a chunk's monitor columns into buffers that double when full (a long mission's
        monitor is then four arrays, not four per chunk)."""
        done = self.count - t.size
        if not self.monitor:
            self.monitor_t = np.empty(max(64, t.size))
            self.monitor = {
                k: np.empty((self.monitor_t.size,) + fields[k].shape[1:], fields[k].dtype)
                for k in self.MONITOR
            }
        if done + t.size > self.monitor_t.size:
            size = max(2 * self.monitor_t.size, done + t.size)
            self.monitor_t = np.resize(self.monitor_t, size)
            self.monitor = {k: np.resize(v, (size,) + v.shape[1:]) for k, v in self.monitor.items()}
        self.monitor_t[done : done + t.size] = t
        for k in self.MONITOR:
            self.monitor[k][done : done + t.size] = fields[k]

    def build(self, m: int, first: int = 0) -> UpdateRecord | None:
        """Method ``m``'s record of the sealed chunks from ``first`` on (None if there are none)."""
        chunks = self.chunks[first:]
        if not chunks:
            return None
        rows = None if self.rows_of is None else int(self.rows_of[m])
        fields = {}
        for k in chunks[0][1]:
            if k.startswith("shared:"):
                fields[k[len("shared:") :]] = np.concatenate([c[1][k] for c in chunks])
                continue
            a = np.concatenate([c[1][k][:, m] for c in chunks])
            fields[k] = a[..., :rows] if rows is not None and k in self.ROW_FIELDS else a
        return UpdateRecord(t_s=np.concatenate([c[0] for c in chunks]), **fields)

    def drain(self) -> None:
        self.chunks = []
        self.taken = 0

    def divergence_s(self, m: int) -> np.ndarray:
        """First flag of method ``m``'s innovation test over the whole mission so far (R,)."""
        n = self.count - len(self.t)  # sealed updates
        c = {k: v[:n, m] for k, v in self.monitor.items()}
        return innovation_divergence_s(self.monitor_t[:n], c["nis"], c["nis_dof"], c["fused"], c["valid"])


@dataclass(frozen=True)
class SimChunk:
    """Samples ``k0 .. k0 + n - 1`` of a simulation: truth and IMU rows for those samples, the aiding
    sensors' epochs among them (global sample indices), run axis after time."""

    k0: int
    truth: Truth
    imu: imu_sensor.ImuData
    dvl: dvl_sensor.DvlData
    pressure: pressure_sensor.PressureData
    mag: mag_sensor.MagnetometerData
    echo: echo_sensor.EchoSounderData | None = None
    rpm: rpm_sensor.RpmData | None = None

    @classmethod
    def whole(cls, sim: Simulation) -> SimChunk:
        return cls(0, sim.truth, sim.imu, sim.dvl, sim.pressure, sim.mag, sim.echo, sim.rpm)


DVL_ROWS = 4
"""The widest DVL measurement (tightly coupled: one row per beam); narrower ones are padded with
inactive rows so that one compiled correction fuses every DVL method of a ping."""


DVL_MODE_CODES = np.array([MODE_COAST, MODE_LC, MODE_PARTIAL, MODE_TC], dtype=np.int64)
"""The record's DVL mode codes in the order the compiled DVL kernel takes them."""


PartialTables = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""n_cand, ok, C, D, gain, assumption error and measured rows: :func:`partial_tables`."""


def partial_tables(methods: Sequence[str], config: Config) -> PartialTables:
    """The two-beam constructions of each DVL method, for every pattern of two returned beams
    (index: the sum of 2^k over the beams k), from the methods' own ``solve`` functions
    (tauvcore.aiding.elc_*): candidates (1, or the selector's 4), ok, C, D, gain, assumption
    error and measured rows, as :func:`tauvcore.filter.kernels.dvl_measure_bank` takes them."""
    n, K = len(methods), kernels.MAX_CANDIDATES
    n_cand = np.ones(n, np.int64)
    ok = np.zeros((n, 16, K), bool)
    Cc, Dc = np.zeros((n, 16, K, 3, 4)), np.zeros((n, 16, K, 3, 3))
    gc, ac, mc = np.ones((n, 16, K, 3)), np.zeros((n, 16, K, 3)), np.zeros((n, 16, K, 3), bool)
    pitch, n_f, eps = config.dvl.beam_pitch_rad, config.partial.vb_nf, config.nsv_epsilon_value_m2_per_s2()
    for i, method in enumerate(methods):
        if DVL_FUSION[method] != "elc":
            continue
        for code in range(16):
            pattern = tuple(bool(code >> k & 1) for k in range(4))
            if sum(pattern) != 2:
                continue
            if method == "elc":
                solutions = elc_select.candidate_solutions(pitch, pattern, n_f, eps)
                n_cand[i] = len(solutions)
            else:
                solutions = [DvlExtended(method, config.dvl, config.earth, 0.0, n_f, eps)._solution(pattern)]
            for c, sol in enumerate(solutions):
                ok[i, code, c] = sol.ok
                Cc[i, code, c], Dc[i, code, c] = sol.C, sol.D
                gc[i, code, c], ac[i, code, c], mc[i, code, c] = (
                    sol.pred_gain,
                    sol.assumption_sd,
                    sol.measured,
                )
    return n_cand, ok, Cc, Dc, gc, ac, mc


def rpm_measurement(
    v_b: np.ndarray, sf: np.ndarray, b_dvl: np.ndarray, A_pinv: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The RPM velocity's prediction ``h`` (..., 3) and Jacobian ``H`` (..., 3, 20) at a state of
    body velocity ``v_b`` (..., 3) [m/s], DVL scale factor ``sf`` (...) and beam biases ``b_dvl``
    (..., 4) [m/s] (``--rpm-fallback``, FilterBank._rpm_fallback). Surge is the speed the VKF
    learned from the DVL, ``(1 + SF) v_b1 + A+_1 . b`` (the first row of the LC measurement, with
    ``A_pinv`` (3, 4) the DVL's A+); sway and heave are the body velocity (taken as zero)."""
    h = np.array(v_b, dtype=float, copy=True)
    h[..., 0] = (1.0 + sf) * v_b[..., 0] + b_dvl @ A_pinv[0]
    H = np.zeros(np.shape(v_b)[:-1] + (3, STATE.dim))
    H[..., STATE.vel] = np.eye(3)
    H[..., 0, STATE.vel.start] = 1.0 + sf
    H[..., 0, STATE.b_dvl] = A_pinv[0]
    H[..., 0, STATE.sf_dvl.start] = v_b[..., 0]
    return h, H


class FilterBank:
    """Every method of ``config.run.methods`` over R runs, fed a simulation chunk by chunk.

    The (methods, runs) nominal states and covariances live in contiguous arrays that the
    compiled kernels (tauvcore.filter.kernels) update in place; between two covariance or event
    epochs the nominal state advances in one kernel call. The state carried from one chunk to the
    next: the last raw IMU increments (coning/sculling and the ping's rate need their
    predecessor), the gyro increments since the last covariance step, and the true DVL errors of
    the latest ping (for the records). Results are kept (``keep``), or handed out chunk by chunk
    (:meth:`take`) and dropped, so that memory does not grow with the mission.
    """

    def __init__(
        self,
        config: Config,
        num_runs: int,
        num_samples: int,
        dt_s: float,
        rng: np.random.Generator | Sequence[np.random.Generator],
        keep: bool = True,
    ) -> None:
        self.config, self.rng, self.keep = config, rng, keep
        self.methods = methods = tuple(config.run.methods)
        M, R = len(methods), num_runs
        self.batch = (M, R)
        self.num_samples, self.dt = num_samples, dt_s
        earth = config.earth
        strapdown = Strapdown(earth, dt_s)
        self.geodetic = earth.geodetic
        self.sd_consts = (
            dt_s,
            strapdown.C_earth,
            strapdown.C_earth_half,
            strapdown.g_n,
            strapdown.coriolis_T,
            self.geodetic,
        )
        # NED positions are recorded from the sea-surface point above the start (Truth.pos_n)
        self.origin = np.array([earth.latitude_rad, earth.longitude_rad, 0.0])
        self.g_n, self.w_ie = np.ascontiguousarray(earth.g_n), np.ascontiguousarray(earth.omega_ie_n)
        self.q_psd = noise_psd(config.imu, config.dvl)
        self.aiding = set(config.run.aiding)
        gyro_rate_noise = config.imu.gyro_noise_rad_per_sqrt_s / np.sqrt(dt_s) * np.sqrt(2.5)
        # the aided methods (every one but the standalone INS) take the depth and magnetometer
        self.other_mask = np.array([DVL_FUSION.get(m) is not None or m in REGISTRY for m in methods])[
            :, None
        ] & np.ones(self.batch, bool)
        self.depth_model = Depth(config.pressure)
        self.mag_model = MagAttitude(config.magnetometer)
        self.dvl_methods = [(i, m) for i, m in enumerate(methods) if DVL_FUSION.get(m) is not None]
        self.dvl_index = np.array([i for i, _ in self.dvl_methods], dtype=np.int64)
        self.dvl_codes = np.array(
            [
                {"lc": kernels.DVL_LC, "tc": kernels.DVL_TC, "elc": kernels.DVL_ELC}[DVL_FUSION[m]]
                for _, m in self.dvl_methods
            ],
            dtype=np.int64,
        )
        self.partial_tables = partial_tables([m for _, m in self.dvl_methods], config)
        self.A_b = np.ascontiguousarray(config.dvl.A_b, dtype=float)
        self.l_dvl_b = np.ascontiguousarray(config.dvl.l_dvl_b, dtype=float)
        self.gyro_rate_noise = gyro_rate_noise
        # tightly coupled beams are gated row by row, the velocities whole (eskf.correct)
        self.dvl_gate_rows = np.zeros(self.batch, bool)
        for m, method in self.dvl_methods:
            self.dvl_gate_rows[m] = DVL_FUSION[method] == "tc"
        dvl_members = np.isin(np.arange(M), self.dvl_index)
        dvl_rows = np.array([DVL_ROWS if DVL_FUSION.get(m) == "tc" else 3 for m in methods], dtype=np.int64)
        others = self.other_mask.any(axis=1)
        self.recorders = {
            "dvl": _Recorder(dvl_members, dvl_rows),
            "depth": _Recorder(others),
            "mag": _Recorder(others),
            "rpm": _Recorder(dvl_members, dvl_rows),
        }
        # registered methods (tauvcore.aiding.registry): each its model, members and epochs
        self.registered = []
        for name in (m for m in methods if m in REGISTRY):
            spec = REGISTRY[name]
            step = max(1, round(config.imu.rate_hz / spec.rate_hz))
            members = np.array([m == name for m in methods])
            self.registered.append(
                (spec.source, spec.model(config), members, np.arange(step, num_samples, step))
            )
            self.recorders[spec.source] = _Recorder(members)
        # --rpm-fallback: one velocity Kalman filter per run (tauvcore.eval.yoo_bank.RpmAid)
        self.rpm_aid = None
        if config.run.rpm_fallback and self.dvl_methods and "dvl" in self.aiding:
            from tauvcore.eval.yoo_bank import RpmAid

            self.rpm_aid = RpmAid(config.vkf, R)
            self.rpm_A_pinv = np.linalg.pinv(np.asarray(config.dvl.A_b, dtype=float))  # (3, 4): LC's A+
        out_step = max(1, round(config.imu.rate_hz / config.filter.output_rate_hz))
        self.out_idx = np.arange(0, num_samples, out_step)
        self.cov_step = max(1, round(config.imu.rate_hz / config.filter.covariance_rate_hz))
        self.check_step = max(1, round(config.imu.rate_hz / CONDITION_CHECK_RATE_HZ))
        self.block_of_state = np.full(STATE.dim, -1)
        for b, ix in enumerate(NEES_BLOCKS.values()):
            self.block_of_state[list(ix)] = b
        self.gate = config.filter.gate_sigma
        self.p_floor_count = np.zeros(self.batch, dtype=int)
        self.nonfinite_at_s = np.full(self.batch, np.nan)  # first output epoch with a non-finite state or P
        self.implausible_at_s = np.full(
            self.batch, np.nan
        )  # first aiding epoch with a sensor error outside its prior
        self.slot = 0  # output epochs recorded so far
        self.taken = 0  # output epochs handed out by take()
        self.stored: list[dict[str, np.ndarray]] = []  # recorded output epochs, chunk by chunk
        self.started = False
        self.stopped = False
        self.stopped_at_s = np.nan  # the output epoch a stop request ended the results at

    # ------------------------------------------------------------------ set-up at the first chunk
    def start(self, chunk: SimChunk) -> None:
        """Initial states from the first chunk (its truth and the initial-error draws); done by
        :meth:`feed` unless called first."""
        config, truth = self.config, chunk.truth
        self.P0 = P0 = initial_covariance(config, truth.euler[0])
        self.P = np.broadcast_to(P0, self.batch + P0.shape).copy()
        nom = _initial_nominal(config, truth, self.rng, self.batch, P0[STATE.att, STATE.att])
        arrays = [
            np.array(a, dtype=float, order="C")
            for a in (
                nom.nav.pos_n,
                nom.nav.vel_n,
                nom.nav.C_nb,
                nom.accel_bias,
                nom.gyro_bias,
                nom.dvl_bias,
                nom.dvl_sf,
            )
        ]
        self.pos, self.vel, self.C, self.ba, self.bg, self.bdvl, self.sf = arrays
        self.initial_nav = (
            self.pos[0].copy(),
            self.vel[0].copy(),
            self.C[0].copy(),
        )  # per run (methods share it)
        self.flat = (
            self.pos.reshape(-1, 3),
            self.vel.reshape(-1, 3),
            self.C.reshape(-1, 3, 3),
            self.ba.reshape(-1, 3),
            self.bg.reshape(-1, 3),
            self.bdvl.reshape(-1, 4),
            self.sf.reshape(-1),
        )
        sensor_states = (STATE.ba, STATE.bg, STATE.b_dvl, STATE.sf_dvl)
        self.prior_var0 = np.concatenate([np.diag(P0)[s] for s in sensor_states])
        self.prior_rate = np.concatenate(
            [self.q_psd[n] for n in (NOISE.ba, NOISE.bg, NOISE.b_dvl, NOISE.sf_dvl)]
        )
        self.sensor_bound = sensor_prior_bound(self.prior_var0.size)
        R = self.batch[1]
        # true DVL errors at a sample: those of the latest ping (the first ping's before it; zero without pings)
        dvl = chunk.dvl
        self.ping_bias = np.array(dvl.bias_mps[0] if len(dvl.index) else np.zeros((R, 4)), dtype=float)
        self.ping_sf = np.array(dvl.scale_factor[0] if len(dvl.index) else np.zeros(R), dtype=float)
        self.prev_raw: tuple[np.ndarray, np.ndarray] | None = (
            None  # raw increments of the sample before a chunk
        )
        self.k_state = 0  # sample the nominal state is at
        self.k_cov = 0  # sample the covariance was last propagated to
        self.k_checked = 0  # sample P was last checked (positive definite) at
        self.dtheta_sum = np.zeros((R, 3))  # gyro increments since k_cov
        self.started = True

    def nominal(self, m: int | None = None) -> Nominal:
        """The current estimate (views): of method m, or of the whole bank."""
        sel = slice(None) if m is None else m
        return Nominal(
            NavState(self.pos[sel], self.vel[sel], self.C[sel]),
            self.ba[sel],
            self.bg[sel],
            self.bdvl[sel],
            self.sf[sel],
        )

    # ------------------------------------------------------------------ the pieces of an epoch
    def _condition(self) -> None:
        """Keep every P positive definite (one compiled Cholesky per filter; numpy repair if one fails)."""
        ok = kernels.positive_definite_bank(self.P)
        if not ok.all():
            self._repair()

    def _repair(self) -> None:
        """The numpy repair of the bank's covariances (tauvcore.filter.eskf.condition_covariance)."""
        P_new, repaired = condition_covariance(self.P)
        self.P[...] = P_new
        self.p_floor_count[...] += repaired

    def _check_sensor_errors(self, t: float) -> None:
        """After the corrections of an aiding epoch (the only moments the estimates change)."""
        kernels.flag_implausible_bank(
            self.ba,
            self.bg,
            self.bdvl,
            self.sf,
            self.prior_var0,
            self.prior_rate,
            t,
            self.sensor_bound,
            self.implausible_at_s,
        )  # metrics.implausible_sensor_errors

    def _fuse(
        self, H: np.ndarray, Rm: np.ndarray, nu: np.ndarray, active: np.ndarray, gate_rows: np.ndarray
    ) -> tuple[np.ndarray, ...]:
        """One compiled gated correction and injection of the whole bank in place (inactive rows
        and entries untouched). Arrays (M, R, m, ...); returns the per-entry outcome (M, R, ...)."""
        fused = fuse_in_place(
            self.P.reshape(-1, STATE.dim, STATE.dim),
            self.flat,
            H,
            Rm,
            nu,
            active,
            gate_rows.reshape(-1),
            self.gate,
            self.geodetic,
        )
        return tuple(a.reshape(self.batch + a.shape[1:]) for a in fused)

    def _update_all(self, source: str, meas: Measurement, t: float) -> None:
        """A source every aided method takes (depth, magnetometer): one batched correction."""
        valid = meas.valid & self.other_mask
        m_rows = meas.R.shape[-1]
        active = np.ones(self.batch + (m_rows,), bool) if meas.active is None else meas.active.astype(bool)
        active = active & valid[..., None]
        fused = self._fuse(meas.H, meas.R, meas.innovation, active, np.full(self.batch, meas.gate_rows))
        outcome = make_outcome(meas.z, meas.innovation, active, *fused)
        self.recorders[source].add(t, outcome, meas.valid & self.other_mask)

    def _update_registered(self, r: int, t: float) -> None:
        """Registered method ``r`` (tauvcore.aiding.registry): its model's measurement, fused into
        its own rows of the bank only, in the same compiled correction as every source."""
        source, model, members, _ = self.registered[r]
        meas = model.measure(self.nominal())
        valid = meas.valid & members[:, None]
        m_rows = meas.R.shape[-1]
        active = np.ones(self.batch + (m_rows,), bool) if meas.active is None else meas.active.astype(bool)
        active = active & valid[..., None]
        fused = self._fuse(
            np.ascontiguousarray(meas.H),
            np.ascontiguousarray(meas.R),
            np.ascontiguousarray(meas.innovation),
            active,
            np.full(self.batch, meas.gate_rows),
        )
        self.recorders[source].add(t, make_outcome(meas.z, meas.innovation, active, *fused), valid)

    def _update_dvl(
        self, y: np.ndarray, available: np.ndarray, omega_meas: np.ndarray, t: float
    ) -> np.ndarray:
        """Every DVL-aided method measures the ping its own way (lc, tc, an extended method's
        loosely coupled velocity or two-beam construction) in one compiled call for every method
        and run; one compiled correction then fuses them all. Returns (M, R): which methods had a
        velocity from the ping."""
        batch = self.batch
        H = np.empty(batch + (DVL_ROWS, STATE.dim))
        Rm = np.ones(batch + (DVL_ROWS, DVL_ROWS))
        nu = np.zeros(batch + (DVL_ROWS,))
        z = np.zeros(batch + (DVL_ROWS,))
        active = np.zeros(batch + (DVL_ROWS,), bool)
        valid = np.zeros(batch, bool)
        mode = np.zeros(batch, np.int64)
        measured_axes = np.zeros(batch + (3,), bool)
        choice = np.full(batch + (3,), -1, np.int64)
        dvl = self.config.dvl
        kernels.dvl_measure_bank(
            self.dvl_index,
            self.dvl_codes,
            np.ascontiguousarray(y),
            np.ascontiguousarray(available),
            np.ascontiguousarray(omega_meas),
            self.C,
            self.vel,
            self.bg,
            self.bdvl,
            self.sf,
            self.P,
            self.A_b,
            self.l_dvl_b,
            dvl_beam_sigma_mps(dvl.noise_mps) ** 2,
            self.gyro_rate_noise**2,
            self.w_ie,
            *self.partial_tables,
            DVL_MODE_CODES,
            z,
            nu,
            H,
            Rm,
            active,
            valid,
            mode,
            measured_axes,
            choice,
        )
        fused = self._fuse(H, Rm, nu, active, self.dvl_gate_rows)
        self.recorders["dvl"].add(
            t,
            make_outcome(z, nu, active, *fused),
            valid,
            shared={"beams_available": available},
            mode=mode,
            measured_axes=measured_axes,
            elc_choice=choice,
        )
        return valid

    def _rpm_fallback(self, chunk: SimChunk, p: int, i: int, t: float, dvl_valid: np.ndarray) -> None:
        """``run.rpm_fallback``: step the runs' velocity Kalman filters (learning from the DVL while
        it is in range), and where a DVL method had no velocity from this ping, fuse the RPM's body
        velocity ``[V_rpm, 0, 0]`` (R from the VKF and RPM_LATERAL_SIGMA_MPS; source "rpm" in the
        records).

        The VKF learns the speed the DVL measures, ``(1 + SF) v_b + A+ b`` (the LC measurement,
        kernels.lc_jacobian_into), not the true one: a DVL 0.7 % off in scale makes the RPM speed
        0.7 % off. So the surge row is predicted and linearised as that measurement is, with the
        DVL scale factor and beam bias columns (H = [(1 + SF) e1, A+ row 1, v_b1] on the velocity,
        beam bias and scale factor states), and the filter knows the RPM speed shares the DVL's
        errors; the sway and heave rows are the zero lateral velocity on the velocity block. (With
        H on the velocity alone the methods were over-confident, velocity NEES/dim about 2.)"""
        from tauvcore.eval.yoo_bank import dvl_body_velocity

        dvl = self.config.dvl
        R = self.batch[1]
        lat = self.pos[0, :, 0] if self.geodetic else np.full(R, self.config.earth.latitude_rad)
        v_b, _, ok = dvl_body_velocity(
            chunk.dvl.y_beam_mps[p],
            chunk.dvl.available[p],
            chunk.imu.dtheta_b[i],
            self.dt,
            self.C[0],
            lat,
            self.A_b,
            self.l_dvl_b,
            dvl_beam_sigma_mps(dvl.noise_mps) ** 2,
        )
        assert self.rpm_aid is not None  # called only with run.rpm_fallback's filters (see the caller)
        _, have_rpm = self.rpm_aid.step(chunk, i, v_b, ok)
        coast = np.zeros(self.batch, bool)
        coast[self.dvl_index] = ~dvl_valid[self.dvl_index] & have_rpm
        if not coast.any():  # every method had its DVL velocity: the bank is left as it was
            return
        z = np.broadcast_to(self.rpm_aid.velocity_b(), self.batch + (3,))
        v_b = np.einsum("mrji,mrj->mri", self.C, self.vel)
        h, H = rpm_measurement(
            v_b, self.sf.reshape(self.batch), self.bdvl.reshape(self.batch + (4,)), self.rpm_A_pinv
        )
        nu = z - h
        Rm = np.ascontiguousarray(np.broadcast_to(self.rpm_aid.covariance_b(), self.batch + (3, 3)))
        active = np.repeat(coast[..., None], 3, axis=-1)
        fused = self._fuse(H, Rm, np.ascontiguousarray(nu), active, np.zeros(self.batch, bool))
        self.recorders["rpm"].add(t, make_outcome(np.array(z), nu, active, *fused), coast)

    def _record(self, out: dict[str, np.ndarray], row: int, chunk: SimChunk, i: int) -> None:
        t_s, pos_t, vel_t, C_t, ba_t, bg_t = self._chunk_in[3:9]
        kernels.record_bank(
            row,
            float(t_s[i]),
            pos_t[i],
            vel_t[i],
            C_t[i],
            ba_t[i],
            bg_t[i],
            self.ping_bias,
            self.ping_sf,
            self.pos,
            self.vel,
            self.C,
            self.ba,
            self.bg,
            self.bdvl,
            self.sf,
            self.P,
            self.block_of_state,
            len(NEES_BLOCKS),
            units.DEG,
            out["series"],
            out["nees_block"],
            out["est_pos_n"],
            self.nonfinite_at_s,
            self.geodetic,
            self.origin,
            out["est_vel_n"],
            out["est_euler"],
        )
        out["t_s"][row] = t_s[i]
        self.slot += 1

    # ------------------------------------------------------------------ the chunk loop
    def feed(
        self,
        chunk: SimChunk,
        progress: Callable[[float, dict[str, MethodResult]], None] | None = None,
        progress_interval_s: float = 5.0,
        should_stop: Callable[[], bool] | None = None,
    ) -> bool:
        """Run the bank over one chunk (chunks in order, the first at sample 0). Returns False once
        ``should_stop()`` said so (at an output epoch); the results then end at that epoch."""
        if self.stopped:
            return False
        if not self.started:
            if chunk.k0 != 0:
                raise ValueError(f"the first chunk must start at sample 0, got {chunk.k0}")
            self.start(chunk)
        k0, n = chunk.k0, chunk.truth.num_samples
        if k0 != (0 if self.prev_raw is None else self.k_state + 1):
            raise ValueError(
                f"chunks must follow each other: expected one at sample {self.k_state + 1}, got {k0}"
            )
        k1 = k0 + n
        imu, dt = chunk.imu, self.dt
        dtheta = np.ascontiguousarray(imu.dtheta_b)
        phi_raw, dv_raw = (np.ascontiguousarray(a) for a in body_increments(dtheta, imu.dv_b, self.prev_raw))
        prev_dtheta = self.prev_raw[0] if self.prev_raw is not None else None
        self.prev_raw = (dtheta[-1].copy(), np.array(imu.dv_b[-1]))
        aiding = self.aiding
        dvl_at = _epoch_map(chunk.dvl.index) if "dvl" in aiding and self.dvl_methods else {}
        depth_at = _epoch_map(chunk.pressure.index) if "depth" in aiding and self.other_mask.any() else {}
        mag_at = _epoch_map(chunk.mag.index) if "mag" in aiding and self.other_mask.any() else {}
        registered_at = [
            {int(k) for k in epochs[(epochs >= k0) & (epochs < k1)]} for _, _, _, epochs in self.registered
        ]
        outs = self.out_idx[(self.out_idx >= k0) & (self.out_idx < k1)]
        out = {
            "series": np.zeros((len(kernels.SERIES_NAMES), outs.size) + self.batch),
            "nees_block": np.zeros((outs.size,) + self.batch + (len(NEES_BLOCKS),)),
            "est_pos_n": np.zeros((outs.size,) + self.batch + (3,)),
            "t_s": np.zeros(outs.size),
            "est_vel_n": np.zeros((outs.size,) + self.batch + (3,)),
            "est_euler": np.zeros((outs.size,) + self.batch + (3,)),
        }
        out_row = {int(k): r for r, k in enumerate(outs)}
        ping_rows = np.asarray(chunk.dvl.index, dtype=np.int64)
        truth = chunk.truth
        # the chunk's inputs of the compiled stretch between aiding epochs (kernels.run_stops)
        chunk_in = (
            phi_raw,
            dv_raw,
            dtheta,
            np.ascontiguousarray(truth.t_s),
            np.ascontiguousarray(truth.pos_nav),
            np.ascontiguousarray(truth.vel_n),
            np.ascontiguousarray(truth.C_nb),
            np.ascontiguousarray(imu.accel_bias),
            np.ascontiguousarray(imu.gyro_bias),
            ping_rows,
            np.ascontiguousarray(chunk.dvl.bias_mps, dtype=float),
            np.ascontiguousarray(chunk.dvl.scale_factor, dtype=float),
        )
        self._chunk_in = chunk_in
        slot0 = self.slot
        if k0 == 0 and 0 in out_row:
            self._record(out, 0, chunk, 0)
        events = np.zeros(n, dtype=bool)  # aiding epochs
        for keys in (dvl_at, depth_at, mag_at, *registered_at):
            events[[k - k0 for k in keys]] = True
        marks = events.copy()  # and output epochs: where the covariance step stops
        marks[outs - k0] = True
        progress_every = max(1, round(progress_interval_s * self.config.filter.output_rate_hz))

        def flush() -> None:
            rows = self.slot - slot0
            self.stored.append(
                {name: a[:rows] if name != "series" else a[:, :rows] for name, a in out.items()}
            )
            for rec in self.recorders.values():
                rec.seal()

        stops = np.asarray(
            covariance_stops(np.flatnonzero(marks) + k0, self.k_cov, k1, self.cov_step), dtype=np.int64
        )
        is_event = events[stops - k0]
        stop_row = np.array([out_row.get(int(k), -1) for k in stops], dtype=np.int64)
        # back to Python at every output epoch when someone polls there, else at aiding epochs only
        yield_every = 1 if should_stop is not None else (progress_every if progress is not None else 0)
        counters = np.zeros(4, dtype=np.int64)
        s = 0
        while s < stops.size:
            counters[:] = (self.k_state, self.k_cov, self.k_checked, self.slot)
            s, why = kernels.run_stops(
                stops,
                is_event,
                stop_row,
                s,
                stops.size,
                k0,
                self.check_step,
                yield_every,
                counters,
                self.pos,
                self.vel,
                self.C,
                self.ba,
                self.bg,
                self.bdvl,
                self.sf,
                self.P,
                self.dtheta_sum,
                self.ping_bias,
                self.ping_sf,
                self.nonfinite_at_s,
                *chunk_in,
                *self.sd_consts,
                self.origin,
                self.w_ie,
                self.q_psd,
                self.block_of_state,
                len(NEES_BLOCKS),
                units.DEG,
                out["series"],
                out["nees_block"],
                out["est_pos_n"],
                out["t_s"],
                out["est_vel_n"],
                out["est_euler"],
            )
            self.k_state, self.k_cov, self.k_checked, self.slot = (int(c) for c in counters)
            if why == kernels.STOPS_DONE:
                break
            k = int(stops[s])
            i = k - k0
            t = float(truth.t_s[i])
            if why == kernels.STOPS_REPAIR:
                self._repair()
            if why in (kernels.STOPS_EVENT, kernels.STOPS_REPAIR):
                if k in dvl_at:
                    p = dvl_at[k]
                    before = dtheta[i - 1] if i > 0 else prev_dtheta
                    omega_meas = (3.0 * dtheta[i] - before) / (2.0 * dt)  # rate at t_k, 2nd order
                    dvl_valid = self._update_dvl(
                        chunk.dvl.y_beam_mps[p], chunk.dvl.available[p], omega_meas, t
                    )
                    if self.rpm_aid is not None:
                        self._rpm_fallback(chunk, p, i, t, dvl_valid)
                if k in depth_at:
                    self._update_all(
                        "depth",
                        self.depth_model.measure(self.nominal(), chunk.pressure.depth_m[depth_at[k]]),
                        t,
                    )
                if k in mag_at:
                    self._update_all(
                        "mag", self.mag_model.measure(self.nominal(), chunk.mag.euler[mag_at[k]]), t
                    )
                for r, keys in enumerate(registered_at):
                    if k in keys:
                        self._update_registered(r, t)
                if is_event[s]:
                    self._condition()
                    self.k_checked = k
                    self._check_sensor_errors(t)
                if k in out_row:
                    latest = np.searchsorted(ping_rows, k, side="right") - 1
                    if latest >= 0:
                        self.ping_bias[...] = chunk.dvl.bias_mps[latest]
                        self.ping_sf[...] = chunk.dvl.scale_factor[latest]
                    self._record(out, out_row[k], chunk, i)
            if k in out_row:
                if should_stop is not None and should_stop():
                    self.stopped, self.stopped_at_s = True, t
                    flush()
                    return False
                if progress is not None and self.slot % progress_every == 0 and self.slot < self.out_idx.size:
                    flush()
                    progress(t, self.results())
                    self.stored.pop()
            s += 1
        # the rest of the chunk: the nominal state goes on, the covariance step waits for its epoch
        kernels.advance(
            self.pos,
            self.vel,
            self.C,
            self.ba,
            self.bg,
            phi_raw,
            dv_raw,
            dtheta,
            self.dtheta_sum,
            self.k_state - k0,
            n - 1,
            *self.sd_consts,
        )
        self.k_state = k1 - 1
        if len(ping_rows):
            self.ping_bias[...] = chunk.dvl.bias_mps[-1]
            self.ping_sf[...] = chunk.dvl.scale_factor[-1]
        flush()
        return True

    # ------------------------------------------------------------------ results
    def _results(
        self, stored: list[dict[str, np.ndarray]], first_update: dict[str, int]
    ) -> dict[str, MethodResult]:
        if stored:
            t_s = np.concatenate([c["t_s"] for c in stored])
            series_all = np.concatenate([c["series"] for c in stored], axis=1)
            nees_block = np.concatenate([c["nees_block"] for c in stored])
            est_pos_n = np.concatenate([c["est_pos_n"] for c in stored])
            est_vel_n = np.concatenate([c["est_vel_n"] for c in stored])
            est_euler = np.concatenate([c["est_euler"] for c in stored])
        else:
            t_s, series_all = np.zeros(0), np.zeros((len(kernels.SERIES_NAMES), 0) + self.batch)
            nees_block = np.zeros((0,) + self.batch + (len(NEES_BLOCKS),))
            est_pos_n = np.zeros((0,) + self.batch + (3,))
            est_vel_n = est_euler = est_pos_n
        series = dict(zip(kernels.SERIES_NAMES, series_all))
        out = {}
        for m, method in enumerate(self.methods):
            recs = {src: rec for src, rec in self.recorders.items() if rec.members[m] and rec.count}
            built = {src: rec.build(m, first_update.get(src, 0)) for src, rec in recs.items()}
            updates = {src: record for src, record in built.items() if record is not None}
            flagged = [self.nonfinite_at_s[m], self.implausible_at_s[m]] + [
                rec.divergence_s(m) for rec in recs.values()
            ]
            diverged_at = np.fmin.reduce(np.stack(flagged), axis=0)
            out[method] = MethodResult(
                method=method,
                t_s=t_s,
                vel_err_mps=series["vel_err"][:, m],
                att_err_deg=series["att_err"][:, m],
                pos_err_m=series["pos_err"][:, m],
                vel_sigma_mps=series["vel_sigma"][:, m],
                att_sigma_deg=series["att_sigma"][:, m],
                pos_sigma_m=series["pos_sigma"][:, m],
                nees=series["nees"][:, m],
                est_pos_n=est_pos_n[:, m],
                est_vel_n=est_vel_n[:, m],
                est_euler_rad=est_euler[:, m],
                tilt_err_deg=series["tilt_err"][:, m],
                heading_err_deg=series["heading_err"][:, m],
                tilt_sigma_deg=series["tilt_sigma"][:, m],
                heading_sigma_deg=series["heading_sigma"][:, m],
                nees_block=nees_block[:, m],
                diverged=~np.isnan(diverged_at),
                diverged_at_s=diverged_at,
                p_floor_count=self.p_floor_count[m].copy(),
                updates=updates,
            )
        return out

    def results(self) -> dict[str, MethodResult]:
        """Every output epoch and update kept so far (all of them unless ``keep`` is False)."""
        return self._results(self.stored, {})

    def take(self) -> dict[str, MethodResult]:
        """The output epochs and updates since the last :meth:`take` (the monitor's verdict is the
        whole mission's so far); without ``keep`` they are dropped from the bank."""
        if self.keep:
            new, seen = [], 0
            for c in self.stored:
                size = c["t_s"].size
                if seen + size > self.taken:
                    lo = max(0, self.taken - seen)
                    new.append({k: (v[:, lo:] if k == "series" else v[lo:]) for k, v in c.items()})
                seen += size
            result = self._results(new, {key: rec.taken for key, rec in self.recorders.items()})
            for rec in self.recorders.values():
                rec.taken = len(rec.chunks)
            self.taken = seen
            return result
        result = self._results(self.stored, {})
        self.stored = []
        for rec in self.recorders.values():
            rec.drain()
        return result


def run(
    config: Config,
    sim: Simulation,
    rng: np.random.Generator | Sequence[np.random.Generator],
    progress: Callable[[float, dict[str, MethodResult]], None] | None = None,
    progress_interval_s: float = 5.0,
    should_stop: Callable[[], bool] | None = None,
) -> dict[str, MethodResult]:
    """Run every method of ``config.run.methods`` on a whole simulation; results keyed by method.

    ``progress(t_s, partial_results)`` is called every ``progress_interval_s`` of simulated time
    with the results so far (for live displays); ``should_stop()`` is polled at every output
    epoch (10 Hz of simulated time, a few milliseconds of wall time) and ends the run early,
    returning the results up to that epoch. :func:`run_streaming` does the same without holding
    the whole simulation.
    """
    banks = _Banks(config, sim.num_runs, sim.truth.num_samples, sim.truth.dt_s, rng)
    banks.feed(SimChunk.whole(sim), progress, progress_interval_s, should_stop)
    return banks.results()


class _Banks:
    """The 20-state FilterBank for the first paper's methods and the YooBank for Yoo 2014's
    (tauvcore.eval.yoo_bank), fed the same chunks, their results in ``config.run.methods`` order.
    The Yoo methods start from the same initial errors as the others (the same draws)."""

    def __init__(
        self,
        config: Config,
        num_runs: int,
        num_samples: int,
        dt_s: float,
        rng: np.random.Generator | Sequence[np.random.Generator],
        keep: bool = True,
    ) -> None:
        from tauvcore.config import YOO_METHODS
        from tauvcore.eval.yoo_bank import YooBank

        self.config, self.rng, self.keep, self.num_runs = config, rng, keep, num_runs
        self.order = config.run.methods
        first = tuple(m for m in self.order if m not in YOO_METHODS)
        second = tuple(m for m in self.order if m in YOO_METHODS)
        self.bank = (
            FilterBank(config.replace("run", methods=first), num_runs, num_samples, dt_s, rng, keep=keep)
            if first or not second
            else None
        )
        self.yoo = YooBank(config, second, num_runs, num_samples, dt_s) if second else None
        self.stopped = False
        self.until_s: float | None = None  # where the 20-state bank stopped the run (the Yoo bank goes on)

    def feed(
        self,
        chunk: SimChunk,
        progress: Callable | None = None,
        progress_interval_s: float = 5.0,
        should_stop: Callable[[], bool] | None = None,
    ) -> bool:
        """Both banks over one chunk. The Yoo bank goes first (compiled, it takes a few percent of
        the time), so the 20-state bank's progress can carry its results up to the same time; a
        stop request, polled by the 20-state bank, ends both at its epoch (:attr:`until_s`)."""
        if self.stopped:
            return False
        bank, yoo = self.bank, self.yoo
        if yoo is None:
            assert bank is not None  # __init__ builds the 20-state bank whenever there is no Yoo method
            going = bank.feed(chunk, progress, progress_interval_s, should_stop)
        else:
            if not yoo.started:
                if bank is not None and not bank.started:
                    bank.start(chunk)  # its draws first (_start_yoo)
                self._start_yoo(chunk)
            if bank is None:
                going = yoo.feed(chunk, progress, progress_interval_s, should_stop)
            else:
                yoo.feed(chunk)
                both = (
                    None
                    if progress is None
                    else (lambda t, first: progress(t, self._merge(first, yoo.results(until_s=t))))
                )
                going = bank.feed(chunk, both, progress_interval_s, should_stop)
                if not going:
                    self.until_s = bank.stopped_at_s
        self.stopped = not going
        return going

    def _start_yoo(self, chunk: SimChunk) -> None:
        config, truth = self.config, chunk.truth
        P0 = initial_covariance(config, truth.euler[0])
        if self.bank is not None:
            nav = self.bank.initial_nav  # its draws, before any update
        else:
            nom = _initial_nominal(config, truth, self.rng, (1, self.num_runs), P0[STATE.att, STATE.att])
            nav = nom.nav.pos_n[0], nom.nav.vel_n[0], nom.nav.C_nb[0]
        assert self.yoo is not None  # called by feed only when there are Yoo methods
        self.yoo.start(*nav, P0[STATE.att, STATE.att], P0[STATE.ba, STATE.ba], P0[STATE.bg, STATE.bg])

    def _merge(
        self, first: dict[str, MethodResult], second: dict[str, MethodResult]
    ) -> dict[str, MethodResult]:
        both = {**first, **second}
        return {m: both[m] for m in self.order if m in both}

    def results(self) -> dict[str, MethodResult]:
        return self._merge(
            self.bank.results() if self.bank is not None else {},
            self.yoo.results(self.until_s) if self.yoo is not None else {},
        )

    def take(self) -> dict[str, MethodResult]:
        return self._merge(
            self.bank.take() if self.bank is not None else {},
            self.yoo.take(self.keep, self.until_s) if self.yoo is not None else {},
        )


def covariance_stops(event_idx: np.ndarray, k_cov: int, k_end: int, cov_step: int) -> list[int]:
    """Samples in ``(k_cov, k_end)`` at which the covariance is propagated (and the nominal state
    stops), the covariance having been propagated last at ``k_cov``: every event (aiding or output
    epoch, ``event_idx`` sorted) and every ``cov_step`` samples in between."""
    stops: list[int] = []
    prev = k_cov
    for e in [int(e) for e in event_idx if e > k_cov] + [k_end]:
        stops.extend(range(prev + cov_step, e, cov_step))
        if e < k_end:
            stops.append(e)
        prev = e
    return stops


STREAM_CHUNK_S = 10.0
"""Seconds of mission :func:`run_streaming` generates and filters at a time (1,500 IMU samples at
150 Hz): memory then holds one chunk of truth and sensors, whatever the mission's length."""


def run_streaming(
    config: Config,
    rng: np.random.Generator | Sequence[np.random.Generator],
    num_runs: int = 1,
    chunk_s: float = STREAM_CHUNK_S,
    on_chunk: Callable[[dict[str, MethodResult]], None] | None = None,
    keep: bool = True,
    progress: Callable[[float, dict[str, MethodResult]], None] | None = None,
    progress_interval_s: float = 5.0,
    should_stop: Callable[[], bool] | None = None,
    on_sim_chunk: Callable[[SimChunk], None] | None = None,
) -> dict[str, MethodResult]:
    """Simulate and run chunk by chunk: truth (tauvcore.truth.truth_stream: kinematic or dynamic) and sensors
    (tauvcore.sensors.stream.SensorStream) are generated ``chunk_s`` at a time and fed to the
    :class:`FilterBank`, so memory does not depend on the mission's length.

    ``rng``: one generator for the batch of ``num_runs`` runs, or one per run (a study's runs,
    tauvcore.eval.study). Each is split into independent named streams
    (:meth:`~tauvcore.sensors.stream.SensorStreams.spawned`: the IMU's, the DVL's, ..., the
    initial errors'), so the numbers do not depend on ``chunk_s`` (tests/unit/test_stream_engine.py);
    they differ from :func:`simulate` + :func:`run`, which draw everything from one stream.
    ``on_chunk(results)`` receives each chunk's output epochs and updates (and the monitor's
    verdict so far); with ``keep`` False they are not kept and the return value holds only the
    last chunk's. ``progress`` and ``should_stop`` as in :func:`run`. ``on_sim_chunk(chunk)``
    receives each chunk of the simulation itself (truth and sensors) before the bank runs it
    (``tauv run --save-log`` writes them as a log: tauvcore.logs).
    """
    per_run = not isinstance(rng, np.random.Generator)
    if per_run:
        rngs = list(rng)
        if len(rngs) != num_runs:
            raise ValueError(f"one generator per run expected ({num_runs}), got {len(rngs)}")
        streams: SensorStreams | list[SensorStreams] = [SensorStreams.spawned(g) for g in rngs]
        initial: np.random.Generator | list[np.random.Generator] = [s.initial for s in streams]
    else:
        streams = SensorStreams.spawned(rng)
        initial = streams.initial
    ideal = config.run.ideal
    rate = config.imu.rate_hz
    # the first chunk holds the first DVL ping: the records before it use that ping's true errors
    chunk_samples = max(2, round(max(chunk_s, 1.0 / config.dvl.rate_hz + 1.0 / rate) * rate))
    truths = truth_stream(config.trajectory, config.earth, rate, chunk_samples)
    sensors = SensorStream(
        config.imu.ideal() if ideal else config.imu,
        config.dvl.ideal() if ideal else config.dvl,
        config.pressure.ideal() if ideal else config.pressure,
        config.magnetometer.ideal() if ideal else config.magnetometer,
        streams,
        num_runs,
        truths.num_samples,
        truths.dt_s,
        bathymetry(config.trajectory),
        config.echo_sounder.ideal() if ideal else config.echo_sounder,
        config.rpm.ideal() if ideal else config.rpm,
    )
    bank = _Banks(config, num_runs, truths.num_samples, truths.dt_s, initial, keep=keep)
    last: dict[str, MethodResult] = {}
    for k0, truth in truths:
        chunk = SimChunk(k0, truth, *sensors.next_chunk_all(k0, truth))
        if on_sim_chunk is not None:
            on_sim_chunk(chunk)
        going = bank.feed(chunk, progress, progress_interval_s, should_stop)
        if on_chunk is not None or not keep:
            last = bank.take()
            if on_chunk is not None:
                on_chunk(last)
        if not going:
            break
    return bank.results() if keep else last
