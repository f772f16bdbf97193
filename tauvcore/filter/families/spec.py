"""What a filter family declares (tauvcore.filter.families: the registry of them)."""

from __future__ import annotations

from dataclasses import dataclass


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
    """

    name: str
    title: str
    methods: tuple[str, ...]
    in_all: bool
    block_dims: dict[str, int]
    position_state: bool
    sensor_blocks: tuple[str, ...]
    log_det: bool
