"""One scenario and its errors: the figure-eight mission, standalone INS against the DVL-aided filters.

Shows the library's basic loop, as ``tauv run`` does it: a :class:`tauvcore.config.Config`
(defaults, with sections replaced), a seeded generator, :func:`tauvcore.engine.mission.run_streaming`
(truth, sensors and every method, a few seconds at a time), and the per-epoch errors, the filter's
own sigma and the consistency (:func:`tauvcore.eval.consistency.method_consistency`) of each
method's :class:`~tauvcore.engine.results.MethodResult`. It also writes run 0's error series as CSV.

Run::

    .venv/bin/python examples/01_scenario_errors.py [--duration 250] [--out DIR]
"""

from __future__ import annotations

import numpy as np
from _common import error_table, finite, out_dir, parser

from tauvcore.config import Config
from tauvcore.engine.mission import run_streaming
from tauvcore.eval.consistency import method_consistency


def main() -> None:
    args = parser(__doc__, duration_s=250.0, short_duration_s=20.0).parse_args()
    config = (
        Config()
        .replace("trajectory", name="figure8", duration_s=args.duration)
        .replace("run", methods=("ins", "lc", "tc"), seed=7)
    )
    results = run_streaming(config, np.random.default_rng(config.run.seed))

    print(f"figure8, {args.duration:g} s, seed {config.run.seed}, all four DVL beams\n")
    print(error_table(results))
    lc = results["lc"]
    print(
        f"\nLC at the end: position error {lc.pos_err_m[-1, 0]:.3f} m, the filter's own 1-sigma "
        f"{lc.pos_sigma_m[-1, 0]:.3f} m; heading error {lc.heading_err_deg[-1, 0]:.4f} deg "
        f"(1-sigma {lc.heading_sigma_deg[-1, 0]:.4f} deg)"
    )
    nis = method_consistency(lc).nis["dvl"]
    print(
        f"LC's DVL innovations: NIS/dof {nis.per_dof:.2f} over {nis.count} pings, "
        f"{100 * nis.in_band:.0f} % inside the 99 % band"
    )

    target = out_dir(args.out, "tauv-example-01-") / "errors_run0.csv"
    columns = {"t_s": lc.t_s}
    for name, r in results.items():
        columns[f"{name}_pos_err_m"] = r.pos_err_m[:, 0]
        columns[f"{name}_vel_err_mps"] = r.vel_err_mps[:, 0]
        columns[f"{name}_att_err_deg"] = r.att_err_deg[:, 0]
    np.savetxt(
        target, np.column_stack(list(columns.values())), delimiter=",", header=",".join(columns), comments=""
    )
    print(f"\nwrote {target}")
    if not finite(results):
        raise SystemExit("a method's errors are not finite")


if __name__ == "__main__":
    main()
