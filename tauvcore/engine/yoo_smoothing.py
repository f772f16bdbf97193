"""The fixed-interval smoother of Yoo 2014's bank (tauvcore.engine.yoo_bank): what its marks on
the tape hold (:func:`tape_shape`, :func:`nominal_difference`; the one
tauvcore.engine.tape.TapeWriter writes them) and its smoothed records.

The same tape and Rauch-Tung-Striebel recursion as the 20-state bank's (tauvcore.engine.smoothing; its
equations in tauvcore.filter.kernels.smoother) over the 12 estimated states (NED velocity,
attitude, accelerometer and gyro biases) and the DVL's 5 consider states (tauvcore.engine.yoo_bank:
the forward filter never corrects them, so its corrections ``d`` are zero there, and the smoother
carries them as the covariance does). The transition is the 12 states' dense ``Phi``
(``X = Phi - I`` on the first 12 rows and columns; the consider states are constants plus walks).

The marks: the output epochs; each DVL ping (the bank's velocity update, or none, as the gate
decided); the sources' epochs (the magnetometer), whose corrections come after the epoch's output
record, which is then recorded again (tauvcore.engine.yoo_bank.YooBank._fuse_sources): their mark
is put before that output epoch, with the transition the first record took, so that the marks
follow one another as the filter's covariances do.

The states the sources add (the DVL's current, tauvcore.engine.yoo_velocity) follow the consider
states: estimated, corrected, their transition their own diagonal over the time between the
marks (tauvcore.engine.tape.extra_transitions), smoothed with the 12 into the records'
``state_est``, ``state_sigma`` and their NEES block.

The smoothed records are the filter's, for ``x+ (+) s``: the velocity ``v + s_v`` (NED), the
attitude ``exp([s_rho x]) C``, the biases ``b + s_b``; the errors against truth ``dx - s`` (the
velocity's norm in the body frame from the true body velocity, as the filter's record); the
1-sigma and NEES from the smoothed covariance's 12 states. The filter has no position state: its
position, and so the smoothed one, is the strapdown's, the error the filter's, its sigma NaN.
"""

from __future__ import annotations

import numpy as np

from tauvcore.engine.smoothing import Carry
from tauvcore.engine.tape import TapeShape
from tauvcore.filter import statistics
from tauvcore.filter.families.yoo import model as yoo
from tauvcore.filter.families.yoo.model_kernels import NA
from tauvcore.filter.kernels.nees import add_reference_batch
from tauvcore.geo.rotations import C_nb_from_euler, euler_from_C_nb, exp_so3, log_so3, mv

DIM = yoo.DIM


def tape_shape(na: int, num_extra: int) -> TapeShape:
    """The 12-state filter's :class:`~tauvcore.engine.tape.TapeShape`: 12 by 12 transitions, P
    over ``na`` states (the 12, the consider states, the ``num_extra`` added), the errors of the
    estimated ones, the true body velocity at each output mark, the filtered position and velocity
    errors (the smoothed records keep them where the smoother leaves the state as it was), the
    pings' marks written by the compiled loop."""
    return TapeShape(
        (DIM, DIM), na, DIM + num_extra, {"tape_vel_b_mps": (3,)}, {"pos_err": 2, "vel_err": 0}, True
    )


def nominal_difference(now: tuple[np.ndarray, ...], before: tuple[np.ndarray, ...], na: int) -> np.ndarray:
    """The 12-state filter's correction between two nominal states (vel, C, ba, bg, the added
    states), each (M, R, ...): the NED velocity's, the misalignment ``log(C C0^T)``, the biases' and
    the added states', zero on the consider states. -> (M, R, na)."""
    vel, C, ba, bg, extra = now
    vel0, C0, ba0, bg0, extra0 = before
    d = np.zeros(vel.shape[:-1] + (na,))
    d[..., yoo.VEL] = vel - vel0
    d[..., yoo.ATT] = log_so3(C @ np.swapaxes(C0, -1, -2))
    d[..., yoo.BA] = ba - ba0
    d[..., yoo.BG] = bg - bg0
    d[..., NA:] = extra - extra0
    return d


def with_reference(P: np.ndarray, ref_var: np.ndarray, C_nb: np.ndarray, vel_n: np.ndarray) -> np.ndarray:
    """The covariance the 12-state filter's NEES takes: P (..., n, n) of the estimated states (the
    12, then the added) and the covariance of the reference's own errors, ``ref_var`` (9,)
    (tauvcore.filter.reference.ReferenceConfig.variances) at the reference's attitude ``C_nb``
    (..., 3, 3) or (3, 3) and NED velocity ``vel_n`` (..., 3) or (3,), on the NED velocity and the
    misalignment (tauvcore.filter.kernels.nees.add_reference_batch; no position state); P itself
    when the reference is exact."""
    if not ref_var.any():
        return P
    batch = P.shape[:-2]
    n = P.shape[-1]
    C = np.broadcast_to(C_nb, batch + (3, 3)).reshape(-1, 3, 3)
    v = np.broadcast_to(vel_n, batch + (3,)).reshape(-1, 3)
    out = add_reference_batch(
        np.ascontiguousarray(P.reshape(-1, n, n)),
        ref_var,
        np.ascontiguousarray(C),
        np.ascontiguousarray(v),
        -1,
        yoo.ATT.start,
        yoo.VEL.start,
        False,
    )
    return out.reshape(P.shape)


