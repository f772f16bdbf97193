"""Geometry for the 3-D view. THE one place where NED becomes the view's frame.

viser's world is right-handed with z up; we show east as x, north as y, up as z:
``p_view = M p_n`` with ``M = [[0, 1, 0], [1, 0, 0], [0, 0, -1]]`` (a proper rotation, det +1).
A body-frame vector goes to the view as ``M C_nb v_b``.

The seabed is a triangle mesh of the mission's bathymetry under the track (:func:`seabed_mesh_n`),
and each DVL beam ends where it meets it, or at the DVL's range where it does not (drawn "lost").

The fins are children of the vehicle's node: their placement (:func:`fin_wxyz_body`) is a
rotation in the body frame, which the parent's ``M C_nb`` carries into the view.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import viser.transforms as vtf
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from tauvcore.truth.seabed import Bathymetry
from tauvcore.truth.vehicle import FIN_POSITION_ANGLES_RAD

ASSETS_DIR = Path(__file__).resolve().parent.parent / "assets"
M_VIEW_FROM_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])

BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED = "returning", "switched off", "lost", "rejected"
BEAM_COLORS = {
    BEAM_RETURNING: (40, 200, 90),
    BEAM_SWITCHED_OFF: (150, 150, 150),
    BEAM_OUTAGE: (255, 150, 30),
    BEAM_REJECTED: (220, 30, 30),
}
SEABED_MARGIN_M = 300.0        # the seabed mesh reaches this far beyond the track on every side (the flat grid: 600 m square)
SEABED_MAX_TRIANGLES = 20000   # ... in at most this many triangles
SEABED_MIN_CELL_M = 5.0        # ... and cells no finer than this (a short track's seabed needs no more)
SEABED_COLOR = (194, 170, 120)  # sand, as the flat seabed's plane


def ned_to_view(p_n: np.ndarray) -> np.ndarray:
    """Points (..., 3) from NED to the view frame (east, north, up)."""
    return np.asarray(p_n) @ M_VIEW_FROM_NED.T


def wxyz_view(C_nb: np.ndarray) -> np.ndarray:
    """Quaternion (w, x, y, z) placing a body-frame mesh in the view: rotation ``M C_nb``."""
    return vtf.SO3.from_matrix(M_VIEW_FROM_NED @ C_nb).wxyz


@lru_cache(maxsize=4)
def load_obj(path: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (N, 3) and triangle faces (F, 3) of a plain OBJ file (v and f lines)."""
    verts, faces = [], []
    for line in Path(path).read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            verts.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            faces.append([int(x.split("/")[0]) - 1 for x in parts[1:4]])
    return np.asarray(verts), np.asarray(faces, dtype=np.int32)


def auv_mesh_view_body() -> tuple[np.ndarray, np.ndarray]:
    """The AUV mesh in the body frame (apply ``wxyz_view`` to place it)."""
    return load_obj(str(ASSETS_DIR / "auv.obj"))


@dataclass(frozen=True)
class Fin:
    """One fin of the AUV mesh, ready to turn about its hinge."""

    verts_hinge: np.ndarray   # (V, 3) vertices relative to the hinge point, body axes [m]
    faces: np.ndarray         # (F, 3) triangles
    hinge_b: np.ndarray       # (3,) hinge point in the body frame [m]: on the hull's axis below the root chord's middle
    angle_rad: float          # where the fin stands about x, from starboard towards down [rad]


def _components(verts: np.ndarray, faces: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The mesh's connected parts (vertices linked by triangles), each re-indexed from 0."""
    n = len(verts)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]]])
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    parts = []
    for c in np.unique(label):
        keep = np.flatnonzero(label == c)
        index = np.full(n, -1)
        index[keep] = np.arange(keep.size)
        parts.append((verts[keep], index[faces[label[faces[:, 0]] == c]]))
    return parts


