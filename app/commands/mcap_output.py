"""``tauv run --mcap FILE`` and ``tauv replay --mcap FILE``: the results written as MCAP as the run
goes (app.reports.mcap_export.McapResults), the file checked before the run as ``--json``'s is
(app.commands.outputs.output_target) and renamed into place only when the run succeeded.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from app.commands.outputs import Inputs, output_target
from app.commands.values import UsageError
from tauvcore.config import Config
from tauvcore.validation import show_path

if TYPE_CHECKING:
    from tauvcore.engine.simulation import ChunkSource
    from tauvcore.sensors.imu import ImuData
    from tauvcore.truth import Truth


def mcap_target(args: argparse.Namespace, inputs: Inputs) -> str | None:
    """The real path ``--mcap`` will replace, checked before the run (the rules of ``--json``:
    app.commands.outputs.output_target), or None without ``--mcap``. It may be none of
    ``inputs`` nor the ``--json`` file."""
    if args.mcap is None:
        return None
    return output_target("--mcap", args.mcap, [*inputs, ("the --json file", args.json)])


class McapOutput:
    """The ``--mcap`` file of one command: the writer and one line for any failure to write it.

    Parameters
    ----------
    path : str
        The output, checked (:func:`mcap_target`).
    arg : str
        ``--mcap`` as given, for the messages.
    config : Config
        The run's configuration.
    origin_s : float
        The stamps' origin: 0 for a simulation, a log's first IMU time [s].
    """

    def __init__(self, path: str, arg: str, config: Config, origin_s: float = 0.0) -> None:
        from app.reports.mcap_export import McapResults

        self.name = show_path(str(arg))
        self.config = config
        self.writer = self._writing(McapResults, path, config, origin_s)

    def _writing(self, write: Callable[..., Any], *args: Any) -> Any:
        try:
            return write(*args)
        except OSError as exc:
            raise UsageError(f"--mcap: cannot write {self.name}: {exc.strerror or exc}") from None

    def add(self, results: Any) -> None:
        """One chunk of results (the engine's ``on_chunk``)."""
        self._writing(self.writer.add, results)

    def add_smoothed(self, results: Any) -> None:
        """One chunk of smoothed results (the engine's ``on_smoothed_chunk``)."""
        self._writing(self.writer.add_smoothed, results)

    def add_truth(self, truth: Any, k0: int) -> None:
        """The truth of one chunk of IMU samples from sample ``k0``."""
        self._writing(self.writer.add_truth, truth, k0)

    def add_sim_chunk(self, chunk: Any) -> None:
        """The truth of one simulation chunk (the engine's ``on_sim_chunk``)."""
        self.add_truth(chunk.truth, chunk.k0)

    def finish(self) -> None:
        """Close the file and rename it over the output (nothing left on failure)."""
        self._writing(self.writer.finish)

    def discard(self) -> None:
        """The run failed: the temporary files go, the output untouched."""
        self.writer.discard()


def chained(*calls: Callable[[Any], None] | None) -> Callable[[Any], None] | None:
    """One callback calling each of ``calls`` that is not None, in order; None if none is."""
    present = [call for call in calls if call is not None]
    if not present:
        return None

    def call_each(value: Any) -> None:
        for call in present:
            call(value)

    return call_each


class TruthTap:
    """A chunk source (tauvcore.engine.simulation.ChunkSource) that hands each chunk's truth to
    ``on_truth(truth, k0)`` as the engine asks for its rows (a replay's reference for ``--mcap``);
    everything else is ``source``'s."""

    def __init__(self, source: ChunkSource, on_truth: Callable[[Any, int], None]) -> None:
        self.source = source
        self.on_truth = on_truth

    @property
    def num_runs(self) -> int:
        return self.source.num_runs

    @property
    def sources(self) -> Mapping[str, Any]:
        return self.source.sources

    @property
    def num_samples(self) -> int:
        return self.source.num_samples

    @property
    def dt_s(self) -> float:
        return self.source.dt_s

    def rows(self, k0: int, k1: int) -> tuple[Truth, ImuData]:
        truth, imu = self.source.rows(k0, k1)
        self.on_truth(truth, k0)
        return truth, imu
