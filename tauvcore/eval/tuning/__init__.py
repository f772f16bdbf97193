"""The filters' noise from the data: the parameters that maximise the likelihood of the innovations
(the prediction-error method).

A Kalman filter whose model is right produces innovations ``nu_k`` that are independent, Gaussian,
zero mean, with the covariance the filter predicts, ``S_k = H_k P_k^- H_k^T + R_k``. The negative
log-likelihood of a set of noise parameters ``theta`` given a log is then that of the innovations of
the filter run with ``theta`` (Schweppe 1965; Mehra 1970; Ljung's prediction-error method)::

    L(theta) = 1/2 sum_k ( nu_k^T S_k^-1 nu_k + log det S_k + m_k log 2 pi )

summed over every update of every aiding source (``m_k`` rows), each log's sum added for several
logs. The NIS term alone would reward a large ``S`` and ``log det S`` alone a small one; their sum is
smallest where ``S`` matches the innovations' spread. The update records carry both
(tauvcore.engine.results.UpdateRecord ``nis`` and ``log_det_s``, over the active rows, before the
gate).

Each evaluation is a replay of the log (tauvcore.eval.replay, the compiled filter bank) with
``theta`` laid over the configuration, with two changes: the innovation gate is opened
(``filter.gate_sigma`` at its largest, :data:`~tauvcore.eval.tuning.likelihood.TUNING_GATE_SIGMA`) and the lock-out reset is off
(``filter.lockout_reset_updates`` 0). With a gate, the set of updates fused would change with
``theta`` (the objective would jump where an update crosses the gate) and a small ``S`` would
reject the updates that contradict it and be judged on the others. With the gate open every
valid update is fused and counts, and the likelihood is a smooth function of ``theta``. The
tuned values are then replayed with the gate as configured (the "after" of the CLI's table).

What is minimised is ``L`` plus a Gaussian term in ``ln theta`` per parameter (a maximum a
posteriori estimate): where a log holds a still stretch, the IMU's white noises its Allan
deviation measures, with that measurement's 1-sigma (:func:`~tauvcore.eval.tuning.search.start_values`); every other parameter
a weak prior at its configured value, a factor of ten at 1 sigma (:data:`~tauvcore.eval.tuning.search.CONFIG_PRIOR_SIGMA_LN`).
Where the innovations determine a parameter, their curvature is hundreds to thousands of times the
weak prior's and it moves the estimate by well under a percent; where they do not (the
accelerometer's white noise beside a DVL's ping noise, a gyro's bias walk over 400 s: their
likelihood is flat over decades), the prior keeps the configured value instead of a bound the
search would drift to.

The parameters (:data:`~tauvcore.eval.tuning.parameters.PARAMETERS`) are searched in log space within bounds (from six decades
below the largest value the configuration accepts, or the floor the filter puts under it, up to
that largest) by scipy's L-BFGS-B with a
forward-difference gradient, or Nelder-Mead. The uncertainty of each is the curvature of the
objective at the optimum: it is a negative log-posterior, so the inverse of its Hessian in
``ln theta`` is the covariance of the estimate (Laplace's approximation); a parameter whose 1-sigma
factor is large (near the weak prior's ten) is not observable in these logs.
"""

from tauvcore.eval.tuning.likelihood import (
    TUNING_GATE_SIGMA,
    Evaluator,
    PreparedLog,
    SourceLikelihood,
    TuningLog,
    dask_evaluator,
    negative_log_likelihood,
    serial_evaluator,
    source_likelihoods,
    tuning_config,
)
from tauvcore.eval.tuning.parameters import (
    BOUND_DECADES,
    DEFAULT_PARAMETERS,
    PARAMETERS,
    Parameter,
    parameter_values,
    with_values,
)
from tauvcore.eval.tuning.search import (
    CONFIG_PRIOR_SIGMA_LN,
    CURVATURE_STEP_LN,
    GRADIENT_STEP_LN,
    MAX_EVALUATIONS,
    OPTIMIZERS,
    SIGNIFICANT_DIGITS,
    STOP_GAIN,
    UNDETERMINED_FACTOR,
    Evaluation,
    Start,
    TuningResult,
    start_values,
    tune,
    tuned_sections,
)

__all__ = [
    "BOUND_DECADES",
    "CONFIG_PRIOR_SIGMA_LN",
    "CURVATURE_STEP_LN",
    "DEFAULT_PARAMETERS",
    "GRADIENT_STEP_LN",
    "MAX_EVALUATIONS",
    "OPTIMIZERS",
    "PARAMETERS",
    "SIGNIFICANT_DIGITS",
    "STOP_GAIN",
    "TUNING_GATE_SIGMA",
    "UNDETERMINED_FACTOR",
    "Evaluation",
    "Evaluator",
    "Parameter",
    "PreparedLog",
    "SourceLikelihood",
    "Start",
    "TuningLog",
    "TuningResult",
    "dask_evaluator",
    "negative_log_likelihood",
    "parameter_values",
    "serial_evaluator",
    "source_likelihoods",
    "start_values",
    "tune",
    "tuned_sections",
    "tuning_config",
    "with_values",
]
