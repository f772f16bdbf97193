"""The fixed-interval smoother: its options and its backward pass over the tape, and the 20-state
filter bank's smoothed records (Yoo 2014's bank takes the same tape and pass:
tauvcore.engine.yoo_smoothing).

During the forward pass a bank leaves its marks on a tape (tauvcore.engine.tape: the transition
since the mark before, P before and after the corrections, the correction the nominal state took,
and at an output mark the error against truth and the filtered estimates).

After the forward pass, :func:`smooth_tape` runs the Rauch-Tung-Striebel backward pass
(tauvcore.filter.kernels.smoother: its equations) over the segments, latest first, and makes of
each a store of smoothed output epochs with the fields of the filtered one (error norms, 1-sigma,
NEES of the full state and of each block, estimated position, velocity, attitude and sensor
errors): the smoothed error against truth is ``dx - s``, the smoothed estimate ``x+ (+) s``
(position and the sensor errors add, the attitude turns by ``exp([s_rho x])``, the body velocity
adds), both to first order in ``s`` as the filter's own correction is. The gate's decisions,
velocity resets and repairs of the forward pass are kept as they were.
"""

from __future__ import annotations

import contextlib
import math
import shutil
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace

import numpy as np

from tauvcore.engine import loop
from tauvcore.engine.smooth_defaults import DEFAULT_BUDGET_MB
from tauvcore.engine.tape import SmoothingError, Tape, tape_bytes_per_epoch
from tauvcore.filter.kernels.common import ATT, CORE, NAV, POS, VEL, N, jit
from tauvcore.filter.kernels.nees import add_reference_into, nees_plan
from tauvcore.filter.kernels.smoother import AidingMarks, CarriedMark, OutputMarks, smooth_backward
from tauvcore.filter.layout import STATE
from tauvcore.geo.rotations import C_nb_from_euler, euler_from_C_nb, exp_so3, mv


@dataclass(frozen=True)
class SmoothOptions:
    """Ask a run for the smoother (tauvcore.engine.mission.run and its siblings)."""

    budget_mb: float = DEFAULT_BUDGET_MB  # what the smoother holds in memory [MB], all its tapes
    # together (the forward pass's and the smoothed stores', each bank's); beyond, a temporary directory
    directory: str | None = None  # where that directory is made; None: the system's (TMPDIR)
    on_start: Callable[[], None] | None = field(default=None, compare=False, repr=False)  # called as
    # the backward pass begins, the forward pass done or stopped (a live display says so)

    def tape(self, share: float = 1.0) -> Tape:
        """An empty tape with these options, holding ``share`` of the budget in memory.

        Parameters
        ----------
        share : float
            The fraction of ``budget_mb`` this tape holds (the smoother's tapes share it).

        Returns
        -------
        Tape
            The tape.
        """
        return Tape(int(self.budget_mb * share * 1e6), self.directory)


@contextlib.contextmanager
def scratch(options: SmoothOptions | None) -> Iterator[SmoothOptions | None]:
    """``options`` with a temporary directory of their own, made in ``options.directory`` (None:
    the system's) and removed with everything in it on leaving, also on an error or an
    interruption: what the smoother's tapes spill to while a run goes on.

    Parameters
    ----------
    options : SmoothOptions or None
        The smoother's options; None: no smoother (nothing made, None given back).

    Yields
    ------
    SmoothOptions or None
        ``options`` with ``directory`` the new temporary directory; None for None.

    Raises
    ------
    SmoothingError
        The directory cannot be made (naming where and why).
    """
    if options is None:
        yield None
        return
    where = options.directory or tempfile.gettempdir()
    try:
        own = tempfile.mkdtemp(prefix="tauv-smoother-", dir=options.directory)
    except OSError as exc:
        raise SmoothingError(
            f"the smoother cannot make its temporary directory in {where}: {exc.strerror or exc}"
        ) from None
    try:
        yield replace(options, directory=own)
    finally:
        shutil.rmtree(own, ignore_errors=True)


