"""Geometry for the 3-D view. THE one place where NED becomes the view's frame.

viser's world is right-handed with z up; we show east as x, north as y, up as z:
``p_view = M p_n`` with ``M = [[0, 1, 0], [1, 0, 0], [0, 0, -1]]`` (a proper rotation, det +1).
A body-frame vector goes to the view as ``M C_nb v_b``.

The seabed is a triangle mesh of the mission's bathymetry under the track (:func:`seabed_mesh_n`),
and each DVL beam ends where it meets it, or at the DVL's range where it does not (drawn "lost");
a beam that water-tracks (``dvl.water_track``, :func:`water_tracking`) ends at its water layer.

The fins are children of the vehicle's node: their placement (:func:`fin_wxyz_body`) is a
rotation in the body frame, which the parent's ``M C_nb`` carries into the view.

The ocean current is an arrow over the vehicle, in the view's frame, not the hull's (it does not
turn with the vehicle): a velocity vector from above the vehicle to where the water flows,
CURRENT_ARROW_M_PER_MPS metres per m/s (:func:`current_arrow_view`), labelled at its tip with its
speed and direction (:func:`current_label`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from importlib.resources import files
from pathlib import Path

import numpy as np
import viser.transforms as vtf
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from tauvcore.truth.seabed import Bathymetry
from tauvcore.truth.vehicle import FIN_POSITION_ANGLES_RAD

ASSETS_DIR = Path(str(files("app") / "assets"))  # package data (pyproject.toml), so in the wheel too
M_VIEW_FROM_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])

BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED, BEAM_WATER = (
    "returning",
    "switched off",
    "lost",
    "rejected",
    "water-track",
)
# The beams' palette is kept apart from the methods' (app.figures.shared.METHOD_COLORS, matplotlib's tab10, which
# covers the hue circle at middle lightness): saturated blue, magenta and aqua, and a navy near black,
# each at least BEAM_MIN_DELTA_E (CIE76) from every method's colour and the truth's (tests/unit/app/figures/test_scene.py).
BEAM_COLORS = {
    BEAM_RETURNING: (0, 0, 255),  # blue
    BEAM_SWITCHED_OFF: (0, 0, 102),  # navy, nearly black: a dead beam
    BEAM_OUTAGE: (0, 255, 204),  # aqua
    BEAM_REJECTED: (255, 0, 255),  # magenta
    BEAM_WATER: (0, 255, 0),  # lime: the beam measures the water, not the seabed
}
BEAM_COLOR_NAMES = {
    BEAM_RETURNING: "blue",
    BEAM_SWITCHED_OFF: "navy stub",
    BEAM_OUTAGE: "aqua",
    BEAM_REJECTED: "magenta",
    BEAM_WATER: "lime",
}
BEAM_MIN_DELTA_E = (
    40.0  # CIE76 distance every beam colour keeps from every method colour (a clear difference: > 10)
)
# A switched-off beam is drawn thin and short, a stub of its first BEAM_OFF_FRACTION: blue and navy
# lines read alike where the beams are thin or far away, a stub beside a full beam does not.
BEAM_OFF_FRACTION = 0.25
BEAM_THICKNESS_PX = {
    BEAM_RETURNING: 2.5,
    BEAM_SWITCHED_OFF: 1.5,
    BEAM_OUTAGE: 2.5,
    BEAM_REJECTED: 2.5,
    BEAM_WATER: 4.0,  # thicker: drawn beside a bottom-track beam (water-track "both") it shows around it
}
BEAM_LABEL_DISTANCE_M = 4.0  # each beam's number stands this far along it from the DVL head
SEABED_MARGIN_M = 300.0  # the seabed (mesh or flat grid) reaches this far beyond the track on every side
SEABED_MAX_TRIANGLES = 20000  # ... in at most this many triangles
SEABED_MIN_CELL_M = 5.0  # ... and cells no finer than this (a short track's seabed needs no more)
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

    verts_hinge: np.ndarray  # (V, 3) vertices relative to the hinge point, body axes [m]
    faces: np.ndarray  # (F, 3) triangles
    hinge_b: (
        np.ndarray
    )  # (3,) hinge point in the body frame [m]: on the hull's axis below the root chord's middle
    angle_rad: float  # where the fin stands about x, from starboard towards down [rad]


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
        raise ValueError(
            f"the AUV mesh has {len(others)} parts besides the hull, expected "
            f"{len(FIN_POSITION_ANGLES_RAD)} fins"
        )
    fins: list[Fin | None] = [None] * len(FIN_POSITION_ANGLES_RAD)
    for v, f in others:
        centre = v.mean(axis=0)
        angle = np.arctan2(centre[2], centre[1])
        off = np.abs(np.angle(np.exp(1j * (FIN_POSITION_ANGLES_RAD - angle))))
        k = int(np.argmin(off))
        if fins[k] is not None or off[k] > np.radians(10.0):
            raise ValueError(
                f"the AUV mesh has a part at {np.degrees(angle):.1f} deg about x, not a fin of its own"
            )
        radius = np.hypot(v[:, 1], v[:, 2])
        root = v[np.isclose(radius, radius.min(), atol=1e-3)]
        hinge = np.array([0.5 * (root[:, 0].min() + root[:, 0].max()), 0.0, 0.0])
        fins[k] = Fin(
            verts_hinge=v - hinge, faces=f, hinge_b=hinge, angle_rad=float(FIN_POSITION_ANGLES_RAD[k])
        )
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


def beam_rays_n(
    pos_n: np.ndarray, C_nb: np.ndarray, l_dvl_b: np.ndarray, A_b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The DVL head ``pos_n + C_nb l_dvl_b`` (3,) and the unit beam directions ``C_nb b_k`` (4, 3), NED."""
    return pos_n + C_nb @ l_dvl_b, A_b @ C_nb.T


