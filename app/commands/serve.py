"""``tauv serve``: the browser dashboard (app.dashboard.server, imported only here: viser loads only when
serving), its address, port, worker processes and the directory of logs and ROS bags it offers
checked first.
"""

from __future__ import annotations

import argparse
import contextlib
import os
from collections.abc import Iterator

from app.commands.values import UsageError, parse_flag
from tauvcore.validation import show, show_path


@contextlib.contextmanager
def viser_console_muted() -> Iterator[None]:
    """Mute rich's console for the duration: viser (1.x) prints its own address box there when
    the server starts, whatever its ``verbose`` (``http://127.0.0.1:8080``, beside the
    dashboard's ``http://localhost:8080``), and "(viser) Server stopped" at the end. In the
    server nothing else writes to it: callbacks' tracebacks reach stderr through plain print,
    and the dashboard's own lines through ``print``."""
    # viser's dependency: imported when serving only, as viser is
    import rich

    console = rich.get_console()
    quiet, console.quiet = console.quiet, True
    try:
        yield
    finally:
        console.quiet = quiet


def _raw_layouts_in(directory: str) -> str:
    """The vendor hint (tauvcore.logs.raw_layout_hint) of the first subdirectory that has one."""
    from tauvcore.logs import raw_layout_hint

    with contextlib.suppress(OSError):
        for entry in sorted(os.scandir(directory), key=lambda e: e.name):
            hint = raw_layout_hint(entry.path) if entry.is_dir() else ""
            if hint:
                return f"; {entry.name!r}{hint.replace('; it holds', ' holds', 1)}"
    return ""


def cmd_serve(args: argparse.Namespace) -> int:
    try:
        port = int(args.port)
    except ValueError:
        raise UsageError(f"--port: expected a TCP port number, got {show(args.port)}") from None
    if not 1 <= port <= 65535:
        raise UsageError(f"--port: must be within 1-65535, got {port}")
    if not args.host.strip():
        raise UsageError(f"--host: expected an address such as 127.0.0.1, got {show(args.host)}")
    workers = None
    if args.workers is not None:
        workers = parse_flag("--workers", args.workers, int, "a whole number of worker processes")
        if not 1 <= workers <= 64:
            raise UsageError(f"--workers: must be within 1-64, got {workers}")
    from app.dashboard import budget

    try:
        budget.budget_bytes()  # a bad TAUV_RUN_BUDGET_MB is refused now, not at the first Run
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    logs = None
    if args.logs is not None:
        from tauvcore.logs.bags import find_recordings

        if not os.path.isdir(args.logs):
            raise UsageError(f"--logs: {show_path(args.logs)} is not a directory")
        try:
            logs = find_recordings(args.logs)  # its logs and its ROS bags
        except OSError as exc:
            raise UsageError(f"--logs: cannot list {show_path(args.logs)}: {exc.strerror or exc}") from None
        if not logs:
            raise UsageError(
                f"--logs: no log or ROS bag in {show_path(args.logs)} (a log is a directory with imu.csv or "
                "imu.parquet, docs/replay.md; a bag a .bag or .mcap file or a ROS 2 bag directory, "
                f"docs/bags.md){_raw_layouts_in(args.logs)}"
            )
    from app.dashboard.hardening import exit_now  # viser only when serving
    from app.dashboard.server import main as serve_main

    try:
        with viser_console_muted():  # the dashboard prints the one address to open
            serve_main(args.host, port, workers, logs)
    except OSError as exc:
        raise UsageError(
            f"--host/--port: cannot listen on {args.host}:{port}: {exc.strerror or exc}"
        ) from None
    except KeyboardInterrupt:
        pass
    # Stopped by SIGTERM/SIGINT, the workers already gone: leave without the interpreter's
    # finalization, whose garbage collection of the tabs' sessions took 0.5-1.1 s on a loaded
    # machine (docker stop's SIGTERM must end the container within 2 s: tests/release).
    exit_now()
