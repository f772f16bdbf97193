"""The likelihood of a log's innovations under noise values: a replay of the log through the
compiled filter bank with the gate open (tauvcore.eval.tuning), evaluated for many values from one
reading of the log, in this process or on Dask."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from tauvcore.config import Config
from tauvcore.engine.results import MethodResult
from tauvcore.eval.tuning.parameters import with_values
from tauvcore.filter.families import family_of
from tauvcore.logs import Log

TUNING_GATE_SIGMA = 1000.0
"""``filter.gate_sigma`` during the search: its largest value, no gate (module docstring)."""


def tuning_config(config: Config) -> Config:
    """The configuration an evaluation of the likelihood replays with: the gate open
    (:data:`TUNING_GATE_SIGMA`) and no lock-out reset (module docstring).

    Parameters
    ----------
    config : Config
        The configuration.

    Returns
    -------
    Config
        ``config`` with ``filter.gate_sigma`` :data:`TUNING_GATE_SIGMA` and
        ``filter.lockout_reset_updates`` 0.
    """
    return config.replace("filter", gate_sigma=TUNING_GATE_SIGMA, lockout_reset_updates=0)


@dataclass(frozen=True)
class SourceLikelihood:
    """One aiding source's share of the negative log-likelihood."""

    source: str
    nll: float  # 1/2 sum (NIS + log det S + dof log 2 pi) over its updates [-]; inf: an update with
    #             no finite NIS or log det S (S unusable)
    updates: int  # the updates that measured (valid, at least one active row)
    dof: int  # their rows


def source_likelihoods(result: MethodResult) -> dict[str, SourceLikelihood]:
    """Each aiding source's share of a method's negative log-likelihood (module docstring).

    Parameters
    ----------
    result : MethodResult
        One run (R = 1) of a 20-state method: its update records carry ``log_det_s``.

    Returns
    -------
    dict[str, SourceLikelihood]
        Source name -> its share, over the updates that measured (valid, at least one active row),
        fused or rejected.

    Raises
    ------
    ValueError
        A record without ``log_det_s`` (Yoo 2014's bank does not keep it).
    """
    out = {}
    for source, record in result.updates.items():
        if record.log_det_s is None:
            raise ValueError(f"the {source} updates of {result.method} carry no log det S")
        used = record.valid & (record.nis_dof > 0)
        nis, log_det, dof = record.nis[used], record.log_det_s[used], record.nis_dof[used]
        finite = bool(np.all(np.isfinite(nis)) and np.all(np.isfinite(log_det)))
        nll = 0.5 * float(np.sum(nis + log_det + dof * math.log(2.0 * math.pi))) if finite else math.inf
        out[source] = SourceLikelihood(source, nll, int(used.sum()), int(dof.sum()))
    return out


def negative_log_likelihood(result: MethodResult) -> float:
    """A method's negative log-likelihood of its innovations, every source's summed
    (:func:`source_likelihoods`; inf where one is).

    Parameters
    ----------
    result : MethodResult
        One run (R = 1) of a 20-state method.

    Returns
    -------
    float
        ``1/2 sum (NIS + log det S + dof log 2 pi)`` over every update that measured [-].
    """
    return float(sum(s.nll for s in source_likelihoods(result).values()))


@dataclass(frozen=True)
class TuningLog:
    """One log to tune on, with the configuration it is replayed with."""

    name: str  # how it is named in messages and tables (its directory)
    log: Log
    config: Config  # as given (defaults, the log's own file, --config, the flags): one 20-state method
    # in run.methods, the seed the replay draws from

    def __post_init__(self) -> None:
        methods = self.config.run.methods
        if len(methods) != 1:
            raise ValueError(f"tuning takes one method, got {', '.join(methods) or 'none'}")
        family = family_of(methods[0])
        if not family.log_det:
            raise ValueError(
                f"tuning takes the methods of a filter whose records keep log det S, not {methods[0]} "
                f"({family.title})"
            )

    @property
    def method(self) -> str:
        """The method tuned."""
        return self.config.run.methods[0]