def seabed_ranges_m(
    pos_n: np.ndarray,
    C_nb: np.ndarray,
    l_dvl_b: np.ndarray,
    A_b: np.ndarray,
    seabed: Bathymetry,
    max_range_m: float,
) -> np.ndarray:
    """(4,) range [m] along each beam from the DVL head to ``seabed``; inf beyond ``max_range_m``
    (:meth:`tauvcore.truth.seabed.Bathymetry.slant_range_m`). For a view with no per-epoch ranges
    of the simulated DVL (before a run, a replayed log)."""
    head, dirs = beam_rays_n(pos_n, C_nb, l_dvl_b, A_b)
    return seabed.slant_range_m(head, dirs, max_range_m)


def beam_segments_n(
    pos_n: np.ndarray,
    C_nb: np.ndarray,
    l_dvl_b: np.ndarray,
    A_b: np.ndarray,
    range_m: np.ndarray,
    max_range_m: float,
) -> np.ndarray:
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


def seabed_mesh_n(
    seabed: Bathymetry,
    pos_n: np.ndarray,
    margin_m: float = SEABED_MARGIN_M,
    max_triangles: int = SEABED_MAX_TRIANGLES,
    min_cell_m: float = SEABED_MIN_CELL_M,
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
    n_grid, e_grid = np.meshgrid(north, east, indexing="ij")  # (cells_n + 1, cells_e + 1)
    verts = np.stack([n_grid, e_grid, seabed.depth_m(n_grid, e_grid)], axis=-1).reshape(-1, 3)
    index = np.arange(verts.shape[0]).reshape(n_grid.shape)
    a, b = index[:-1, :-1].ravel(), index[:-1, 1:].ravel()  # (i, j), (i, j + 1): a step east
    c, d = index[1:, 1:].ravel(), index[1:, :-1].ravel()  # (i + 1, j + 1), (i + 1, j): north of them
    # in the view (x east, y north, z up) a -> b -> c turns from +x to +y: counter-clockwise from above
    faces = np.concatenate([np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)]).astype(np.int32)
    return verts, faces


def beam_states(
    enabled: np.ndarray, returned: np.ndarray, rejected: np.ndarray, water: np.ndarray | None = None
) -> list[str]:
    """State of each beam at one ping: switched off by the user, water-tracking (``water``, where
    it returns no bottom-track), lost (outage or dropout), rejected by the gate, or returning. All
    arguments (4,) bool."""
    states = []
    water = np.zeros(4, bool) if water is None else np.asarray(water, bool)
    for on, ret, rej, wat in zip(enabled, returned, rejected, water):
        if not on:
            states.append(BEAM_SWITCHED_OFF)
        elif not ret and wat:
            states.append(BEAM_WATER)
        elif not ret:
            states.append(BEAM_OUTAGE)
        elif rej:
            states.append(BEAM_REJECTED)
        else:
            states.append(BEAM_RETURNING)
    return states


