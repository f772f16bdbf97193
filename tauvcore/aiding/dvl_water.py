"""The DVL's water-track beams against the current states (tauvcore.sensors.dvl, ``water_track``).

A water-tracking beam k measures the head's velocity relative to the layer of water it tracks,

    y_k = [(v_b - C_nb^T c_n) (1 + SF) + omega_nb_b x l] . b_k + b_k + n_k,    c_n = [c_N, c_E, 0],

the bottom-track beam's model (tauvcore.aiding.dvl_tight) with the current taken out. With the
current states of the DVL (``dvl.current_states``, tauvcore.aiding.dvl_beams), each beam is one
row of a tightly coupled measurement, gated row by row, whose Jacobian over the error state
``dx = x_true - x_hat`` is the bottom-track row's plus

- on the misalignment rho (``C_true = exp([rho x]) C_hat``): ``C^T c`` moves by
  ``C^T [c x] rho``, so ``-(1 + SF) b_k^T C^T [c x]``;
- on the current (north, east): ``-(1 + SF) b_k^T C^T [e_N e_E]``;
- on the scale factor: ``(v_b - C^T c) . b_k``.

The current is the water's at the vehicle; the layer's differs by the shear over the layer's
distance (tauvcore.truth.current), which the model leaves out: with a shear the water-track
measures the layer's current, and the filter's current is an estimate of it.

Without current states the methods do not fuse water-track (it measures nothing over ground).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.aiding.noise_floors import dvl_beam_sigma_mps
from tauvcore.filter.eskf import Measurement, Nominal
from tauvcore.filter.layout import STATE
from tauvcore.geo.rotations import skew
from tauvcore.sensors.dvl import DvlConfig

CURRENT_BLOCK = "current"
"""The name of the current states' block (tauvcore.filter.layout.StateBlock)."""


@dataclass(frozen=True)
class WaterSetup:
    """One ping's water-track beams for a batch ``B``."""

    y: np.ndarray  # (B, 4) measured water-track beam velocities [m/s] (0 where not returned)
    active: np.ndarray  # (B, 4) bool: the beam water-tracked
    omega_b: np.ndarray  # (B, 3) the measured body rate less the earth's [rad/s] (the gyro bias
    # estimate is taken out by the model)
    R: np.ndarray  # (B, 4, 4) the beams' white noise


@dataclass(frozen=True)
class WaterTrack:
    """The water-track beams' model for a DVL ``config``, its current states at ``current``
    (their slice of the error state, tauvcore.filter.layout.Layout.slice_of)."""

    config: DvlConfig
    current: slice  # the current states (north, east) in the error state
    dim: int  # the error state's size, 20 and the sources' states

    def prepare(
        self, y: np.ndarray, available: np.ndarray, omega_b: np.ndarray, batch: tuple[int, ...]
    ) -> WaterSetup:
        """The ping's beams for the batch.

        Parameters
        ----------
        y : numpy.ndarray
            Water-track beam velocities, shape (..., 4) broadcast to ``batch``, NaN where a beam
            did not water-track [m/s].
        available : numpy.ndarray
            Shape (..., 4) bool: the beam water-tracked.
        omega_b : numpy.ndarray
            Measured body rate less the earth's, shape (..., 3) [rad/s].
        batch : tuple[int, ...]
            The batch shape ``B``.

        Returns
        -------
        WaterSetup
            The beams (B, 4) [m/s], which are active, the rate (B, 3) [rad/s] and R (B, 4, 4)
            [m^2/s^2] from ``water_track_noise_mps`` (floored as the bottom-track noise).
        """
        active = np.broadcast_to(np.asarray(available, dtype=bool) & np.isfinite(y), batch + (4,))
        sigma = dvl_beam_sigma_mps(self.config.water_track_noise_mps)
        return WaterSetup(
            y=np.where(active, np.broadcast_to(y, batch + (4,)), 0.0),
            active=active,
            omega_b=np.broadcast_to(omega_b, batch + (3,)),
            R=np.broadcast_to(np.eye(4) * sigma**2, batch + (4, 4)).copy(),
        )

    def _current_b(self, nom: Nominal) -> np.ndarray:
        c_n = np.zeros(nom.dvl_sf.shape + (3,))
        assert nom.extra is not None  # the model exists only with the current states
        c_n[..., :2] = nom.extra[..., self.current.start - STATE.dim : self.current.stop - STATE.dim]
        return np.einsum("...ji,...j->...i", nom.nav.C_nb, c_n)

    def predict(self, nom: Nominal, setup: WaterSetup) -> np.ndarray:
        """``h_k(x_hat)`` of every beam, shape (B, 4) [m/s] (zero where not active)."""
        A = self.config.A_b
        v_rel = (nom.vel_b - self._current_b(nom)) * (1.0 + nom.dvl_sf[..., None])
        v_head = v_rel + np.cross(setup.omega_b - nom.gyro_bias, self.config.l_dvl_b)
        return np.where(setup.active, v_head @ A.T + nom.dvl_bias, 0.0)

    def jacobian(self, nom: Nominal, setup: WaterSetup) -> np.ndarray:
        """H over the error state, shape (B, 4, dim) (module docstring)."""
        A = self.config.A_b
        scale = (1.0 + nom.dvl_sf)[..., None, None]
        C = nom.nav.C_nb
        c_b = self._current_b(nom)
        c_n = np.einsum("...ij,...j->...i", C, c_b)
        H = np.zeros(nom.dvl_sf.shape + (4, self.dim))
        H[..., STATE.vel] = scale * A
        CT = np.swapaxes(C, -1, -2)
        H[..., STATE.att] = -scale * (A @ (CT @ skew(c_n)))
        H[..., STATE.bg] = A @ skew(self.config.l_dvl_b)
        H[..., STATE.b_dvl] = np.eye(4)
        H[..., STATE.sf_dvl.start] = (nom.vel_b - c_b) @ A.T
        H[..., self.current] = -scale * (A @ CT[..., :, :2])
        return H

    def measure(self, nom: Nominal, y: np.ndarray, available: np.ndarray, omega_b: np.ndarray) -> Measurement:
        """The water-track beams of one ping as a row-gated measurement.

        Parameters
        ----------
        nom : Nominal
            The estimates, batch ``B``, with the current states in ``extra``.
        y : numpy.ndarray
            Water-track beam velocities, shape (..., 4), NaN where a beam did not water-track [m/s].
        available : numpy.ndarray
            Shape (..., 4) bool: the beam water-tracked.
        omega_b : numpy.ndarray
            Measured body rate less the earth's, shape (..., 3) [rad/s].

        Returns
        -------
        Measurement
            z (B, 4) [m/s], innovation, H (B, 4, dim), R (B, 4, 4), valid (B,): some beam
            water-tracked, active (B, 4), gated row by row.
        """
        batch = nom.dvl_sf.shape
        setup = self.prepare(y, available, omega_b, batch)
        innovation = np.where(setup.active, setup.y - self.predict(nom, setup), 0.0)
        return Measurement(
            z=setup.y,
            innovation=innovation,
            H=self.jacobian(nom, setup),
            R=setup.R,
            valid=np.asarray(setup.active.any(axis=-1)),
            active=setup.active,
            gate_rows=True,
        )
