"""The Docker page's sequence with podman, timed: the stand-in base, the build, serving, health,
a dashboard run in Chromium, and the stop.

    python benchmarks/bench_container.py [--keep-base] [--cache]

writes docs/results/container.md (benchmarks/fragment.py), which docs/docker.md includes. Needs
root, podman, runc and debootstrap (scripts/test.sh installs them) and Debian's Chromium. By
default the stand-in base is made again and the image is built without the layer cache, so the
figures are those of a fresh machine; ``--keep-base`` and ``--cache`` reuse what the engine holds.
The sequence is tests/release/container.py's, the same the container test runs.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from playwright.sync_api import sync_playwright

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

from tests.browser.conftest import CHROMIUM_ARGS, chromium_path, free_port
from tests.release.container import Engine, base_image, dashboard_run, missing_tools, sequence

TAG = "localhost/tauv:container-bench"
CONTAINER = "tauv-container-bench"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep-base", action="store_true", help="use the base image the engine holds")
    parser.add_argument("--cache", action="store_true", help="build with the engine's layer cache")
    args = parser.parse_args()
    missing = missing_tools()
    if missing:
        sys.exit(f"bench_container: {', '.join(missing)} not installed (bash scripts/test.sh installs them)")
    with tempfile.TemporaryDirectory() as tmp:
        engine = Engine.create(Path(tmp) / "engine")
        if not args.keep_base:
            engine.run(["rmi", "--force", "--ignore", TAG, base_image()], timeout_s=300)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS)
            try:
                figures = sequence(engine, tag=TAG, container=CONTAINER, port=free_port(), cache=args.cache,
                                   use_dashboard=lambda url: dashboard_run(browser, url))
            finally:
                browser.close()
    print("\n".join(engine.log))
    stop = figures.stop
    assert stop is not None
    base = (f"{figures.base_made_s:.0f} s" if figures.base_made_s is not None else "present, not timed")
    rows = [
        ("stand-in base (`debootstrap` bookworm, Debian's Python 3.11, imported as "
         f"`{figures.base}`)", base),
        ("`build` of the unchanged Dockerfile" + (" (layer cache)" if args.cache else " (no cache)"),
         f"{figures.build_s:.0f} s"),
        ("`run -d` to GET / answering 200", f"{figures.serving_s:.1f} s"),
        ("PID 1, user", f"`{figures.pid1}`, UID {figures.uid}"),
        ("`healthcheck run`: exit status, health", f"{figures.health_rc}, {figures.health_status}"),
        ("a dashboard run in Chromium (defaults): Run to \"Run complete\"", f"{figures.run_s:.1f} s"),
        ("`stop`: time taken, exit status", f"{stop.seconds:.2f} s, {stop.exit_code}"),
    ]
    table = "| step | measured |\n|---|---|\n" + "\n".join(f"| {a} | {b} |" for a, b in rows)
    print(table)
    print(f"written to {fragment.write('container', table)}")


if __name__ == "__main__":
    main()
