"""A Monte Carlo study with a plot: RMS errors over seeded runs, written as a self-contained HTML figure.

Shows :func:`tauvcore.eval.study.run_study` (what ``tauv mc`` runs): every run its own seeded
unit (initial errors drawn per run), the runs computed in chunks and reduced as they come into
per-epoch RMS errors over runs, mean NEES and a consistency summary per method. The figure
(plotly, the JavaScript embedded: it opens offline) plots the RMS position error and the mean
full-state NEES/dim of each method against time; the summary is printed.

Run::

    .venv/bin/python examples/03_monte_carlo.py [--runs 20] [--duration 250] [--out DIR]
"""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
from _common import out_dir, parser
from plotly.subplots import make_subplots

from tauvcore.config import Config
from tauvcore.engine.results import BLOCK_DIMS
from tauvcore.eval.study import run_study


def main() -> None:
    p = parser(__doc__, duration_s=250.0, short_duration_s=10.0)
    p.add_argument("--runs", type=int, default=None, help="Monte Carlo runs (default 20; 3 when short)")
    p.add_argument("--workers", type=int, default=1, help="local worker processes (default 1)")
    args = p.parse_args()
    num_runs = args.runs if args.runs is not None else (3 if args.duration <= 30.0 else 20)
    config = (
        Config()
        .replace("trajectory", name="lawnmower", duration_s=args.duration)
        .replace("dvl", beams=(1, 2))
        .replace("run", methods=("ins", "tc", "nsv", "elc"), seed=3)
    )

    acc = run_study(
        config,  # config.run.seed is the study's seed
        num_runs,
        workers=args.workers,
        progress=lambda done, total: print(f"  {done}/{total} runs", end="\r", flush=True),
    )
    print()
    summary = acc.summary()
    t_s = summary["t_s"]

    print(f"\nlawnmower, beams 1 and 2, {num_runs} runs of {args.duration:g} s\n")
    print(
        f"{'method':<7} {'pos RMS end':>12} {'vel RMS end':>12} {'NEES/dim':>9} {'in band':>8} {'flagged':>8}"
    )
    fig = make_subplots(
        rows=2,
        cols=1,
        shared_xaxes=True,
        subplot_titles=("RMS position error over runs", "mean full-state NEES / dim"),
    )
    for method, s in summary["methods"].items():
        full = s["consistency"]["full"]
        print(
            f"{method:<7} {s['final_rms']['pos_err_m']:>10.3f} m {s['final_rms']['vel_err_mps']:>8.4f} m/s "
            f"{full['per_dim']:>9.2f} {full['in_band']:>8.2f} {s['runs_flagged_by_monitor']:>8d}"
        )
        fig.add_trace(
            go.Scatter(x=t_s, y=s["rms"]["pos_err_m"], name=method, legendgroup=method), row=1, col=1
        )
        fig.add_trace(
            go.Scatter(
                x=t_s,
                y=s["mean_nees"]["nees"] / BLOCK_DIMS["full"],
                name=method,
                legendgroup=method,
                showlegend=False,
            ),
            row=2,
            col=1,
        )
    lo, hi = summary["methods"][next(iter(summary["methods"]))]["consistency"]["full"]["band_per_dim"]
    for bound in (lo, hi):
        fig.add_hline(y=bound, line_dash="dot", line_color="grey", row=2, col=1)
    fig.update_yaxes(title_text="[m]", row=1, col=1)
    fig.update_yaxes(title_text="NEES / dim", type="log", row=2, col=1)
    fig.update_xaxes(title_text="time [s]", row=2, col=1)
    fig.update_layout(title=f"Monte Carlo: {num_runs} runs, lawnmower, beams 1 and 2")

    target = out_dir(args.out, "tauv-example-03-") / "monte_carlo.html"
    fig.write_html(target, include_plotlyjs=True)  # embedded: the page needs no network
    print(f"\nwrote {target}")
    if not all(np.isfinite(s["final_rms"]["pos_err_m"]) for s in summary["methods"].values()):
        raise SystemExit("a method's RMS error is not finite")


if __name__ == "__main__":
    main()
