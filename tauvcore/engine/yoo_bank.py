"""Yoo 2014's navigation filter as methods of the engine: ``ins-dvl`` and ``vkf``.

Each is the paper's 12-state indirect feedback Kalman filter (section 2.1; error model
tauvcore.filter.families.yoo.model: NED velocity, attitude, accelerometer and gyro bias errors, no position)
on the same strapdown as the 20-state methods (tauvcore.filter.kernels.strapdown_kernels.advance, geodetic on
WGS-84), aided at every DVL ping by a NED velocity (eq. 16-18; with the attitude column the paper's H
leaves out, tauvcore.filter.families.yoo.model_kernels.fuse):

- ``ins-dvl``, the paper's "conventional INS-DVL": the DVL's velocity, least squares over the
  beams that returned (at least three), rotated into n with the INS attitude; nothing when fewer
  return (beyond range) or, with Yoo's own DVL model (``dvl.beyond_range = "noisy"``), beams
  that carry 5 m/s of noise, which only the gate can refuse.
- ``vkf``, "INS-DVL + VKF": the velocity Kalman filter (tauvcore.filter.vkf, eq. 20-26) learns
  the propeller's scale factor and bias from the DVL's forward speed while the echo sounder's
  altitude is within ``vkf.switch_altitude_m``; the aiding velocity is the switch of eq. 29: the
  DVL's when within, else the RPM's, ``C_nb [V_rpm, 0, 0]`` (eq. 27-28), with the VKF's own
  variance for surge and ``RPM_LATERAL_SIGMA_MPS`` for the sway and heave it assumes zero.

The measurement noise ("R has been properly adjusted", the paper gives none): the beams' white
noise through the least squares. The DVL's scale factor and beam biases (the 12-state filter has
no states for them) are constant within a run, not white noise, so they are carried as
*consider* states (Schmidt-Kalman, :data:`NC`: scale factor, 4 beam biases, their prior and random
walks from ``[dvl]``): the covariance is propagated and updated over the 12 + 5 states, the gain
only ever corrects the 12 (the consider rows of K are zero; the Joseph form keeps P exact for that
gain), so the estimate is the paper's 12-state filter while its P knows that a DVL 0.7 % off in
scale stays 0.7 % off from ping to ping. The RPM velocity of ``vkf`` was learnt from the DVL's
forward speed, so its surge inherits the same errors: its row of ``H_c`` is the DVL's surge row
(``V_rpm`` for the scale factor, the 4-beam least squares' x row for the biases). Updates are
gated like the 20-state methods' (every row within ``filter.gate_sigma``), then injected and the
error reset (feedback). As white noise of their 1-sigma size they would leave both
methods over-confident (velocity NEES/dim 1.8-4 and 2.7-7.7 over seeds on ``longrange``).

Both methods also fuse the registry's sources that ``run.aiding`` turns on and whose measurement
weighs only the misalignment and the IMU biases (tauvcore.engine.yoo_sources: the magnetometer),
at their epochs, after the DVL's update (:meth:`YooBank._fuse_sources`), with the 20-state
methods' gate and records (tauvcore.filter.families.yoo.model.correct_consider).

The covariance is propagated at ``filter.covariance_rate_hz`` with ``Phi = I + F dt + (F dt)^2 / 2``
and ``Qd = G Q G^T dt`` (accelerometer and gyro white noise on velocity and attitude, the bias
walks on the biases). Records at the output epochs carry the same series as the 20-state
methods; there is no position state, so the position's 1-sigma and NEES are NaN, and the NEES
dimensions are the filter's own (:data:`BLOCK_DIMS`: 12 in all, 6 sensor states).
"""

from __future__ import annotations

from collections.abc import Iterator
from functools import partial

import numpy as np

