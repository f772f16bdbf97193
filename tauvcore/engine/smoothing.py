"""The fixed-interval smoother of the 20-state filter bank: its tape and its backward pass (Yoo
2014's bank takes the same tape and pass: tauvcore.engine.yoo_smoothing).

During the forward pass the bank (tauvcore.engine.filter_bank.FilterBank with a :class:`Tape`)
leaves a mark at every output epoch and at every epoch where it corrected (an aiding epoch, a
velocity reset, a repair of P): the transition since the mark before, P (before and after the
corrections at an aiding mark, and the correction the nominal state took there), and at an output
mark the error against truth and the filtered estimates. A chunk's marks are one segment of the
tape, kept in memory up to the tape's budget and written to a temporary directory beyond it.

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
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from tauvcore.engine import loop
from tauvcore.engine.results import STATE_FIELDS
from tauvcore.filter.eskf import Nominal, difference
from tauvcore.filter.kernels.common import ATT, CORE, NAV, POS, VEL, N, jit
from tauvcore.filter.kernels.nees import add_reference_into, nees_plan
from tauvcore.filter.kernels.smoother import AidingMarks, CarriedMark, OutputMarks, smooth_backward
from tauvcore.filter.layout import STATE, NavState
from tauvcore.geo.rotations import C_nb_from_euler, euler_from_C_nb, exp_so3, mv

OUTPUT_TAPE = ("tape_X", "tape_P", "tape_dx")
"""The output marks' fields of a segment the compiled records fill (tauvcore.engine.loop.Outputs)."""

ESTIMATES = (
    "t_s",
    "out_k",
    "est_pos_n",
    "est_vel_n",
    "est_euler",
    "sensor_est",
    "sensor_sigma",
    "sensor_true",
    *STATE_FIELDS,
)
"""The filtered store's fields a segment keeps, for the smoothed estimates and their records."""


DEFAULT_BUDGET_MB = 64.0
"""Megabytes of tape the smoother holds in memory by default; the rest goes to a temporary file."""


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


class SmoothingError(ValueError):
    """The smoother cannot do what it was asked (its budget, its temporary directory): one line."""


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


