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

Numerical health: after the corrections of every aiding epoch, and at least once per
second of propagation (:data:`CONDITION_CHECK_RATE_HZ`), P goes through
:func:`~tauvcore.filter.eskf.condition_covariance` (one batched Cholesky for all methods and
runs; an eigenvalue floor only where it fails, counted per run in ``MethodResult.p_floor_count``). The divergence
monitor flags a run's solution (``MethodResult.diverged``, ``diverged_at_s``) at the first of

- an output epoch where its state or P is not finite;
- an aiding epoch after which an estimated sensor error (IMU or DVL bias, DVL scale factor) lies far
  outside the filter's own prior (:func:`~tauvcore.engine.monitor.implausible_sensor_errors`);
- an innovation inconsistency of any of its aiding sources
  (:func:`~tauvcore.engine.monitor.innovation_divergence_s`: windowed NIS above its chi-square
  bound, or the source locked out by the gate).

It uses no truth, as a real filter could not; so it cannot see an error in a direction nothing
measures (heading on a straight line with the DVL alone, or VB's self-confirming virtual beam on
a fixed pair at a small n_f): the NEES against truth in the records shows those. The standalone
INS has no innovations and estimates no sensor error: it is flagged only if not finite.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from functools import partial
from typing import Any

import numpy as np

from tauvcore import units
from tauvcore.aiding.noise_floors import dvl_beam_sigma_mps
from tauvcore.aiding.registry import REGISTRY
from tauvcore.aiding.sources import SOURCES
from tauvcore.config import Config
from tauvcore.engine import loop, smoothing
from tauvcore.engine.chunk_driver import ChunkDriver, ChunkInputs, Store, covariance_stops
from tauvcore.engine.dvl_fusion import (
    DVL_FUSION,
    DVL_MODE_CODES,
    DVL_ROWS,
    INVARIANT_METHODS,
    dvl_innovation,
    fuse_water_track,
    partial_tables,
    rpm_fallback,
    water_model,
)
from tauvcore.engine.lockout import fuse_reacquiring, lockout_reset
from tauvcore.engine.monitor import sensor_prior_bound
from tauvcore.engine.recorder import Recorder, handed_out
from tauvcore.engine.results import SENSOR_FIELDS, SENSOR_STATES, STATE_FIELDS, MethodResult, method_result
from tauvcore.engine.rpm_aid import RpmAid
from tauvcore.engine.scale_factor import VelocityAverage, body_velocity, scale_factor_rows
from tauvcore.engine.simulation import SimChunk
from tauvcore.engine.source_streams import active, layout_of, states_truth
from tauvcore.engine.start import initial_covariance, initial_nominal
from tauvcore.engine.tape import OUTPUT_TAPE, Tape, TapeWriter, eskf_tape_shape, nominal_difference, tape_rows
from tauvcore.filter.eskf import (
    Nominal,
    condition_covariance,
    fuse_in_place,
    make_outcome,
    widen,
)
from tauvcore.filter.families import FAMILIES, family_of
from tauvcore.filter.kernels.common import CORE, NAV, plain
from tauvcore.filter.kernels.dvl_kernels import (
    DVL_ELC,
    DVL_LC,
    DVL_TC,
    DvlMethods,
    DvlRows,
    DvlState,
    Ping,
    dvl_measure_bank,
)
from tauvcore.filter.layout import NOISE, STATE, NavState
from tauvcore.ins.error_model import noise_psd

CONDITION_CHECK_RATE_HZ = 1.0
"""P is checked (and repaired if need be) after the corrections of every aiding epoch, where
updates can lose definiteness to round-off, and at least this often in between (propagation
alone, e.g. the standalone INS or a DVL outage, only carries a positive definite P forward)."""


SENSOR_INDEX = np.array([getattr(STATE, c.block).start + c.component for c in SENSOR_STATES], dtype=np.int64)
"""The error state of each column of the sensor-error records (tauvcore.engine.results.SENSOR_STATES)."""
_DVL_COLUMNS = np.array([c.block in ("b_dvl", "sf_dvl") for c in SENSOR_STATES])


def _epoch_map(indices: np.ndarray) -> dict[int, int]:
    return {int(k): i for i, k in enumerate(indices)}