class PreparedLog:
    """A log made ready for many evaluations: read into a one-run simulation once
    (tauvcore.eval.replay.prepare), each evaluation a replay of it with other noise values.

    An evaluation is :func:`tauvcore.eval.replay.replay` of the configuration with the values laid
    over it, to the last bit: the simulation does not depend on the noise values (the log's
    sensors are what they are), and each run draws from a copy of the generator as
    :func:`~tauvcore.eval.replay.prepare` left it.

    Parameters
    ----------
    case : TuningLog
        The log and its configuration.
    """

    def __init__(self, case: TuningLog) -> None:
        from tauvcore.eval.replay import prepare

        self.case = case
        rng = np.random.default_rng(case.config.run.seed)
        _, self.sim = prepare(case.config, case.log, rng)
        self.rng = rng  # as prepare left it: every evaluation draws from a copy

    def results(self, values: Mapping[str, float], tuning: bool = True) -> dict[str, MethodResult]:
        """The replay of the log with ``values`` laid over its configuration.

        Parameters
        ----------
        values : Mapping[str, float]
            Parameter name -> value in its configuration key's unit.
        tuning : bool
            Replay as the search does (:func:`tuning_config`: gate open, no lock-out reset); False:
            with the gate as configured (the before/after table).

        Returns
        -------
        dict[str, MethodResult]
            The method's results (one run, R = 1), judged as far as the log can judge them
            (tauvcore.eval.judging.judged).
        """
        # the engine imported when a replay runs, not when the command line's parser is built
        from tauvcore.engine.mission import run
        from tauvcore.eval.judging import judged
        from tauvcore.eval.replay import replay_config

        config = with_values(self.case.config, values)
        if tuning:
            config = tuning_config(config)
        config = replay_config(config, self.case.log)
        return judged(
            self.case.log, run(config, self.sim, copy.deepcopy(self.rng)), config.filter.output_rate_hz
        )

    def nll(self, values: Mapping[str, float]) -> float:
        """The negative log-likelihood of the log's innovations under ``values`` (gate open).

        Parameters
        ----------
        values : Mapping[str, float]
            Parameter name -> value in its configuration key's unit.

        Returns
        -------
        float
            :func:`negative_log_likelihood` of the method's replay [-].
        """
        return negative_log_likelihood(self.results(values)[self.case.method])


def _nll_of(prepared: PreparedLog, values: Mapping[str, float]) -> float:
    """:meth:`PreparedLog.nll`, as a function a Dask worker runs."""
    return prepared.nll(values)


Evaluator = Callable[[Sequence[Mapping[str, float]]], list[float]]
"""Sums the logs' negative log-likelihoods at each of a batch of points (parameter values)."""


def serial_evaluator(prepared: Sequence[PreparedLog]) -> Evaluator:
    """Each point's logs one after the other, in this process.

    Parameters
    ----------
    prepared : Sequence[PreparedLog]
        The logs.

    Returns
    -------
    Evaluator
        ``points -> [sum over the logs of the NLL at each point]``.
    """

    def evaluate(points: Sequence[Mapping[str, float]]) -> list[float]:
        return [float(sum(p.nll(values) for p in prepared)) for values in points]

    return evaluate


def dask_evaluator(prepared: Sequence[PreparedLog], client: Any) -> Evaluator:
    """Every (point, log) pair of a batch as its own task on a Dask cluster.

    The prepared logs are scattered to the workers once; each batch sends only the points.

    Parameters
    ----------
    prepared : Sequence[PreparedLog]
        The logs.
    client : distributed.Client
        A client of the cluster (a local one: ``distributed.LocalCluster``).

    Returns
    -------
    Evaluator
        ``points -> [sum over the logs of the NLL at each point]``.
    """
    remote = client.scatter(list(prepared), broadcast=True)

    def evaluate(points: Sequence[Mapping[str, float]]) -> list[float]:
        futures = [[client.submit(_nll_of, r, dict(values), pure=False) for r in remote] for values in points]
        return [float(sum(f.result() for f in row)) for row in futures]

    return evaluate
