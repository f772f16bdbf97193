"""The fixed-interval smoother of Yoo 2014's bank (tauvcore.engine.yoo_bank): its tape and its
smoothed records.

The same Rauch-Tung-Striebel recursion as the 20-state bank's (tauvcore.engine.smoothing; its
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

The smoothed records are the filter's, for ``x+ (+) s``: the velocity ``v + s_v`` (NED), the
attitude ``exp([s_rho x]) C``, the biases ``b + s_b``; the errors against truth ``dx - s`` (the
velocity's norm in the body frame from the true body velocity, as the filter's record); the
1-sigma and NEES from the smoothed covariance's 12 states. The filter has no position state: its
position, and so the smoothed one, is the strapdown's, the error the filter's, its sigma NaN.
"""

from __future__ import annotations

import numpy as np

from tauvcore.engine.smoothing import ESTIMATES, Carry, Tape, event_arrays
from tauvcore.filter import statistics, yoo
from tauvcore.geo.rotations import C_nb_from_euler, euler_from_C_nb, exp_so3, log_so3, mv

DIM = yoo.DIM


class YooTapeWriter:
    """What the Yoo bank leaves on its :class:`~tauvcore.engine.smoothing.Tape`: a chunk's marks.

    Parameters
    ----------
    tape : Tape
        Where the segments go.
    batch : tuple of int
        (M, R): methods and runs.
    na : int
        The covariance's dimension (the 12 states and the consider states).
    """

    def __init__(self, tape: Tape, batch: tuple[int, int], na: int) -> None:
        self.tape, self.batch, self.na = tape, batch, na
        self.phi_acc = np.zeros(batch + (DIM, DIM))  # Phi - I since the last mark
        self.out: dict[str, np.ndarray] | None = None
        self.store: dict[str, np.ndarray] = {}
        self.rows = 0  # output epochs of the chunk recorded so far
        self.events: list[tuple] = []

    def open(self, store: dict[str, np.ndarray]) -> None:
        """A chunk begins, its filtered results going to ``store``.

        Parameters
        ----------
        store : dict[str, numpy.ndarray]
            The chunk's store (tauvcore.engine.yoo_bank.YooBank._store).
        """
        T, shape = store["out_k"].size, self.batch
        self.out = {
            "tape_X": np.zeros((T,) + shape + (DIM, DIM)),
            "tape_P": np.zeros((T,) + shape + (self.na, self.na)),
            "tape_dx": np.zeros((T,) + shape + (DIM,)),
            "tape_vel_b_mps": np.zeros((T,) + shape + (3,)),
        }
        self.store, self.rows, self.events = store, 0, []

    def propagated(self, Phi: np.ndarray) -> None:
        """A covariance step's transition ``Phi`` (M * R, 12, 12) composed into the one since the
        last mark.

        Parameters
        ----------
        Phi : numpy.ndarray
            The step's transition of every filter, the batch flattened.
        """
        X = (Phi - np.eye(DIM)).reshape(self.phi_acc.shape)
        self.phi_acc = X + self.phi_acc + X @ self.phi_acc

    def before(self, P: np.ndarray, nominal: tuple[np.ndarray, ...], row: int = -1) -> tuple:
        """A correction's mark before it: its transition, prior and nominal state.

        Parameters
        ----------
        P : numpy.ndarray
            (M, R, na, na) the covariances.
        nominal : tuple of numpy.ndarray
            The nominal states (vel, C, ba, bg), each (M, R, ...).
        row : int
            The chunk's output epoch already recorded at this sample, which is recorded again after
            the correction (the mark goes before it and takes its transition); -1 for none.

        Returns
        -------
        tuple
            What :meth:`after` takes.
        """
        assert self.out is not None  # opened at the chunk's start
        if row >= 0:
            X, pos = self.out["tape_X"][row].copy(), row
        else:
            X, pos = self.phi_acc.copy(), self.rows
            self.phi_acc[...] = 0.0
        return X, P.copy(), tuple(a.copy() for a in nominal), pos

    def after(self, before: tuple, P: np.ndarray, nominal: tuple[np.ndarray, ...]) -> None:
        """The mark after its correction: posterior and the correction the nominal state took.

        Parameters
        ----------
        before : tuple
            What :meth:`before` returned.
        P : numpy.ndarray
            (M, R, na, na) the covariances now.
        nominal : tuple of numpy.ndarray
            The nominal states now (vel, C, ba, bg).
        """
        X, Pm, (vel0, C0, ba0, bg0), pos = before
        vel, C, ba, bg = nominal
        d = np.zeros(self.batch + (self.na,))
        d[..., yoo.VEL] = vel - vel0
        d[..., yoo.ATT] = log_so3(C @ np.swapaxes(C0, -1, -2))
        d[..., yoo.BA] = ba - ba0
        d[..., yoo.BG] = bg - bg0
        d[(P == Pm).all(axis=(-2, -1))] = 0.0  # nothing fused: round-off, not a correction
        self.events.append((X, Pm, P.copy(), d, pos))

    def record(self, row: int, P: np.ndarray, dx: np.ndarray, vel_b_true_mps: np.ndarray) -> None:
        """An output epoch's mark (again, after a source's correction at it).

        Parameters
        ----------
        row : int
            Its row in the chunk.
        P : numpy.ndarray
            (M, R, na, na) the covariances.
        dx : numpy.ndarray
            (M, R, 12) the error against truth.
        vel_b_true_mps : numpy.ndarray
            (3,) or (R, 3) the true body velocity [m/s] (FRD).
        """
        assert self.out is not None  # opened at the chunk's start
        out = self.out
        out["tape_X"][row] = self.phi_acc
        self.phi_acc[...] = 0.0
        out["tape_P"][row] = P
        out["tape_dx"][row] = dx
        out["tape_vel_b_mps"][row] = vel_b_true_mps
        self.rows = max(self.rows, row + 1)

    def close(self) -> None:
        """The chunk's marks onto the tape, up to the output epochs recorded; nothing if none is
        open."""
        if self.out is None:
            return
        T, batch, na, events = self.rows, self.batch, self.na, self.events
        order = sorted(range(len(events)), key=lambda j: (events[j][4], j))  # by place, then time
        parts = {name: a[:T] for name, a in self.out.items()}
        parts.update(event_arrays([events[j] for j in order], batch, (DIM, DIM), na))
        for name in ESTIMATES:
            parts[name] = np.array(self.store[name][:T])
        parts["pos_err"] = np.array(self.store["series"][2, :T])
        parts["vel_err"] = np.array(self.store["series"][0, :T])
        self.out, self.store, self.events = None, {}, []
        self.tape.add(parts)


