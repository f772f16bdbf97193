"""Geometry for the 3-D view. THE one place where NED becomes the view's frame.

viser's world is right-handed with z up; we show east as x, north as y, up as z:
``p_view = M p_n`` with ``M = [[0, 1, 0], [1, 0, 0], [0, 0, -1]]`` (a proper rotation, det +1).
A body-frame vector goes to the view as ``M C_nb v_b``.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import viser.transforms as vtf

ASSETS_DIR = Path(__file__).resolve().parent.parent / "assets"
M_VIEW_FROM_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])

BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED = "returning", "switched off", "lost", "rejected"
BEAM_COLORS = {
    BEAM_RETURNING: (40, 200, 90),
    BEAM_SWITCHED_OFF: (150, 150, 150),
    BEAM_OUTAGE: (255, 150, 30),
    BEAM_REJECTED: (220, 30, 30),
}


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


def beam_segments_n(pos_n: np.ndarray, C_nb: np.ndarray, l_dvl_b: np.ndarray, A_b: np.ndarray,
                    seabed_depth_m: float, max_range_m: float = 200.0) -> np.ndarray:
    """DVL beams from the head to where they meet the seabed (flat, at ``seabed_depth_m``), NED.

    Returns (4, 2, 3): start and end of each beam. A beam pointing level or up, or reaching the
    seabed only beyond ``max_range_m``, is drawn ``max_range_m`` long; with the DVL head below
    the seabed the beams have zero length.
    """
    head = pos_n + C_nb @ l_dvl_b
    dirs = A_b @ C_nb.T                                   # (4, 3) beam directions in n
    down = dirs[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        rng = np.where(down > 1e-6, (seabed_depth_m - head[2]) / down, max_range_m)
    rng = np.clip(rng, 0.0, max_range_m)
    ends = head + dirs * rng[:, None]
    return np.stack([np.broadcast_to(head, (4, 3)), ends], axis=1)


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