@jit
def smoothed_series_into(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    dx: np.ndarray,
    s: np.ndarray,
    Ps: np.ndarray,
    ref_var: np.ndarray,
    C_t: np.ndarray,
    vel_t: np.ndarray,
    deg: float,
    block_of_state: np.ndarray,
    num_blocks: int,
    series: np.ndarray,
    nees_block: np.ndarray,
) -> None:
    """The records (tauvcore.engine.loop.error_series_into) of T epochs of B filters smoothed:
    the error ``dx - s`` (T, B, d) and covariance ``Ps`` (T, B, d, d), the NEES against ``Ps``
    and the covariance of the reference's own errors ``ref_var`` (9,) at its attitude ``C_t``
    (T, B, 3, 3) and NED velocity ``vel_t`` (T, B, 3) (tauvcore.filter.kernels.nees.add_reference_into),
    into ``series`` (11, T, B) and ``nees_block`` (T, B, num_blocks)."""
    members, sizes, lead, order = nees_plan(block_of_state, num_blocks)
    d = dx.shape[-1]
    e = np.empty(d)
    L = np.empty((d, d))
    A = np.empty((d, d))
    y = np.empty(d)
    for t in range(dx.shape[0]):
        for f in range(dx.shape[1]):
            for i in range(d):
                e[i] = dx[t, f, i] - s[t, f, i]
            P = Ps[t, f]
            if add_reference_into(P, ref_var, C_t[t, f], vel_t[t, f], POS, ATT, VEL, True, A):
                loop.error_series_into(
                    e, P, A, deg, members, sizes, lead, order, L, y, series[:, t, f], nees_block[t, f]
                )
            else:
                loop.error_series_into(
                    e, P, P, deg, members, sizes, lead, order, L, y, series[:, t, f], nees_block[t, f]
                )


def _reference_state(segment: dict[str, np.ndarray], T: int, B: int) -> tuple[np.ndarray, np.ndarray]:
    """The reference's (the truth's) attitude (T, B, 3, 3) and NED velocity (T, B, 3) at a segment's
    output marks, from the filtered estimate and its error against it: ``C_t = exp([rho x]) C``,
    ``v_t = C_t (C^T v + dv_b)`` (tauvcore.filter.eskf.difference, inverted)."""
    dx = np.asarray(segment["tape_dx"], dtype=float).reshape(T, B, -1)
    C = C_nb_from_euler(np.asarray(segment["est_euler"], dtype=float).reshape(T, B, 3))
    C_t = exp_so3(dx[..., STATE.att]) @ C
    v_b = mv(np.swapaxes(C, -1, -2), np.asarray(segment["est_vel_n"], dtype=float).reshape(T, B, 3))
    return np.ascontiguousarray(C_t), np.ascontiguousarray(mv(C_t, v_b + dx[..., STATE.vel]))


class Carry:
    """The backward pass between two segments: the later segment's first mark, per filter
    (tauvcore.filter.kernels.smoother.smooth_backward), for B filters of n states whose
    transitions differ from I in their first a rows and b columns.

    Parameters
    ----------
    B : int
        Filters.
    a : int
        Rows of a transition's block (9 for the 20-state filter).
    b : int
        Its columns (15).
    n : int
        States (20, and the sources' own).
    e : int
        The last of them the sources add, whose transitions are their own diagonal (the tape's
        ``tape_E``, ``ev_E``).
    """

    def __init__(self, B: int, a: int = NAV, b: int = CORE, n: int = N, e: int = 0) -> None:
        self.has = np.zeros(B, bool)
        self.X = np.zeros((B, a, b))
        self.E = np.zeros((B, e))
        self.Pm = np.zeros((B, n, n))
        self.s = np.zeros((B, n))
        self.Ps = np.zeros((B, n, n))
        self.cuts = np.zeros(B, np.int64)

    def backward(self, segment: dict[str, np.ndarray], B: int) -> tuple[np.ndarray, np.ndarray]:
        """The backward pass over one segment's marks (the carry holds the segment after it, and
        then this one's first mark).

        Parameters
        ----------
        segment : dict[str, numpy.ndarray]
            The segment: its output marks' ``tape_X`` (T, ..., a, b) and ``tape_P`` (T, ..., n,
            n), its aiding marks' ``ev_X``, ``ev_Pm``, ``ev_Pp``, ``ev_d`` (V, ...) and ``ev_pos``
            (V,), the batch axes flattened to B filters.
        B : int
            Filters.

        Returns
        -------
        tuple of numpy.ndarray
            The smoothed errors (T, B, n) and their covariances (T, B, n, n) at the output marks.
        """
        a, b, n, e = self.X.shape[1], self.X.shape[2], self.s.shape[1], self.E.shape[1]

        def flat(name: str, tail: tuple[int, ...]) -> np.ndarray:
            a = np.ascontiguousarray(segment[name], dtype=float)
            return a.reshape((a.shape[0], B) + tail)

        T = segment["tape_P"].shape[0]
        if e == 0:  # a tape without the sources' states (Yoo's has no tape_E)
            segment = {
                **segment,
                "tape_E": np.ones((T, B, 0)),
                "ev_E": np.ones((segment["ev_Pm"].shape[0], B, 0)),
            }
        s = np.empty((T, B, n))
        Ps = np.empty((T, B, n, n))
        smooth_backward(
            OutputMarks(flat("tape_X", (a, b)), flat("tape_E", (e,)), flat("tape_P", (n, n))),
            AidingMarks(
                flat("ev_X", (a, b)),
                flat("ev_E", (e,)),
                flat("ev_Pm", (n, n)),
                flat("ev_Pp", (n, n)),
                flat("ev_d", (n,)),
                np.ascontiguousarray(segment["ev_pos"], dtype=np.int64),
            ),
            CarriedMark(self.has, self.X, self.E, self.Pm, self.s, self.Ps),
            s,
            Ps,
            self.cuts,
        )
        return s, Ps


