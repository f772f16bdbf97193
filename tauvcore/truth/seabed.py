"""The seabed under a mission: bathymetry, the depth under the vehicle, and where each DVL beam
meets the bottom (Yoo 2014 section 3: the DVL loses the bottom where the sea is deeper
than its range).

Depth of the seabed at a horizontal position (NED frame of the mission, metres from the
sea-surface point above the start)::

    depth(n, e) = mean_depth_m + slope . (n, e) + relief(n, e) + trenches(n)

- ``relief`` (``trajectory.seabed = "terrain"``): smooth seeded terrain, the sum of
  ``TERRAIN_WAVES`` plane waves of random direction, phase and wavelength within a factor two of
  ``terrain_wavelength_m``; crests and troughs of the sum are the ridges and trenches. Its RMS is
  ``terrain_relief_m``. The same seed gives the same seabed on every run and every machine (it
  is the world, not a sensor error: every Monte Carlo run flies over it).
- ``trenches``: features of a scenario (the ``longrange`` mission's two deep zones): the depth
  falls to ``floor_depth_m`` between ``north_start_m`` and ``north_end_m`` along half-cosine
  walls ``wall_m`` long centred on those two lines.
- ``slope``: a plane's gradient (for known-answer tests of the beam geometry).

A beam from the DVL head ``p`` along the unit vector ``d`` (NED) meets the seabed at the smallest
range ``r > 0`` with ``p_D + r d_D = depth(p_N + r d_N, p_E + r d_E)``: over a plane this is closed
form (:meth:`Bathymetry.slant_range_m` uses it when the seabed is one), otherwise the altitude
along the ray is marched in steps of an eighth of the shortest terrain wavelength (or of the
trench walls) and the first sign change bisected to 1e-9 m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TERRAIN_WAVES = 16
SEABED_MODELS = ("flat", "terrain")


@dataclass(frozen=True)
class Trench:
    """A zone of deep water across the track: the seabed at ``floor_depth_m`` between two lines of
    constant north, reached along half-cosine walls ``wall_m`` long centred on those lines."""

    north_start_m: float
    north_end_m: float
    floor_depth_m: float
    wall_m: float


class Bathymetry:
    """Seabed depth, and the ranges at which rays meet it (module docstring)."""

    def __init__(
        self,
        mean_depth_m: float,
        model: str = "flat",
        seed: int = 0,
        relief_m: float = 0.0,
        wavelength_m: float = 500.0,
        slope: tuple[float, float] = (0.0, 0.0),
        trenches: tuple[Trench, ...] = (),
    ) -> None:
        self.mean_depth_m = float(mean_depth_m)
        self.slope = np.asarray(slope, dtype=float)
        self.trenches = tuple(trenches)
        self.relief_m = float(relief_m) if model == "terrain" else 0.0
        self.wavelength_m = float(wavelength_m)
        if self.relief_m > 0.0:
            rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0x5EABED,)))
            heading = rng.uniform(0.0, 2.0 * np.pi, TERRAIN_WAVES)
            wavelength = wavelength_m * 2.0 ** rng.uniform(-1.0, 1.0, TERRAIN_WAVES)
            self._k = (
                np.stack([np.cos(heading), np.sin(heading)], axis=1) * (2.0 * np.pi / wavelength)[:, None]
            )
            self._phase = rng.uniform(0.0, 2.0 * np.pi, TERRAIN_WAVES)
            self._amp = self.relief_m * np.sqrt(2.0 / TERRAIN_WAVES)  # RMS of the sum: relief_m
        self.is_plane = self.relief_m == 0.0 and not self.trenches

    def depth_m(self, north_m: np.ndarray, east_m: np.ndarray) -> np.ndarray:
        """Seabed depth [m] under horizontal positions (any matching shapes)."""
        n, e = np.broadcast_arrays(np.asarray(north_m, dtype=float), np.asarray(east_m, dtype=float))
        depth = self.mean_depth_m + self.slope[0] * n + self.slope[1] * e
        if self.relief_m > 0.0:
            arg = n[..., None] * self._k[:, 0] + e[..., None] * self._k[:, 1] + self._phase
            depth = depth + self._amp * np.sin(arg).sum(axis=-1)
        for tr in self.trenches:
            deeper = tr.floor_depth_m - self.mean_depth_m
            depth = depth + deeper * _wall(n - tr.north_start_m, tr.wall_m) * _wall(
                tr.north_end_m - n, tr.wall_m
            )
        return depth

    def altitude_m(self, pos_n: np.ndarray) -> np.ndarray:
        """Height above the seabed straight below (what an echo sounder measures) [m]. (..., 3) -> (...)."""
        return self.depth_m(pos_n[..., 0], pos_n[..., 1]) - pos_n[..., 2]

    def _step_m(self) -> float:
        steps = [20.0]
        if self.relief_m > 0.0:
            steps.append(0.5 * self.wavelength_m / 8.0)
        steps += [tr.wall_m / 8.0 for tr in self.trenches]
        return min(steps)

    def slant_range_m(self, head_n: np.ndarray, dir_n: np.ndarray, max_range_m: float) -> np.ndarray:
        """Range [m] along unit rays ``dir_n`` from ``head_n`` (both (..., 3), NED) to the seabed;
        ``inf`` where the ray does not meet it within ``max_range_m`` (or points up, or the head
        is below the seabed: no bottom to lock on)."""
        head, d = np.broadcast_arrays(np.asarray(head_n, dtype=float), np.asarray(dir_n, dtype=float))
        altitude = self.altitude_m(head)
        if self.is_plane:
            # depth(p + r d) - (p_D + r d_D) = altitude - r (d_D - slope . d_NE) = 0
            closing = d[..., 2] - self.slope[0] * d[..., 0] - self.slope[1] * d[..., 1]
            with np.errstate(divide="ignore", invalid="ignore"):
                r = np.where(closing > 0.0, altitude / closing, np.inf)
            return np.where((altitude > 0.0) & (r <= max_range_m), r, np.inf)
        return self._marched(head, d, altitude, max_range_m)

    def _marched(
        self, head: np.ndarray, d: np.ndarray, altitude: np.ndarray, max_range_m: float
    ) -> np.ndarray:
        """The march and bisection of the module docstring, compiled
        (:func:`tauvcore.truth.seabed_kernels.march_into`: one ray at a time; numpy's per-call
        overhead over a few hundred rays per chunk was half of the ``longrange`` mission's
        simulation), imported here with numba: a flat seabed and ``tauv --help`` need neither."""
        from tauvcore.truth.seabed_kernels import march_into

        flat_head = np.ascontiguousarray(head.reshape(-1, 3))
        flat_d = np.ascontiguousarray(d.reshape(-1, 3))
        out = np.empty(flat_head.shape[0])
        if self.relief_m > 0.0:
            k, phase, amp = self._k, self._phase, self._amp
        else:
            k, phase, amp = np.zeros((0, 2)), np.zeros(0), 0.0
        trenches = np.array(
            [
                [tr.north_start_m, tr.north_end_m, tr.floor_depth_m - self.mean_depth_m, tr.wall_m]
                for tr in self.trenches
            ],
            dtype=float,
        ).reshape(-1, 4)
        march_into(
            flat_head,
            flat_d,
            np.ascontiguousarray(altitude.reshape(-1), dtype=float),
            float(max_range_m),
            self._step_m(),
            self.mean_depth_m,
            self.slope,
            k,
            phase,
            amp,
            trenches,
            out,
        )
        return out.reshape(altitude.shape)


def _wall(x: np.ndarray, width: float) -> np.ndarray:
    """0 for x <= -width/2, 1 for x >= width/2, a half-cosine between."""
    tau = np.clip(x / width + 0.5, 0.0, 1.0)
    return 0.5 * (1.0 - np.cos(np.pi * tau))
