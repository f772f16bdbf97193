"""Geometry of the 3-D view (app/figures/scene.py): NED -> view frame, mesh placement, the AUV mesh,
DVL beam segments to the seabed (flat, sloping, the longrange trenches), the seabed's mesh and the
beam states, by known answers."""

from __future__ import annotations

import importlib.util
import itertools
from pathlib import Path

import numpy as np
import pytest
import viser.transforms as vtf

from app.figures.scene import (
    ASSETS_DIR,
    BEAM_COLORS,
    BEAM_OUTAGE,
    BEAM_REJECTED,
    BEAM_RETURNING,
    BEAM_SWITCHED_OFF,
    M_VIEW_FROM_NED,
    SEABED_MARGIN_M,
    SEABED_MAX_TRIANGLES,
    SEABED_MIN_CELL_M,
    auv_mesh_view_body,
    auv_parts_body,
    beam_readout,
    beam_segments_n,
    beam_states,
    fin_wxyz_body,
    load_obj,
    ned_to_view,
    seabed_mesh_n,
    seabed_ranges_m,
    wxyz_view,
)
from tauvcore.config import Config, from_dict, merge, trajectory_preset
from tauvcore.geo.rotations import C_nb_from_euler, exp_so3
from tauvcore.sensors.dvl import DvlConfig
from tauvcore.truth import generate
from tauvcore.truth.kinematic import bathymetry
from tauvcore.truth.seabed import Bathymetry
from tauvcore.truth.vehicle import FIN_POSITION_ANGLES_RAD, vehicle_params

DVL = DvlConfig()
A_B = DVL.A_b                    # (4, 3) beam directions, body frame
L_DVL_B = DVL.l_dvl_b            # (0.6, 0, 0.15) m
MAX_RANGE_M = 200.0
DEG = np.pi / 180.0
NORTH, EAST, DOWN = np.eye(3)
HULL_LENGTH_M, HULL_RADIUS_M = 3.0, 0.15
OBJ_DECIMALS_ATOL = 1e-5         # the OBJ stores 5 decimals