def tape_bytes_per_epoch(batch: tuple[int, int]) -> int:
    """Bytes of tape an output epoch of ``batch`` (methods, runs) filters takes (P as its upper
    triangle)."""
    return int(np.prod(batch)) * 8 * (NAV * CORE + N * (N + 1) // 2 + N)


SYMMETRIC = ("tape_P", "ev_Pm", "ev_Pp")
"""A segment's covariances, which the tape keeps as their upper triangles (:func:`_packed`)."""


def _packed(a: np.ndarray) -> np.ndarray:
    """Symmetric matrices (..., n, n) as their upper triangles, row by row (..., n (n + 1) / 2)."""
    upper = np.triu_indices(a.shape[-1])
    return np.ascontiguousarray(a[..., upper[0], upper[1]])


def _unpacked(a: np.ndarray) -> np.ndarray:
    """The symmetric matrices (..., n, n) of their upper triangles (:func:`_packed`)."""
    n = (math.isqrt(8 * a.shape[-1] + 1) - 1) // 2
    upper = np.triu_indices(n)
    out = np.empty(a.shape[:-1] + (n, n))
    out[..., upper[0], upper[1]] = a
    out[..., upper[1], upper[0]] = a
    return out


def tape_rows(T: int, batch: tuple[int, int], n: int = N) -> dict[str, np.ndarray]:
    """The output marks' rows of a segment of ``T`` output epochs (:data:`OUTPUT_TAPE`, zeros):
    with ``T`` 0, what the compiled records take when there is no smoother.

    Parameters
    ----------
    T : int
        Output epochs.
    batch : tuple of int
        (M, R): methods and runs.
    n : int
        The error state's size: 20 and the sources' states.

    Returns
    -------
    dict[str, numpy.ndarray]
        ``tape_X`` (T, M, R, 9, 15), ``tape_P`` (T, M, R, n, n), ``tape_dx`` (T, M, R, n).
    """
    return {
        "tape_X": np.zeros((T,) + batch + (NAV, CORE)),
        "tape_P": np.zeros((T,) + batch + (n, n)),
        "tape_dx": np.zeros((T,) + batch + (n,)),
    }


class Tape:
    """The forward pass's marks, segment by segment (module docstring).

    Parameters
    ----------
    budget_bytes : int
        Bytes of segments held in memory; the segments beyond go to files in a temporary
        directory (removed by :meth:`close`).
    directory : str or None
        Where the temporary directory is made; None: the system's (``TMPDIR``).
    """

    def __init__(self, budget_bytes: int, directory: str | None = None) -> None:
        self.budget_bytes = budget_bytes
        self.directory = directory
        self.held_bytes = 0
        self.spilled_bytes = 0
        self.segments: list[dict[str, np.ndarray] | str] = []
        self.tmp: str | None = None

    def add(self, segment: dict[str, np.ndarray]) -> None:
        """Keep one segment (its arrays are not copied), in memory while the budget allows.

        Parameters
        ----------
        segment : dict[str, numpy.ndarray]
            The segment's arrays by name.

        Raises
        ------
        SmoothingError
            The temporary directory cannot be made or written (naming it and why).
        """
        segment = {name: _packed(a) if name in SYMMETRIC else a for name, a in segment.items()}
        size = sum(a.nbytes for a in segment.values())
        if self.held_bytes + size <= self.budget_bytes:
            self.segments.append(segment)
            self.held_bytes += size
            return
        path = os.path.join(self._tmp(), f"{len(self.segments):06d}")
        try:
            os.mkdir(path)
            for name, a in segment.items():
                np.save(os.path.join(path, name + ".npy"), a)
        except OSError as exc:
            self.close()
            raise SmoothingError(
                f"the smoother's tape cannot be written to {path}: {exc.strerror or exc} "
                "(free disk space there, or give another directory with --smooth-dir)"
            ) from None
        self.segments.append(path)
        self.spilled_bytes += size

    def _tmp(self) -> str:
        if self.tmp is None:
            try:
                self.tmp = tempfile.mkdtemp(prefix="tauv-smoother-", dir=self.directory)
            except OSError as exc:
                raise SmoothingError(
                    f"the smoother cannot make its temporary directory in {self.directory or tempfile.gettempdir()}: "
                    f"{exc.strerror or exc}"
                ) from None
        return self.tmp

    def segment(self, i: int) -> dict[str, np.ndarray]:
        """Segment ``i`` (from a file: its arrays mapped, read as they are used).

        Parameters
        ----------
        i : int
            The segment's index, in the order they were added.

        Returns
        -------
        dict[str, numpy.ndarray]
            Its arrays by name.
        """
        held = self.segments[i]
        if isinstance(held, str):
            held = {
                name[:-4]: np.load(os.path.join(held, name), mmap_mode="r")
                for name in sorted(os.listdir(held))
            }
        return {name: _unpacked(a) if name in SYMMETRIC else a for name, a in held.items()}

    def __len__(self) -> int:
        return len(self.segments)

    def close(self) -> None:
        """Drop every segment and remove the temporary directory."""
        self.segments = []
        self.held_bytes = self.spilled_bytes = 0
        if self.tmp is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            self.tmp = None


def event_arrays(
    events: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]],
    batch: tuple[int, int],
    block: tuple[int, int],
    n: int,
) -> dict[str, np.ndarray]:
    """A segment's aiding marks as its arrays.

    Parameters
    ----------
    events : list of tuple
        Each mark's transition block, prior and posterior P, correction and place among the
        output marks (the output marks before it), in the order they follow one another.
    batch : tuple of int
        (M, R): methods and runs.
    block : tuple of int
        The transition block's shape (a, b).
    n : int
        States of P.

    Returns
    -------
    dict[str, numpy.ndarray]
        ``ev_X`` (V, M, R, a, b), ``ev_Pm``, ``ev_Pp`` (V, M, R, n, n), ``ev_d`` (V, M, R, n) and
        ``ev_pos`` (V,).
    """
    shapes = (block, (n, n), (n, n), (n,))
    out = {
        name: np.array([e[j] for e in events]).reshape((-1,) + batch + shape)
        for j, (name, shape) in enumerate(zip(("ev_X", "ev_Pm", "ev_Pp", "ev_d"), shapes, strict=True))
    }
    out["ev_pos"] = np.array([e[4] for e in events], dtype=np.int64)
    return out