def water_tracking(mode: str, scheduled: np.ndarray, in_range: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which beams bottom-track and which water-track at a ping, by ``dvl.water_track``.

    Parameters
    ----------
    mode : str
        ``dvl.water_track``: "off", "beyond_range", "always" or "both" (tauvcore.sensors.dvl).
    scheduled : numpy.ndarray
        Shape (4,) bool: the beams the schedule lets return (no outage).
    in_range : numpy.ndarray
        Shape (4,) bool: the seabed is within the DVL's range.

    Returns
    -------
    bottom : numpy.ndarray
        Shape (4,) bool: the beam returns bottom-track.
    water : numpy.ndarray
        Shape (4,) bool: it returns water-track and no bottom-track ("both" water-tracks where it
        bottom-tracks too; such a beam is drawn returning).
    """
    scheduled, in_range = np.asarray(scheduled, bool), np.asarray(in_range, bool)
    if mode == "always":
        return np.zeros(4, bool), scheduled.copy()
    bottom = scheduled & in_range
    if mode == "off":
        return bottom, np.zeros(4, bool)
    return bottom, scheduled & ~in_range


def water_beside(mode: str, states: list[str], layer_m: np.ndarray, range_m: np.ndarray) -> np.ndarray:
    """Which beams water-track beside their bottom-track at a ping (``dvl.water_track`` "both":
    every beam that returns a bottom-track also returns a water-track, if the layer is nearer
    than the seabed along it; tauvcore.sensors.dvl).

    Parameters
    ----------
    mode : str
        ``dvl.water_track``.
    states : list of str
        Each beam's state (:func:`beam_states`).
    layer_m : numpy.ndarray
        Shape (4,): each beam's slant distance to the water layer [m] (:func:`water_ranges_m`).
    range_m : numpy.ndarray
        Shape (4,): each beam's slant range to the seabed [m] (inf beyond the DVL's range).

    Returns
    -------
    numpy.ndarray
        Shape (4,) bool: the beam is drawn water-tracking too.
    """
    if mode != "both":
        return np.zeros(4, bool)
    bottom = np.array([s in (BEAM_RETURNING, BEAM_REJECTED) for s in states], bool)
    return bottom & (np.asarray(layer_m, float) < np.asarray(range_m, float))


def water_ranges_m(C_nb: np.ndarray, A_b: np.ndarray, layer_m: float) -> np.ndarray:
    """Each beam's slant distance to the water layer ``layer_m`` below the head, ``layer_m /
    cos``, with ``cos`` the beam's downward direction cosine (tauvcore.sensors.dvl); inf for a beam
    that does not point down.

    Parameters
    ----------
    C_nb : numpy.ndarray
        Attitude, shape (3, 3), body (FRD) to NED.
    A_b : numpy.ndarray
        Beam directions, shape (4, 3), body frame.
    layer_m : float
        The layer's distance below the head [m].

    Returns
    -------
    numpy.ndarray
        Shape (4,) [m].
    """
    cos_down = (np.asarray(A_b, float) @ np.asarray(C_nb, float).T)[:, 2]
    return np.where(cos_down > 1e-6, layer_m / np.where(cos_down > 1e-6, cos_down, 1.0), np.inf)


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


# ---------------------------------------------------------------------------------- beams on the hull
def beam_segments_b(
    l_dvl_b: np.ndarray, A_b: np.ndarray, range_m: np.ndarray, max_range_m: float
) -> np.ndarray:
    """The four beams in the body frame (4, 2, 3): :func:`beam_segments_n` of a vehicle at the origin,
    level and heading north. Drawn as children of the hull's node, whose pose ``M C_nb`` and position
    carry them into the view: beam and hull move in one message and cannot come apart."""
    return beam_segments_n(np.zeros(3), np.eye(3), l_dvl_b, A_b, range_m, max_range_m)


def beam_stub(segments: np.ndarray, fraction: float = BEAM_OFF_FRACTION) -> np.ndarray:
    """The first ``fraction`` of each beam of ``segments`` (..., 2, 3): a switched-off beam's stub."""
    segments = np.asarray(segments, float)
    out = segments.copy()
    out[..., 1, :] = segments[..., 0, :] + fraction * (segments[..., 1, :] - segments[..., 0, :])
    return out


def beam_label_positions_b(
    l_dvl_b: np.ndarray, A_b: np.ndarray, distance_m: float = BEAM_LABEL_DISTANCE_M
) -> np.ndarray:
    """(4, 3) where beams 1-4 carry their numbers, body frame: ``distance_m`` along each from the head."""
    return l_dvl_b + np.asarray(A_b) * distance_m


