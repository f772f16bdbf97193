"""Extended loosely coupled DVL fusion (Tal et al. 2017 Figure 7): loosely coupled when three
or four beams return, the method's partial construction when exactly two do, nothing (coast on
the INS) with fewer. One class serves VB, NSV, PLCF, VHV and the ELC selector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.aiding import elc_nsv, elc_plcf, elc_select, elc_vb, elc_vhv
from tauvcore.aiding.dvl_loose import DvlLoose
from tauvcore.aiding.dvl_partial import (
    apply_solution,
    beam_noise_cov,
    compensated_beams,
)
from tauvcore.filter.eskf import Measurement, Nominal
from tauvcore.filter.layout import STATE
from tauvcore.geo.earth import Earth
from tauvcore.geo.rotations import mv
from tauvcore.sensors.dvl import DvlConfig

ELC_METHODS = ("vb", "nsv", "plcf", "vhv", "elc")
MODE_COAST, MODE_LC, MODE_PARTIAL, MODE_TC = 0, 1, 2, 3
"""Per-epoch record of what a method did with the DVL."""


@dataclass(frozen=True)
class DvlInfo:
    """What the DVL fusion did at one ping, per batch entry."""

    mode: np.ndarray  # (B,) MODE_* code
    measured_axes: np.ndarray  # (B, 3) bool: body axes the velocity measurement carried
    elc_choice: np.ndarray  # (B, 3) index into elc_select.CANDIDATES, -1 none (ELC only)


@dataclass(frozen=True)
class DvlExtended:
    method: str  # one of ELC_METHODS
    dvl: DvlConfig
    earth: Earth
    gyro_rate_noise_rps: float
    vb_nf: float  # n_f of eq. 28 (VB), also VHV's (tauvcore.aiding.elc_vhv)
    nsv_epsilon_m2_per_s2: float  # epsilon of eq. 36
    sensor_columns: bool = True  # the two-beam rows carry the DVL errors (partial.sensor_columns)

    name = "dvl"

    def _solution(self, pattern: tuple[bool, ...]):
        pitch = self.dvl.beam_pitch_rad
        if self.method == "vb":
            return elc_vb.solve(pitch, pattern, self.vb_nf)
        if self.method == "nsv":
            return elc_nsv.solve(pitch, pattern, self.nsv_epsilon_m2_per_s2)
        if self.method == "plcf":
            return elc_plcf.solve(pitch, pattern)
        return elc_vhv.solve(pitch, pattern, self.vb_nf)

    def measure(
        self,
        nom: Nominal,
        P_vel: np.ndarray,
        y_beam: np.ndarray,
        available: np.ndarray,
        omega_meas_b: np.ndarray,
        lc: Measurement | None = None,
    ) -> tuple[Measurement, DvlInfo]:
        """``lc``: the loosely coupled measurement at ``nom`` if already made (the filter bank makes
        it once for every method that uses it)."""
        batch = available.shape[:-1]
        if lc is None:
            lc = DvlLoose(self.dvl, self.earth, self.gyro_rate_noise_rps).measure(
                nom, y_beam, available, omega_meas_b
            )
        n_beams = available.sum(axis=-1)
        two = n_beams == 2
        v_meas = np.zeros(batch + (3,))
        R = np.broadcast_to(np.eye(3), batch + (3, 3)).copy()
        measured = np.zeros(batch + (3,), dtype=bool)
        choice = np.full(batch + (3,), -1)
        C_rows = np.zeros(batch + (3, 4))  # each measured row's weights on the compensated beams
        if two.any():
            C_bn = np.swapaxes(nom.nav.C_nb, -1, -2)
            omega_comp = omega_meas_b - nom.gyro_bias - mv(C_bn, self.earth.omega_ie_n)
            y_c = compensated_beams(
                self.dvl.A_b, y_beam, available, nom.dvl_bias, nom.dvl_sf, omega_comp, self.dvl.l_dvl_b
            )
            S_y = beam_noise_cov(
                self.dvl.A_b, self.dvl.noise_mps, self.gyro_rate_noise_rps, self.dvl.l_dvl_b, nom.dvl_sf
            )
            v_hat = nom.vel_b
            for pattern in np.unique(available[two], axis=0):
                idx = two & np.all(available == pattern, axis=-1)
                key = tuple(bool(b) for b in pattern)
                if self.method == "elc":
                    sols = elc_select.candidate_solutions(
                        self.dvl.beam_pitch_rad, key, self.vb_nf, self.nsv_epsilon_m2_per_s2
                    )
                    v, Rm, meas, ch = elc_select.select(sols, y_c[idx], S_y[idx], v_hat[idx], P_vel[idx])
                    choice[idx] = ch
                    C_rows[idx] = [[sols[max(c, 0)].C[k] for k, c in enumerate(row)] for row in ch]
                else:
                    sol = self._solution(key)
                    if not sol.ok:
                        continue
                    v, Rm = apply_solution(
                        sol.C,
                        sol.D,
                        sol.pred_gain,
                        sol.assumption_sd,
                        y_c[idx],
                        S_y[idx],
                        v_hat[idx],
                        P_vel[idx],
                    )
                    meas = np.broadcast_to(sol.measured, v.shape)
                    C_rows[idx] = sol.C
                v_meas[idx], R[idx], measured[idx] = v, Rm, meas
        partial_ok = two & measured.any(axis=-1)
        H_partial = np.zeros(batch + (3, STATE.dim))
        H_partial[..., STATE.vel] = np.eye(3)
        if self.sensor_columns:  # tauvcore.filter.kernels.dvl_kernels.partial_sensor_row_into
            scale = 1.0 / (1.0 + nom.dvl_sf)[..., None, None]
            H_partial[..., STATE.b_dvl] = C_rows * scale
            H_partial[..., STATE.sf_dvl] = (C_rows @ mv(self.dvl.A_b, nom.vel_b)[..., None]) * scale
        use_lc = lc.valid
        z = np.where(use_lc[..., None], lc.z, v_meas)
        innovation = np.where(use_lc[..., None], lc.innovation, v_meas - nom.vel_b)
        H = np.where(use_lc[..., None, None], lc.H, H_partial)
        R = np.where(use_lc[..., None, None], lc.R, R)
        active = np.where(use_lc[..., None], True, measured)
        meas = Measurement(z=z, innovation=innovation, H=H, R=R, valid=use_lc | partial_ok, active=active)
        mode = np.where(use_lc, MODE_LC, np.where(partial_ok, MODE_PARTIAL, MODE_COAST))
        info = DvlInfo(mode=mode, measured_axes=active & meas.valid[..., None], elc_choice=choice)
        return meas, info