def smooth_segment(
    segment: dict[str, np.ndarray],
    carry: Carry,
    batch: tuple[int, int],
    block_of_state: np.ndarray,
    sensor_index: np.ndarray,
    deg: float,
    ref_var: np.ndarray,
) -> dict[str, np.ndarray]:
    """The backward pass over one segment (the carry holds the segment after it, and then this
    one's first mark) and its smoothed store (module docstring).

    Parameters
    ----------
    segment : dict[str, numpy.ndarray]
        The segment (:class:`Tape`): the output marks' ``tape_X``, ``tape_P``, ``tape_dx``
        (T, M, R, ...), the aiding marks' ``ev_X``, ``ev_Pm``, ``ev_Pp``, ``ev_d`` (V, M, R, ...)
        and ``ev_pos`` (V,), and the filtered :data:`ESTIMATES`.
    carry : Carry
        The pass so far, updated in place.
    batch : tuple of int
        (M, R): methods and runs.
    block_of_state : numpy.ndarray
        Each state's NEES block (tauvcore.filter.layout.NEES_BLOCKS), -1 for none.
    sensor_index : numpy.ndarray
        The state of each sensor-error column of the records.
    deg : float
        Degrees per radian of the attitude series.
    ref_var : numpy.ndarray
        Shape (9,): the reference's own variances, whose covariance the NEES adds to P
        (tauvcore.filter.reference.ReferenceConfig.variances; all zero: exact), at the
        reference's state (the filtered estimate and its error against the reference, both on
        the tape).

    Returns
    -------
    dict[str, numpy.ndarray]
        The smoothed store: ``t_s``, ``out_k``, ``series``, ``nees_block``, ``est_pos_n``,
        ``pos_cov_ne_m2`` (the smoothed P_NN, P_NE, P_EE [m^2]),
        ``est_vel_n``, ``est_euler`` and, where the segment has them, the sensor errors'.
    """
    B = int(np.prod(batch))
    T, d = segment["tape_P"].shape[0], segment["tape_P"].shape[-1]
    s, Ps = carry.backward(segment, B)
    dx = np.ascontiguousarray(segment["tape_dx"], dtype=float).reshape(T, B, d)
    num_blocks = int(block_of_state.max()) + 1
    series = np.empty((len(loop.SERIES_NAMES), T, B))
    nees_block = np.empty((T, B, num_blocks))
    C_t, vel_t = _reference_state(segment, T, B)
    smoothed_series_into(dx, s, Ps, ref_var, C_t, vel_t, deg, block_of_state, num_blocks, series, nees_block)
    shape = (T,) + batch
    s = s.reshape(shape + (d,))
    moved = np.any(s[..., STATE.att] != 0.0, axis=-1, keepdims=True) | np.any(
        s[..., STATE.vel] != 0.0, axis=-1, keepdims=True
    )  # elsewhere the filter's own numbers, not their round trip through C
    C = exp_so3(s[..., STATE.att]) @ C_nb_from_euler(np.asarray(segment["est_euler"]))
    v_b = mv(np.swapaxes(C_nb_from_euler(np.asarray(segment["est_euler"])), -1, -2), segment["est_vel_n"])
    store = {
        "t_s": np.array(segment["t_s"]),
        "out_k": np.array(segment["out_k"]),
        "series": series.reshape((len(loop.SERIES_NAMES),) + shape),
        "nees_block": nees_block.reshape(shape + (num_blocks,)),
        "est_pos_n": segment["est_pos_n"] + s[..., STATE.pos],
        "pos_cov_ne_m2": horizontal_covariance(Ps, POS).reshape(shape + (3,)),
        "est_vel_n": np.where(moved, mv(C, v_b + s[..., STATE.vel]), segment["est_vel_n"]),
        "est_euler": np.where(moved, euler_from_C_nb(C), segment["est_euler"]),
    }
    sigma = np.sqrt(np.einsum("tfii->tfi", Ps)).reshape(shape + (d,))
    store["state_est"] = (
        np.asarray(segment.get("state_est", np.zeros(shape + (0,))))[..., : d - N] + s[..., N:]
    )
    store["state_sigma"] = sigma[..., N:]
    store["state_true"] = np.array(segment.get("state_true", np.zeros(shape + (0,))))
    if "sensor_est" in segment and segment["sensor_est"].shape[0]:
        store["sensor_est"] = segment["sensor_est"] + s[..., sensor_index]
        store["sensor_sigma"] = sigma[..., sensor_index]
        store["sensor_true"] = np.array(segment["sensor_true"])
    else:
        S = sensor_index.size
        for name in ("sensor_est", "sensor_sigma", "sensor_true"):
            store[name] = np.zeros((0,) + batch + (S,))
    return store