def interpolate_pose(
    t_s: float, t_grid: np.ndarray, pos_n: np.ndarray, C_nb: np.ndarray
) -> tuple[int, np.ndarray, np.ndarray]:
    """The vehicle between two samples of its track, for smooth playback.

    ``t_grid`` (T,) [s] increasing, ``pos_n`` (T, 3) [m], ``C_nb`` (T, 3, 3). With ``i`` the last
    sample at or before ``t_s`` and ``a = (t_s - t_i) / (t_{i+1} - t_i)``: position
    ``p_i + a (p_{i+1} - p_i)``, attitude ``C_i exp(a log(C_i^T C_{i+1}))`` (slerp). Clamped to
    the track's ends. Returns ``(i, pos_n (3,), C_nb (3, 3))``.
    """
    last = len(t_grid) - 1
    i = int(np.clip(np.searchsorted(t_grid, t_s, side="right") - 1, 0, last))
    if i == last or t_s <= t_grid[i]:
        return i, np.asarray(pos_n[i], float), np.asarray(C_nb[i], float)
    a = float((t_s - t_grid[i]) / (t_grid[i + 1] - t_grid[i]))
    pos = pos_n[i] + a * (pos_n[i + 1] - pos_n[i])
    step = vtf.SO3.from_matrix(C_nb[i].T @ C_nb[i + 1]).log()
    return i, pos, C_nb[i] @ vtf.SO3.exp(a * step).as_matrix()


# ---------------------------------------------------------------------------------- the current
CURRENT_ARROW_M_PER_MPS = 8.0  # the current's arrow is this long per m/s of current [m]: 0.5 m/s, 4 m
CURRENT_ARROW_ABOVE_M = 3.0  # ... and stands this far above the vehicle, clear of hull and fins [m]
CURRENT_ARROW_SHAFT_M = 0.08  # its shaft's radius [m]
CURRENT_ARROW_HEAD_M = 0.6  # its head's longest length [m] (at most a third of a short arrow)
CURRENT_LABEL_ABOVE_M = 0.5  # its label stands this far above its tip [m]
CURRENT_COLOR = (25, 25, 25)  # near black, as the compass's arrows it is read against


def current_arrow_view(current_n_mps: np.ndarray, m_per_mps: float = CURRENT_ARROW_M_PER_MPS) -> np.ndarray:
    """The current's arrow in the view, a velocity vector from the origin (its node stands over the
    vehicle: the water at the vehicle flows from there, and the hull stays in view from above).

    Parameters
    ----------
    current_n_mps : numpy.ndarray
        The current at the vehicle, NED, shape (3,) [m/s].
    m_per_mps : float
        Length of the arrow per m/s of current [m/(m/s) = s].

    Returns
    -------
    numpy.ndarray
        Start and end, shape (1, 2, 3), view frame [m]: from the origin, pointing where the water
        flows, ``m_per_mps |c|`` long.
    """
    tip = m_per_mps * ned_to_view(np.asarray(current_n_mps, float))
    return np.stack([np.zeros(3), tip])[None]


def current_head_m(current_n_mps: np.ndarray, m_per_mps: float = CURRENT_ARROW_M_PER_MPS) -> float:
    """Length of the current arrow's head [m]: CURRENT_ARROW_HEAD_M, or a third of a shorter
    arrow's length (a 0.1 m/s current's arrow stays an arrow, not a cone).

    Parameters
    ----------
    current_n_mps : numpy.ndarray
        The current, NED, shape (3,) [m/s].
    m_per_mps : float
        Length of the arrow per m/s of current [s].

    Returns
    -------
    float
        The head's length [m].
    """
    length_m = m_per_mps * float(np.linalg.norm(current_n_mps))
    return min(CURRENT_ARROW_HEAD_M, length_m / 3.0)


def current_label(current_n_mps: np.ndarray) -> str:
    """The current's label in the view: its horizontal speed and the direction it flows toward,
    clockwise from north, and a vertical part if it has one.

    Parameters
    ----------
    current_n_mps : numpy.ndarray
        The current at the vehicle, NED, shape (3,) [m/s].

    Returns
    -------
    str
        E.g. ``"current 0.50 m/s toward 90 deg"``, ``"..., down 0.10 m/s"``.
    """
    north, east, down = (float(v) for v in current_n_mps)
    toward_deg = np.degrees(np.arctan2(east, north)) % 360.0
    text = f"current {np.hypot(north, east):.2f} m/s toward {toward_deg:.0f} deg"
    if abs(down) >= 0.005:
        text += f", {'down' if down > 0 else 'up'} {abs(down):.2f} m/s"
    return text