def _random_rotations(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return exp_so3(rng.uniform(-np.pi, np.pi, (n, 3)) * 0.9)


# ------------------------------------------------------------------------------------------ NED -> view

def test_view_matrix_is_a_proper_rotation():
    M = M_VIEW_FROM_NED
    np.testing.assert_allclose(M @ M.T, np.eye(3), rtol=0, atol=1e-15)
    assert np.linalg.det(M) == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize("p_n, p_view", [(NORTH, (0, 1, 0)), (EAST, (1, 0, 0)), (DOWN, (0, 0, -1))])
def test_ned_to_view_axes(p_n, p_view):
    """North -> +y, east -> +x, down -> -z (view: x east, y north, z up)."""
    np.testing.assert_array_equal(ned_to_view(p_n), np.asarray(p_view, float))


def test_ned_to_view_batches():
    rng = np.random.default_rng(3)
    p_n = rng.normal(size=(4, 5, 3)) * 50.0
    view = ned_to_view(p_n)
    assert view.shape == p_n.shape
    np.testing.assert_array_equal(view[..., 0], p_n[..., 1])     # east
    np.testing.assert_array_equal(view[..., 1], p_n[..., 0])     # north
    np.testing.assert_array_equal(view[..., 2], -p_n[..., 2])    # up = -down
    # a list of points is accepted as well as an array
    np.testing.assert_array_equal(ned_to_view([[1.0, 2.0, 3.0]]), [[2.0, 1.0, -3.0]])


# ------------------------------------------------------------------------------------------ wxyz_view

def _same_quaternion(q: np.ndarray, expected: np.ndarray) -> None:
    """q and -q are the same rotation."""
    q, expected = np.asarray(q), np.asarray(expected)
    sign = 1.0 if np.dot(q, expected) >= 0 else -1.0
    np.testing.assert_allclose(sign * q, expected, rtol=0, atol=1e-12)


def test_wxyz_view_of_level_north_heading_is_the_view_rotation():
    # M swaps x and y and flips z: a half turn about (1, 1, 0)/sqrt(2) -> q = (0, 1/sqrt2, 1/sqrt2, 0)
    expected = np.array([0.0, 1.0, 1.0, 0.0]) / np.sqrt(2.0)
    q = wxyz_view(np.eye(3))
    assert q.shape == (4,)
    _same_quaternion(q, expected)
    np.testing.assert_allclose(vtf.SO3(q).as_matrix(), M_VIEW_FROM_NED, rtol=0, atol=1e-12)


def test_wxyz_view_places_the_body_axes_for_random_attitudes():
    for C in _random_rotations(25, seed=7):
        R_view = vtf.SO3(wxyz_view(C)).as_matrix()
        np.testing.assert_allclose(R_view @ np.array([1.0, 0.0, 0.0]), M_VIEW_FROM_NED @ C[:, 0],
                                   rtol=0, atol=1e-12)           # forward
        np.testing.assert_allclose(R_view, M_VIEW_FROM_NED @ C, rtol=0, atol=1e-12)


def test_wxyz_view_known_heading():
    """Heading east (yaw 90 deg), level: the nose points along view +x (east), body down along -z."""
    C = C_nb_from_euler(np.array([0.0, 0.0, 90.0 * DEG]))
    R_view = vtf.SO3(wxyz_view(C)).as_matrix()
    np.testing.assert_allclose(R_view @ [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(R_view @ [0.0, 0.0, 1.0], [0.0, 0.0, -1.0], rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------------ meshes

def test_load_obj_tiny_file(tmp_path):
    path = tmp_path / "tiny.obj"
    path.write_text("# a comment\n"
                    "o tiny\n"
                    "v 0 0 0\n"
                    "v 1.5 0 0\n"
                    "\n"
                    "v 0 2 0\n"
                    "vn 0 0 1\n"
                    "vt 0.5 0.5\n"
                    "v 0 0 -3.25\n"
                    "f 1 2 3\n"
                    "f 1/1/1 3/1/1 4/1/1\n"
                    "f 2//1 4//1 3//1\n")
    verts, faces = load_obj(str(path))
    np.testing.assert_array_equal(verts, [[0, 0, 0], [1.5, 0, 0], [0, 2, 0], [0, 0, -3.25]])
    np.testing.assert_array_equal(faces, [[0, 1, 2], [0, 2, 3], [1, 3, 2]])
    assert verts.shape == (4, 3) and faces.shape == (3, 3)
    assert np.issubdtype(faces.dtype, np.integer)


@pytest.fixture(scope="module")
def auv_mesh() -> tuple[np.ndarray, np.ndarray]:
    return auv_mesh_view_body()


def test_auv_mesh_faces_index_valid_vertices(auv_mesh):
    verts, faces = auv_mesh
    assert verts.ndim == 2 and verts.shape[1] == 3 and len(verts) > 100
    assert faces.ndim == 2 and faces.shape[1] == 3 and len(faces) > 100
    assert np.issubdtype(faces.dtype, np.integer)
    assert faces.min() == 0 and faces.max() == len(verts) - 1
    assert np.isfinite(verts).all()
    assert (faces[:, 0] != faces[:, 1]).all() and (faces[:, 1] != faces[:, 2]).all() and (faces[:, 0] != faces[:, 2]).all()


def test_auv_mesh_is_3m_long_along_x(auv_mesh):
    verts, _ = auv_mesh
    assert verts[:, 0].min() == pytest.approx(-HULL_LENGTH_M / 2, abs=OBJ_DECIMALS_ATOL)
    assert verts[:, 0].max() == pytest.approx(HULL_LENGTH_M / 2, abs=OBJ_DECIMALS_ATOL)
    # longest along x: the fins' span stays well inside the length
    assert np.ptp(verts[:, 1]) < 1.0 and np.ptp(verts[:, 2]) < 1.0


def test_auv_mesh_hull_radius(auv_mesh):
    verts, _ = auv_mesh
    radius = np.hypot(verts[:, 1], verts[:, 2])
    forward = verts[:, 0] > -0.5          # ahead of the tail cone and fins: only the hull
    assert radius[forward].max() == pytest.approx(HULL_RADIUS_M, abs=OBJ_DECIMALS_ATOL)
    # the hull is a body of revolution: at the widest station the ring is a circle of 0.15 m
    ring = forward & np.isclose(radius, HULL_RADIUS_M, atol=OBJ_DECIMALS_ATOL)
    assert ring.sum() >= 24


def test_auv_mesh_has_four_x_fins_at_the_tail(auv_mesh):
    verts, _ = auv_mesh
    radius = np.hypot(verts[:, 1], verts[:, 2])
    outside = radius > HULL_RADIUS_M + 0.01             # only fins reach beyond the hull
    assert outside.sum() >= 8
    assert (verts[outside, 0] < -1.0).all()                # at the tail
    angle = np.degrees(np.arctan2(verts[outside, 2], verts[outside, 1]))  # about x, in the y-z plane
    diagonals = np.array([45.0, 135.0, -135.0, -45.0])
    off = np.abs((angle[:, None] - diagonals[None, :] + 180.0) % 360.0 - 180.0)   # (n, 4)
    assert (off.min(axis=1) < 3.0).all(), angle           # every outer vertex on a diagonal ("x" fins)
    nearest = off.argmin(axis=1)
    for k in range(4):
        assert (nearest == k).sum() >= 2, f"no fin at {diagonals[k]} deg"
    # no fin on the vertical or horizontal ("+" layout)
    axes_off = np.abs((angle[:, None] - np.array([0.0, 90.0, 180.0, -90.0])[None, :] + 180.0) % 360.0 - 180.0)
    assert axes_off.min() > 30.0


def test_auv_asset_is_what_the_generator_writes(auv_mesh):
    """app/assets/auv.obj is the output of assets/make_auv_mesh.py (not stale), which writes it there."""
    generator = Path(__file__).resolve().parents[4] / "assets" / "make_auv_mesh.py"
    spec = importlib.util.spec_from_file_location("make_auv_mesh", generator)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    verts_gen, faces_gen = module.build()
    verts, faces = auv_mesh
    assert module.OUTPUT == (Path(ASSETS_DIR) / "auv.obj").resolve()    # the file app.figures.scene reads
    assert module.LENGTH_M == HULL_LENGTH_M and module.RADIUS_M == HULL_RADIUS_M
    np.testing.assert_allclose(verts, verts_gen, rtol=0, atol=OBJ_DECIMALS_ATOL)
    np.testing.assert_array_equal(faces, faces_gen)


# ------------------------------------------------------------------------------------------ moving fins

def _sorted_rows(v: np.ndarray) -> list[tuple[float, ...]]:
    return sorted(map(tuple, np.round(v, 5)))


def test_the_mesh_splits_into_the_hull_and_four_fins(auv_mesh):
    """Hull and fins together are the whole mesh; fin k stands where tauvcore.truth.vehicle puts
    fin k (45, 135, 225, 315 deg from starboard towards down), its hinge on the hull's axis."""
    verts, faces = auv_mesh
    (hull_v, hull_f), fins = auv_parts_body()
    assert len(fins) == 4
    assert len(hull_v) + sum(len(f.verts_hinge) for f in fins) == len(verts)
    assert len(hull_f) + sum(len(f.faces) for f in fins) == len(faces)
    assert hull_v[:, 0].min() == pytest.approx(-HULL_LENGTH_M / 2, abs=OBJ_DECIMALS_ATOL)
    assert np.hypot(hull_v[:, 1], hull_v[:, 2]).max() == pytest.approx(HULL_RADIUS_M, abs=OBJ_DECIMALS_ATOL)
    placed = np.vstack([hull_v] + [f.verts_hinge + f.hinge_b for f in fins])
    assert _sorted_rows(placed) == _sorted_rows(verts)               # every vertex where the OBJ has it
    for fin, angle in zip(fins, FIN_POSITION_ANGLES_RAD):
        assert fin.angle_rad == angle
        v = fin.verts_hinge + fin.hinge_b
        assert fin.faces.min() == 0 and fin.faces.max() == len(v) - 1
        centre = v.mean(axis=0)
        np.testing.assert_allclose(centre[1:] / np.hypot(*centre[1:]), [np.cos(angle), np.sin(angle)], atol=1e-6)
        assert fin.hinge_b[1] == fin.hinge_b[2] == 0.0 and v[:, 0].min() <= fin.hinge_b[0] <= v[:, 0].max()
    lower_starboard = fins[0].verts_hinge.mean(axis=0) + fins[0].hinge_b
    assert lower_starboard[1] > 0 and lower_starboard[2] > 0            # fin 1: +y starboard, +z down


def test_zero_deflection_leaves_the_fins_as_the_mesh_has_them():
    q = fin_wxyz_body(np.zeros(4))
    assert q.shape == (4, 4)
    for qk in q:
        _same_quaternion(qk, np.array([1.0, 0.0, 0.0, 0.0]))


@pytest.mark.parametrize("fin", range(4))
@pytest.mark.parametrize("deflection_deg", [10.0, -25.0])
def test_a_deflection_turns_the_leading_edge_towards_the_fin_s_force(fin, deflection_deg):
    """A positive deflection pushes along the fin's normal (the dynamics' fin_normal_b): the fin's
    chord turns from x_b towards that normal by the deflection, about the fin's own radial axis."""
    normal = vehicle_params().fin_normal_b[fin]
    g = FIN_POSITION_ANGLES_RAD[fin]
    e_r = np.array([0.0, np.cos(g), np.sin(g)])
    d = deflection_deg * DEG
    deflections = np.zeros(4)
    deflections[fin] = d
    q = fin_wxyz_body(deflections)
    R = vtf.SO3(q[fin]).as_matrix()
    np.testing.assert_allclose(R @ [1.0, 0.0, 0.0], np.cos(d) * np.array([1.0, 0.0, 0.0]) + np.sin(d) * normal,
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(R @ e_r, e_r, rtol=0, atol=1e-12)        # the hinge axis stays
    for other in set(range(4)) - {fin}:                                  # the other fins stay
        _same_quaternion(q[other], np.array([1.0, 0.0, 0.0, 0.0]))
    # the mesh's fin: its leading edge (front of the root chord) moves along +normal for d > 0
    fin_mesh = auv_parts_body()[1][fin]
    leading = fin_mesh.verts_hinge[np.argmax(fin_mesh.verts_hinge[:, 0])]
    moved = R @ leading - leading
    assert np.sign(moved @ normal) == np.sign(d)


# ------------------------------------------------------------------------------------------ DVL beams

def _flat_ranges(pos_n: np.ndarray, C_nb: np.ndarray, depth_m: float, max_range_m: float = MAX_RANGE_M) -> np.ndarray:
    return seabed_ranges_m(pos_n, C_nb, L_DVL_B, A_B, Bathymetry(depth_m), max_range_m)


def _check_beams_reach_seabed(pos_n: np.ndarray, C_nb: np.ndarray, seabed: float) -> np.ndarray:
    seg = beam_segments_n(pos_n, C_nb, L_DVL_B, A_B, _flat_ranges(pos_n, C_nb, seabed), MAX_RANGE_M)
    assert seg.shape == (4, 2, 3)
    head = pos_n + C_nb @ L_DVL_B
    np.testing.assert_allclose(seg[:, 0], np.broadcast_to(head, (4, 3)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(seg[:, 1, 2], seabed, rtol=0, atol=1e-12)           # every end on the seabed
    d = seg[:, 1] - seg[:, 0]
    length = np.linalg.norm(d, axis=1)
    np.testing.assert_allclose(d / length[:, None], A_B @ C_nb.T, rtol=0, atol=1e-12)  # along C_nb b_k
    # slant range = vertical distance / cosine of the beam's angle from the vertical
    np.testing.assert_allclose(length, (seabed - head[2]) / (A_B @ C_nb.T)[:, 2], rtol=1e-12, atol=0)
    return seg


def test_beams_level_vehicle_known_answer():
    pos = np.array([12.0, -7.0, 20.0])
    seg = _check_beams_reach_seabed(pos, np.eye(3), 60.0)
    head = pos + L_DVL_B
    np.testing.assert_allclose(seg[:, 1, 2], np.full(4, 60.0), rtol=0, atol=1e-12)       # 60 m
    # level: each beam is 20 deg off vertical, so the slant range is (60 - 20.15) / cos 20 deg
    expected_range = (60.0 - head[2]) / np.cos(20.0 * DEG)
    np.testing.assert_allclose(np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1), expected_range, rtol=1e-12)
    # footprints on the "x": beam 1 forward-starboard, 2 aft-starboard, 3 aft-port, 4 forward-port
    horiz = seg[:, 1, :2] - head[:2]
    np.testing.assert_array_equal(np.sign(horiz), [[1, 1], [-1, 1], [-1, -1], [1, -1]])


@pytest.mark.parametrize("euler_deg", [(0.0, 15.0, 0.0), (0.0, -25.0, 60.0), (10.0, 20.0, -135.0), (30.0, 0.0, 200.0)])
def test_beams_pitched_vehicle_still_end_on_seabed(euler_deg):
    C = C_nb_from_euler(np.radians(euler_deg))
    _check_beams_reach_seabed(np.array([3.0, 4.0, 20.0]), C, 60.0)


def test_beams_vehicle_below_seabed_no_nan():
    """No bottom to lock on: every range is inf, every beam drawn at the DVL's range."""
    ranges = _flat_ranges(np.array([0.0, 0.0, 70.0]), np.eye(3), 60.0)
    assert np.isinf(ranges).all()
    seg = beam_segments_n(np.array([0.0, 0.0, 70.0]), np.eye(3), L_DVL_B, A_B, ranges, MAX_RANGE_M)
    assert np.isfinite(seg).all()
    np.testing.assert_allclose(np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1), MAX_RANGE_M, rtol=1e-12)
    np.testing.assert_allclose(seg[:, 0], np.broadcast_to([0.6, 0.0, 70.15], (4, 3)), rtol=0, atol=1e-12)


def test_beams_pointing_up_drawn_at_max_range():
    C = C_nb_from_euler(np.array([180.0 * DEG, 0.0, 0.0]))        # upside down: every beam points up
    pos = np.array([0.0, 0.0, 20.0])
    seg = beam_segments_n(pos, C, L_DVL_B, A_B, _flat_ranges(pos, C, 60.0, 150.0), 150.0)
    assert np.isfinite(seg).all()
    d = seg[:, 1] - seg[:, 0]
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 150.0, rtol=1e-12)
    np.testing.assert_allclose(d / 150.0, A_B @ C.T, rtol=0, atol=1e-12)
    assert (seg[:, 1, 2] < seg[:, 0, 2]).all()                     # going up, away from the seabed


def test_beams_seabed_beyond_max_range_stop_at_max_range():
    pos = np.array([0.0, 0.0, 20.0])
    ranges = _flat_ranges(pos, np.eye(3), 5000.0, 200.0)
    assert np.isinf(ranges).all()
    seg = beam_segments_n(pos, np.eye(3), L_DVL_B, A_B, ranges, 200.0)
    np.testing.assert_allclose(np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1), 200.0, rtol=1e-12)
    assert (seg[:, 1, 2] < 5000.0).all()


def test_beams_horizontal_beam_no_nan():
    """Beam 1 exactly horizontal (zero downward component): drawn at max range, no division by 0."""
    b1 = A_B[0]
    roll = -np.arctan2(b1[2], b1[1])          # the roll that brings b1's (y, z) onto the horizontal
    C = C_nb_from_euler(np.array([roll, 0.0, 0.0]))
    assert abs((C @ b1)[2]) < 1e-12
    pos = np.array([0.0, 0.0, 20.0])
    seg = beam_segments_n(pos, C, L_DVL_B, A_B, _flat_ranges(pos, C, 60.0, 200.0), 200.0)
    assert np.isfinite(seg).all()
    assert np.linalg.norm(seg[0, 1] - seg[0, 0]) == pytest.approx(200.0, rel=1e-12)


def test_beams_end_on_a_sloping_seabed_where_the_ranges_say():
    """Given the ranges to a seabed that is not flat, each beam is that long along its direction,
    its end lies on that seabed, and a beam whose range is inf is drawn at the DVL's range."""
    seabed = Bathymetry(60.0, slope=(0.3, -0.1))
    pos, C = np.array([5.0, -3.0, 20.0]), C_nb_from_euler(np.radians([4.0, -6.0, 35.0]))
    ranges = seabed_ranges_m(pos, C, L_DVL_B, A_B, seabed, MAX_RANGE_M)
    assert np.isfinite(ranges).all() and len(set(np.round(ranges, 6))) == 4      # four different ranges
    seg = beam_segments_n(pos, C, L_DVL_B, A_B, ranges, MAX_RANGE_M)
    np.testing.assert_allclose(np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1), ranges, rtol=1e-12)
    ends = seg[:, 1]
    np.testing.assert_allclose(ends[:, 2], seabed.depth_m(ends[:, 0], ends[:, 1]), rtol=0, atol=1e-9)
    lost = ranges.copy()
    lost[[0, 3]] = np.inf
    seg = beam_segments_n(pos, C, L_DVL_B, A_B, lost, MAX_RANGE_M)
    np.testing.assert_allclose(np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1),
                               [MAX_RANGE_M, ranges[1], ranges[2], MAX_RANGE_M], rtol=1e-12)


def test_the_longrange_trench_puts_the_forward_beams_out_of_range_first():
    """Over the longrange mission's first trench wall the seabed falls away ahead: the forward beams
    (1 and 4) lose the bottom before the aft ones, and over its floor all four are beyond range."""
    config = _longrange()
    seabed = bathymetry(config.trajectory)
    wall = seabed.trenches[0].north_start_m
    ranges = seabed_ranges_m(np.array([wall + 10.0, 0.0, 50.0]), np.eye(3), L_DVL_B, A_B, seabed,
                             config.dvl.max_range_m)
    np.testing.assert_array_equal(np.isinf(ranges), [True, False, False, True])
    floor = 0.5 * (seabed.trenches[0].north_start_m + seabed.trenches[0].north_end_m)
    ranges = seabed_ranges_m(np.array([floor, 0.0, 50.0]), np.eye(3), L_DVL_B, A_B, seabed, config.dvl.max_range_m)
    assert np.isinf(ranges).all()


# ------------------------------------------------------------------------------------------ seabed mesh

def _longrange() -> Config:
    return from_dict(merge(trajectory_preset("longrange"), {"trajectory": {"name": "longrange"}}))


@pytest.fixture(scope="module")
def longrange_track() -> np.ndarray:
    config = _longrange()
    return generate(config.trajectory, config.earth, 1.0).pos_n


@pytest.mark.parametrize("seabed", ["longrange", "terrain"])
def test_seabed_mesh_vertices_lie_on_the_seabed_and_cover_the_track(seabed, longrange_track):
    """Given the longrange track (7.2 km north) over its trenches or over seeded terrain, the mesh's
    vertices are the seabed's depth at the grid points, its faces index its vertices, it covers
    the track with the margin on every side and stays within the triangle budget."""
    config = _longrange()
    if seabed == "terrain":
        config = config.replace("trajectory", name="straight", seabed="terrain")
    bathy = bathymetry(config.trajectory)
    verts, faces = seabed_mesh_n(bathy, longrange_track)
    assert verts.shape[1] == 3 and faces.shape[1] == 3 and faces.dtype == np.int32
    np.testing.assert_array_equal(verts[:, 2], bathy.depth_m(verts[:, 0], verts[:, 1]))
    assert faces.min() == 0 and faces.max() == len(verts) - 1
    assert len(np.unique(faces)) == len(verts)                       # every vertex in some triangle
    assert 1000 < len(faces) <= SEABED_MAX_TRIANGLES
    lo, hi = longrange_track[:, :2].min(axis=0), longrange_track[:, :2].max(axis=0)
    np.testing.assert_allclose(verts[:, :2].min(axis=0), lo - SEABED_MARGIN_M, rtol=0, atol=1e-9)
    np.testing.assert_allclose(verts[:, :2].max(axis=0), hi + SEABED_MARGIN_M, rtol=0, atol=1e-9)
    # fine enough for the trenches' 200 m walls
    north = np.unique(verts[:, 0])
    assert np.max(np.diff(north)) < 25.0
    if seabed == "longrange":                                        # the trenches are in it
        assert verts[:, 2].max() == pytest.approx(bathy.trenches[0].floor_depth_m)
        assert verts[:, 2].min() == pytest.approx(config.trajectory.seabed_depth_m)


def test_seabed_mesh_triangles_face_up_and_tile_the_extent():
    """Every triangle's normal points up in the view (+z) and the triangles' plan areas add up to
    the extent: no hole, no overlap."""
    track = np.array([[0.0, 0.0, 20.0], [130.0, 40.0, 20.0], [60.0, -25.0, 22.0]])
    verts, faces = seabed_mesh_n(Bathymetry(60.0, "terrain", seed=3, relief_m=5.0, wavelength_m=100.0), track,
                                 margin_m=50.0)
    v = ned_to_view(verts)[faces]                                    # (F, 3 corners, 3)
    normal = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    assert (normal[:, 2] > 0).all()
    extent = (130.0 + 100.0) * (65.0 + 100.0)
    assert 0.5 * normal[:, 2].sum() == pytest.approx(extent, rel=1e-12)
    assert np.max(np.diff(np.unique(verts[:, 0]))) >= SEABED_MIN_CELL_M - 1e-9


@pytest.mark.parametrize("max_triangles", [2, 50, 999, 20000])
def test_seabed_mesh_keeps_to_its_triangle_budget(max_triangles, longrange_track):
    verts, faces = seabed_mesh_n(Bathymetry(110.0), longrange_track, max_triangles=max_triangles)
    assert 2 <= len(faces) <= max(2, max_triangles)


# ------------------------------------------------------------------------------------------ beam states

def _expected_state(on: bool, ret: bool, rej: bool) -> str:
    if not on:
        return BEAM_SWITCHED_OFF
    if not ret:
        return BEAM_OUTAGE
    return BEAM_REJECTED if rej else BEAM_RETURNING


@pytest.mark.parametrize("on, ret, rej", list(itertools.product([False, True], repeat=3)))
def test_beam_state_truth_table(on, ret, rej):
    """Switched off wins over everything, then lost, then rejected; returning otherwise."""
    states = beam_states(np.full(4, on), np.full(4, ret), np.full(4, rej))
    assert states == [_expected_state(on, ret, rej)] * 4


def test_beam_states_per_beam():
    enabled = np.array([False, True, True, True])
    returned = np.array([True, False, True, True])
    rejected = np.array([True, True, True, False])
    assert beam_states(enabled, returned, rejected) == [BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED, BEAM_RETURNING]
    assert beam_states(enabled, returned, rejected) == [
        _expected_state(*flags) for flags in zip(enabled, returned, rejected)]


def test_every_beam_state_has_a_distinct_colour():
    from app.figures.scene import BEAM_WATER
    states = {BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED, BEAM_RETURNING, BEAM_WATER}
    assert len(states) == 5
    assert set(BEAM_COLORS) == states
    assert len(set(BEAM_COLORS.values())) == 5
    for rgb in BEAM_COLORS.values():
        assert len(rgb) == 3 and all(0 <= c <= 255 for c in rgb)


@pytest.mark.parametrize("mode, bottom, water", [
    ("off", [1, 1, 0, 0], [0, 0, 0, 0]),
    ("beyond_range", [1, 1, 0, 0], [0, 0, 1, 0]),
    ("both", [1, 1, 0, 0], [0, 0, 1, 0]),
    ("always", [0, 0, 0, 0], [1, 1, 1, 0]),
])
def test_a_water_tracking_beam_is_drawn_as_such_and_not_as_lost(mode: str, bottom: list, water: list) -> None:
    """Beams 1, 2 in range, 3 beyond it, 4 in an outage: by ``dvl.water_track`` the beams beyond
    range water-track (every scheduled beam with "always", which bottom-tracks none), and are
    drawn "water-track", not "lost"; a beam in an outage stays lost."""
    from app.figures.scene import BEAM_WATER, water_tracking
    scheduled = np.array([True, True, True, False])
    in_range = np.array([True, True, False, True])
    b, w = water_tracking(mode, scheduled, in_range)
    np.testing.assert_array_equal(b, np.array(bottom, bool))
    np.testing.assert_array_equal(w, np.array(water, bool))
    states = beam_states(np.ones(4, bool), b, np.zeros(4, bool), w)
    assert states[3] == BEAM_OUTAGE
    assert [s == BEAM_WATER for s in states] == [bool(x) for x in water]


def test_a_water_tracking_beam_ends_at_its_layer() -> None:
    """Level, each beam (20 deg from the vertical in the default Janus) reaches the layer 10 m
    below the head after 10 / cos(20 deg); rolled 90 deg, a beam pointing up never does."""
    from app.figures.scene import water_ranges_m
    from tauvcore.geo.rotations import exp_so3
    from tauvcore.sensors.dvl import DvlConfig
    A = DvlConfig().A_b
    level = water_ranges_m(np.eye(3), A, 10.0)
    np.testing.assert_allclose(level, 10.0 / A[:, 2], rtol=1e-12)
    rolled = water_ranges_m(exp_so3(np.array([np.pi / 2, 0.0, 0.0])), A, 10.0)
    cos_down = (exp_so3(np.array([np.pi / 2, 0.0, 0.0])) @ A.T)[2]
    assert np.all(np.isinf(rolled[cos_down <= 0])) and np.all(np.isfinite(rolled[cos_down > 0]))


def test_beam_readout_names_the_lost_beams_beyond_range():
    states = [BEAM_OUTAGE, BEAM_RETURNING, BEAM_RETURNING, BEAM_OUTAGE]
    text = beam_readout(301.04, states, np.array([False, True, True, False]), 103.2288)
    assert text == ("**301.0 s**, altitude 103.2 m. Beams: 1 lost, 2 returning, 3 returning, 4 lost "
                    "(beyond the DVL's range: 1, 4)")
    assert beam_readout(0.0, [BEAM_RETURNING] * 4, np.ones(4, bool)) == (
        "**0.0 s**. Beams: 1 returning, 2 returning, 3 returning, 4 returning")


# ------------------------------------------------------------------------------------------ palettes

def _lab(rgb) -> np.ndarray:
    """sRGB (0-255) to CIE L*a*b* (D65), the textbook formulas."""
    c = np.asarray(rgb, float) / 255.0
    c = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    xyz = np.array([[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750],
                    [0.0193339, 0.1191920, 0.9503041]]) @ c / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def _delta_e76(a, b) -> float:
    return float(np.linalg.norm(_lab(a) - _lab(b)))


def test_lab_known_answers():
    np.testing.assert_allclose(_lab((255, 255, 255)), [100.0, 0.0, 0.0], atol=0.01)
    np.testing.assert_allclose(_lab((255, 0, 0)), [53.24, 80.09, 67.20], atol=0.05)


def test_beam_colours_cannot_be_taken_for_a_method_s_or_the_truth_s():
    """Every beam colour is at least BEAM_MIN_DELTA_E (CIE76) from every method's colour and the
    truth's, and from every other beam colour (before: lost 20 from TC's orange, rejected 9 from
    NSV's red, returning 17 from VB's green, switched off 12 from INS's grey)."""
    from app.figures.scene import BEAM_MIN_DELTA_E
    from app.figures.shared import METHOD_COLORS, TRUTH_COLOR

    def rgb(h: str) -> tuple[int, ...]:
        return tuple(int(h[i:i + 2], 16) for i in (1, 3, 5))
    others = {m: rgb(c) for m, c in METHOD_COLORS.items()} | {"truth": rgb(TRUTH_COLOR)}
    for state, beam in BEAM_COLORS.items():
        for name, color in others.items():
            assert _delta_e76(beam, color) >= BEAM_MIN_DELTA_E, (state, name, _delta_e76(beam, color))
    for (s1, c1), (s2, c2) in itertools.combinations(BEAM_COLORS.items(), 2):
        assert _delta_e76(c1, c2) >= BEAM_MIN_DELTA_E, (s1, s2)
    # the former palette fails the test: it measures what the issue saw
    assert _delta_e76((255, 150, 30), rgb(METHOD_COLORS["tc"])) < BEAM_MIN_DELTA_E


# ------------------------------------------------------------------------------------------ beams on the hull

def test_body_frame_beams_placed_by_the_hull_s_pose_are_the_ned_beams():
    """A beam drawn in the body frame under the hull's node (view pose ``M C_nb``, position
    ``M p_n``) lands where beam_segments_n draws it in NED: hull and beams cannot come apart."""
    from app.figures.scene import beam_segments_b
    rng_m = np.array([40.0, np.inf, 55.0, 61.0])
    for C_nb in _random_rotations(5, seed=21):
        pos_n = np.array([120.0, -35.0, 22.0])
        body = beam_segments_b(L_DVL_B, A_B, rng_m, MAX_RANGE_M)
        placed = ned_to_view(pos_n) + body @ (M_VIEW_FROM_NED @ C_nb).T
        np.testing.assert_allclose(placed, ned_to_view(beam_segments_n(pos_n, C_nb, L_DVL_B, A_B, rng_m, MAX_RANGE_M)),
                                   rtol=0, atol=1e-9)


def test_beam_numbers_stand_on_their_beams():
    from app.figures.scene import BEAM_LABEL_DISTANCE_M, beam_label_positions_b
    at = beam_label_positions_b(L_DVL_B, A_B)
    for k in range(4):
        np.testing.assert_allclose(at[k] - L_DVL_B, A_B[k] * BEAM_LABEL_DISTANCE_M, atol=1e-12)


def test_interpolated_pose_is_between_the_samples():
    from app.figures.scene import interpolate_pose
    t = np.array([0.0, 0.1, 0.2])
    pos = np.array([[0.0, 0, 20], [1.0, 0, 20], [2.0, 0, 20]])
    C = np.stack([C_nb_from_euler(np.array([0.0, 0.0, h * DEG])) for h in (0.0, 10.0, 20.0)])
    i, p, R = interpolate_pose(0.125, t, pos, C)
    assert i == 1
    np.testing.assert_allclose(p, [1.25, 0, 20], atol=1e-12)
    np.testing.assert_allclose(R, C_nb_from_euler(np.array([0.0, 0.0, 12.5 * DEG])), atol=1e-12)
    for t_s, k in ((-1.0, 0), (0.2, 2), (5.0, 2)):        # clamped at the ends
        i, p, R = interpolate_pose(t_s, t, pos, C)
        assert i == k and np.array_equal(p, pos[k]) and np.array_equal(R, C[k])


# ------------------------------------------------------------------------------------------ mission, compass, scale

@pytest.mark.parametrize("x, nice", [(1.0, 1.0), (3.7, 2.0), (7.9, 5.0), (240.0, 200.0), (1000.0, 1000.0),
                                     (0.049, 0.02)])
def test_nice_length(x, nice):
    from app.figures.scene import nice_length
    assert nice_length(x) == pytest.approx(nice)


def test_the_seabed_covers_a_long_straight_run_with_its_margin():
    """A 1,200 s straight run (1.8 km north) left the fixed 600 m seabed: now the grid covers the
    track plus SEABED_MARGIN_M on every side, and the scale bar is a fifth of it, rounded."""
    from app.figures.scene import mission_frame
    track = np.column_stack([np.linspace(0.0, 1800.0, 50), np.linspace(0.0, 30.0, 50), np.full(50, 20.0)])
    frame = mission_frame(track, 60.0)
    view = ned_to_view(track)
    (w, h), c = frame.seabed_size_m, frame.seabed_center_view
    assert np.all(view[:, 0] >= c[0] - w / 2 + SEABED_MARGIN_M - 1e-9)
    assert np.all(view[:, 0] <= c[0] + w / 2 - SEABED_MARGIN_M + 1e-9)
    assert np.all(view[:, 1] >= c[1] - h / 2 + SEABED_MARGIN_M - 1e-9)
    assert np.all(view[:, 1] <= c[1] + h / 2 - SEABED_MARGIN_M + 1e-9)
    assert c[2] == -60.0 and h == pytest.approx(1800.0 + 2 * SEABED_MARGIN_M)
    assert frame.scale_m == 200.0                       # 1800 / 5 = 360 -> 200
    assert frame.lo_view[2] == -60.0 and frame.hi_view[2] == 0.0


def test_compass_points_north_and_east_and_the_scale_bar_is_its_length():
    from app.figures.scene import compass_view, scale_bar_view
    corner = np.array([10.0, -20.0, 0.0])
    arrows, labels = compass_view(corner, 50.0)
    np.testing.assert_allclose(arrows[:, 0], [corner, corner])
    np.testing.assert_allclose(arrows[0, 1] - corner, 50.0 * ned_to_view(NORTH))
    np.testing.assert_allclose(arrows[1, 1] - corner, 50.0 * ned_to_view(EAST))
    assert np.all(np.linalg.norm(labels - corner, axis=1) > 50.0)       # beyond the tips
    bar = scale_bar_view(corner, 200.0)
    np.testing.assert_allclose(bar[0, 1] - bar[0, 0], 200.0 * ned_to_view(EAST))
    assert bar.shape == (3, 2, 3)


# ------------------------------------------------------------------------------------------ cameras

@pytest.mark.parametrize("heading_deg", [0.0, 37.0, 135.0, -90.0])
def test_chase_views_see_the_hull_lengthwise_with_the_bow_to_the_right(heading_deg):
    """From behind, the hull pointed into the screen (a vertical stick). The side view looks at it
    nearly square to its axis and the view from above nearly straight down; in both the bow is to
    the screen's right (scene up +z)."""
    from app.figures.scene import CAMERA_ABOVE, CAMERA_SIDE, chase_camera_view
    C_nb = C_nb_from_euler(np.array([0.0, 5 * DEG, heading_deg * DEG]))
    pos = np.array([3.0, 4.0, -20.0])
    bow = M_VIEW_FROM_NED @ C_nb[:, 0]
    for mode, max_dot in ((CAMERA_SIDE, 0.1), (CAMERA_ABOVE, 0.1)):
        cam, look = chase_camera_view(pos, C_nb, mode, 22.0)
        np.testing.assert_allclose(look, pos)
        assert np.linalg.norm(cam - pos) == pytest.approx(22.0)
        forward = (look - cam) / np.linalg.norm(look - cam)
        assert abs(forward @ bow) < max_dot                  # the hull lies across the view
        right = np.cross(forward, [0.0, 0.0, 1.0])          # the screen's right, the scene's up being +z
        assert right @ bow / np.linalg.norm(right) > 0.9                             # bow to the right
    cam, _ = chase_camera_view(pos, C_nb, CAMERA_ABOVE, 22.0)
    assert (cam - pos)[2] > 0.98 * 22.0                       # from above


@pytest.mark.parametrize("aspect", [0.45, 1.0, 1.8])
def test_fit_mission_frames_every_corner_of_the_mission(aspect):
    """Every corner of the mission's box lies inside the view's frustum, horizontally and
    vertically, also in a view narrower than it is tall (the 3-D view beside the workbench)."""
    from app.figures.scene import fit_camera_view
    lo, hi = np.array([-300.0, 0.0, -110.0]), np.array([50.0, 7000.0, 0.0])
    fov_v = np.radians(50.0)
    cam, look = fit_camera_view(lo, hi, fov_v, aspect)
    forward = (look - cam) / np.linalg.norm(look - cam)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    tan_h, tan_v = aspect * np.tan(0.5 * fov_v), np.tan(0.5 * fov_v)
    for corner in itertools.product(*zip(lo, hi)):
        d = np.asarray(corner) - cam
        depth = d @ forward
        assert depth > 0
        assert abs(d @ right) / depth < tan_h and abs(d @ up) / depth < tan_v, (aspect, corner)
    assert cam[2] > hi[2]                                   # above the water


def test_fit_mission_in_a_narrow_view_stands_back_by_the_horizontal_field():
    """The former fit used the vertical field alone: in a view half as wide as tall the mission's
    ends fell outside the sides. The distance grows as tan(fov_v / 2) / tan(fov_h / 2) says."""
    from app.figures.scene import fit_camera_view
    lo, hi = np.array([-300.0, 0.0, -110.0]), np.array([50.0, 7000.0, 0.0])
    fov_v = np.radians(50.0)
    wide, look = fit_camera_view(lo, hi, fov_v, 1.5)
    narrow, _ = fit_camera_view(lo, hi, fov_v, 0.5)
    fov_h = 2.0 * np.arctan(0.5 * np.tan(0.5 * fov_v))
    ratio = np.linalg.norm(narrow - look) / np.linalg.norm(wide - look)
    assert ratio == pytest.approx(np.sin(0.5 * fov_v) / np.sin(0.5 * fov_h), rel=1e-12)


# ------------------------------------------------------------------------------------------ playback

def test_playback_speeds_span_1x_to_100x():
    from app.figures.scene import PLAYBACK_DEFAULT_SPEED, PLAYBACK_SPEEDS, playback_speed
    speeds = [playback_speed(s) for s in PLAYBACK_SPEEDS]
    assert speeds[0] == 1.0 and speeds[-1] == 100.0 and speeds == sorted(speeds)
    assert PLAYBACK_DEFAULT_SPEED in PLAYBACK_SPEEDS
    with pytest.raises(ValueError, match="playback speed: '3x'"):
        playback_speed("3x")


def test_playback_time_follows_the_wall_clock_and_stops_at_the_end():
    from app.figures.scene import playback_time
    assert playback_time(10.0, 20.0, 0.5, 250.0) == 20.0
    assert playback_time(10.0, 1.0, 2.0, 250.0) == 12.0
    assert playback_time(10.0, 100.0, 10.0, 250.0) == 250.0
    assert playback_time(10.0, 5.0, -1.0, 250.0) == 10.0
