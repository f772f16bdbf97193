"""THE conventions of tauvcore: frames, rotations, errors, units and noise. Every module follows
this page; when in doubt, this page wins.

Frames
------
n    Local NED tangent frame (Tal et al. 2017 "tangent frame" t). Origin at the start point on
     the earth, axes north-east-down, fixed to the earth and rotating with it at the earth rate
     ``omega_ie_n``. Positions ``pos_n`` are metres from the origin; depth is ``pos_n[..., 2]``.
b    Body/platform frame (the paper's p): origin at the IMU (= centre of buoyancy, as the paper
     assumes), x forward, y right (starboard), z down.
s_k  DVL beam k (k = 1..4, stored at index k-1). Unit vector ``b_k`` in the body frame
     (eq. 13-14): ``b_k = [cos(psi_k) sin(theta), sin(psi_k) sin(theta), cos(theta)]`` with
     beam pitch ``theta`` = 20 deg and beam yaw ``psi_k = 45 + (k-1)*90 deg`` ("x" Janus).
     Beams 1, 4 look forward, 2, 3 aft; beams 1, 2 starboard, 3, 4 port. The b_k are fixed in h.
h    DVL head frame: the frame the beams are fixed in and the DVL reports its velocity in.
     Nominally b; a head mounted off by ZYX angles ``[roll, pitch, yaw]`` (its attitude in b, built
     as C_nb is from Euler angles) has ``C_bh = C_nb_from_euler(angles)``: ``v_b = C_bh @ v_h``,
     ``v_h = C_bh.T @ v_b`` (DVL misalignment: dvl.misalignment_deg simulated,
     calibration.dvl_misalignment_deg corrected).
r    A log's reference body frame: the frame its attitude ``C_nr`` is of. The IMU's body is r
     rotated by the boresight, ZYX angles ``[roll, pitch, yaw]``: ``C_rb = C_nb_from_euler(angles)``
     and ``C_nb = C_nr @ C_rb`` (calibration.imu_boresight_deg).

Rotations
---------
``C_nb`` rotates a vector from b to n: ``v_n = C_nb @ v_b``. There is no ``C_bn``; write
``C_nb.T`` (``swapaxes(-1, -2)`` on stacks). Euler angles are ZYX (yaw psi, pitch theta,
roll phi): ``C_nb = Rz(psi) @ Ry(theta) @ Rx(phi)``, stored as ``euler = [roll, pitch, yaw]``.
``omega_ab_c`` is the angular rate of frame b relative to frame a, resolved in c (i = inertial,
e = earth; since n is earth-fixed, ``omega_nb_b = omega_ib_b - C_nb.T @ omega_ie_n``).

Error state (Tal et al. eq. 1 and 8)
------------------------------------
``dx = x_true - x_hat`` for every additive state, and a *left, n-frame* misalignment ``rho``:
``C_nb_true = exp([rho x]) @ C_nb_hat``. Velocity error is in the body frame:
``dv_b = v_b_true - v_b_hat`` where ``v_b = C_nb.T @ v_n``. The layout lives in
``tauvcore.filter.layout``; no module spells a numeric state index.

Sensors
-------
The IMU samples the instantaneous specific force ``f_b`` and rate ``omega_ib_b`` at its rate,
``y = truth + bias + white``; white noise given as a random-walk density N (m/s/sqrt(s),
rad/sqrt(s)) has a per-sample standard deviation ``N / sqrt(dt)``. A random-walk bias with
density q moves by ``q * sqrt(dt) * N(0, 1)`` per sample. A turn-on bias given as "b" is drawn
``N(0, b^2)`` per axis from the run's generator (it is a 1-sigma value, as in Table 2).

Units
-----
SI and radians inside. A field or variable in any other unit carries the unit in its name
(``_deg``, ``_mg``, ``_deg_per_h``, ``_pct``); conversion constants live in ``tauvcore.units``
and degrees appear only at the edges (config files, CLI, GUI, plots).

Randomness
----------
Every random draw takes a ``numpy.random.Generator`` passed in by the caller; nothing seeds or
draws from a global generator.

Arrays
------
Per-step functions accept a leading batch shape ``(...)`` (Monte Carlo runs as an array
dimension): vectors are ``(..., 3)``, rotation matrices ``(..., 3, 3)``, covariances
``(..., n, n)``. Time series put time first: ``(K, ...)``.
"""

NUM_DVL_BEAMS = 4
MAX_SPEED_MPS = 30.0
"""Largest velocity component [m/s] of a DVL beam, a DVL body velocity or the reference (58 kn:
more than the fastest torpedo; a survey vehicle moves at 1-3 m/s); a larger one is in other
units (mm/s, cm/s) or no measurement."""
