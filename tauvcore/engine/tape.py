"""The smoother's tape: the marks a filter bank leaves during the forward pass (tauvcore.engine.smoothing
runs the backward pass over them).

During the forward pass a bank (tauvcore.engine.filter_bank.FilterBank, tauvcore.engine.yoo_bank.YooBank
with a :class:`Tape`) leaves, through its :class:`TapeWriter`, a mark at every output epoch and at
every epoch where it corrected (an aiding epoch, a velocity reset, a repair of P): the transition
since the mark before, P (before and after the corrections at an aiding mark, and the correction
the nominal state took there), and at an output mark the error against truth and the filtered
estimates. What a family's marks hold is its :class:`TapeShape` and its correction between two
nominal states (:data:`Difference`). A chunk's marks are one segment of the tape, kept in memory up
to the tape's budget and written to a temporary directory beyond it.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from tauvcore.engine.results import STATE_FIELDS
from tauvcore.filter.eskf import Nominal, difference
from tauvcore.filter.kernels.common import CORE, NAV, N
from tauvcore.filter.layout import NavState

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


class SmoothingError(ValueError):
    """The smoother cannot do what it was asked (its budget, its temporary directory): one line."""


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
