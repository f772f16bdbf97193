"""The search: where it starts (the configuration, a still stretch's Allan deviation), the
objective (the logs' likelihood with a Gaussian term per parameter), a decade scan, scipy's
L-BFGS-B or Nelder-Mead in ``ln theta``, and each value's 1-sigma from the curvature
(tauvcore.eval.tuning)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from tauvcore.eval.tuning.allan import StillStretch, still_noise
from tauvcore.eval.tuning.likelihood import Evaluator, PreparedLog, TuningLog, serial_evaluator
from tauvcore.eval.tuning.parameters import DEFAULT_PARAMETERS, PARAMETERS, parameter_values

SIGNIFICANT_DIGITS = 4
"""Digits a tuned value keeps (the uncertainty is rarely better than a percent); the "after" replay
uses the rounded values, so ``tauv replay --config`` of the written file gives its numbers."""

CONFIG_PRIOR_SIGMA_LN = math.log(10.0)
"""1-sigma of ``ln theta`` of the weak prior each parameter without a still stretch's measurement
gets at its configured value: a factor of ten (module docstring)."""

CURVATURE_STEP_LN = 0.1
"""Step of the central differences of the Hessian in ``ln theta`` (10 %)."""

GRADIENT_STEP_LN = 1e-3
"""Step of L-BFGS-B's forward-difference gradient in ``ln theta`` (0.1 %): the objective is
deterministic and smooth (gate open) to about 1e-9 of its value, so the difference's error is
the step times the curvature, not round-off."""

MAX_EVALUATIONS = 300
"""Most evaluations of the likelihood a search makes unless told (each a replay of every log);
the curvature's come on top."""

STOP_GAIN = 0.01
"""The search stops when a step gains less than this [units of the negative log-likelihood] (a
parameter moved by its 1-sigma changes it by 0.5), or its gradient is this flat per unit of
``ln theta``; Nelder-Mead's simplex when it is this narrow in ``ln theta`` too."""

OPTIMIZERS = ("l-bfgs-b", "nelder-mead")
"""The searches :func:`tune` offers (scipy.optimize.minimize's methods of those names)."""

UNDETERMINED_FACTOR = 2.0
"""A tuned parameter whose 1-sigma factor ``exp(sigma_ln)`` exceeds this is reported as not
determined by the logs (:attr:`TuningResult.determined`)."""


@dataclass(frozen=True)
class Evaluation:
    """One point the search evaluated, as handed to the progress callback."""

    count: int  # evaluations so far, this one included
    values: dict[str, float]  # parameter name -> value in its key's unit
    nll: float  # the logs' summed negative log-likelihood there [-]
    best_nll: float  # the smallest objective so far (the likelihood's and the still stretch's terms) [-]
    phase: str  # "scan", "search" or "curvature"


@dataclass(frozen=True)
class TuningResult:
    """What :func:`tune` found."""

    parameters: tuple[str, ...]  # the names tuned, in order
    start: dict[str, float]  # name -> where the search started, in its key's unit
    start_from: dict[str, str]  # name -> where that start came from ("configuration", "Allan deviation ...")
    priors: dict[str, tuple[float, float]]  # name -> (mean, 1-sigma) of the Gaussian prior term in ln(value):
    #                                         a still stretch's measurement, or the configured value's
    #                                         weak one (CONFIG_PRIOR_SIGMA_LN)
    tuned: dict[str, float]  # name -> the value found (SIGNIFICANT_DIGITS digits), in its key's unit
    sigma_ln: dict[str, float]  # name -> 1-sigma of ln(value) from the curvature (inf: the likelihood is flat
    #                             along it; NaN: not computed, at a bound or stopped)
    at_bound: dict[str, bool]  # name -> the value found lies on a bound (within 1 %)
    nll_start: float  # the logs' negative log-likelihood at the start [-]
    nll_tuned: float  # at the tuned values [-]
    evaluations: int  # replays of the logs' batch the search and the curvature took
    stopped: bool  # should_stop ended the search: ``tuned`` is the best point so far
    converged: bool  # the optimiser says it converged
    minimum: bool  # no direction of negative curvature at the values found (False: not a minimum, the
    #               search stopped short; True also when the curvature was not computed)
    message: str  # the optimiser's own word

    def determined(self, name: str) -> bool:
        """Whether the logs determine parameter ``name``: its 1-sigma factor is at most
        :data:`UNDETERMINED_FACTOR` and it does not lie on a bound."""
        s = self.sigma_ln[name]
        return bool(np.isfinite(s) and math.exp(s) <= UNDETERMINED_FACTOR and not self.at_bound[name])