class TapeShape(NamedTuple):
    """The arrays a family's bank leaves on its tape (:class:`TapeWriter`).

    Attributes
    ----------
    block : tuple of int
        (a, b): the shape of a transition's block (``X = Phi - I`` on its first a rows and b
        columns): (9, 15) for the 20-state filter, (12, 12) for Yoo's.
    n : int
        States of P: the error state, its consider states and the sources' states.
    dx : int
        Entries of an output mark's error against truth (``tape_dx``).
    rows : dict[str, tuple of int]
        Further arrays of the output marks the compiled records fill, each row's shape by name.
    from_series : dict[str, int]
        Arrays of the output marks taken from the filtered store's ``series`` (their row in it)
        by name.
    pings : bool
        Whether the compiled loop writes the DVL pings' aiding marks itself (:attr:`TapeWriter.marks`,
        handed in by :meth:`TapeWriter.pings_marked`).
    """

    block: tuple[int, int]
    n: int
    dx: int
    rows: dict[str, tuple[int, ...]]
    from_series: dict[str, int]
    pings: bool


Difference = Callable[[tuple[np.ndarray, ...], tuple[np.ndarray, ...]], np.ndarray]
"""A family's correction between two nominal states: ``(now, before)`` -> (M, R, n) the error
state that takes ``before`` to ``now`` (its consider states zero)."""


def nominal_difference(
    now: tuple[np.ndarray, ...], before: tuple[np.ndarray, ...], batch: tuple[int, int], geodetic: bool
) -> np.ndarray:
    """The 20-state filter's correction between two nominal states (:data:`Difference`), each
    (pos, vel, C, ba, bg, bdvl, sf, the sources' states) with the batch flattened: position,
    misalignment, body velocity and sensor errors (tauvcore.filter.eskf.difference; positions
    through the metric at the estimate when ``geodetic``), then the sources' states' own.

    Parameters
    ----------
    now, before : tuple of numpy.ndarray
        The nominal states after and before the corrections.
    batch : tuple of int
        (M, R): methods and runs.
    geodetic : bool
        The positions are latitude, longitude, depth.

    Returns
    -------
    numpy.ndarray
        (M, R, n) the correction.
    """

    def state(arrays: tuple[np.ndarray, ...]) -> Nominal:
        pos, vel, C, ba, bg, bdvl, sf, _ = (a.reshape(batch + a.shape[1:]) for a in arrays)
        return Nominal(NavState(pos, vel, C), ba, bg, bdvl, sf)

    d = difference(state(now), state(before), geodetic)
    if now[-1].shape[-1]:  # the sources' states add
        d = np.concatenate([d, (now[-1] - before[-1]).reshape(batch + (-1,))], axis=-1)
    return d


def eskf_tape_shape(num_extra: int) -> TapeShape:
    """The 20-state filter's :class:`TapeShape`, with ``num_extra`` states the sources add."""
    n = N + num_extra
    return TapeShape((NAV, CORE), n, n, {}, {}, False)


