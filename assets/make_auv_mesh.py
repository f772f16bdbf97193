"""Generate ``app/assets/auv.obj``: the TAUV-like hull shown by the dashboard.

3.0 m long, 0.30 m diameter (Tal et al. 2017, section 1), a body of revolution about the body
x axis (forward) with an ellipsoidal nose, a cylindrical mid-body and a tapered tail, and four
fins in an "x" at the tail (45, 135, 225, 315 deg about x). Vertices are in the body frame
(x forward, y starboard, z down), metres, origin at mid-length.

    python assets/make_auv_mesh.py

The mesh is package data of ``app`` (shipped in the wheel, found by ``app.figures.scene`` through
``importlib.resources``); this generator stays out of the package.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

LENGTH_M = 3.0
RADIUS_M = 0.15
SEGMENTS = 24


def hull_profile() -> tuple[np.ndarray, np.ndarray]:
    """Stations along x (tail to nose) and the hull radius at each."""
    x_tail, x_nose = -LENGTH_M / 2, LENGTH_M / 2
    nose_len, tail_len = 0.45, 0.7
    xs, rs = [], []
    for s in np.linspace(0.0, 1.0, 8):                     # tail cone, from a 3 cm tip
        xs.append(x_tail + s * tail_len)
        rs.append(0.03 + (RADIUS_M - 0.03) * np.sin(0.5 * np.pi * s))
    xs.append(x_nose - nose_len)
    rs.append(RADIUS_M)
    for s in np.linspace(0.0, 1.0, 10)[1:]:                # ellipsoidal nose
        xs.append(x_nose - nose_len + s * nose_len)
        rs.append(RADIUS_M * np.sqrt(max(1.0 - s * s, 0.0)))
    return np.array(xs), np.array(rs)


def hull() -> tuple[np.ndarray, np.ndarray]:
    xs, rs = hull_profile()
    ang = np.linspace(0.0, 2 * np.pi, SEGMENTS, endpoint=False)
    verts = [[x, r * np.cos(a), r * np.sin(a)] for x, r in zip(xs, rs) for a in ang]
    faces = []
    n = SEGMENTS
    for i in range(len(xs) - 1):
        for j in range(n):
            a, b = i * n + j, i * n + (j + 1) % n
            c, d = a + n, b + n
            faces += [[a, c, b], [b, c, d]]
    tail_center = len(verts)
    verts.append([xs[0], 0.0, 0.0])
    for j in range(n):
        faces.append([tail_center, j, (j + 1) % n])
    return np.array(verts), np.array(faces)


def fin(angle_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """A thin trapezoidal fin at the tail, rotated about x by ``angle_rad``."""
    x0 = -LENGTH_M / 2 + 0.1
    root, tip, span, half_t = 0.35, 0.2, 0.22, 0.008
    outline = np.array([[x0, 0.10], [x0 + root, 0.10], [x0 + tip + 0.05, 0.10 + span], [x0 + 0.05, 0.10 + span]])
    verts = []
    for t in (-half_t, half_t):
        for x, r in outline:
            verts.append([x, r, t])
    verts = np.array(verts)
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    rot = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    verts = verts @ rot.T
    faces = np.array([[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6], [0, 4, 5], [0, 5, 1], [1, 5, 6], [1, 6, 2],
                      [2, 6, 7], [2, 7, 3], [3, 7, 4], [3, 4, 0]])
    return verts, faces


def build() -> tuple[np.ndarray, np.ndarray]:
    parts = [hull()] + [fin(np.deg2rad(a)) for a in (45.0, 135.0, 225.0, 315.0)]
    verts, faces, offset = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces.append(f + offset)
        offset += len(v)
    return np.vstack(verts), np.vstack(faces)


def write_obj(path: Path) -> None:
    verts, faces = build()
    lines = ["# TAUV-like AUV, body frame x fwd / y stbd / z down, metres (assets/make_auv_mesh.py)"]
    lines += [f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in verts]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


OUTPUT = Path(__file__).resolve().parent.parent / "app" / "assets" / "auv.obj"

if __name__ == "__main__":
    write_obj(OUTPUT)
