"""What a filter family declares (tauvcore.filter.families: the registry of them)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import numpy as np

    from tauvcore.filter.eskf import Nominal

Remeasure = Callable[["Nominal"], "np.ndarray"]
"""A measurement's innovation ``z (-) h(x)`` at other nominal states than the estimate: given a
nominal state of batch (B', R) (R the runs, B' any number of states per run), the innovations
(B', R, m) in the measurement's SI unit. The bank hands one to a statistical linearisation with
each correction (:class:`Linearize`)."""


class Linearize(Protocol):
    """How a family linearises a measurement for the bank's one gated Joseph correction
    (tauvcore.filter.eskf.fuse_in_place): from the Jacobian ``H`` at the estimate, the noise ``R``,
    the innovation ``nu`` and the measurement itself (``remeasure``), the ``(H, R, nu)`` its filters
    are corrected with. A Kalman update with them is the family's update (for the unscented filter
    of tauvcore.filter.families.ukf: its statistical linearisation, with which the Joseph form is
    the unscented update)."""

    def __call__(
        self,
        P: np.ndarray,
        nominal: Nominal,
        remeasure: Remeasure,
        measurement: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
        geodetic: bool,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The measurement as the family's filters fuse it.

        Parameters
        ----------
        P : numpy.ndarray
            The family's filters' error-state covariances, shape (Mu, R, d, d), in the states' SI
            units squared.
        nominal : Nominal
            Their estimates, batch (Mu, R).
        remeasure : Remeasure
            The innovation at other nominal states.
        measurement : tuple of numpy.ndarray
            ``(H, R, nu, active)`` at the estimate: Jacobians (Mu, R, m, d), noise covariances
            (Mu, R, m, m), innovations (Mu, R, m) in the measurement's SI unit, the rows in use
            (Mu, R, m) bool.
        geodetic : bool
            Positions are latitude, longitude, depth (tauvcore.filter.eskf.inject).

        Returns
        -------
        tuple of numpy.ndarray
            ``(H, R, nu)`` of the shapes given, the rows not in use as given.
        """
        ...


@dataclass(frozen=True)
class Family:
    """What the rest of the lab knows of a filter family.

    Attributes
    ----------
    name : str
        Its folder's name under tauvcore/filter/families.
    title : str
        How tables and notes name it, e.g. "Yoo 2014's 12-state filter".
    methods : tuple[str, ...]
        The methods it runs, as ``run.methods`` and ``--method`` name them.
    in_all : bool
        Whether ``--method all`` runs its methods (the first paper's study: only the 20-state's).
    block_dims : dict[str, int]
        Degrees of freedom of every NEES its results carry: ``"full"`` and each block
        (tauvcore.filter.layout.NEES_BLOCKS' names); the states the aiding sources add are added
        by the engine.
    position_state : bool
        Whether it estimates position; without, its position NEES is NaN throughout and tables
        leave the column empty.
    sensor_blocks : tuple[str, ...]
        The error-state blocks of the sensor errors it estimates, in state order (the columns of
        ``MethodResult.sensor_est``: tauvcore.engine.results.sensor_states).
    log_det : bool
        Whether its update records carry ``log det S``, which the likelihood of ``tauv tune``
        needs (tauvcore.eval.tuning).
    error_state : str
        The error state and process model its filters run on, and so the engine's bank that runs
        them: ``"eskf"`` the 20-state layout (tauvcore.filter.layout.STATE, with the states the
        aiding sources add) propagated by tauvcore.filter.kernels.error_model_kernels; ``"yoo"`` the
        12-state filter of tauvcore.filter.families.yoo.model. Families on one error state share one bank.
    dvl_fusion : dict[str, str or None]
        How each of its methods fuses the DVL on the ``"eskf"`` bank: ``"lc"`` the loosely coupled
        velocity (3-4 beams), ``"tc"`` one row per beam, ``"elc"`` an extended method's
        construction (tauvcore.aiding.dvl_extended), None not at all. Empty on the ``"yoo"`` bank,
        which fuses the DVL's velocity itself.
    linearize : Linearize or None
        How its corrections linearise a measurement: None the Jacobian at the estimate (the
        extended Kalman filter); else the family's own (:class:`Linearize`), given every
        measurement the bank fuses.
    """

    name: str
    title: str
    methods: tuple[str, ...]
    in_all: bool
    block_dims: dict[str, int]
    position_state: bool
    sensor_blocks: tuple[str, ...]
    log_det: bool
    error_state: str
    dvl_fusion: dict[str, str | None] = field(default_factory=dict)
    linearize: Linearize | None = None