@lru_cache(maxsize=1)
def auv_parts_body() -> tuple[tuple[np.ndarray, np.ndarray], tuple[Fin, ...]]:
    """The AUV mesh (:func:`auv_mesh_view_body`) split into the hull (vertices, faces) and its
    four fins, ordered as tauvcore.truth.vehicle numbers them (FIN_POSITION_ANGLES_RAD).

    The hull is the largest connected part; each fin is a separate part, matched to the nearest
    fin position by the angle of its centroid about x. A fin's hinge is its radial line
    ``e_r = (0, cos g, sin g)`` through the middle of its root chord.
    """
    verts, faces = auv_mesh_view_body()
    parts = sorted(_components(verts, faces), key=lambda p: len(p[0]), reverse=True)
    hull, others = parts[0], parts[1:]
    if len(others) != len(FIN_POSITION_ANGLES_RAD):
        raise ValueError(f"the AUV mesh has {len(others)} parts besides the hull, expected "
                         f"{len(FIN_POSITION_ANGLES_RAD)} fins")
    fins: list[Fin | None] = [None] * len(FIN_POSITION_ANGLES_RAD)
    for v, f in others:
        centre = v.mean(axis=0)
        angle = np.arctan2(centre[2], centre[1])
        off = np.abs(np.angle(np.exp(1j * (FIN_POSITION_ANGLES_RAD - angle))))
        k = int(np.argmin(off))
        if fins[k] is not None or off[k] > np.radians(10.0):
            raise ValueError(f"the AUV mesh has a part at {np.degrees(angle):.1f} deg about x, not a fin of its own")
        radius = np.hypot(v[:, 1], v[:, 2])
        root = v[np.isclose(radius, radius.min(), atol=1e-3)]
        hinge = np.array([0.5 * (root[:, 0].min() + root[:, 0].max()), 0.0, 0.0])
        fins[k] = Fin(verts_hinge=v - hinge, faces=f, hinge_b=hinge, angle_rad=float(FIN_POSITION_ANGLES_RAD[k]))
    return hull, tuple(fins)  # type: ignore[arg-type]


def fin_wxyz_body(fin_angles_rad: np.ndarray) -> np.ndarray:
    """Quaternions (4, 4) (w, x, y, z) turning fins 1-4 about their hinges by their deflections
    ``fin_angles_rad`` (4,) [rad], in the body frame.

    A positive deflection pushes along the fin's normal ``n = (0, -sin g, cos g)``
    (tauvcore.truth.vehicle): its leading edge turns towards n, ``x_b -> cos(d) x_b + sin(d) n``,
    a rotation by d about ``x_b x n = -e_r``.
    """
    d = np.asarray(fin_angles_rad, float)
    g = FIN_POSITION_ANGLES_RAD
    minus_e_r = np.stack([np.zeros_like(g), -np.cos(g), -np.sin(g)], axis=1)
    return vtf.SO3.exp(minus_e_r * d[:, None]).wxyz


