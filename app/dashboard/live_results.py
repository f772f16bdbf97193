"""A run's live results thinned for the page: a live view needs the shape of the curves, not every
epoch of a long run (the final message has them all)."""

from __future__ import annotations

import dataclasses

import numpy as np

from tauvcore.engine.results import SENSOR_FIELDS, STATE_FIELDS, MethodResult

THINNED = ("est_vel_n", "est_euler_rad", "pos_cov_ne_m2")
"""The per-epoch records that may be None (not recorded) which :func:`thin` thins with the series."""


def thin(results: dict[str, MethodResult], max_epochs: int) -> dict[str, MethodResult]:
    """Every n-th output epoch (and the last) of each series, so at most ~max_epochs remain."""
    out = {}
    for method, r in results.items():
        n = len(r.t_s)
        if n <= max_epochs:
            out[method] = r
            continue
        step = int(np.ceil(n / max_epochs))
        keep = np.r_[np.arange(0, n - 1, step), n - 1]
        out[method] = dataclasses.replace(
            r,
            t_s=r.t_s[keep],
            vel_err_mps=r.vel_err_mps[keep],
            att_err_deg=r.att_err_deg[keep],
            pos_err_m=r.pos_err_m[keep],
            vel_sigma_mps=r.vel_sigma_mps[keep],
            att_sigma_deg=r.att_sigma_deg[keep],
            pos_sigma_m=r.pos_sigma_m[keep],
            nees=r.nees[keep],
            est_pos_n=r.est_pos_n[keep],
            tilt_err_deg=r.tilt_err_deg[keep],
            heading_err_deg=r.heading_err_deg[keep],
            tilt_sigma_deg=r.tilt_sigma_deg[keep],
            heading_sigma_deg=r.heading_sigma_deg[keep],
            nees_block=r.nees_block[keep],
            **{
                n: None if (a := getattr(r, n)) is None else a[keep]
                for n in (*THINNED, *SENSOR_FIELDS, *STATE_FIELDS)
            },
        )
    return out
