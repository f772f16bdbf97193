"""Geometry of the 3-D view (app/scene.py): NED -> view frame, mesh placement, the AUV mesh,
DVL beam segments to a flat seabed and the beam states, by known answers."""

from __future__ import annotations

import importlib.util
import itertools
from pathlib import Path

import numpy as np
import pytest
import viser.transforms as vtf

from app.scene import (
    ASSETS_DIR,
    BEAM_COLORS,
    BEAM_OUTAGE,
    BEAM_REJECTED,
    BEAM_RETURNING,
    BEAM_SWITCHED_OFF,
    M_VIEW_FROM_NED,
    auv_mesh_view_body,
    auv_parts_body,
    beam_segments_n,
    beam_states,
    fin_wxyz_body,
    load_obj,
    ned_to_view,
    wxyz_view,
)
from tauvcore.geo.rotations import C_nb_from_euler, exp_so3
from tauvcore.sensors.dvl import DvlConfig
from tauvcore.truth.vehicle import FIN_POSITION_ANGLES_RAD, vehicle_params

DVL = DvlConfig()
A_B = DVL.A_b                    # (4, 3) beam directions, body frame
L_DVL_B = DVL.l_dvl_b            # (0.6, 0, 0.15) m
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
    """assets/auv.obj is the output of assets/make_auv_mesh.py (not stale)."""
    spec = importlib.util.spec_from_file_location("make_auv_mesh", Path(ASSETS_DIR) / "make_auv_mesh.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    verts_gen, faces_gen = module.build()
    verts, faces = auv_mesh
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

def _check_beams_reach_seabed(pos_n: np.ndarray, C_nb: np.ndarray, seabed: float) -> np.ndarray:
    seg = beam_segments_n(pos_n, C_nb, L_DVL_B, A_B, seabed)
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
    np.testing.assert_array_equal(seg[:, 1, 2], np.full(4, 60.0))       # exactly 60 m
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
    seg = beam_segments_n(np.array([0.0, 0.0, 70.0]), np.eye(3), L_DVL_B, A_B, 60.0, max_range_m=200.0)
    assert np.isfinite(seg).all()
    length = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
    assert np.all(np.isclose(length, 0.0, atol=1e-12) | np.isclose(length, 200.0, rtol=1e-12)), length
    np.testing.assert_allclose(seg[:, 0], np.broadcast_to([0.6, 0.0, 70.15], (4, 3)), rtol=0, atol=1e-12)


def test_beams_pointing_up_drawn_at_max_range():
    C = C_nb_from_euler(np.array([180.0 * DEG, 0.0, 0.0]))        # upside down: every beam points up
    seg = beam_segments_n(np.array([0.0, 0.0, 20.0]), C, L_DVL_B, A_B, 60.0, max_range_m=150.0)
    assert np.isfinite(seg).all()
    d = seg[:, 1] - seg[:, 0]
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 150.0, rtol=1e-12)
    np.testing.assert_allclose(d / 150.0, A_B @ C.T, rtol=0, atol=1e-12)
    assert (seg[:, 1, 2] < seg[:, 0, 2]).all()                     # going up, away from the seabed


def test_beams_seabed_beyond_max_range_stop_at_max_range():
    seg = beam_segments_n(np.array([0.0, 0.0, 20.0]), np.eye(3), L_DVL_B, A_B, 5000.0, max_range_m=200.0)
    np.testing.assert_allclose(np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1), 200.0, rtol=1e-12)
    assert (seg[:, 1, 2] < 5000.0).all()


def test_beams_horizontal_beam_no_nan():
    """Beam 1 exactly horizontal (zero downward component): drawn at max range, no division by 0."""
    b1 = A_B[0]
    roll = -np.arctan2(b1[2], b1[1])          # the roll that brings b1's (y, z) onto the horizontal
    C = C_nb_from_euler(np.array([roll, 0.0, 0.0]))
    assert abs((C @ b1)[2]) < 1e-12
    seg = beam_segments_n(np.array([0.0, 0.0, 20.0]), C, L_DVL_B, A_B, 60.0, max_range_m=200.0)
    assert np.isfinite(seg).all()
    assert np.linalg.norm(seg[0, 1] - seg[0, 0]) == pytest.approx(200.0, rel=1e-12)


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
    states = {BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED, BEAM_RETURNING}
    assert len(states) == 4
    assert set(BEAM_COLORS) == states
    assert len(set(BEAM_COLORS.values())) == 4
    for rgb in BEAM_COLORS.values():
        assert len(rgb) == 3 and all(0 <= c <= 255 for c in rgb)