class TapeWriter:
    """What a filter bank leaves on its :class:`Tape`: a chunk's marks, as one segment.

    The output marks' rows are filled by the compiled records (:data:`OUTPUT_TAPE` and the
    shape's own ``rows``, through :attr:`out`), and so are the DVL pings' aiding marks where the
    compiled loop fuses them (:attr:`marks`, :meth:`pings_marked`); an aiding mark the bank makes
    in Python is taken around the epoch's corrections (:meth:`before`, :meth:`after`).
    :meth:`close` puts the segment on the tape with the filtered estimates of its output epochs,
    and the transition of the sources' own states from each mark to the next (``tape_E``,
    ``ev_E``: ``exp(rate dt)`` over the time between the marks, the product of the covariance
    steps' own, tauvcore.filter.kernels.error_model_kernels.extra_step_into, which the banks take
    at every mark).

    Parameters
    ----------
    tape : Tape
        Where the segments go.
    batch : tuple of int
        (M, R): methods and runs.
    shape : TapeShape
        The family's arrays.
    difference : Difference
        The family's correction between two nominal states.
    extra_rate : numpy.ndarray or None
        Shape (E,): each of the sources' states' -1/tau [1/s] (0: a random walk); None: none.
    """

    def __init__(
        self,
        tape: Tape,
        batch: tuple[int, int],
        shape: TapeShape,
        difference: Difference,
        extra_rate: np.ndarray | None = None,
    ) -> None:
        self.tape, self.batch, self.shape, self.difference = tape, batch, shape, difference
        self.extra_rate = np.zeros(0) if extra_rate is None else np.asarray(extra_rate, dtype=float)
        self.out: dict[str, np.ndarray] | None = None  # the output marks' rows of the current chunk
        self.marks: dict[str, np.ndarray] = {}  # the pings' marks of the compiled loop (shape.pings)
        self.store: dict[str, np.ndarray] = {}
        self.slot0 = 0
        self.events: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]] = []
        self.event_t: list[float] = []  # the aiding marks' times [s]
        self.last_t: float | None = None  # the time of the last mark put on the tape [s]

    def open(self, store: dict[str, np.ndarray], slot: int) -> None:
        """A chunk begins: its store (output epochs ``store["out_k"]``), the bank's output epochs
        recorded before it (``slot``).

        Parameters
        ----------
        store : dict[str, numpy.ndarray]
            The chunk's store of filtered output epochs (tauvcore.engine.chunk_driver).
        slot : int
            Output epochs recorded before the chunk.
        """
        shape, batch = self.shape, self.batch
        T = store["out_k"].size
        self.out = {
            "tape_X": np.zeros((T,) + batch + shape.block),
            "tape_P": np.zeros((T,) + batch + (shape.n, shape.n)),
            "tape_dx": np.zeros((T,) + batch + (shape.dx,)),
            **{name: np.zeros((T,) + batch + row) for name, row in shape.rows.items()},
        }
        if shape.pings:
            U = store["up_k"].size  # the pings' marks, written by the compiled loop
            n = (shape.n, shape.n)
            self.marks = {
                "ev_X": np.zeros((U,) + batch + shape.block),
                "ev_Pm": np.zeros((U,) + batch + n),
                "ev_P": np.zeros((U,) + batch + n),
                "ev_d": np.zeros((U,) + batch + (shape.n,)),
                "ev_pos": np.zeros(U, dtype=np.int64),
            }
        self.store, self.slot0, self.events, self.event_t = store, slot, [], []

    def pings_marked(self, pings: np.ndarray, t_s: np.ndarray) -> None:
        """The marks the compiled loop wrote for the chunk's pings ``pings`` (their rows of
        :attr:`marks`, in the order fused) at times ``t_s`` [s].

        Parameters
        ----------
        pings : numpy.ndarray
            The pings' rows in the chunk.
        t_s : numpy.ndarray
            Their times [s].
        """
        ev = self.marks
        for p, t in zip(pings, t_s, strict=True):
            self.events.append(
                (ev["ev_X"][p], ev["ev_Pm"][p], ev["ev_P"][p], ev["ev_d"][p], int(ev["ev_pos"][p]))
            )
            self.event_t.append(float(t))

    def before(
        self,
        phi_acc: np.ndarray,
        P: np.ndarray,
        nominal: tuple[np.ndarray, ...],
        t_s: float = 0.0,
        row: int = -1,
    ) -> tuple:
        """An aiding mark, before the epoch's corrections: its transition (``phi_acc``, then
        reset), prior P and nominal state.

        Parameters
        ----------
        phi_acc : numpy.ndarray
            (M, R, a, b) the transition since the last mark.
        P : numpy.ndarray
            (M, R, n, n) the covariances.
        nominal : tuple of numpy.ndarray
            The nominal states (the arrays :attr:`difference` takes).
        t_s : float
            The mark's time [s].
        row : int
            The chunk's output epoch already recorded at this sample, which is recorded again after
            the corrections (the mark goes before it and takes its transition; ``phi_acc`` is
            left as it is); -1 for none.

        Returns
        -------
        tuple
            What :meth:`after` takes.
        """
        if row >= 0:
            assert self.out is not None  # opened at the chunk's start
            X = self.out["tape_X"][row].copy()
        else:
            X = phi_acc.copy()
            phi_acc[...] = 0.0
        self.event_t.append(float(t_s))
        return X, P.copy(), tuple(a.copy() for a in nominal), row

    def after(self, before: tuple, P: np.ndarray, nominal: tuple[np.ndarray, ...], slot: int) -> None:
        """The aiding mark after the epoch's corrections: its posterior P and the correction the
        nominal state took (all the epoch's updates, a velocity reset and a repair of P as they were).

        Parameters
        ----------
        before : tuple
            What :meth:`before` returned.
        P : numpy.ndarray
            (M, R, n, n) the covariances now.
        nominal : tuple of numpy.ndarray
            The nominal states now, as :meth:`before` took them.
        slot : int
            Output epochs the bank recorded so far.
        """
        X, Pm, held, row = before
        d = np.zeros(self.batch + (self.shape.n,))
        d[...] = self.difference(nominal, held)
        # a filter whose P the epoch left as it was fused nothing (a Kalman update with a gain
        # changes P): what moved its nominal state is round-off (e.g. rebuilding the velocity
        # from the attitude, tauvcore.filter.kernels.correction.inject_batch), not a correction
        d[(P == Pm).all(axis=(-2, -1))] = 0.0
        self.events.append((X, Pm, P.copy(), d, row if row >= 0 else slot - self.slot0))

    def close(self, slot: int) -> None:
        """The chunk's marks onto the tape, up to the output epochs recorded (all the chunk's,
        or up to a stop), in the order of their places among the output marks; nothing if no
        chunk is open.

        Parameters
        ----------
        slot : int
            Output epochs the bank recorded so far.
        """
        if self.out is None:
            return
        T = slot - self.slot0
        batch, events = self.batch, self.events
        order = sorted(range(len(events)), key=lambda j: (events[j][4], j))  # by place, then time
        parts = {name: a[:T] for name, a in self.out.items()}
        parts.update(event_arrays([events[j] for j in order], batch, self.shape.block, self.shape.n))
        for name in ESTIMATES:
            parts[name] = np.array(self.store[name][:T])
        for name, row in self.shape.from_series.items():
            parts[name] = np.array(self.store["series"][row, :T])
        parts["tape_E"], parts["ev_E"], self.last_t = extra_transitions(
            self.extra_rate, batch, np.asarray(parts["t_s"]), parts["ev_pos"],
            [self.event_t[j] for j in order], self.last_t,
        )  # fmt: skip
        self.out, self.marks, self.store, self.events, self.event_t = None, {}, {}, [], []
        self.tape.add(parts)