def smooth_yoo_segment(
    segment: dict[str, np.ndarray],
    carry: Carry,
    batch: tuple[int, int],
    block_of_state: np.ndarray,
    num_blocks: int,
    sensor_index: np.ndarray,
    deg: float,
    ref_var: np.ndarray,
) -> dict[str, np.ndarray]:
    """The backward pass over one segment of the Yoo bank's tape and its smoothed store (module
    docstring).

    Parameters
    ----------
    segment : dict[str, numpy.ndarray]
        The segment (tauvcore.engine.tape.TapeWriter, :func:`tape_shape`).
    carry : Carry
        The pass so far (12 by 12 transitions, the covariance's states), updated in place.
    batch : tuple of int
        (M, R): methods and runs.
    block_of_state : numpy.ndarray
        Each estimated state's NEES block (the 12, then the added).
    num_blocks : int
        NEES blocks (the first, position, NaN).
    sensor_index : numpy.ndarray
        The state of each sensor-error column.
    deg : float
        Degrees per radian (the attitude series are in degrees), as the bank's records take it.
    ref_var : numpy.ndarray
        Shape (9,): the reference's own variances, whose covariance the NEES adds to P
        (:func:`with_reference`; all zero: exact).

    Returns
    -------
    dict[str, numpy.ndarray]
        The smoothed store, the fields of the bank's.
    """
    B = int(np.prod(batch))
    T, n = segment["tape_P"].shape[0], segment["tape_P"].shape[-1]
    s_all, Ps = carry.backward(segment, B)
    shape = (T,) + batch
    est = np.r_[np.arange(DIM), np.arange(NA, n)]  # the estimated states: the 12, then the added
    s_all = s_all.reshape(shape + (n,))
    s = s_all[..., :DIM]
    P = np.ascontiguousarray(Ps.reshape(shape + Ps.shape[-2:])[..., est[:, None], est])
    dx = np.asarray(segment["tape_dx"]) - s_all[..., est]
    euler = np.asarray(segment["est_euler"])
    moved = np.any(s[..., yoo.ATT] != 0.0, axis=-1, keepdims=True)
    C = exp_so3(s[..., yoo.ATT]) @ C_nb_from_euler(euler)
    vel = segment["est_vel_n"] + s[..., yoo.VEL]
    vel_err = np.where(  # where s is zero, the filter's own number, not its round trip through C
        moved[..., 0] | np.any(s[..., yoo.VEL] != 0.0, axis=-1),
        np.linalg.norm(segment["tape_vel_b_mps"] - mv(np.swapaxes(C, -1, -2), vel), axis=-1),
        segment["vel_err"],
    )
    att = dx[..., yoo.ATT]
    # the reference (the truth) at the marks: the filtered estimate and its error against it
    C_t = exp_so3(np.asarray(segment["tape_dx"])[..., yoo.ATT]) @ C_nb_from_euler(euler)
    P_nees = with_reference(
        P, ref_var, C_t, segment["est_vel_n"] + np.asarray(segment["tape_dx"])[..., yoo.VEL]
    )
    blocks = statistics.block_nees(dx, P_nees, block_of_state, num_blocks)
    P_est, P = P, P[..., :DIM, :DIM]  # the series are the 12 states'; the full NEES is over all
    blocks[..., 0] = np.nan  # no position state
    series = np.stack(
        [
            vel_err,
            np.linalg.norm(att, axis=-1) * deg,
            np.asarray(segment["pos_err"]),
            np.sqrt(np.einsum("...ii->...", P[..., :3, :3])),
            np.sqrt(np.einsum("...ii->...", P[..., 3:6, 3:6])) * deg,
            np.full(shape, np.nan),
            statistics.nees(dx, P_nees),
            np.linalg.norm(att[..., :2], axis=-1) * deg,
            np.abs(att[..., 2]) * deg,
            np.sqrt(P[..., 3, 3] + P[..., 4, 4]) * deg,
            np.sqrt(P[..., 5, 5]) * deg,
        ]
    )
    store = {
        "t_s": np.array(segment["t_s"]),
        "out_k": np.array(segment["out_k"]),
        "series": series,
        "nees_block": blocks,
        "est_pos_n": np.array(segment["est_pos_n"]),
        "est_vel_n": vel,
        "est_euler": np.where(moved, euler_from_C_nb(C), euler),
        "state_est": np.asarray(segment.get("state_est", np.zeros(shape + (0,)))) + s_all[..., NA:],
        "state_sigma": np.sqrt(np.einsum("...ii->...i", P_est[..., DIM:, DIM:])),
        "state_true": np.array(segment.get("state_true", np.zeros(shape + (0,)))),
    }
    if segment["sensor_est"].shape[0]:
        store["sensor_est"] = segment["sensor_est"] + s[..., sensor_index]
        store["sensor_sigma"] = np.sqrt(np.einsum("...ii->...i", P))[..., sensor_index]
        store["sensor_true"] = np.array(segment["sensor_true"])
    else:
        for name in ("sensor_est", "sensor_sigma", "sensor_true"):
            store[name] = np.zeros((0,) + batch + (sensor_index.size,))
    return store