class _Stopped(Exception):
    """should_stop asked the search to end."""


class _Exhausted(Exception):
    """The search used its evaluations."""


@dataclass(frozen=True)
class Start:
    """Where the search starts, and what a still stretch measured."""

    values: dict[str, float]  # name -> start value in its key's unit
    source: dict[str, str]  # name -> where it came from ("configuration", "Allan deviation of ...")
    priors: dict[str, tuple[float, float]]  # name -> (ln value, 1-sigma of ln) a still stretch measured
    still: StillStretch | None  # the still stretch used, None: none


def start_values(cases: Sequence[TuningLog], names: Sequence[str]) -> Start:
    """Where the search starts: the first log's configuration, and the IMU's white noises from
    the Allan deviation of the longest still stretch among the logs (one of at least
    tauvcore.eval.tuning.allan.MIN_STILL_S), which :func:`tune` also takes as a measurement of them.

    The still stretch measures the IMU's white noise directly, the innovations only through the
    filter's prediction of the next aiding update (between two DVL pings the accelerometer's white
    noise adds ``N^2 dt`` to a velocity whose ping noise is a thousand times that), so the
    stretch's value, with its own 1-sigma (tauvcore.eval.tuning.allan.sigma_ln), joins the likelihood as
    a Gaussian term in ``ln theta``: the search finds the values both data say.

    Parameters
    ----------
    cases : Sequence[TuningLog]
        The logs.
    names : Sequence[str]
        The parameters tuned.

    Returns
    -------
    Start
        The start values, where each came from, the still stretch's measurements (as priors) and
        the stretch.
    """
    values = parameter_values(cases[0].config, names)
    where = dict.fromkeys(names, "configuration")
    if not {"gyro_noise", "accel_noise"} & set(names):
        return Start(values, where, {}, None)
    best: tuple[StillStretch, str] | None = None
    for case in cases:
        still = still_noise(case.log.dtheta_b, case.log.dv_b, case.log.dt_s)
        if still is not None and (best is None or still.duration_s > best[0].duration_s):
            best = (still, case.name)
    if best is None:
        return Start(values, where, {}, None)
    still, name = best
    measured = {
        "gyro_noise": (still.gyro_noise_deg_per_sqrt_h, still.gyro_sigma_ln),
        "accel_noise": (still.accel_noise_mps_per_sqrt_h, still.accel_sigma_ln),
    }
    priors = {}
    for n, (value, sigma) in measured.items():
        if n in values:
            low, high = PARAMETERS[n].bounds
            values[n] = float(np.clip(value, low, high))
            priors[n] = (math.log(values[n]), sigma)
            where[n] = f"Allan deviation of {name}'s still stretch {still.start_s:g}-{still.end_s:g} s"
    return Start(values, where, priors, still)


def _round(value: float) -> float:
    return float(f"{value:.{SIGNIFICANT_DIGITS}g}")