from tauvcore import units
from tauvcore.aiding.sources import SOURCES
from tauvcore.config import Config
from tauvcore.engine import yoo_loop, yoo_sources
from tauvcore.engine.chunk_driver import ChunkDriver, ChunkInputs, Store, cut
from tauvcore.engine.recorder import Recorder, handed_out
from tauvcore.engine.results import (
    SENSOR_COLUMNS,
    SERIES_FIELDS,
    STATE_FIELDS,
    MethodResult,
    UpdateRecord,
    method_result,
)
from tauvcore.engine.rpm_aid import RpmAid
from tauvcore.engine.simulation import SimChunk
from tauvcore.engine.smoothing import Carry, smooth_tape
from tauvcore.engine.source_streams import active, layout_of, states_truth
from tauvcore.engine.start import initial_covariance
from tauvcore.engine.tape import Tape, TapeWriter
from tauvcore.engine.yoo_records import YooSchedule
from tauvcore.engine.yoo_smoothing import nominal_difference, smooth_yoo_segment, tape_shape
from tauvcore.engine.yoo_velocity import (
    added_states,
)
from tauvcore.filter.eskf import Nominal, make_outcome
from tauvcore.filter.families.yoo import FAMILY
from tauvcore.filter.families.yoo import model as yoo
from tauvcore.filter.families.yoo import model_kernels as yoo_kernels
from tauvcore.filter.layout import STATE, NavState
from tauvcore.geo.rotations import exp_so3, skew

BLOCK_DIMS = FAMILY.block_dims
"""Degrees of freedom of this filter's NEES (tauvcore.filter.families.yoo)."""
NC = yoo_kernels.NC
"""Consider states after the 12: the DVL's scale factor error and its 4 beam biases (never corrected)."""
NA = yoo_kernels.NA
"""The covariance's dimension: the 12 estimated states and the consider states (then the states the
sources add, tauvcore.engine.yoo_velocity)."""


SERIES = tuple(SERIES_FIELDS)
"""The per-epoch series, as the 20-state bank's (tauvcore.engine.results.SERIES_FIELDS)."""
SIGMA_SERIES = ("vel_sigma", "att_sigma", "tilt_sigma", "heading_sigma")
"""The series made from the filter's covariance alone (no truth): what :func:`_nonfinite` reads."""
BLOCK_OF_STATE = np.array([1, 1, 1, 2, 2, 3, 4, 4, 4, 4, 4, 4], dtype=np.int64)
"""Each of the 12 states' NEES block (tauvcore.eval.consistency's blocks: position (none here),
velocity, tilt, heading, sensors)."""
NUM_BLOCKS = 5
METHOD_CODES = {"ins-dvl": yoo_loop.INS_DVL, "vkf": yoo_loop.VKF}
_BLOCKS = {
    "ba": yoo.BA,
    "bg": yoo.BG,
}  # the sensor-error blocks of the 12 states (tauvcore.filter.families.yoo.model)
SENSOR_INDEX = np.array([_BLOCKS[c.block].start + c.component for c in SENSOR_COLUMNS["yoo"]], dtype=np.int64)
"""The state of each column of the sensor-error records (tauvcore.engine.results.SENSOR_COLUMNS)."""