class FilterBank(ChunkDriver):
    """Every method of ``config.run.methods`` over R runs, fed a simulation chunk by chunk
    (tauvcore.engine.chunk_driver.ChunkDriver: the chunk order, polling, store and hand-out).

    The (methods, runs) nominal states and covariances live in contiguous arrays that the
    compiled kernels (tauvcore.filter.kernels) update in place; between two covariance or event
    epochs the nominal state advances in one kernel call. The state carried from one chunk to the
    next: the last raw IMU increments (coning/sculling and the ping's rate need their
    predecessor), the gyro increments since the last covariance step, and the true DVL errors of
    the latest ping (for the records). Results are kept (``keep``), or handed out chunk by chunk
    (:meth:`take`) and dropped, so that memory does not grow with the mission. With
    ``sensor_errors`` every output epoch also records the estimated sensor errors, their 1-sigma
    and their truth (tauvcore.engine.results.SENSOR_STATES).
    """

    def __init__(
        self,
        config: Config,
        num_runs: int,
        num_samples: int,
        dt_s: float,
        rng: np.random.Generator | Sequence[np.random.Generator] | None = None,
        keep: bool = True,
        sensor_errors: bool = False,
        tape: Tape | None = None,
    ) -> None:
        methods = tuple(config.run.methods)
        super().__init__(config, methods, num_runs, num_samples, dt_s, keep, sensor_errors)
        self.rng = rng
        self.q_psd = noise_psd(config.imu, config.dvl)
        self.aiding = set(config.run.aiding)
        self.gyro_rate_noise = config.imu.gyro_noise_rad_per_sqrt_s / np.sqrt(dt_s) * np.sqrt(2.5)
        self._set_up_dvl(config, methods)
        self._set_up_layout(config, tape)
        self._set_up_sources(config, methods, num_samples)
        self.p_floor_count = np.zeros(self.batch, dtype=int)
        self.nonfinite_at_s = np.full(self.batch, np.nan)  # first output epoch with a non-finite state or P
        # first aiding epoch with a sensor error outside its prior
        self.implausible_at_s = np.full(self.batch, np.nan)
        self._no_extra = np.zeros((0, 0))
        self.slot = 0  # output epochs recorded so far
        self.dvl_truth_known = True  # the mission has DVL pings (set at start)

    def _set_up_dvl(self, config: Config, methods: tuple[str, ...]) -> None:
        """The DVL's methods: who fuses it how (tauvcore.engine.dvl_fusion.DVL_FUSION), their
        two-beam tables and gates, the invariant filters, the families that linearise their own way."""
        # the aided methods (every one but the standalone INS) take every source of the registry
        self.other_mask = np.array([DVL_FUSION.get(m) is not None or m in REGISTRY for m in methods])[
            :, None
        ] & np.ones(self.batch, bool)
        kinds = [(i, m, DVL_FUSION.get(m)) for i, m in enumerate(methods)]
        self.dvl_methods = [(i, m) for i, m, kind in kinds if kind is not None]
        self.dvl_index = np.array([i for i, _ in self.dvl_methods], dtype=np.int64)
        self.dvl_codes = np.array(
            [{"lc": DVL_LC, "tc": DVL_TC, "elc": DVL_ELC}[kind] for _, _, kind in kinds if kind is not None],
            dtype=np.int64,
        )
        self.partial_tables = partial_tables([m for _, m in self.dvl_methods], config)
        self.A_b = np.ascontiguousarray(config.dvl.A_b, dtype=float)
        self.l_dvl_b = np.ascontiguousarray(config.dvl.l_dvl_b, dtype=float)
        # tightly coupled beams are gated row by row, the velocities whole (eskf.correct)
        self.dvl_gate_rows = np.zeros(self.batch, bool)
        # the right-invariant EKF's filters (tauvcore.filter.invariant): corrected on SE_2(3)
        invariant = np.array([m in INVARIANT_METHODS for m in methods])[:, None] & np.ones(self.batch, bool)
        self.invariant = invariant.reshape(-1) if invariant.any() else None
        for m, method in self.dvl_methods:
            self.dvl_gate_rows[m] = DVL_FUSION[method] == "tc"
        # the families whose corrections linearise their own way (tauvcore.filter.families.spec.Linearize):
        # each its hook and its rows of the bank
        self.linearizing = [
            (family.linearize, np.flatnonzero([family_of(m).name == family.name for m in methods]))
            for family in FAMILIES.values()
            if family.linearize is not None and any(family_of(m).name == family.name for m in methods)
        ]

    def _set_up_layout(self, config: Config, tape: Tape | None) -> None:
        """The error state: the layout's 20 and the states the sources add
        (tauvcore.filter.layout.Layout), its NEES blocks, and the smoother's tape writer."""
        # the smoother's tape of the marks (tauvcore.engine.smoothing); None: no smoother
        self._no_tape = tape_rows(0, self.batch)
        self.layout = layout_of(config)
        self.extra_rate, self.extra_q, _ = self.layout.extra_arrays()
        self.taping: TapeWriter | None = None
        if tape is not None:
            self.taping = TapeWriter(
                tape,
                self.batch,
                eskf_tape_shape(self.layout.num_extra),
                partial(nominal_difference, batch=self.batch, geodetic=self.geodetic),
                self.extra_rate,
            )
        self.state_labels = tuple(label for b in self.layout.blocks for label in b.labels) or None
        blocks = self.layout.nees_blocks  # the results' NEES blocks: None, the 20-state filter's
        self.block_dims = (
            {"full": self.layout.dim, **{k: len(v) for k, v in blocks.items()}}
            if self.layout.num_extra
            else None
        )
        self.ref_var = config.reference.variances()  # the NEES's P + P_ref (loop.Model.ref_var)
        self.block_of_state = np.full(self.layout.dim, -1)
        for b, ix in enumerate(self.layout.nees_blocks.values()):
            self.block_of_state[list(ix)] = b

    def _set_up_sources(self, config: Config, methods: tuple[str, ...], num_samples: int) -> None:
        """The aiding sources besides the DVL's bottom track and their update recorders: the
        registry's sources ``run.aiding`` turns on, the registered methods, the RPM fallback and
        the water-track beams."""
        M, R = self.batch
        dvl_members = np.isin(np.arange(M), self.dvl_index)
        dvl_rows = np.array([DVL_ROWS if DVL_FUSION.get(m) == "tc" else 3 for m in methods], dtype=np.int64)
        others = self.other_mask.any(axis=1)
        self.recorders = {
            "dvl": Recorder(dvl_members, dvl_rows),
        }
        # the sources of tauvcore.aiding.sources that run.aiding turns on: fused by every aided method
        self.plugins = [
            (name, SOURCES[name].model(config.section(SOURCES[name].section_name), config))
            for name in active(config)
        ]
        for name, _ in self.plugins:
            self.recorders[name] = Recorder(others)
        self.recorders["rpm"] = Recorder(dvl_members, dvl_rows)
        # registered methods (tauvcore.aiding.registry): each its model, members and epochs
        self.registered = []
        for name in (m for m in methods if m in REGISTRY):
            spec = REGISTRY[name]
            step = max(1, round(config.imu.rate_hz / spec.rate_hz))
            members = np.array([m == name for m in methods])
            self.registered.append(
                (spec.source, spec.model(config), members, np.arange(step, num_samples, step))
            )
            self.recorders[spec.source] = Recorder(members)
        # --rpm-fallback: one velocity Kalman filter per run (tauvcore.engine.rpm_aid.RpmAid)
        self.rpm_aid = None
        if config.run.rpm_fallback and self.dvl_methods and "dvl" in self.aiding:
            self.rpm_aid = RpmAid(config.vkf, R)
            self.rpm_A_pinv = np.linalg.pinv(np.asarray(config.dvl.A_b, dtype=float))  # (3, 4): LC's A+
        self.check_step = max(1, round(config.imu.rate_hz / CONDITION_CHECK_RATE_HZ))
        self.water = water_model(config, self.layout)  # the water-track beams, with current states
        if self.water is not None:
            self.recorders["water"] = Recorder(dvl_members, np.full(M, DVL_ROWS, dtype=np.int64))

    # ------------------------------------------------------------------ set-up at the first chunk
    def start(self, chunk: SimChunk, nav: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> None:
        """Initial states from the first chunk: the estimate at t = 0 (``nav``: position, NED
        velocity and attitude per run, (R, 3), (R, 3), (R, 3, 3), as tauvcore.engine.mission.Banks
        draws it for every family; None: drawn here from the bank's ``rng``), biases zero; done by
        :meth:`feed` unless called first."""
        config, truth = self.config, chunk.truth
        self.P0 = P0 = initial_covariance(config, truth.euler[0], self.layout)
        self.P = np.broadcast_to(P0, self.batch + P0.shape).copy()
        if nav is None:
            assert self.rng is not None  # a bank fed without Banks draws its own initial errors
            drawn = initial_nominal(config, truth, self.rng, (1, self.batch[1]), P0[STATE.att, STATE.att]).nav
            nav = (drawn.pos_n[0], drawn.vel_n[0], drawn.C_nb[0])
        R = self.batch[1]
        arrays = [
            np.array(np.broadcast_to(a, self.batch + a.shape[1:]), dtype=float, order="C")
            for a in (*nav, np.zeros((R, 3)), np.zeros((R, 3)), np.zeros((R, 4)), np.zeros(R))
        ]
        self.pos, self.vel, self.C, self.ba, self.bg, self.bdvl, self.sf = arrays
        self.extra = np.zeros(self.batch + (self.layout.num_extra,))  # the sources' states start at zero
        self.flat = (
            self.pos.reshape(-1, 3),
            self.vel.reshape(-1, 3),
            self.C.reshape(-1, 3, 3),
            self.ba.reshape(-1, 3),
            self.bg.reshape(-1, 3),
            self.bdvl.reshape(-1, 4),
            self.sf.reshape(-1),
            self.extra.reshape(self.batch[0] * self.batch[1], self.layout.num_extra),
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
        self.dvl_truth_known = bool(len(dvl.index))  # without pings the records' zero stands for no truth
        self.k_checked = 0  # sample P was last checked (positive definite) at
        self.dtheta_sum = np.zeros((R, 3))  # gyro increments since k_cov
        self.dvl_rejected = np.zeros(self.batch, dtype=np.int64)  # consecutive pings the gate rejected
        self.dvl_reacquire = np.zeros(self.batch, bool)  # reset at the last ping: the next one ungated
        # the smoother's transition since its last mark (no rows: no smoother)
        self.phi_acc = np.zeros(((self.batch[0] if self.taping is not None else 0), R, NAV, CORE))
        tau_s = config.filter.scale_factor_velocity_tau_s
        # the velocity the DVL scale factor's column of H is taken at (tauvcore.engine.scale_factor)
        self.sf_velocity = VelocityAverage(tau_s) if tau_s > 0 else None
        self.started = True

    def nominal(self, m: int | np.ndarray | None = None) -> Nominal:
        """The current estimate: of method m (views), of the methods ``m`` (copies), or of the
        whole bank (views)."""
        sel = slice(None) if m is None else m
        return Nominal(
            NavState(self.pos[sel], self.vel[sel], self.C[sel]),
            self.ba[sel],
            self.bg[sel],
            self.bdvl[sel],
            self.sf[sel],
            self.extra[sel] if self.layout.num_extra else None,
        )

    # ------------------------------------------------------------------ the pieces of an epoch
    def _condition(self) -> None:
        """Keep every P positive definite (one compiled Cholesky per filter; numpy repair if one fails)."""
        ok = loop.positive_definite_bank(self.P)
        if not ok.all():
            self._repair()

    def _repair(self) -> None:
        """The numpy repair of the bank's covariances (tauvcore.filter.eskf.condition_covariance)."""
        P_new, repaired = condition_covariance(self.P)
        self.P[...] = P_new
        self.p_floor_count[...] += repaired

    def _check_sensor_errors(self, t: float) -> None:
        """After the corrections of an aiding epoch (the only moments the estimates change)."""
        loop.flag_implausible_bank(
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
        self,
        H: np.ndarray,
        Rm: np.ndarray,
        nu: np.ndarray,
        active: np.ndarray,
        gate_rows: np.ndarray,
        gate: float | None = None,
    ) -> tuple[np.ndarray, ...]:
        """One compiled gated correction and injection of the whole bank in place (inactive rows
        and entries untouched). Arrays (M, R, m, ...); returns the per-entry outcome (M, R, ...).
        ``gate``: the gate's width [sigma], ``filter.gate_sigma`` if None."""
        d = self.layout.dim
        fused = fuse_in_place(
            self.P.reshape(-1, d, d),
            self.flat,
            widen(H, d),
            Rm,
            nu,
            active,
            gate_rows.reshape(-1),
            self.gate if gate is None else gate,
            self.geodetic,
            self.invariant,
        )
        return tuple(a.reshape(self.batch + a.shape[1:]) for a in fused)

    def _linearized(
        self,
        H: np.ndarray,
        Rm: np.ndarray,
        nu: np.ndarray,
        active: np.ndarray,
        remeasure: Callable[[Nominal, np.ndarray], np.ndarray],
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The measurement every filter is corrected with: ``(H, Rm, nu)`` (M, R, m, ...) as given,
        the Jacobian at the estimate, but for the rows of a family that linearises its own way
        (tauvcore.filter.families.spec.Linearize), which it replaces. ``remeasure(nominal,
        methods)``: the innovation (B', R, m) at nominal states of batch (B', R), state b' of the
        bank's method ``methods[b']``."""
        if not self.linearizing:
            return H, Rm, nu
        m_rows = np.shape(nu)[-1]
        H = np.array(np.broadcast_to(widen(H, self.layout.dim), self.batch + (m_rows, self.layout.dim)))
        Rm = np.array(np.broadcast_to(Rm, self.batch + (m_rows, m_rows)), dtype=float)
        nu = np.array(np.broadcast_to(nu, self.batch + (m_rows,)), dtype=float)
        for linearize, rows in self.linearizing:
            if not active[rows].any():
                continue

            def at(nom: Nominal, rows: np.ndarray = rows) -> np.ndarray:
                return remeasure(nom, np.tile(rows, nom.dvl_sf.shape[0] // rows.size))

            H[rows], Rm[rows], nu[rows] = linearize(
                self.P[rows],
                self.nominal(rows),
                at,
                (H[rows], Rm[rows], nu[rows], active[rows]),
                self.geodetic,
            )
        return H, Rm, nu

    def _update_source(self, source: str, model: Any, data: Any, j: int, t: float) -> None:
        """Epoch ``j`` of a source every aided method takes (tauvcore.aiding.sources: its ``model``
        and chunk ``data``): one batched correction."""
        meas = model.measure(self.nominal(), data, j)
        valid = meas.valid & self.other_mask
        m_rows = meas.R.shape[-1]
        active = np.ones(self.batch + (m_rows,), bool) if meas.active is None else meas.active.astype(bool)
        active = active & valid[..., None]
        H, Rm, nu = self._linearized(
            meas.H, meas.R, meas.innovation, active, lambda nom, _: model.measure(nom, data, j).innovation
        )
        fused = self._fuse(H, Rm, nu, active, np.full(self.batch, meas.gate_rows))
        outcome = make_outcome(meas.z, nu, active, *fused)
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
        rows = DvlRows(
            z=np.zeros(batch + (DVL_ROWS,)),
            nu=np.zeros(batch + (DVL_ROWS,)),
            H=np.empty(batch + (DVL_ROWS, STATE.dim)),
            Rm=np.ones(batch + (DVL_ROWS, DVL_ROWS)),
            active=np.zeros(batch + (DVL_ROWS,), bool),
            valid=np.zeros(batch, bool),
            mode=np.zeros(batch, np.int64),
            measured_axes=np.zeros(batch + (3,), bool),
            choice=np.full(batch + (3,), -1, np.int64),
        )
        ping = Ping(
            np.ascontiguousarray(y), np.ascontiguousarray(available), np.ascontiguousarray(omega_meas)
        )
        state = DvlState(self.C, self.vel, self.bg, self.bdvl, self.sf, self.P)
        dvl_measure_bank(
            plain(self._dvl_methods(self.dvl_index, self.dvl_codes)),
            plain(self.partial_tables),
            plain(ping),
            plain(state),
            plain(rows),
        )
        z, nu, H, Rm, active, valid, mode, measured_axes, choice = rows
        if self.sf_velocity is not None:
            v_ref = self.sf_velocity.reference(body_velocity(self.C, self.vel))
            scale_factor_rows(H, mode, self.A_b, v_ref)
        H, Rm, nu = self._linearized(H, Rm, nu, active, lambda nom, at: dvl_innovation(self, nom, at, ping))
        reacquire = self.dvl_reacquire & valid
        if reacquire.any():  # the ping after a reset: fused whatever its innovation
            fused = fuse_reacquiring(self, H, Rm, nu, active, reacquire)
            self.dvl_reacquire[reacquire] = False
        else:
            fused = self._fuse(H, Rm, nu, active, self.dvl_gate_rows)
        outcome = make_outcome(z, nu, active, *fused)
        reset = lockout_reset(self, ~outcome.fused, valid, y, available, omega_meas)
        if self.sf_velocity is not None:
            self.sf_velocity.update(body_velocity(self.C, self.vel), t, reset)
        self.recorders["dvl"].add(
            t,
            outcome,
            valid,
            shared={"beams_available": available},
            mode=mode,
            measured_axes=measured_axes,
            elc_choice=choice,
            reset=reset,
        )
        return valid

    def _dvl_methods(self, index: np.ndarray, codes: np.ndarray) -> DvlMethods:
        """The DVL kernel's methods: the bank's rows ``index`` with their constructions ``codes``."""
        return DvlMethods(
            index,
            codes,
            self.A_b,
            self.l_dvl_b,
            dvl_beam_sigma_mps(self.config.dvl.noise_mps) ** 2,
            self.gyro_rate_noise**2,
            self.w_ie,
            DVL_MODE_CODES,
            self.config.partial.sensor_columns,
        )

    def _rpm_fallback(self, chunk: SimChunk, p: int, i: int, t: float, dvl_valid: np.ndarray) -> None:
        """``run.rpm_fallback`` at ping ``p`` (tauvcore.engine.dvl_fusion.rpm_fallback)."""
        rpm_fallback(self, chunk, p, i, t, dvl_valid)

    def _bank_state(self) -> loop.BankState:
        """The bank's states as the compiled kernels take them: the arrays themselves, not copies,
        in a plain tuple (tauvcore.filter.kernels.common.plain). The arrays are made at
        :meth:`start` and written in place after, so one tuple serves a whole chunk."""
        state = loop.BankState(
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
            self.phi_acc,
            self.extra,
        )
        return plain(state)

    def _model(self) -> loop.Model:
        """The constants of the compiled covariance step and records, in a plain tuple."""
        constants = loop.Model(
            self.origin,
            self.w_ie,
            self.q_psd,
            self.block_of_state,
            len(self.layout.nees_blocks),
            units.DEG,
            SENSOR_INDEX,
            self.extra_rate,
            self.extra_q,
            self.ref_var,
        )
        return plain(constants)

    def _outputs(self, store: Store) -> loop.Outputs:
        """The store's arrays the compiled records write, and the smoother's tape of the current
        chunk (no rows without a smoother), in a plain tuple."""
        tape = self.taping.out if self.taping is not None and self.taping.out is not None else self._no_tape
        first = ("series", "nees_block", "est_pos_n", "t_s", "est_vel_n", "est_euler", *SENSOR_FIELDS)
        outputs = loop.Outputs(
            *(store[name] for name in first),
            *(tape[name] for name in OUTPUT_TAPE),
            *(store[name] for name in STATE_FIELDS),
            pos_cov_ne=store["pos_cov_ne_m2"],
        )
        return plain(outputs)

    def _record(self, out: Store, row: int, i: int) -> None:
        """Output epoch ``row`` of the store ``out``, at sample ``i`` of the current chunk."""
        loop.record_bank(
            row, i, self._chunk_in, self._bank_state(), self._model(), self.geodetic, self._outputs(out)
        )
        self.slot += 1

    # ------------------------------------------------------------------ the chunk
    def _begin(self, chunk: SimChunk) -> None:
        self.start(chunk)

    def _store(self, outs: np.ndarray, chunk: SimChunk | None) -> Store:
        T = outs.size
        return {
            "t_s": np.zeros(T),
            "out_k": outs,
            "series": np.zeros((len(loop.SERIES_NAMES), T) + self.batch),
            "nees_block": np.zeros((T,) + self.batch + (len(self.layout.nees_blocks),)),
            "est_pos_n": np.zeros((T,) + self.batch + (3,)),
            "pos_cov_ne_m2": np.zeros((T,) + self.batch + (3,)),
            "est_vel_n": np.zeros((T,) + self.batch + (3,)),
            "est_euler": np.zeros((T,) + self.batch + (3,)),
            **self._sensor_store(T, SENSOR_INDEX.size, 0.0),
            **{name: np.zeros((T,) + self.batch + (self.layout.num_extra,)) for name in STATE_FIELDS},
        }

    def _sealed(self) -> None:
        for rec in self.recorders.values():
            rec.seal()

    def _chunk_end(self, chunk: SimChunk) -> None:
        if len(chunk.dvl.index):
            self.ping_bias[...] = chunk.dvl.bias_mps[-1]
            self.ping_sf[...] = chunk.dvl.scale_factor[-1]

    def _chunk_truth(self, chunk: SimChunk, inputs: ChunkInputs) -> loop.ChunkTruth:
        """The chunk's inputs of the compiled stretch between aiding epochs (loop.run_stops)."""
        truth, imu, dvl = chunk.truth, chunk.imu, chunk.dvl
        return loop.ChunkTruth(
            inputs.phi_raw,
            inputs.dv_raw,
            inputs.dtheta,
            np.ascontiguousarray(truth.t_s),
            np.ascontiguousarray(truth.pos_nav),
            np.ascontiguousarray(truth.vel_n),
            np.ascontiguousarray(truth.C_nb),
            np.ascontiguousarray(imu.accel_bias),
            np.ascontiguousarray(imu.gyro_bias),
            np.asarray(dvl.index, dtype=np.int64),
            np.ascontiguousarray(dvl.bias_mps, dtype=float),
            np.ascontiguousarray(dvl.scale_factor, dtype=float),
            states_truth(self.config, truth) if self.layout.num_extra else self._no_extra,
        )

    def _schedule(
        self, chunk: SimChunk, aiding_at: Sequence[Iterable[int]], out_row: dict[int, int], poll_every: int
    ) -> loop.Schedule:
        """The chunk's stops for loop.run_stops: the covariance steps, the aiding epochs (the
        global samples of each collection in ``aiding_at``) and the output epochs (output row
        ``out_row[k]`` at global sample k)."""
        k0, n = chunk.k0, chunk.truth.num_samples
        events = np.zeros(n, dtype=bool)  # aiding epochs
        for keys in aiding_at:
            events[[k - k0 for k in keys]] = True
        marks = events.copy()  # and output epochs: where the covariance step stops
        marks[[k - k0 for k in out_row]] = True
        stops = np.asarray(
            covariance_stops(np.flatnonzero(marks) + k0, self.k_cov, k0 + n, self.cov_step), dtype=np.int64
        )
        stop_row = np.array([out_row.get(int(k), -1) for k in stops], dtype=np.int64)
        return loop.Schedule(stops, events[stops - k0], stop_row, k0, self.check_step, poll_every)

    def _fuse_epoch(
        self,
        chunk: SimChunk,
        inputs: ChunkInputs,
        dvl_at: dict[int, int],
        plugin_at: dict[str, dict[int, int]],
        registered_at: list[set[int]],
        k: int,
        t: float,
    ) -> None:
        """The corrections of the aiding epoch at global sample ``k`` (time ``t`` [s]): the DVL's
        ping ``dvl_at[k]`` if any (with its water-track and the RPM fallback), each plug-in
        source's sample ``plugin_at[name][k]``, each registered method due at k."""
        i = k - chunk.k0
        if k in dvl_at:
            p = dvl_at[k]
            before = inputs.dtheta[i - 1] if i > 0 else inputs.prev_dtheta
            omega_meas = (3.0 * inputs.dtheta[i] - before) / (2.0 * self.dt)  # rate at t_k, 2nd order
            dvl_valid = self._update_dvl(chunk.dvl.y_beam_mps[p], chunk.dvl.available[p], omega_meas, t)
            if self.water is not None and chunk.dvl.y_water_mps is not None:
                fuse_water_track(self, chunk, p, omega_meas, t)
            if self.rpm_aid is not None:
                self._rpm_fallback(chunk, p, i, t, dvl_valid)
        for name, model in self.plugins:
            if k in plugin_at.get(name, ()):
                self._update_source(name, model, chunk.sources[name], plugin_at[name][k], t)
        for r, keys in enumerate(registered_at):
            if k in keys:
                self._update_registered(r, t)

    def _run_chunk(
        self, chunk: SimChunk, inputs: ChunkInputs, store: Store, poll_every: int
    ) -> Iterator[int]:
        """The chunk's stops: the compiled stretch between aiding epochs
        (:func:`~tauvcore.engine.loop.run_stops`, which records the output epochs in between),
        the corrections of each aiding epoch here."""
        k0, k1 = chunk.k0, chunk.k0 + chunk.truth.num_samples
        dvl_at = _epoch_map(chunk.dvl.index) if "dvl" in self.aiding and self.dvl_methods else {}
        plugin_at = {
            name: _epoch_map(chunk.sources[name].index)
            for name, _ in self.plugins
            if name in chunk.sources and self.other_mask.any()
        }
        registered_at = [
            {int(k) for k in epochs[(epochs >= k0) & (epochs < k1)]} for _, _, _, epochs in self.registered
        ]
        outs = store["out_k"]
        out_row = {int(k): r for r, k in enumerate(outs)}
        chunk_in = self._chunk_truth(chunk, inputs)
        self._chunk_in = chunk_args = plain(chunk_in)
        if self.taping is not None:
            self.taping.open(store, self.slot)
        if k0 == 0 and 0 in out_row:
            self._record(store, 0, 0)
        aiding_at = [dvl_at, *plugin_at.values(), *registered_at]
        schedule = self._schedule(chunk, aiding_at, out_row, poll_every)
        stops, is_event, args = schedule.stops, schedule.is_event, plain(schedule)
        constants, outputs = self._model(), self._outputs(store)
        bank, sd = self._bank_state(), plain(self.sd_consts)  # the same arrays for the whole chunk
        counters = np.zeros(4, dtype=np.int64)
        s = 0
        while s < stops.size:
            counters[:] = (self.k_state, self.k_cov, self.k_checked, self.slot)
            s, why = loop.run_stops(args, s, stops.size, counters, bank, chunk_args, sd, constants, outputs)
            self.k_state, self.k_cov, self.k_checked, self.slot = (int(c) for c in counters)
            if why == loop.STOPS_DONE:
                break
            k = int(stops[s])
            i = k - k0
            t = float(chunk.truth.t_s[i])
            taping = self.taping if why != loop.STOPS_YIELD else None
            mark = taping.before(self.phi_acc, self.P, self.flat, t) if taping is not None else None
            if why == loop.STOPS_REPAIR:
                self._repair()
            if why in (loop.STOPS_EVENT, loop.STOPS_REPAIR):
                self._fuse_epoch(chunk, inputs, dvl_at, plugin_at, registered_at, k, t)
                if is_event[s]:
                    self._condition()
                    self.k_checked = k
                    self._check_sensor_errors(t)
                if taping is not None and mark is not None:
                    taping.after(mark, self.P, self.flat, self.slot)
                if k in out_row:
                    latest = np.searchsorted(chunk_in.ping_rows, k, side="right") - 1
                    if latest >= 0:
                        self.ping_bias[...] = chunk.dvl.bias_mps[latest]
                        self.ping_sf[...] = chunk.dvl.scale_factor[latest]
                    self._record(store, out_row[k], i)
            if k in out_row and poll_every and self.slot % poll_every == 0:
                yield k
            s += 1
        if self.taping is not None:
            self.taping.close(self.slot)

    # ------------------------------------------------------------------ results
    def _results(self, cat: Store, taking: bool) -> dict[str, MethodResult]:
        first_update = {key: rec.taken for key, rec in self.recorders.items()} if taking and self.keep else {}
        if self.sensor_errors and not self.dvl_truth_known:  # no pings: the DVL's truth is unknown
            cat = {**cat, "sensor_true": np.where(_DVL_COLUMNS, np.nan, cat["sensor_true"])}
        out = {}
        for m, method in enumerate(self.methods):
            recs = {src: rec for src, rec in self.recorders.items() if rec.members[m] and rec.count}
            built = {src: rec.build(m, first_update.get(src, 0)) for src, rec in recs.items()}
            out[method] = method_result(
                method,
                m,
                cat["t_s"],
                cat["series"],
                cat,
                self._flagged_at(m),
                self.sensor_errors,
                p_floor_count=self.p_floor_count[m].copy(),
                updates={src: record for src, record in built.items() if record is not None},
                block_dims=self.block_dims,
                state_labels=self.state_labels,
            )
        if taking:
            handed_out(self.recorders.values(), self.keep)
        return out

    def _flagged_at(self, m: int) -> np.ndarray:
        """(R,) the monitor's first flag of method m's runs [s], NaN: none (module docstring)."""
        recs = [rec for rec in self.recorders.values() if rec.members[m] and rec.count]
        flagged = [self.nonfinite_at_s[m], self.implausible_at_s[m]] + [rec.divergence_s(m) for rec in recs]
        return np.fmin.reduce(np.stack(flagged), axis=0)

    # ------------------------------------------------------------------ the smoother
    def smooth(self, out: Tape) -> np.ndarray:
        """The smoother's backward pass over the tape of the run so far (up to a stop), its
        smoothed stores into ``out`` (tauvcore.engine.smoothing.smooth_tape); the tape is
        emptied. -> (M, R) the steps where the pass started afresh."""
        assert self.taping is not None  # a bank made with a tape
        self.taping.close(self.slot)
        carry = smoothing.Carry(int(np.prod(self.batch)), n=self.layout.dim, e=self.layout.num_extra)
        args = (carry, self.batch, self.block_of_state, SENSOR_INDEX, units.DEG, self.ref_var)
        smoothing.smooth_tape(self.taping.tape, out, lambda segment: smoothing.smooth_segment(segment, *args))
        return carry.cuts.reshape(self.batch)

    def smoothed_results(self, store: Store, cuts: np.ndarray) -> dict[str, MethodResult]:
        """Each method's smoothed results from smoothed stores (:meth:`smooth`) concatenated:
        the monitor's verdict is the forward pass's, there are no updates."""
        if self.sensor_errors and not self.dvl_truth_known:
            store = {**store, "sensor_true": np.where(_DVL_COLUMNS, np.nan, store["sensor_true"])}
        return {
            method: method_result(
                method,
                m,
                store["t_s"],
                store["series"],
                store,
                self._flagged_at(m),
                self.sensor_errors,
                p_floor_count=self.p_floor_count[m].copy(),
                smoother_cuts=cuts[m].copy(),
                block_dims=self.block_dims,
                state_labels=self.state_labels,
            )
            for m, method in enumerate(self.methods)
        }
