"""The machinery of a closed-form mission profile: :class:`BlendedSchedule` (a scalar through
knots joined by half-cosine blends, for speeds, turn rates and pitch), :class:`Profile` (attitude
and body velocity as functions of time), and the motion a profile implies at given times (attitude,
rates, velocities, NED acceleration, and the IMU's specific force and rate on a flat or a WGS-84
earth). The missions themselves, the configuration and the truth they generate are
tauvcore.truth.kinematic's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from tauvcore.geo.earth import Earth, earth_rate_n_rps, gravity_n_mps2, transport_rate_n_rps
from tauvcore.geo.rotations import C_nb_from_euler, euler_rates_to_omega_nb_b


class BlendedSchedule:
    """Scalar function through knots ``(t_i, y_i)`` joined by half-cosine blends.

    On ``[t_i, t_i+1]``: ``y = y_i + (y_i+1 - y_i) s(tau)``, ``s = (1 - cos(pi tau)) / 2``;
    value and first derivative are continuous, and value, derivative and integral are closed
    form. Constant before the first and after the last knot.

    Parameters
    ----------
    t_knots : list of float
        Knot times, shape (N,) with N >= 2, strictly increasing [s].
    y_knots : list of float
        Values at the knots, shape (N,), in the scheduled quantity's unit (m/s for a speed, rad/s
        for a yaw rate, rad for a pitch).

    Raises
    ------
    ValueError
        "BlendedSchedule needs strictly increasing knot times and one value each".
    """

    def __init__(self, t_knots: list[float], y_knots: list[float]) -> None:
        self.t = np.asarray(t_knots, dtype=float)
        self.y = np.asarray(y_knots, dtype=float)
        if self.t.ndim != 1 or self.t.shape != self.y.shape or np.any(np.diff(self.t) <= 0):
            raise ValueError("BlendedSchedule needs strictly increasing knot times and one value each")
        h = np.diff(self.t)
        dy = np.diff(self.y)
        seg_integral = h * (self.y[:-1] + 0.5 * dy)
        self._cum = np.concatenate([[0.0], np.cumsum(seg_integral)])

    def _locate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        idx = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 2)
        h = self.t[idx + 1] - self.t[idx]
        tau = np.clip((t - self.t[idx]) / h, 0.0, 1.0)
        return idx, h, tau

    def value(self, t: np.ndarray) -> np.ndarray:
        """The schedule's value at times ``t``.

        Parameters
        ----------
        t : numpy.ndarray
            Times, any shape (e.g. (K,)) [s].

        Returns
        -------
        numpy.ndarray
            Values, the shape of ``t``, in the knot values' unit.
        """
        idx, _, tau = self._locate(t)
        return self.y[idx] + (self.y[idx + 1] - self.y[idx]) * 0.5 * (1.0 - np.cos(np.pi * tau))

    def derivative(self, t: np.ndarray) -> np.ndarray:
        """The schedule's time derivative at times ``t``; zero outside the knots.

        Parameters
        ----------
        t : numpy.ndarray
            Times, any shape (e.g. (K,)) [s].

        Returns
        -------
        numpy.ndarray
            Derivatives, the shape of ``t``, in the knot values' unit per second (e.g. rad/s^2 for
            a yaw rate schedule).
        """
        idx, h, tau = self._locate(t)
        inside = (t > self.t[0]) & (t < self.t[-1])
        d = (self.y[idx + 1] - self.y[idx]) * 0.5 * np.pi / h * np.sin(np.pi * tau)
        return np.where(inside, d, 0.0)

    def integral(self, t: np.ndarray) -> np.ndarray:
        """Integral from ``t_0``; extends linearly (constant value) beyond the knots.

        Parameters
        ----------
        t : numpy.ndarray
            Upper limits of integration, any shape (a 0-d array or a scalar too) [s].

        Returns
        -------
        numpy.ndarray
            Integrals from the first knot time to ``t``, the shape of ``t``, in the knot values'
            unit times seconds (e.g. m for a speed schedule, rad for a yaw rate schedule).
        """
        t = np.asarray(t, dtype=float)
        idx, h, tau = self._locate(t)
        dy = self.y[idx + 1] - self.y[idx]
        part = h * (self.y[idx] * tau + dy * (0.5 * tau - np.sin(np.pi * tau) / (2.0 * np.pi)))
        out = self._cum[idx] + part
        before = t < self.t[0]
        after = t > self.t[-1]
        out = np.where(before, (t - self.t[0]) * self.y[0], out)
        out = np.where(after, self._cum[-1] + (t - self.t[-1]) * self.y[-1], out)
        return out


@dataclass(frozen=True)
class Profile:
    """Closed-form motion: functions of time arrays (K,) returning (K, 3) arrays."""

    euler: Callable[[np.ndarray], np.ndarray]  # roll, pitch, yaw [rad]
    euler_dot: Callable[[np.ndarray], np.ndarray]  # their rates [rad/s]
    vel_b: Callable[[np.ndarray], np.ndarray]  # surge, sway, heave [m/s]
    vel_b_dot: Callable[[np.ndarray], np.ndarray]  # their rates [m/s^2]


_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(4)


def _kinematics(profile: Profile, t: np.ndarray) -> dict[str, np.ndarray]:
    """Attitude, rates, velocities and NED acceleration at times ``t``: the profile alone."""
    euler = profile.euler(t)
    C_nb = C_nb_from_euler(euler)
    omega_nb_b = euler_rates_to_omega_nb_b(euler, profile.euler_dot(t))
    vel_b = profile.vel_b(t)
    vel_n = np.einsum("kij,kj->ki", C_nb, vel_b)
    acc_n = np.einsum("kij,kj->ki", C_nb, profile.vel_b_dot(t) + np.cross(omega_nb_b, vel_b))
    return {
        "euler": euler,
        "C_nb": C_nb,
        "omega_nb_b": omega_nb_b,
        "vel_b": vel_b,
        "vel_n": vel_n,
        "acc_n": acc_n,
    }


def _motion(profile: Profile, earth: Earth, t: np.ndarray) -> dict[str, np.ndarray]:
    """The flat model: constant gravity and earth rate (tauvcore.geo.earth.Earth)."""
    m = _kinematics(profile, t)
    C_nb, vel_n = m["C_nb"], m["vel_n"]
    omega_ie_n = earth.omega_ie_n
    C_bn = np.swapaxes(C_nb, -1, -2)
    m["f_b"] = np.einsum("kij,kj->ki", C_bn, m["acc_n"] - earth.g_n + 2.0 * np.cross(omega_ie_n, vel_n))
    m["omega_ib_b"] = m["omega_nb_b"] + C_bn @ omega_ie_n
    return m


def _motion_geodetic(m: dict[str, np.ndarray], lat: np.ndarray, depth: np.ndarray) -> dict[str, np.ndarray]:
    """The IMU quantities of kinematics ``m`` on the WGS-84 ellipsoid at (lat, depth) (K,): the
    local-level frame turns at ``omega_ie + omega_en``, so ``f_n = acc_n - g + (2 omega_ie +
    omega_en) x vel_n`` and ``omega_ib_b = omega_nb_b + C_nb^T (omega_ie + omega_en)`` (Groves
    eq. 5.54, 5.41)."""
    h = -depth
    vel_n = m["vel_n"]
    g_n = np.stack(np.broadcast_arrays(*gravity_n_mps2(lat, h)), axis=-1)
    w_ie = np.stack(np.broadcast_arrays(*earth_rate_n_rps(lat)), axis=-1)
    w_en = np.stack(transport_rate_n_rps(lat, h, vel_n[:, 0], vel_n[:, 1]), axis=-1)
    C_bn = np.swapaxes(m["C_nb"], -1, -2)
    m["f_b"] = np.einsum("kij,kj->ki", C_bn, m["acc_n"] - g_n + np.cross(2.0 * w_ie + w_en, vel_n))
    m["omega_ib_b"] = m["omega_nb_b"] + np.einsum("kij,kj->ki", C_bn, w_ie + w_en)
    return m


def num_samples(duration_s: float, rate_hz: float) -> int:
    """Samples of a mission of ``duration_s`` at ``rate_hz``, both ends included.

    Parameters
    ----------
    duration_s : float
        Mission duration [s].
    rate_hz : float
        Sample rate [Hz].

    Returns
    -------
    int
        ``round(duration_s * rate_hz) + 1`` samples.
    """
    return round(duration_s * rate_hz) + 1