class YooBank(ChunkDriver):
    """The Yoo methods of ``config.run.methods`` over R runs, fed chunk by chunk
    (tauvcore.engine.chunk_driver.ChunkDriver, as FilterBank).

    Each chunk runs in tauvcore.engine.yoo_loop (a numpy reference it is held equal to lives in
    tests/unit/tauvcore/engine/yoo_reference.py). It writes a chunk's output epochs, updates and VKF trace into
    the chunk's store (:meth:`_store`), handed out by :meth:`take` and :meth:`results`; with
    ``sensor_errors`` the output epochs carry the bias estimates, their 1-sigma and their truth
    (tauvcore.engine.results.SENSOR_COLUMNS)."""

    def __init__(
        self,
        config: Config,
        num_runs: int,
        num_samples: int,
        dt_s: float,
        keep: bool = True,
        sensor_errors: bool = False,
        tape: Tape | None = None,
    ) -> None:
        methods = tuple(config.run.methods)
        super().__init__(config, methods, num_runs, num_samples, dt_s, keep, sensor_errors)
        # the states the sources add (the DVL's current), after the consider states
        self.added = added_states(config, layout_of(config))
        # the smoother's marks (tauvcore.engine.yoo_smoothing), the pings' and output epochs' written
        # by the compiled loop: the transition since the last mark and the chunk's output epochs
        # recorded so far
        self.taping: TapeWriter | None = None
        self.phi_acc = np.zeros((0, 0, yoo.DIM, yoo.DIM))
        self.rows = 0
        if tape is not None:
            na = self.added.dim
            self.taping = TapeWriter(
                tape,
                self.batch,
                tape_shape(na, self.added.num),
                partial(nominal_difference, na=na),
                self.added.rate,
            )
            self.phi_acc = np.zeros(self.batch + (yoo.DIM, yoo.DIM))
        self.state_labels = tuple(label for b in self.added.layout.blocks for label in b.labels) or None
        self.block_of_state, self.num_blocks = self.added.nees_blocks(BLOCK_OF_STATE, NUM_BLOCKS)
        self.block_dims = {**BLOCK_DIMS, "full": yoo.DIM + self.added.num}
        self.ref_var = config.reference.variances()  # the NEES's P + P_ref (yoo_records.YooModel.ref_var)
        self.block_dims.update({b.name: b.dim for b in self.added.layout.blocks})
        self.extra = np.zeros(self.batch + (self.added.num,))
        self._extra_truth: tuple[int, np.ndarray] | None = None  # (chunk start, (K, E)) of the last chunk
        imu = config.imu
        self.q = np.r_[
            np.full(3, imu.accel_noise_mps_per_sqrt_s**2),
            np.full(3, imu.gyro_noise_rad_per_sqrt_s**2),
            np.full(3, imu.accel_bias_rw_mps2_per_sqrt_s**2),
            np.full(3, imu.gyro_bias_rw_rps_per_sqrt_s**2),
        ]
        self.q = np.maximum(self.q, 1e-24)
        dvl = config.dvl
        self.A_b = dvl.A_b
        self.l_dvl_b = dvl.l_dvl_b
        self.beam_var = max(dvl.noise_mps, 1e-3) ** 2
        # the consider states' prior and random walks (the DVL's error model, tauvcore.sensors.dvl)
        self.c_var0 = np.r_[dvl.scale_factor**2, np.full(4, dvl.bias_mps**2)] + 1e-16
        self.qc = np.r_[dvl.scale_factor_rw_per_sqrt_s**2, np.full(4, dvl.bias_rw_mps_per_sqrt_s**2)]
        self.L4 = np.linalg.pinv(np.asarray(self.A_b, dtype=float))  # the 4-beam least squares (3, 4)
        self.has_vkf = "vkf" in methods
        # the sources of tauvcore.aiding.sources that run.aiding turns on and the 12 states can take
        # (tauvcore.engine.yoo_sources): fused by both methods at their epochs
        self.sources = [
            (name, SOURCES[name].model(config.section(SOURCES[name].section_name), config))
            for name in active(config)
            if yoo_sources.takes(SOURCES[name])
        ]
        self.recorders = {name: Recorder(np.ones(len(methods), bool)) for name, _ in self.sources}
        self._until_s: float | None = None
        # the first output epoch with a non-finite NEES per method and run [s] (NaN: none) among
        # the results handed out by take(), so that a verdict so far spans the chunks taken before
        self.nonfinite_at_s = np.full(self.batch, np.nan)

    # ------------------------------------------------------------------ set-up
    def start(self, chunk: SimChunk, nav: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        """Initial states from the first chunk: the estimate at t = 0 every family starts from
        (``nav``: position, NED velocity and attitude per run, (R, 3), (R, 3), (R, 3, 3):
        tauvcore.engine.mission.Banks draws it), and the attitude and bias blocks of the 20-state
        filter's P0 (the same initial uncertainty)."""
        pos, vel_n, C = nav
        P0_20 = initial_covariance(self.config, chunk.truth.euler[0])
        P0_att, P0_ba, P0_bg = (P0_20[b, b] for b in (STATE.att, STATE.ba, STATE.bg))
        M, R = self.batch
        config = self.config
        ie = config.initial_error.ideal() if config.run.ideal else config.initial_error
        self.pos = np.array(np.broadcast_to(pos, (M, R, 3)), dtype=float, order="C")  # copies: the kernels
        self.vel = np.array(np.broadcast_to(vel_n, (M, R, 3)), dtype=float, order="C")  # write in place
        self.C = np.array(np.broadcast_to(C, (M, R, 3, 3)), dtype=float, order="C")
        self.ba = np.zeros((M, R, 3))
        self.bg = np.zeros((M, R, 3))
        na = self.added.dim
        P0 = np.zeros((na, na))
        C0 = self.C[0, 0]
        P0[yoo.VEL, yoo.VEL] = C0 @ np.diag(np.square(ie.vel_mps)) @ C0.T
        P0[yoo.ATT, yoo.ATT] = P0_att
        P0[yoo.BA, yoo.BA] = P0_ba
        P0[yoo.BG, yoo.BG] = P0_bg
        P0[yoo.DIM : NA, yoo.DIM : NA] = np.diag(self.c_var0)
        P0[NA:, NA:] = np.diag(self.added.sigma0**2)
        self.P = np.broadcast_to(P0 + np.eye(na) * 1e-16, (M, R, na, na)).copy()
        self.extra[...] = 0.0
        # the initial NED velocity is the body velocity rotated with the estimated attitude, so its
        # error carries the attitude's: dv = ... - [v x] rho (without this correlation the first
        # updates moved the heading by up to 1 deg at random)
        Vx = skew(self.vel)
        self.P[..., yoo.VEL, yoo.VEL] += Vx @ P0_att @ Vx.swapaxes(-1, -2)
        self.P[..., yoo.VEL, yoo.ATT] = -Vx @ P0_att
        self.P[..., yoo.ATT, yoo.VEL] = (-Vx @ P0_att).swapaxes(-1, -2)
        self.rpm_aid = RpmAid(config.vkf, R)
        self.dtheta_sum = np.zeros((R, 3))
        self.started = True

    # ------------------------------------------------------------------ one chunk
    def _begin(self, chunk: SimChunk) -> None:
        raise ValueError("YooBank.start must come before the first chunk (tauvcore.engine.mission.Banks)")

    def _run_chunk(
        self, chunk: SimChunk, inputs: ChunkInputs, store: Store, poll_every: int
    ) -> Iterator[int]:
        """The chunk's stops (covariance steps, DVL pings, output epochs, the sources' epochs) in
        compiled spans that end at the output epochs where the driver polls and at the sources'
        epochs, whose corrections are made here (:meth:`_fuse_sources`)."""
        k0, n = chunk.k0, chunk.truth.num_samples
        pings = store["up_k"]
        outs = store["out_k"]
        cov = np.arange(self.k_cov + self.cov_step, k0 + n, self.cov_step)
        source_at = {}
        for name, _ in self.sources:
            if name in chunk.sources:
                index = np.asarray(chunk.sources[name].index, dtype=np.int64)
                source_at[name] = {int(k): j for j, k in enumerate(index) if k0 <= k < k0 + n}
        source_k = np.array(sorted({k for at in source_at.values() for k in at}), dtype=np.int64)
        stops = np.unique(np.concatenate([pings, outs, cov, source_k]).astype(np.int64))
        stops = stops[stops >= k0]
        ping_of_stop = np.full(stops.size, -1, np.int64)
        ping_of_stop[np.searchsorted(stops, pings)] = np.arange(pings.size)
        row_of_stop = np.full(stops.size, -1, np.int64)
        row_of_stop[np.searchsorted(stops, outs)] = np.arange(outs.size)
        out_stops = np.flatnonzero(row_of_stop >= 0)
        if poll_every:
            before = int(np.count_nonzero(self.out_idx < k0))  # output epochs of the earlier chunks
            polls = out_stops[(before + np.arange(out_stops.size) + 1) % poll_every == 0] + 1
        else:
            polls = np.zeros(0, np.int64)
        polls = np.unique(np.r_[polls, stops.size]).astype(np.int64)
        fixes = np.searchsorted(stops, source_k) + 1  # a span ends at each source epoch
        if self.taping is not None:
            self.taping.open(store, 0)
            self.rows = 0
        s0 = 0
        for s1 in np.unique(np.r_[polls, fixes]).astype(np.int64):
            self._run_span(chunk, s0, int(s1), stops, ping_of_stop, row_of_stop, inputs, store)
            s0 = int(s1)
            if s1 == 0:
                continue
            k = int(stops[s1 - 1])
            if k in source_k:
                self._fuse_sources(chunk, k, source_at, int(row_of_stop[s1 - 1]), inputs, store)
            if s1 in polls and row_of_stop[s1 - 1] >= 0 and poll_every:
                yield k
        if self.taping is not None:
            self.taping.close(self.rows)

    def _store(self, outs: np.ndarray, chunk: SimChunk | None) -> Store:
        k0 = chunk.k0 if chunk is not None else 0
        if chunk is not None and "dvl" in self.config.run.aiding:
            pings = np.asarray(chunk.dvl.index, dtype=np.int64)
        else:
            pings = np.zeros(0, np.int64)
        t_s = chunk.truth.t_s if chunk is not None else np.zeros(0)
        return self._chunk_store(outs, pings, t_s[outs - k0], t_s[pings - k0])

    def _chunk_store(
        self, outs: np.ndarray, pings: np.ndarray, out_t_s: np.ndarray, ping_t_s: np.ndarray
    ) -> dict[str, np.ndarray]:
        """The arrays a chunk's results are written into (NaN until written): output epochs at
        samples ``outs`` (times ``out_t_s``), updates at the pings ``pings`` (``ping_t_s``)."""
        M, R = self.batch
        T, U = len(outs), len(pings)
        nan = np.nan
        return {
            "t_s": np.asarray(out_t_s, dtype=float),
            "out_k": outs,
            "series": np.full((len(SERIES), T, M, R), nan),
            "nees_block": np.full((T, M, R, self.num_blocks), nan),
            **{name: np.full((T, M, R, self.added.num), nan) for name in STATE_FIELDS},
            "est_pos_n": np.full((T, M, R, 3), nan),
            "est_vel_n": np.full((T, M, R, 3), nan),
            "est_euler": np.full((T, M, R, 3), nan),
            **self._sensor_store(T, SENSOR_INDEX.size, nan),
            "up_t": np.asarray(ping_t_s, dtype=float),
            "up_k": pings,
            "up_z": np.full((U, M, R, 3), nan),
            "up_nu": np.full((U, M, R, 3), nan),
            "up_S": np.full((U, M, R, 3), nan),
            "up_flags": np.zeros((U, M, R, 3), bool),
            "up_nis": np.full((U, M, R), nan),
            **{  # the water-track's, with current states and a water-tracking DVL
                f"wt_{name}": np.full((U if self.added.water_var is not None else 0, M, R) + tail, fill)
                for name, tail, fill in (
                    ("z", (3,), nan),
                    ("nu", (3,), nan),
                    ("S", (3,), nan),
                    ("flags", (3,), False),
                    ("nis", (), nan),
                )
            },
            "tr_x": np.full((U, R, 3), nan),
            "tr_sigma": np.full((U, R, 3), nan),
            "tr_truth": np.full((U, R, 2), nan),
            "tr_use": np.zeros((U, R), bool),
            "tr_alt": np.full((U, R), nan),
        }

    def _run_span(
        self,
        chunk: SimChunk,
        s0: int,
        s1: int,
        stops: np.ndarray,
        ping_of_stop: np.ndarray,
        row_of_stop: np.ndarray,
        inputs: ChunkInputs,
        store: Store,
    ) -> None:
        """Stops ``s0 .. s1 - 1`` of the chunk in the compiled loop (tauvcore.engine.yoo_loop.run_chunk)."""
        schedule = YooSchedule(stops, ping_of_stop, row_of_stop, chunk.k0)
        yoo_loop.run_chunk(self, chunk, s0, s1, schedule, inputs, store, METHOD_CODES, SENSOR_INDEX)

    def _record_again(self, chunk: SimChunk, i: int, row: int, inputs: ChunkInputs, store: Store) -> None:
        """Output epoch ``row`` (sample ``i``) recorded again after the sources' corrections
        (tauvcore.engine.yoo_loop.record_again)."""
        yoo_loop.record_again(self, chunk, i, row, inputs, store, METHOD_CODES, SENSOR_INDEX)

    def _fuse_sources(
        self,
        chunk: SimChunk,
        k: int,
        source_at: dict[str, dict[int, int]],
        row: int,
        inputs: ChunkInputs,
        store: Store,
    ) -> None:
        """The sources' corrections at sample ``k`` (after the DVL's, which the span ending at ``k``
        made), in registry order, for both methods and every run; then the output epoch at ``k``,
        if there is one, is recorded again (``row``), after the corrections, as the 20-state bank
        records it."""
        i = k - chunk.k0
        t = float(chunk.truth.t_s[i])
        M, R = self.batch
        nominal = Nominal(
            NavState(self.pos, self.vel, self.C), self.ba, self.bg, np.zeros((M, R, 4)), np.zeros((M, R))
        )
        mark = None
        if self.taping is not None:
            mark = self.taping.before(self.phi_acc, self.P, self._nominal(), t, row)
        for name, model in self.sources:
            if k not in source_at.get(name, {}):
                continue
            meas = model.measure(nominal, chunk.sources[name], source_at[name][k])
            m_rows = meas.R.shape[-1]
            active = np.ones((M, R, m_rows), bool) if meas.active is None else meas.active.astype(bool)
            active = active & meas.valid[..., None]
            P, dx, outcome = yoo.correct_consider(
                self.P,
                yoo_sources.yoo_H(meas.H, self.added.dim),
                meas.R,
                meas.innovation,
                active,
                meas.gate_rows,
                self.gate,
                slice(yoo.DIM, NA),
            )
            self.P[...] = P
            self.inject(dx)
            self.recorders[name].add(t, make_outcome(meas.z, meas.innovation, active, *outcome), meas.valid)
        if self.taping is not None and mark is not None:
            self.taping.after(mark, self.P, self._nominal(), self.rows)
        if row >= 0:
            self._record_again(chunk, i, row, inputs, store)

    def inject(self, dx: np.ndarray) -> None:
        """Inject a correction ``dx`` (M, R, N) over every state into every method and run (the
        error is then reset: feedback); its consider entries are zero."""
        self.vel += dx[..., yoo.VEL]
        self.C[...] = exp_so3(dx[..., yoo.ATT]) @ self.C
        self.ba += dx[..., yoo.BA]
        self.bg += dx[..., yoo.BG]
        self.extra += dx[..., NA:]

    def _nominal(self) -> tuple[np.ndarray, ...]:
        """The nominal states the smoother's marks take (velocity, attitude, biases, added states)."""
        return self.vel, self.C, self.ba, self.bg, self.extra

    def _sealed(self) -> None:
        for rec in self.recorders.values():
            rec.seal()

    def _concatenate(self, chunks: list[Store], until_s: float | None) -> Store:
        self._until_s = until_s  # the sources' records are cut there too (_results)
        return super()._concatenate(chunks, until_s)

    def _ping_record(self, cat: Store, prefix: str, m: int) -> UpdateRecord:
        """Method ``m``'s record of a velocity fused at the pings, from the store's ``prefix`` rows."""
        nu, S = cat[f"{prefix}_nu"][:, m], cat[f"{prefix}_S"][:, m]
        valid, fused, rejected = (cat[f"{prefix}_flags"][:, m, :, j] for j in range(3))
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.max(nu**2 / (self.gate**2 * S), axis=-1)
        return UpdateRecord(
            t_s=cat["up_t"],
            z=cat[f"{prefix}_z"][:, m],
            innovation=nu,
            innovation_var=S,
            test_ratio=ratio,
            fused=fused,
            rejected=rejected,
            valid=valid,
            fused_rows=np.repeat(fused[..., None], 3, -1),
            rejected_rows=np.repeat(rejected[..., None], 3, -1),
            nis=cat[f"{prefix}_nis"][:, m],
            nis_dof=np.where(valid, 3, 0),
            unusable=np.zeros_like(valid),
        )

    def _added_truth(self, chunk: SimChunk) -> np.ndarray:
        """The added states' truth at the chunk's samples (K, E) (tauvcore.engine.source_streams.states_truth)."""
        if self._extra_truth is None or self._extra_truth[0] != chunk.k0:
            self._extra_truth = (chunk.k0, states_truth(self.config, chunk.truth))
        return self._extra_truth[1]

    # ------------------------------------------------------------------ results
    def _results(self, cat: Store, taking: bool) -> dict[str, MethodResult]:
        _, R = self.batch
        t_s = cat["t_s"]
        U = cat["up_t"].size
        trace = None
        if self.has_vkf and U:
            trace = {
                "t_s": cat["up_t"],
                "x": cat["tr_x"],
                "sigma": cat["tr_sigma"],
                "sf_true": cat["tr_truth"][..., 0],
                "b_true": cat["tr_truth"][..., 1],
                "rpm_in_use": cat["tr_use"],
                "altitude_m": cat["tr_alt"],
            }
        first_update = {key: rec.taken for key, rec in self.recorders.items()} if taking and self.keep else {}
        out = {}
        for m, method in enumerate(self.methods):
            updates = {}
            if U:  # the velocity aid, from the DVL or (vkf) the RPM; and the water-track's
                updates["dvl"] = self._ping_record(cat, "up", m)
                if self.added.water_var is not None:
                    updates["water"] = self._ping_record(cat, "wt", m)
            for name, rec in self.recorders.items():
                record = rec.build(m, first_update.get(name, 0)) if rec.count else None
                if record is not None:
                    updates[name] = record if self._until_s is None else record.until(self._until_s)
            nonfinite = _nonfinite(cat, m)  # (T, R)
            first_bad = (
                np.array([t_s[np.argmax(col)] if col.any() else np.nan for col in nonfinite.T])
                if t_s.size
                else np.full(R, np.nan)
            )
            first_bad = np.fmin(first_bad, self.nonfinite_at_s[m])
            if taking:
                self.nonfinite_at_s[m] = first_bad
            flags = [first_bad] + [rec.divergence_s(m) for rec in self.recorders.values() if rec.count]
            first_bad = np.fmin.reduce(np.stack(flags), axis=0)
            out[method] = method_result(
                method,
                m,
                t_s,
                cat["series"],
                cat,
                first_bad,
                self.sensor_errors,
                p_floor_count=np.zeros(R, int),
                updates=updates,
                block_dims=self.block_dims,
                vkf_trace=trace if method == "vkf" else None,
                state_labels=self.state_labels,
            )
        if taking:
            handed_out(self.recorders.values(), self.keep)
        return out

    # ------------------------------------------------------------------ the smoother
    def smooth(self, out: Tape) -> np.ndarray:
        """The smoother's backward pass over the tape (tauvcore.engine.yoo_smoothing), its
        smoothed stores into ``out``; the tape is emptied. -> (M, R) the steps where the pass
        started afresh."""
        assert self.taping is not None  # a bank made with a tape
        self.taping.close(self.rows)
        carry = Carry(int(np.prod(self.batch)), yoo.DIM, yoo.DIM, self.added.dim, self.added.num)
        args = (
            carry,
            self.batch,
            self.block_of_state,
            self.num_blocks,
            SENSOR_INDEX,
            1.0 / units.DEG,
            self.ref_var,
        )
        smooth_tape(self.taping.tape, out, lambda segment: smooth_yoo_segment(segment, *args))
        return carry.cuts.reshape(self.batch)

    def smoothed_results(self, store: Store, cuts: np.ndarray) -> dict[str, MethodResult]:
        """Each method's smoothed results from smoothed stores (:meth:`smooth`) concatenated, cut
        where a stop ended the run (the monitor's verdict the forward pass's, no updates)."""
        if self._until_s is not None:
            store = cut(store, self._until_s, "t_s", "up_t")
        out = {}
        for m, method in enumerate(self.methods):
            flags = [self.nonfinite_at_s[m]] + [
                rec.divergence_s(m) for rec in self.recorders.values() if rec.count
            ]
            out[method] = method_result(
                method,
                m,
                store["t_s"],
                store["series"],
                store,
                np.fmin.reduce(np.stack(flags), axis=0),
                self.sensor_errors,
                p_floor_count=np.zeros(self.batch[1], int),
                block_dims=self.block_dims,
                smoother_cuts=cuts[m].copy(),
                state_labels=self.state_labels,
            )
        return out


def _nonfinite(cat: Store, m: int) -> np.ndarray:
    """Output epochs at which method ``m``'s state or covariance is not finite: (T, R) bool.

    Judged from the filter's own output alone (its position, velocity and attitude, and the 1-sigma
    of its velocity and attitude), as the 20-state bank judges its own (tauvcore.engine.loop.record):
    the NEES and the errors need the truth, which a log without one (or without its IMU's biases)
    does not give.
    """
    own = [cat["series"][SERIES.index(name), :, m] for name in SIGMA_SERIES]
    finite = np.logical_and.reduce([np.isfinite(s) for s in own])
    for key in ("est_pos_n", "est_vel_n", "est_euler"):
        finite &= np.isfinite(cat[key][:, m]).all(axis=-1)
    return ~finite