def tune(
    prepared: Sequence[PreparedLog],
    names: Sequence[str] = DEFAULT_PARAMETERS,
    start: Start | None = None,
    optimizer: str = "l-bfgs-b",
    max_evaluations: int = MAX_EVALUATIONS,
    evaluator: Evaluator | None = None,
    progress: Callable[[Evaluation], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    curvature: bool = True,
    scan: bool = True,
) -> TuningResult:
    """The parameters ``names`` that minimise the logs' summed negative log-likelihood of the
    innovations (module docstring), and their uncertainty.

    Parameters
    ----------
    prepared : Sequence[PreparedLog]
        The logs, each with its configuration (one 20-state method), made ready.
    names : Sequence[str]
        Keys of :data:`PARAMETERS`, each at most once.
    start : Start or None
        Where the search starts (values clipped into the bounds) and the still stretch's
        measurements, each a Gaussian term ``((ln theta - mu) / sigma)^2 / 2`` added to the
        objective; None: :func:`start_values`.
    optimizer : str
        One of :data:`OPTIMIZERS`: ``"l-bfgs-b"`` (a forward-difference gradient of
        :data:`GRADIENT_STEP_LN`, its points one batch) or ``"nelder-mead"``.
    max_evaluations : int
        Most evaluations of the likelihood the scan and the search make (each a replay of every
        log), at least 1; the curvature's come on top.
    evaluator : Evaluator or None
        How a batch of points is evaluated (:func:`~tauvcore.eval.tuning.likelihood.dask_evaluator`); None:
        :func:`~tauvcore.eval.tuning.likelihood.serial_evaluator`.
    progress : Callable[[Evaluation], None] or None
        Called after each evaluation.
    should_stop : Callable[[], bool] or None
        Polled before each batch of evaluations; True ends the search, the best point so far
        returned (:attr:`TuningResult.stopped`, no curvature).
    scan : bool
        Before the search, scan each parameter in turn over its bounds a decade at a time
        (:func:`_scan`), the search starting from the best point; False: from the start.
    curvature : bool
        Also the Hessian of the likelihood in ``ln theta`` at the optimum by central differences of
        :data:`CURVATURE_STEP_LN` (``2 n^2 + 1`` evaluations less the shared ones), hence each
        parameter's 1-sigma; False: ``sigma_ln`` NaN.

    Returns
    -------
    TuningResult
        The start, the values found (rounded to :data:`SIGNIFICANT_DIGITS` digits), their
        uncertainty and the likelihood at both.

    Raises
    ------
    ValueError
        No log, an unknown or repeated parameter, an unknown optimiser, or ``max_evaluations``
        below 1.
    """
    names = _checked(prepared, names, optimizer, max_evaluations)
    if start is None:
        start = start_values([p.case for p in prepared], names)
    limits = np.array([PARAMETERS[n].bounds for n in names])
    bounds = np.log(limits)
    start_map = dict(
        zip(names, np.clip([start.values[n] for n in names], limits[:, 0], limits[:, 1]).tolist())
    )
    x0 = np.log([start_map[n] for n in names])
    priors = {n: start.priors.get(n, (float(x0[i]), CONFIG_PRIOR_SIGMA_LN)) for i, n in enumerate(names)}
    search = _Search(
        names,
        limits,
        prior_mu=np.array([priors[n][0] for n in names]),
        prior_sigma=np.array([priors[n][1] for n in names]),
        evaluate=evaluator if evaluator is not None else serial_evaluator(prepared),
        spread=evaluator is not None,
        max_evaluations=max_evaluations,
        progress=progress,
        should_stop=should_stop,
        best_x=x0.copy(),
    )
    stopped, converged, message = False, False, ""
    nll_start = math.nan
    try:
        nll_start = search.batch([x0])[0]
        if not np.isfinite(nll_start):
            raise ValueError(
                "the likelihood is not finite at the start (an update's innovation covariance is unusable): "
                + ", ".join(f"{n} = {v:g}" for n, v in start_map.items())
            )
        if scan:  # not the values a still stretch measured: its term keeps them within percent
            x0 = _scan(search.objective, x0, bounds, search.prior_sigma >= CONFIG_PRIOR_SIGMA_LN)
        search.phase = "search"
        converged, message = _minimise(search, x0, bounds, optimizer, nll_start)
    except _Stopped:
        stopped = True
        message = "stopped"
    except _Exhausted:
        message = f"used its {max_evaluations} evaluations"
    tuned = {n: _round(v) for n, v in search.values_at(search.best_x).items()}
    x_tuned = np.log(np.array([tuned[n] for n in names]))
    at_bound = {
        n: bool(x_tuned[i] <= bounds[i, 0] + 0.01 or x_tuned[i] >= bounds[i, 1] - 0.01)
        for i, n in enumerate(names)
    }
    free = [i for i, n in enumerate(names) if not at_bound[n]] if curvature and not stopped else []
    nll_tuned, sigma, minimum, stopped_there = _at_tuned(search, x_tuned, free)
    return TuningResult(
        parameters=names,
        start=start_map,
        start_from={n: start.source.get(n, "given") for n in names},
        priors=priors,
        tuned=tuned,
        sigma_ln=sigma,
        at_bound=at_bound,
        nll_start=nll_start,
        nll_tuned=nll_tuned,
        evaluations=search.count,
        stopped=stopped or stopped_there,
        converged=converged,
        minimum=minimum,
        message=message,
    )


def _checked(
    prepared: Sequence[PreparedLog], names: Sequence[str], optimizer: str, max_evaluations: int
) -> tuple[str, ...]:
    """``names`` as a tuple, once :func:`tune`'s arguments pass its checks (its Raises)."""
    if not prepared:
        raise ValueError("tuning needs at least one log")
    names = tuple(names)
    unknown = [n for n in names if n not in PARAMETERS]
    if unknown or len(set(names)) != len(names) or not names:
        raise ValueError(
            f"parameters must be distinct names from {', '.join(PARAMETERS)}, got {', '.join(names) or 'none'}"
        )
    if optimizer not in OPTIMIZERS:
        raise ValueError(f"optimizer must be one of {', '.join(OPTIMIZERS)}, got {optimizer!r}")
    if max_evaluations < 1:
        raise ValueError(f"max_evaluations must be at least 1, got {max_evaluations}")
    return names


@dataclass
class _Search:
    """:func:`tune`'s evaluations at points ``x`` in ``ln theta``: counted, cached, the best so far
    kept, each handed to ``progress``."""

    names: tuple[str, ...]  # the parameters, in the order of x
    limits: np.ndarray  # (n, 2) their bounds, each in its key's unit
    prior_mu: np.ndarray  # (n,) mean of each parameter's Gaussian prior term [ln of its unit]
    prior_sigma: np.ndarray  # (n,) its 1-sigma [-]
    evaluate: Evaluator  # the logs' negative log-likelihood at a batch of values
    spread: bool  # the evaluator was given: it spreads a batch over its workers
    max_evaluations: int  # most evaluations outside the curvature's
    progress: Callable[[Evaluation], None] | None
    should_stop: Callable[[], bool] | None
    best_x: np.ndarray  # (n,) the best point so far (the start before any)
    best: float = math.inf  # the objective there [-]
    count: int = 0  # evaluations so far
    phase: str = "scan"  # "scan", "search" or "curvature" (Evaluation.phase)
    cache: dict[bytes, float] = field(default_factory=dict)  # x.tobytes() -> the logs' likelihood

    def values_at(self, x: np.ndarray) -> dict[str, float]:
        return dict(zip(self.names, np.clip(np.exp(x), self.limits[:, 0], self.limits[:, 1]).tolist()))

    def prior(self, x: np.ndarray) -> float:
        return float(0.5 * np.sum(((x - self.prior_mu) / self.prior_sigma) ** 2))

    def batch(self, xs: list[np.ndarray]) -> list[float]:
        """The logs' negative log-likelihood at each point (cached: a point the search revisits
        costs nothing)."""
        todo = [x for x in xs if x.tobytes() not in self.cache]
        if todo and self.phase != "curvature" and self.count + len(todo) > self.max_evaluations:
            raise _Exhausted
        # an evaluator spreads a batch over its workers; in this process the points go one by one,
        # so that a stop request waits for one replay, not a whole scan's
        for part in [todo] if self.spread else [[x] for x in todo]:
            if self.should_stop is not None and self.should_stop():
                raise _Stopped
            for x, f in zip(part, self.evaluate([self.values_at(x) for x in part])):
                f = f if np.isfinite(f) else math.inf
                self.cache[x.tobytes()] = f
                self.count += 1
                if f + self.prior(x) < self.best and self.phase != "curvature":
                    self.best, self.best_x = f + self.prior(x), x.copy()
                if self.progress is not None:
                    self.progress(Evaluation(self.count, self.values_at(x), f, self.best, self.phase))
        return [self.cache[x.tobytes()] for x in xs]

    def objective(self, xs: list[np.ndarray]) -> list[float]:
        """What the search minimises: the likelihood's and the still stretch's terms."""
        return [f + self.prior(x) for f, x in zip(self.batch(xs), xs)]


def _minimise(
    search: _Search, x0: np.ndarray, bounds: np.ndarray, optimizer: str, nll_start: float
) -> tuple[bool, str]:
    """scipy's ``optimizer`` from ``x0`` within ``bounds`` (ln theta), stopping as :data:`STOP_GAIN`
    says (relative to ``nll_start`` for L-BFGS-B); whether it converged and its message."""
    from scipy.optimize import minimize

    # each parameter in units of its own 1-sigma there (the diagonal curvature, at least its
    # prior's): the likelihood's curvatures span thousands, and a search in ln theta would stop on
    # the steep ones' progress while a flat one still has half a unit to gain
    objective = search.objective
    scale = _diagonal_scale(objective, x0, bounds, search.prior_sigma)
    z_bounds = (bounds - x0[:, None]) * scale[:, None]

    def x_of(z: np.ndarray) -> np.ndarray:
        return np.clip(x0 + np.asarray(z, dtype=float) / scale, bounds[:, 0], bounds[:, 1])

    if optimizer == "l-bfgs-b":

        def fun_and_grad(z: np.ndarray) -> tuple[float, np.ndarray]:
            x = x_of(z)
            steps = [
                np.where(
                    np.arange(x.size) == i,
                    x + (GRADIENT_STEP_LN if x[i] < bounds[i, 1] - 1e-12 else -GRADIENT_STEP_LN),
                    x,
                )
                for i in range(x.size)
            ]
            f, *fs = objective([x, *steps])
            if not np.isfinite(f):
                return math.inf, np.zeros_like(x)
            h = np.array([s[i] - x[i] for i, s in enumerate(steps)])
            g = (np.array(fs) - f) / h / scale
            return f, np.where(np.isfinite(g), g, 0.0)

        res = minimize(
            fun_and_grad,
            np.zeros_like(x0),
            jac=True,
            method="L-BFGS-B",
            bounds=z_bounds,
            options={
                "ftol": STOP_GAIN / max(abs(nll_start), 1.0),
                "gtol": STOP_GAIN,
                "maxfun": search.max_evaluations,
            },
        )
    else:
        simplex = [np.zeros_like(x0)]  # a step of 1 sigma along each parameter, within its bounds
        for i in range(x0.size):
            step = 1.0 if z_bounds[i, 1] >= 1.0 else -1.0
            simplex.append(step * (np.arange(x0.size) == i))
        res = minimize(
            lambda z: objective([x_of(z)])[0],
            np.zeros_like(x0),
            method="Nelder-Mead",
            bounds=z_bounds,
            options={
                "initial_simplex": np.array(simplex),
                "xatol": STOP_GAIN,  # a hundredth of each parameter's 1-sigma
                "fatol": STOP_GAIN,
                "maxfev": search.max_evaluations,
            },
        )
    return bool(res.success), str(res.message)


def _at_tuned(search: _Search, x: np.ndarray, free: list[int]) -> tuple[float, dict[str, float], bool, bool]:
    """At the tuned point ``x``: the logs' negative log-likelihood, each parameter's 1-sigma of
    ``ln theta`` from the curvature (:func:`_curvature_variances`, those of ``free``; NaN the
    others), whether ``x`` is a minimum, and whether should_stop ended it."""
    sigma = dict.fromkeys(search.names, math.nan)
    search.phase = "curvature"
    nll, minimum = math.nan, True
    try:
        nll = search.batch([x])[0]
        if free:
            variances, minimum = _curvature_variances(search.objective, x, free)
            for j, var in zip(free, variances):
                sigma[search.names[j]] = float(math.sqrt(var))
    except _Stopped:
        return nll, sigma, minimum, True
    return nll, sigma, minimum, False


def _scan(
    objective: Callable[[list[np.ndarray]], list[float]],
    x0: np.ndarray,
    bounds: np.ndarray,
    which: np.ndarray,
) -> np.ndarray:
    """The best point of a coarse scan from ``x0``: each parameter of ``which`` (bool per
    parameter) in turn over the decades of its bounds (``x_i + k ln 10`` within them, the others
    at the best so far), one batch each.

    The likelihood of a filter far from its data can be flat over decades of a parameter (a
    navigation-grade gyro's noise under unmodelled errors that want a tactical grade's: every
    value below a point leaves the same over-confident filter), where a local search from the
    configured value stops; a decade's step crosses such a plateau. ``1 + sum_i (decades_i)``
    evaluations."""
    best = x0.copy()
    f_best = objective([best])[0]
    for i in np.flatnonzero(which):
        ks = np.arange(
            -math.floor((best[i] - bounds[i, 0]) / LN10), math.floor((bounds[i, 1] - best[i]) / LN10) + 1
        )
        points = [np.where(np.arange(best.size) == i, best[i] + k * LN10, best) for k in ks if k != 0]
        if not points:
            continue
        values = objective(points)
        j = int(np.argmin(values))
        if values[j] < f_best:
            best, f_best = points[j], values[j]
    return best


LN10 = math.log(10.0)


def _diagonal_scale(
    objective: Callable[[list[np.ndarray]], list[float]],
    x: np.ndarray,
    bounds: np.ndarray,
    prior_sigma: np.ndarray,
) -> np.ndarray:
    """Each parameter's curvature scale at ``x``: ``sqrt`` of the objective's second difference of
    :data:`CURVATURE_STEP_LN` along it (one batch of ``2 n`` points, each inside the bounds), at least
    its prior term's ``1 / sigma``, so one unit of the scaled parameter is about its 1-sigma."""
    h = CURVATURE_STEP_LN
    n = x.size
    lo = np.maximum(x - h, bounds[:, 0])
    hi = np.minimum(x + h, bounds[:, 1])
    points = [np.where(np.arange(n) == i, v, x) for i in range(n) for v in (lo[i], hi[i])]
    f0 = objective([x])[0]
    f = np.array(objective(points)).reshape(n, 2)
    a, b = x - lo, hi - x  # an uneven second difference where a bound cuts one side
    with np.errstate(invalid="ignore", divide="ignore"):
        second = 2.0 * (b * f[:, 0] + a * f[:, 1] - (a + b) * f0) / (a * b * (a + b))
    curvature = np.where(np.isfinite(second), second, 0.0)
    return np.sqrt(np.maximum(curvature, 1.0 / prior_sigma**2))


CURVATURE_FLOOR = 1e-6
"""Smallest eigenvalue of the Hessian in ``ln theta`` taken as curvature: along a flatter direction
the likelihood says nothing, and every parameter that direction moves is undetermined (inf)."""


def _curvature_variances(
    batch: Callable[[list[np.ndarray]], list[float]], x: np.ndarray, free: list[int]
) -> tuple[np.ndarray, bool]:
    """The variances of ``ln theta`` of the parameters ``free`` at ``x``: the diagonal of the inverse
    of the objective's Hessian there, by central differences of :data:`CURVATURE_STEP_LN`; inf for a
    parameter moved by a direction of curvature below :data:`CURVATURE_FLOOR`. And whether ``x``
    is a minimum: no curvature below ``-CURVATURE_FLOOR``."""
    n, h = len(free), CURVATURE_STEP_LN

    def at(*moves: tuple[int, float]) -> np.ndarray:
        y = x.copy()
        for i, d in moves:
            y[free[i]] += d
        return y

    points = [x]
    for i in range(n):
        points += [at((i, h)), at((i, -h))]
    for i in range(n):
        for j in range(i + 1, n):
            points += [at((i, h), (j, h)), at((i, h), (j, -h)), at((i, -h), (j, h)), at((i, -h), (j, -h))]
    f = batch(points)
    H = np.zeros((n, n))
    for i in range(n):
        H[i, i] = (f[1 + 2 * i] + f[2 + 2 * i] - 2.0 * f[0]) / h**2
    k = 1 + 2 * n
    for i in range(n):
        for j in range(i + 1, n):
            pp, pm, mp, mm = f[k : k + 4]
            H[i, j] = H[j, i] = (pp - pm - mp + mm) / (4.0 * h**2)
            k += 4
    if not np.all(np.isfinite(H)):
        return np.full(n, math.inf), False
    lam, V = np.linalg.eigh(H)
    flat = lam <= CURVATURE_FLOOR
    var = (V[:, ~flat] ** 2) @ (1.0 / lam[~flat])
    return np.where(np.any(np.abs(V[:, flat]) > 1e-3, axis=1), math.inf, var), bool(
        np.all(lam >= -CURVATURE_FLOOR)
    )


def tuned_sections(result: TuningResult) -> dict[str, dict[str, float]]:
    """The tuned values as configuration sections (section -> key -> value, in the keys' units),
    for a TOML file.

    Parameters
    ----------
    result : TuningResult
        What :func:`tune` found.

    Returns
    -------
    dict[str, dict[str, float]]
        Each tuned parameter's value under its section and key.
    """
    out: dict[str, dict[str, float]] = {}
    for name, value in result.tuned.items():
        p = PARAMETERS[name]
        out.setdefault(p.section, {})[p.key] = value
    return out
