"""``tauv mc`` and ``tauv reproduce``: seeded Monte Carlo studies computed by local worker processes
or a Dask cluster and written to an output directory all at once (app.reports.study_output), with a
progress bar on a terminal. A study that fails for a reason outside its input (a worker died, the
cluster went away) is one line and exit status 1 (:class:`StudyFailedError`); nothing is written.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from typing import Any

from app.commands.smooth_flags import smooth_options
from app.commands.values import UsageError, check_dask, parse_flag, replace_for_flag, resolve_config
from app.reports.payload import config_to_json
from app.reports.tables import study_table
from tauvcore.config import Config
from tauvcore.truth import PAPER_TRAJECTORIES
from tauvcore.validation import one_line, show, show_path

MAX_STUDY_RUNS = 100_000
"""Most runs of one ``tauv mc`` study: memory stays flat (chunks are reduced as they finish), so
the bound is time: 100,000 runs of 250 s are hours even on a cluster."""
MAX_WORKERS = 64


class StudyFailedError(Exception):
    """A study could not finish for a reason outside its input (a worker process died, the Dask
    scheduler or a worker went away); the message is the one line shown to the user."""


def _count(flag: str, text: str | None, low: int, high: int, default: int) -> int:
    if text is None:
        return default
    value = parse_flag(flag, text, int, f"a whole number from {low} to {high}")
    if not low <= value <= high:
        raise UsageError(f"{flag}: must be a whole number from {low} to {high}, got {show(text)}")
    return value


def _study_setup(args: argparse.Namespace, default_runs: int) -> tuple[int, int, str | None, Any]:
    """Runs, workers, Dask address and the output writer of a study command (holding the
    output directory's lock), every check done before anything is computed or created: the
    output directory follows the rule of every writer (tauvcore.logs.writer.output_dir; an earlier
    study of the same command replaced only with ``--replace``) and must not hold the --config file."""
    from app.reports.study_output import OutputDirError, StudyWriter

    num_runs = _count("--runs", args.runs, 1, MAX_STUDY_RUNS, default_runs)
    workers = _count("--workers", args.workers, 1, MAX_WORKERS, 1)
    if args.dask is not None and not args.dask.strip():
        raise UsageError(
            f"--dask: expected a scheduler address such as tcp://host:8786, got {show(args.dask)}"
        )
    if args.dask is not None and args.workers is not None:
        raise UsageError("--workers: not with --dask (the Dask cluster has its own workers)")
    out_dir = _checked_out(args).path
    if args.dask is not None:
        check_dask(args.dask)
    try:
        writer = StudyWriter(out_dir, name=args.out)
    except OutputDirError as exc:
        raise UsageError(f"--out: {exc}") from None
    try:
        writer.replaces = _checked_out(args).replaces  # again, now that no other tauv writes there
    except BaseException:
        writer.abort()
        raise
    return num_runs, workers, args.dask, writer


def _checked_out(args: argparse.Namespace) -> Any:
    """tauvcore.logs.writer.output_dir of ``--out`` for this command's kind of study, as one line."""
    from app.reports.study_output import MC_STUDY, REPRODUCE_STUDY
    from tauvcore.logs.writer import output_dir
    from tauvcore.validation import OutputDirError

    kind = REPRODUCE_STUDY if args.command == "reproduce" else MC_STUDY
    try:
        return output_dir(
            args.out,
            "--out",
            kind,
            replace=args.replace,
            inputs=[("the --config file", getattr(args, "config", None))],
        )
    except OutputDirError as exc:
        raise UsageError(str(exc)) from None


def cmd_mc(args: argparse.Namespace) -> int:
    """``tauv mc``: a seeded Monte Carlo study written to ``--out`` (see app.reports.study_output); with
    ``--smooth`` every run also smoothed inside its chunk, where the chunk is computed (a worker
    process, a Dask worker), and the smoothed series summed beside the filtered."""
    from app.reports.study_report import report_html
    from tauvcore.eval.study import CHUNK_RUNS, run_study

    config = resolve_config(args)
    trajectory = config.trajectory.name
    runs = _count("--runs", args.runs, 1, MAX_STUDY_RUNS, 1)
    smooth = smooth_options(args, config, runs=min(CHUNK_RUNS, runs))
    num_runs, workers, dask, writer = _study_setup(args, 1)
    started = time.perf_counter()
    with _written_or_aborted(writer):
        with _progress_bar(num_runs) as bar, _study_failures(dask):
            acc = run_study(
                config,
                num_runs,
                workers=workers,
                dask_address=dask,
                on_chunk=lambda chunk: writer.add_chunk(trajectory, chunk),
                progress=lambda done, total: bar.update(done - bar.n),
                smooth=smooth,
            )
        summary = acc.summary()
        description = (
            f"{num_runs} seeded Monte Carlo runs (seed {config.run.seed}), {config.trajectory.duration_s:g} s, "
            f"methods {', '.join(config.run.methods)}, beams {','.join(map(str, config.dvl.beams))}, "
            f"aiding {','.join(config.run.aiding) or 'none'}"
            + ("; smoothed (fixed-interval smoother)" if smooth is not None else "")
            + "; tauv mc"
        )
        writer.finish(
            {
                "config": config_to_json(config),
                "num_runs": num_runs,
                "seed": config.run.seed,
                "trajectories": {trajectory: summary},
            },
            report_html("tauv Monte Carlo study", description, {trajectory: summary}),
        )
        written = writer.commit()
    elapsed = time.perf_counter() - started
    print(study_table(summary, trajectory, num_runs, elapsed))
    _print_written(writer, written)
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    """``tauv reproduce``: Tal et al. 2017 section 4.2 (three trajectories, beams 3 and 4 lost,
    INS, TC and the ELC methods; LC with four beams as the reference), every stated figure
    beside ours with a verdict."""
    from app.reports.study_report import report_html
    from tauvcore.eval.paper import comparison_table
    from tauvcore.eval.study import ERROR_SERIES

    base = _paper_config(args)
    num_runs, workers, dask, writer = _study_setup(args, 100)
    started = time.perf_counter()
    with _written_or_aborted(writer):
        summaries = _paper_studies(base, num_runs, workers, dask, writer)
        finals = {
            name: {m: {n: s["methods"][m]["final_rms"][n] for n in ERROR_SERIES} for m in s["methods"]}
            for name, s in summaries.items()
        }
        table = comparison_table(finals)
        description = (
            f"Tal, Klein & Katz 2017, section 4.2: {num_runs} seeded runs per trajectory (seed "
            f"{base.run.seed}), {base.trajectory.duration_s:g} s, beams 3 and 4 lost (LC with all four as "
            "the reference), DVL aiding only; tauv reproduce"
        )
        writer.finish(
            {
                "config": config_to_json(base),
                "num_runs": num_runs,
                "seed": base.run.seed,
                "trajectories": summaries,
                "paper_comparison": table,
            },
            report_html("tauv reproduce: Tal, Klein & Katz 2017", description, summaries, table),
            table,
        )
        written = writer.commit()
    elapsed = time.perf_counter() - started
    print("\n\n".join(study_table(s, name, num_runs, elapsed) for name, s in summaries.items()))
    print("\nEvery figure of the paper's section 4.2 beside ours\n")
    print(table)
    print(f"\n({elapsed:.1f} s wall)")
    _print_written(writer, written)
    return 0


def _paper_config(args: argparse.Namespace) -> Config:
    """The configuration of ``tauv reproduce``'s studies: the defaults on the paper's flat earth,
    with ``--duration`` and ``--seed``."""
    # the paper's earth: a tangent plane with constant gravity (its F has a zero position column);
    # over 250 s and 500 m the round Earth changes its figures in the fourth digit at most
    base = Config().replace("earth", model="flat")
    if args.duration is not None:
        base = replace_for_flag(
            "--duration",
            base,
            "trajectory",
            duration_s=parse_flag("--duration", args.duration, float, "a number of seconds"),
        )
    if args.seed is not None:
        base = replace_for_flag(
            "--seed", base, "run", seed=parse_flag("--seed", args.seed, int, "a non-negative integer")
        )
    return base


def _paper_studies(
    base: Config, num_runs: int, workers: int, dask: str | None, writer: Any
) -> dict[str, dict[str, Any]]:
    """The paper's studies of ``base``, ``num_runs`` runs each: every trajectory with LC on all
    four beams and the other methods on beams 1 and 2, their chunks written by ``writer``; the
    summaries by trajectory, their methods in the paper's order."""
    from tauvcore.eval.paper import TWO_BEAM_METHODS
    from tauvcore.eval.study import local_pool, paper_chunk_runs, run_study, submit_chunks

    studies = [
        (name, beams, methods)
        for name in PAPER_TRAJECTORIES
        for beams, methods in (((1, 2, 3, 4), ("lc",)), ((1, 2), TWO_BEAM_METHODS))
    ]
    configs = [
        base.replace("trajectory", name=name).replace("dvl", beams=beams).replace("run", methods=methods)
        for name, beams, methods in studies
    ]
    sizes = [paper_chunk_runs(c) for c in configs]
    summaries: dict[str, dict[str, Any]] = {}
    with (
        _progress_bar(num_runs * len(studies)) as bar,
        local_pool(workers if dask is None else 1) as pool,
    ):
        # every study's chunks queued at once (they wait as files): no worker idles between studies
        with _study_failures(dask):
            queued = [
                submit_chunks(c, num_runs, base.run.seed, pool, size) if pool is not None else None
                for c, size in zip(configs, sizes, strict=True)
            ]
        for (name, _, _), config, size, submitted in zip(studies, configs, sizes, queued, strict=True):
            done_before = bar.n
            with _study_failures(dask):
                acc = run_study(
                    config,  # base's seed, as the chunks queued above
                    num_runs,
                    workers=workers,
                    dask_address=dask,
                    on_chunk=lambda chunk, name=name: writer.add_chunk(name, chunk),
                    progress=lambda done, total, b=done_before: bar.update(b + done - bar.n),
                    chunk_runs=size,
                    pool=pool,
                    submitted=submitted,
                )
            part = acc.summary()
            if name in summaries:
                summaries[name]["methods"].update(part["methods"])
            else:
                summaries[name] = part
    order = ("ins", "lc") + TWO_BEAM_METHODS[1:]
    for s in summaries.values():
        s["methods"] = {m: s["methods"][m] for m in order}
    return summaries


@contextlib.contextmanager
def _written_or_aborted(writer: Any):
    """A study's files written by ``writer`` (app.reports.study_output.StudyWriter) all at once or
    not at all: on any failure inside, the writer is aborted; a file of the study that cannot be
    written (full disk, size limit) is one line naming ``--out``, the smoother's directory on a
    worker one naming ``--smooth-dir``."""
    from app.reports.study_output import OutputDirError
    from tauvcore.engine.tape import SmoothingError

    try:
        yield
    except OutputDirError as exc:  # a file of the study cannot be written: full disk, size limit
        writer.abort()
        raise UsageError(f"--out: {exc}") from None
    except SmoothingError as exc:  # from a worker: the smoother's directory there
        writer.abort()
        raise UsageError(f"--smooth-dir: {exc}") from None
    except BaseException:
        writer.abort()
        raise


def _print_written(writer: Any, written: list[str]) -> None:
    """The files a study wrote, and the earlier study they replaced (``--replace``), if any."""
    if writer.replaces is not None:
        print(f"replaced the earlier {writer.replaces} in {show_path(writer.name)} (--replace)")
    for path in written:
        print(f"wrote {path}")


@contextlib.contextmanager
def _study_failures(dask: str | None):
    """A worker process that dies (out of memory, killed) or a Dask cluster that goes away ends
    the study with one line and exit status 1, not a traceback; nothing is written."""
    from concurrent.futures.process import BrokenProcessPool

    try:
        yield
    except BrokenProcessPool as exc:
        raise StudyFailedError(
            f"a worker process died during the study ({one_line(str(exc)) or 'killed'}); nothing was written"
        ) from None
    except (OSError, TimeoutError) as exc:
        if dask is None:
            raise
        raise StudyFailedError(
            f"--dask {dask}: the cluster failed during the study ({type(exc).__name__}: "
            f"{one_line(str(exc))}); nothing was written"
        ) from None


@contextlib.contextmanager
def _progress_bar(total: int):
    """A tqdm bar on stderr (runs done of total); silent when stderr is not a terminal."""
    from tqdm import tqdm

    bar = tqdm(
        total=total,
        unit="run",
        desc="tauv mc",
        file=sys.stderr,
        disable=not sys.stderr.isatty(),
        dynamic_ncols=True,
    )
    try:
        yield bar
    finally:
        bar.close()
