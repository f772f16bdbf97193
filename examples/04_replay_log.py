"""Replay of a log: a simulated mission written as a log directory, read back and replayed.

Shows the path your own data takes (docs/replay.md): a log is a
directory of tables (``imu``, ``reference``, optional ``dvl``, ``depth``, ``attitude``; CSV or
Parquet, one clock ``t_s``). Here the log is made as ``tauv run --save-log DIR`` makes it:
:func:`~tauvcore.engine.mission.run_streaming` hands every chunk of the simulation to
``on_sim_chunk``, :func:`tauvcore.logs.writer.simulation_tables` turns run 0 into tables and
:func:`tauvcore.logs.writer.write_log` writes them. :func:`tauvcore.logs.read_log` reads and checks the
directory, and :func:`tauvcore.eval.replay.replay` runs the methods on it exactly as on a
simulation (what ``tauv replay DIR --initial-errors`` does: the filters start off the reference
by the simulation's initial errors), so the replayed errors equal the simulated ones.
Replace the written directory with your own log to navigate on real data.

Run::

    .venv/bin/python examples/04_replay_log.py [--duration 60] [--out DIR] [--log-format csv|parquet]
"""

from __future__ import annotations

import numpy as np
from _common import error_table, finite, out_dir, parser

from tauvcore.config import Config
from tauvcore.engine.mission import Sinks, run_streaming
from tauvcore.engine.simulation import SimChunk
from tauvcore.eval.replay import replay
from tauvcore.logs import read_log
from tauvcore.logs.writer import simulation_tables, write_log

METHODS = ("ins", "lc", "tc", "elc")


def main() -> None:
    p = parser(__doc__, duration_s=60.0, short_duration_s=10.0)
    p.add_argument("--log-format", choices=("csv", "parquet"), default="csv")
    args = p.parse_args()
    config = (
        Config()
        .replace("trajectory", name="lawnmower", duration_s=args.duration)
        .replace("run", methods=METHODS, aiding=("dvl", "depth"), seed=5)
    )

    chunks: list[SimChunk] = []
    simulated = run_streaming(
        config, np.random.default_rng(config.run.seed), sinks=Sinks(on_sim_chunk=chunks.append)
    )
    directory = out_dir(args.out, "tauv-example-04-") / "log"
    write_log(directory, simulation_tables(chunks), args.log_format)
    print(
        f"wrote a {args.duration:g} s log to {directory}: {', '.join(sorted(f.name for f in directory.iterdir()))}"
    )

    log = read_log(directory)
    for note in log.notes:
        print(f"note: {note}")
    # the simulation's filters started off the truth by the initial errors: so do the replay's
    offset = config.replace("replay", initial_errors=True)
    _, replayed = replay(offset, log, np.random.default_rng(config.run.seed))
    print(f"\nreplayed {log.duration_s:g} s at {1.0 / log.dt_s:g} Hz\n")
    # a log has no true sensor errors, so the full NEES is NaN; position and attitude have a reference
    print(error_table(replayed, block="pos"))
    worst = max(float(np.nanmax(np.abs(replayed[m].pos_err_m - simulated[m].pos_err_m))) for m in METHODS)
    print(f"\nlargest difference from the simulated run's position error: {worst:.2e} m")
    if not (finite(replayed) and worst < 1e-6):
        raise SystemExit("the replay does not reproduce the simulation")


if __name__ == "__main__":
    main()