def horizontal_covariance(P: np.ndarray, pos: int) -> np.ndarray:
    """The horizontal position block of covariances ``P`` (..., d, d) whose position error states
    (north, east, down [m]) start at index ``pos``: (..., 3) P_NN, P_NE, P_EE [m^2]."""
    return np.stack([P[..., pos, pos], P[..., pos, pos + 1], P[..., pos + 1, pos + 1]], axis=-1)


def smooth_tape(
    tape: Tape, out: Tape, smooth_one: Callable[[dict[str, np.ndarray]], dict[str, np.ndarray]]
) -> None:
    """The backward pass over the whole tape, latest segment first: each segment's smoothed store
    (``smooth_one``, which carries the pass from one segment to the one before) into ``out`` (in
    the tape's order once done: :func:`forward`). The tape is closed after, and each segment
    dropped (its files removed) once read.

    Parameters
    ----------
    tape : Tape
        The forward pass's marks.
    out : Tape
        Receives the smoothed stores, latest first.
    smooth_one : Callable
        A segment -> its smoothed store (:func:`smooth_segment` with its carry).
    """
    try:
        for i in range(len(tape) - 1, -1, -1):
            out.add(smooth_one(tape.segment(i)))
            held = tape.segments[i]
            tape.segments[i] = {}
            if isinstance(held, str):
                shutil.rmtree(held, ignore_errors=True)
    finally:
        tape.close()


def forward(out: Tape) -> Iterator[dict[str, np.ndarray]]:
    """The smoothed stores :func:`smooth_tape` put into ``out``, earliest first.

    Parameters
    ----------
    out : Tape
        The smoothed stores, latest first.

    Yields
    ------
    dict[str, numpy.ndarray]
        Each segment's smoothed store, in the mission's order.
    """
    for i in range(len(out) - 1, -1, -1):
        yield out.segment(i)


def spill_floor_bytes(batch: tuple[int, int], rate_hz: float, chunk_s: float) -> int:
    """Bytes the smoother holds at least whatever its budget: one chunk's segment being written
    and one being read back, of ``batch`` filters at ``rate_hz`` output epochs over ``chunk_s``.

    Parameters
    ----------
    batch : tuple of int
        (M, R): methods and runs.
    rate_hz : float
        Output epochs per second (marks of the tape).
    chunk_s : float
        Seconds of mission per chunk.

    Returns
    -------
    int
        The bytes.
    """
    return 2 * tape_bytes_per_epoch(batch) * max(1, math.ceil(rate_hz * chunk_s))
