"""Where the whole suite's time goes: its two passes as ``scripts/test.sh`` runs them, each pass's
wall time, and the test modules that take the longest, from pytest's JUnit report.

    python benchmarks/suite_time.py [--top 12]
    python benchmarks/suite_time.py --junit NB.xml BR.xml --wall NB_S BR_S [--top 12]

The first form runs both passes (about half an hour on 2 cores: everything but the browser and
container tests with ``-n 2 --dist loadscope``, then those alone) into a temporary directory; the
second reads the reports of passes already run with ``--junitxml`` and their wall times [s]. A
module's time is the sum of its tests' (setup, call and teardown); under ``-n 2`` the two workers
share the pass's wall time, so the sum over modules is about twice the wall time. Writes
docs/results/suite_time.md (benchmarks/fragment.py), which docs/contributing.md includes.
"""

from __future__ import annotations

import argparse
import collections
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

ROOT = Path(__file__).resolve().parents[1]
PASSES = (
    ("everything but the browser and container tests, `-n 2 --dist loadscope`",
     ["-n", "2", "--dist", "loadscope", "-m", "not browser and not container"]),
    ("the browser and container tests, alone", ["-m", "browser or container"]),
)


def run_pass(args: list[str], junit: Path) -> float:
    """One pass of the suite with its JUnit report written to ``junit``; its wall time [s]."""
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--junitxml={junit}", *args],
                   cwd=ROOT, check=False, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def modules(junit: Path) -> tuple[collections.Counter, collections.Counter, dict[str, int]]:
    """Per test module: its tests' summed time [s], their number; and the report's outcome counts."""
    seconds: collections.Counter = collections.Counter()
    count: collections.Counter = collections.Counter()
    outcomes = {"passed": 0, "failed": 0, "skipped": 0}
    for case in ET.parse(junit).iter("testcase"):
        module = ".".join(p for p in case.get("classname", "").split(".") if not p[:1].isupper())
        path = module.replace(".", "/") + ".py"
        seconds[path] += float(case.get("time", 0.0))
        count[path] += 1
        if case.find("failure") is not None or case.find("error") is not None:
            outcomes["failed"] += 1
        elif case.find("skipped") is not None:
            outcomes["skipped"] += 1
        else:
            outcomes["passed"] += 1
    return seconds, count, outcomes


def table(reports: list[Path], walls: list[float], top: int) -> str:
    rows = ["| pass | wall [min] | tests' summed time [min] | passed / failed / skipped |", "|---|---|---|---|"]
    details = []
    for (name, _), junit, wall in zip(PASSES, reports, walls, strict=True):
        seconds, count, outcomes = modules(junit)
        rows.append(f"| {name} | {wall / 60:.1f} | {sum(seconds.values()) / 60:.1f} | "
                    f"{outcomes['passed']} / {outcomes['failed']} / {outcomes['skipped']} |")
        details += ["", f"**{name}**: the {top} longest modules", "",
                    "| module | tests | summed time [s] |", "|---|---|---|"]
        details += [f"| `{path}` | {count[path]} | {s:.0f} |" for path, s in seconds.most_common(top)]
    rows.append(f"| both | {sum(walls) / 60:.1f} | | |")
    return "\n".join(rows + details)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--top", type=int, default=12, help="modules listed per pass")
    parser.add_argument("--junit", nargs=2, type=Path, metavar=("NB_XML", "BR_XML"),
                        help="the two passes' JUnit reports, already run")
    parser.add_argument("--wall", nargs=2, type=float, metavar=("NB_S", "BR_S"),
                        help="the two passes' wall times [s] (with --junit)")
    args = parser.parse_args()
    if (args.junit is None) != (args.wall is None):
        parser.error("--junit and --wall go together")
    with tempfile.TemporaryDirectory() as tmp:
        if args.junit is None:
            reports = [Path(tmp) / f"pass{i}.xml" for i in range(len(PASSES))]
            walls = [run_pass(flags, junit) for (_, flags), junit in zip(PASSES, reports, strict=True)]
        else:
            reports, walls = list(args.junit), list(args.wall)
        text = table(reports, walls, args.top)
    print(text)
    print(f"written to {fragment.write('suite_time', text)}")


if __name__ == "__main__":
    main()