def smooth_yoo_segment(
    segment: dict[str, np.ndarray],
    carry: Carry,
    batch: tuple[int, int],
    block_of_state: np.ndarray,
    num_blocks: int,
    sensor_index: np.ndarray,
    deg: float,
) -> dict[str, np.ndarray]:
    """The backward pass over one segment of the Yoo bank's tape and its smoothed store (module
    docstring).

    Parameters
    ----------
    segment : dict[str, numpy.ndarray]
        The segment (:class:`YooTapeWriter`).
    carry : Carry
        The pass so far (12 by 12 transitions, the covariance's states), updated in place.
    batch : tuple of int
        (M, R): methods and runs.
    block_of_state : numpy.ndarray
        Each of the 12 states' NEES block.
    num_blocks : int
        NEES blocks (the first, position, NaN).
    sensor_index : numpy.ndarray
        The state of each sensor-error column.
    deg : float
        Degrees per radian (the attitude series are in degrees), as the bank's records take it.

    Returns
    -------
    dict[str, numpy.ndarray]
        The smoothed store, the fields of the bank's.
    """
    B = int(np.prod(batch))
    T = segment["tape_P"].shape[0]
    s, Ps = carry.backward(segment, B)
    shape = (T,) + batch
    s = s.reshape(shape + (-1,))[..., :DIM]
    P = np.ascontiguousarray(Ps.reshape(shape + Ps.shape[-2:])[..., :DIM, :DIM])
    dx = np.asarray(segment["tape_dx"]) - s
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
    blocks = statistics.block_nees(dx, P, block_of_state, num_blocks)
    blocks[..., 0] = np.nan  # no position state
    series = np.stack(
        [
            vel_err,
            np.linalg.norm(att, axis=-1) * deg,
            np.asarray(segment["pos_err"]),
            np.sqrt(np.einsum("...ii->...", P[..., :3, :3])),
            np.sqrt(np.einsum("...ii->...", P[..., 3:6, 3:6])) * deg,
            np.full(shape, np.nan),
            statistics.nees(dx, P),
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
    }
    if segment["sensor_est"].shape[0]:
        store["sensor_est"] = segment["sensor_est"] + s[..., sensor_index]
        store["sensor_sigma"] = np.sqrt(np.einsum("...ii->...i", P))[..., sensor_index]
        store["sensor_true"] = np.array(segment["sensor_true"])
    else:
        for name in ("sensor_est", "sensor_sigma", "sensor_true"):
            store[name] = np.zeros((0,) + batch + (sensor_index.size,))
    return store