# ---------------------------------------------------------------------------------- the mission's extent
def nice_length(x_m: float) -> float:
    """The largest 1, 2 or 5 times a power of ten not above ``x_m`` (> 0) [m]: a scale bar's length."""
    power = 10.0 ** np.floor(np.log10(x_m))
    return float(max(m * power for m in (1.0, 2.0, 5.0) if m * power <= x_m * (1 + 1e-12)))


@dataclass(frozen=True)
class MissionFrame:
    """Where the mission is, in the view (x east, y north, z up), and the scene's furniture sized to it."""

    lo_view: np.ndarray  # (3,) south-west-bottom corner of the track's box, seabed included [m]
    hi_view: np.ndarray  # (3,) north-east-top corner (the surface, z = 0) [m]
    seabed_center_view: np.ndarray  # (3,) centre of the seabed grid, at the seabed's depth [m]
    seabed_size_m: tuple[float, float]  # (east, north) size of the seabed grid and the surface [m]
    cell_m: float  # the grid's cell [m] (its sections: 5 cells)
    scale_m: float  # length of the scale bar and the compass's arrows [m]


def mission_frame(
    pos_n: np.ndarray, seabed_depth_m: float, margin_m: float = SEABED_MARGIN_M
) -> MissionFrame:
    """The box of the track ``pos_n`` (T, 3) NED from the surface to ``seabed_depth_m`` [m] and a seabed
    ``margin_m`` beyond the track on every side (a 1,200 s straight run's 1.8 km, not a fixed 600 m).
    The scale bar is a :func:`nice_length` of about a fifth of the track's larger side (at least 10 m)."""
    p = ned_to_view(np.asarray(pos_n, float).reshape(-1, 3))
    lo, hi = p.min(axis=0), p.max(axis=0)
    lo_view = np.array([lo[0], lo[1], min(lo[2], -seabed_depth_m)])
    hi_view = np.array([hi[0], hi[1], max(hi[2], 0.0)])
    size = (float(hi[0] - lo[0] + 2 * margin_m), float(hi[1] - lo[1] + 2 * margin_m))
    centre = 0.5 * (lo + hi)
    span = float(max(hi[0] - lo[0], hi[1] - lo[1], 50.0))
    return MissionFrame(
        lo_view=lo_view,
        hi_view=hi_view,
        seabed_center_view=np.array([centre[0], centre[1], -seabed_depth_m]),
        seabed_size_m=size,
        cell_m=nice_length(max(size) / 60.0),
        scale_m=nice_length(span / 5.0),
    )


def compass_view(corner_view: np.ndarray, length_m: float) -> tuple[np.ndarray, np.ndarray]:
    """A compass rose at ``corner_view`` (3,): arrows to north and east ``length_m`` long, (2, 2, 3)
    start and end in the view, and where their labels "N" and "E" stand (2, 3), just beyond the tips."""
    north_v, east_v = ned_to_view(np.array([1.0, 0.0, 0.0])), ned_to_view(np.array([0.0, 1.0, 0.0]))
    tips = corner_view + length_m * np.stack([north_v, east_v])
    arrows = np.stack([np.broadcast_to(corner_view, (2, 3)), tips], axis=1)
    return arrows, corner_view + 1.12 * length_m * np.stack([north_v, east_v])


def scale_bar_view(start_view: np.ndarray, length_m: float) -> np.ndarray:
    """A scale bar ``length_m`` long from ``start_view`` (3,) to the east, with a tick at each end
    pointing north (a twentieth of its length): (3, 2, 3) segments in the view."""
    east_v, north_v = ned_to_view(np.array([0.0, 1.0, 0.0])), ned_to_view(np.array([1.0, 0.0, 0.0]))
    end = start_view + length_m * east_v
    tick = 0.05 * length_m * north_v
    return np.stack([[start_view, end], [start_view, start_view + tick], [end, end + tick]])