def beam_rays_n(pos_n: np.ndarray, C_nb: np.ndarray, l_dvl_b: np.ndarray,
                A_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The DVL head ``pos_n + C_nb l_dvl_b`` (3,) and the unit beam directions ``C_nb b_k`` (4, 3), NED."""
    return pos_n + C_nb @ l_dvl_b, A_b @ C_nb.T


def seabed_ranges_m(pos_n: np.ndarray, C_nb: np.ndarray, l_dvl_b: np.ndarray, A_b: np.ndarray,
                    seabed: Bathymetry, max_range_m: float) -> np.ndarray:
    """(4,) range [m] along each beam from the DVL head to ``seabed``; inf beyond ``max_range_m``
    (:meth:`tauvcore.truth.seabed.Bathymetry.slant_range_m`). For a view with no per-epoch ranges
    of the simulated DVL (before a run, a replayed log)."""
    head, dirs = beam_rays_n(pos_n, C_nb, l_dvl_b, A_b)
    return seabed.slant_range_m(head, dirs, max_range_m)


def beam_segments_n(pos_n: np.ndarray, C_nb: np.ndarray, l_dvl_b: np.ndarray, A_b: np.ndarray,
                    range_m: np.ndarray, max_range_m: float) -> np.ndarray:
    """DVL beams from the head to where they meet the seabed, NED.

    ``range_m`` (4,) [m] is each beam's slant range to the seabed, inf where it does not meet it
    within the DVL's range (tauvcore.sensors.dvl.slant_ranges_m, :func:`seabed_ranges_m`): such a
    beam (beyond range, no bottom lock) is drawn ``max_range_m`` long. Returns (4, 2, 3): start
    and end of each beam.
    """
    head, dirs = beam_rays_n(pos_n, C_nb, l_dvl_b, A_b)
    rng = np.clip(np.where(np.isfinite(range_m), range_m, max_range_m), 0.0, max_range_m)
    ends = head + dirs * rng[:, None]
    return np.stack([np.broadcast_to(head, (4, 3)), ends], axis=1)


def seabed_mesh_n(seabed: Bathymetry, pos_n: np.ndarray, margin_m: float = SEABED_MARGIN_M,
                  max_triangles: int = SEABED_MAX_TRIANGLES, min_cell_m: float = SEABED_MIN_CELL_M,
                  ) -> tuple[np.ndarray, np.ndarray]:
    """A triangle mesh of ``seabed`` under the track ``pos_n`` (T, 3), NED.

    The grid spans the track's north and east extent plus ``margin_m`` on every side, in square-ish
    cells no smaller than ``min_cell_m`` and at most ``max_triangles`` triangles (two per cell):
    a 7 km track stays a few hundred kB for the browser. Each vertex lies on the seabed,
    ``(n, e, depth_m(n, e))``. Returns vertices (V, 3) and faces (F, 3) int32, wound so that their
    normals point up (towards -down: +z in the view).
    """
    lo = pos_n[:, :2].min(axis=0) - margin_m
    hi = pos_n[:, :2].max(axis=0) + margin_m
    size = hi - lo
    max_cells = max(1, max_triangles // 2)
    cell = max(min_cell_m, float(np.sqrt(size[0] * size[1] / max_cells)))
    cells_n = max(1, int(size[0] // cell))
    cells_e = max(1, int(size[1] // cell))
    cells_n = min(cells_n, max(1, max_cells // cells_e))
    north = np.linspace(lo[0], hi[0], cells_n + 1)
    east = np.linspace(lo[1], hi[1], cells_e + 1)
    n_grid, e_grid = np.meshgrid(north, east, indexing="ij")          # (cells_n + 1, cells_e + 1)
    verts = np.stack([n_grid, e_grid, seabed.depth_m(n_grid, e_grid)], axis=-1).reshape(-1, 3)
    index = np.arange(verts.shape[0]).reshape(n_grid.shape)
    a, b = index[:-1, :-1].ravel(), index[:-1, 1:].ravel()          # (i, j), (i, j + 1): a step east
    c, d = index[1:, 1:].ravel(), index[1:, :-1].ravel()            # (i + 1, j + 1), (i + 1, j): north of them
    # in the view (x east, y north, z up) a -> b -> c turns from +x to +y: counter-clockwise from above
    faces = np.concatenate([np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)]).astype(np.int32)
    return verts, faces


def beam_states(enabled: np.ndarray, returned: np.ndarray, rejected: np.ndarray) -> list[str]:
    """State of each beam at one ping: switched off by the user, lost (outage or dropout),
    rejected by the gate, or returning. All arguments (4,) bool."""
    states = []
    for on, ret, rej in zip(enabled, returned, rejected):
        if not on:
            states.append(BEAM_SWITCHED_OFF)
        elif not ret:
            states.append(BEAM_OUTAGE)
        elif rej:
            states.append(BEAM_REJECTED)
        else:
            states.append(BEAM_RETURNING)
    return states


def beam_readout(t_s: float, states: list[str], in_range: np.ndarray, altitude_m: float | None = None) -> str:
    """One Markdown line under the time slider: the time, the altitude above the seabed (if known)
    and each beam's state, naming the beams that are beyond the DVL's range (``in_range`` (4,) bool
    False: the seabed is too far for a bottom lock)."""
    text = f"**{t_s:.1f} s**"
    if altitude_m is not None and np.isfinite(altitude_m):
        text += f", altitude {altitude_m:.1f} m"
    text += ". Beams: " + ", ".join(f"{k} {state}" for k, state in enumerate(states, start=1))
    beyond = [str(k) for k, ok in enumerate(in_range, start=1) if not ok]
    if beyond:
        text += f" (beyond the DVL's range: {', '.join(beyond)})"
    return text