def extra_transitions(
    rate: np.ndarray,
    batch: tuple[int, int],
    out_t: np.ndarray,
    ev_pos: np.ndarray,
    ev_t: list[float],
    last_t: float | None,
) -> tuple[np.ndarray, np.ndarray, float | None]:
    """The sources' states' transition from the mark before to each mark of a segment.

    Each is uncoupled, its transition ``exp(rate dt)`` over the time between the marks (the
    banks propagate P at every mark, so it is the product of their covariance steps'); the marks
    in their order, aiding mark j after the first ``ev_pos[j]`` output marks.

    Parameters
    ----------
    rate : numpy.ndarray
        Shape (E,): each state's -1/tau [1/s] (0: a random walk).
    batch : tuple of int
        (M, R): methods and runs.
    out_t : numpy.ndarray
        Shape (T,): the output marks' times [s].
    ev_pos : numpy.ndarray
        Shape (V,): each aiding mark's place among the output marks.
    ev_t : list of float
        The aiding marks' times [s], in the order of ``ev_pos``.
    last_t : float or None
        The time of the mark before the segment [s]; None: the mission's first (its transition 1).

    Returns
    -------
    out_E : numpy.ndarray
        Shape (T, M, R, E) [-].
    ev_E : numpy.ndarray
        Shape (V, M, R, E) [-].
    last_t : float or None
        The time of the segment's last mark [s].
    """
    E = rate.size
    out_E, ev_E = np.ones((out_t.size,) + batch + (E,)), np.ones((ev_pos.size,) + batch + (E,))
    if E == 0:
        return out_E, ev_E, last_t
    marks = sorted([(int(p), 0, j, float(t)) for j, (p, t) in enumerate(zip(ev_pos, ev_t))]
                   + [(j, 1, j, float(t)) for j, t in enumerate(out_t)])  # fmt: skip
    for _, is_output, j, t in marks:
        dt = 0.0 if last_t is None else t - last_t
        (out_E if is_output else ev_E)[j] = np.exp(rate * dt)
        last_t = t
    return out_E, ev_E, last_t


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