# ---------------------------------------------------------------------------------- cameras
CAMERA_SIDE, CAMERA_ABOVE, CAMERA_FREE = "chase: side", "chase: above", "free"
CAMERA_MODES = (CAMERA_SIDE, CAMERA_ABOVE, CAMERA_FREE)
CHASE_SIDE_ELEVATION_RAD = np.radians(
    20.0
)  # the side view looks down this much: the hull lies across the screen
CHASE_ABOVE_TILT_RAD = np.radians(
    8.0
)  # the view from above leans this much from the vertical (up = +z stays defined)


def chase_camera_view(
    pos_view: np.ndarray, C_nb: np.ndarray, mode: str, distance_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Camera position and look-at (view frame) that show the hull at ``pos_view`` lengthwise.

    From behind (the former chase view) the 3 m hull pointed into the screen and showed as a
    vertical stick. ``chase: side`` stands to starboard, ``distance_m`` away and
    CHASE_SIDE_ELEVATION_RAD above; ``chase: above`` looks down, leaning CHASE_ABOVE_TILT_RAD to
    starboard. With the scene's up +z, either puts the bow to the right of the screen. Uses the
    horizontal heading only: the camera does not roll or pitch with the vehicle.
    """
    forward = M_VIEW_FROM_NED @ C_nb[:, 0]
    f = np.array([forward[0], forward[1], 0.0])
    f = f / np.linalg.norm(f) if np.linalg.norm(f) > 1e-6 else np.array([0.0, 1.0, 0.0])
    starboard = np.array([f[1], -f[0], 0.0])  # f turned clockwise seen from above (z up)
    up = np.array([0.0, 0.0, 1.0])
    e = CHASE_SIDE_ELEVATION_RAD if mode == CAMERA_SIDE else 0.5 * np.pi - CHASE_ABOVE_TILT_RAD
    offset = distance_m * (np.cos(e) * starboard + np.sin(e) * up)
    return pos_view + offset, np.asarray(pos_view, float)


def fit_camera_view(
    lo_view: np.ndarray, hi_view: np.ndarray, fov_v_rad: float, aspect: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Camera position and look-at that frame the box ``lo_view``-``hi_view`` (3,) whole: from the
    south-west and above (a 50 deg elevation), at the distance where the box's bounding sphere
    fits the narrower of the two fields of view with 10 % to spare. ``fov_v_rad`` is the vertical
    field of view [rad] (three.js's, viser's ``camera.fov``) and ``aspect`` the canvas's width over
    its height (viser's ``camera.aspect``): in a view narrower than it is tall (the 3-D view beside
    the workbench) the horizontal field, 2 atan(aspect tan(fov_v / 2)), is the narrower one."""
    fov_h_rad = 2.0 * np.arctan(max(float(aspect), 1e-3) * np.tan(0.5 * fov_v_rad))
    fov_rad = min(float(fov_v_rad), float(fov_h_rad))
    centre = 0.5 * (np.asarray(lo_view, float) + np.asarray(hi_view, float))
    radius = max(0.5 * float(np.linalg.norm(np.asarray(hi_view) - np.asarray(lo_view))), 5.0)
    distance = 1.1 * radius / np.sin(0.5 * fov_rad)
    e = np.radians(50.0)
    direction = np.array([-np.sqrt(0.5) * np.cos(e), -np.sqrt(0.5) * np.cos(e), np.sin(e)])
    return centre + distance * direction, centre


# ---------------------------------------------------------------------------------- playback
PLAYBACK_SPEEDS = ("1x", "2x", "5x", "10x", "20x", "50x", "100x")
PLAYBACK_DEFAULT_SPEED = "20x"
PLAYBACK_FPS = 15.0  # frames per second of wall time: the pose is interpolated between them


def playback_speed(label: str) -> float:
    """Seconds of mission per second of wall time for a choice of PLAYBACK_SPEEDS ("20x": 20)."""
    if label not in PLAYBACK_SPEEDS:
        raise ValueError(f"playback speed: {label!r} is not one of {', '.join(PLAYBACK_SPEEDS)}")
    return float(label[:-1])


def playback_time(t_start_s: float, speed: float, elapsed_s: float, t_end_s: float) -> float:
    """The mission time [s] shown ``elapsed_s`` of wall time after playback started at
    ``t_start_s`` at ``speed`` (:func:`playback_speed`), stopping at ``t_end_s``. Time drives the
    frames, not a count of them: a late frame shows the right moment, the pace stays steady."""
    return min(t_start_s + speed * max(elapsed_s, 0.0), t_end_s)
