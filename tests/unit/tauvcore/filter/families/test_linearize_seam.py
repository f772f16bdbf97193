"""The seam a filter family linearises its measurements through (tauvcore.filter.families.spec
.Linearize, tauvcore.engine.filter_bank.FilterBank._linearized): every correction of the 20-state
bank (the DVL loosely and tightly coupled, the water-track beams with the current as states, the
RPM fallback, depth, magnetometer, USBL) hands the family its measurement as a function of the
nominal state. Known answers: at the estimate it is the innovation the bank fuses; its central
differences along every error state are the Jacobian the bank fuses (so a statistical
linearisation linearises the measurement the extended filter does); a hook that hands the
measurement back unchanged leaves every result as it was."""

from __future__ import annotations

import dataclasses
from collections import Counter

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine import filter_bank
from tauvcore.engine.mission import run_streaming
from tauvcore.filter.eskf import Nominal, inject
from tauvcore.filter.families import FAMILIES
from tauvcore.sensors.dvl import Outage

STEP = 1e-6
"""The central difference's step along each error state [its SI unit]."""
SLOPE_TOLERANCE = 5e-4
"""Largest |central difference - H| / (1 + |H|): the USBL's H takes the origin's tangent frame, its
fixes' frame, as the local level at the estimate, off by the distance over the earth's radius
(1.6e-4 on this figure eight on WGS-84); the DVL's beams leave out the earth rate's turn with the
attitude in ``omega x l`` (4e-5: 7.3e-5 rad/s through the lever arm); every other row agrees to 1e-6."""


class Checking:
    """A family's hook that checks what the bank hands it and hands the measurement back."""

    def __init__(self) -> None:
        self.rows: Counter[int] = Counter()  # calls by the measurement's width
        self.worst = 0.0  # largest |central difference - H| over every active row and state

    def __call__(self, P, nominal: Nominal, remeasure, measurement, geodetic):
        H, Rm, nu, active = measurement
        mu, runs, m, d = H.shape
        np.testing.assert_allclose(
            np.where(active, remeasure(nominal), 0.0), np.where(active, nu, 0.0), atol=1e-9
        )
        for j in range(d):
            dx = np.zeros((2, mu, runs, d))
            dx[0, ..., j], dx[1, ..., j] = STEP, -STEP
            flat = inject(nominal, dx, geodetic).reshaped((2 * mu, runs))
            nu_pm = remeasure(flat).reshape(2, mu, runs, m)
            slope = -(nu_pm[0] - nu_pm[1]) / (2.0 * STEP)
            gap = np.abs(np.where(active, slope - H[..., j], 0.0))
            scale = 1.0 + np.abs(H[..., j])
            self.worst = max(self.worst, float(np.max(gap / scale)))
        self.rows[m] += 1
        return H, Rm, nu


def _checked(monkeypatch, config: Config) -> tuple[Checking, dict, dict]:
    plain = run_streaming(config, np.random.default_rng(3), num_runs=2)
    hook = Checking()
    families = dict(FAMILIES, eskf=dataclasses.replace(FAMILIES["eskf"], linearize=hook))
    monkeypatch.setattr(filter_bank, "FAMILIES", families)
    checked = run_streaming(config, np.random.default_rng(3), num_runs=2)
    return hook, plain, checked


BASE = (
    Config()
    .replace("trajectory", name="figure8", duration_s=20.0)
    .replace("initial_error", mode="random")
    .replace("filter", scale_factor_velocity_tau_s=0.0)  # H's scale-factor column at the estimate
)


@pytest.mark.parametrize(
    "config, widths",
    [
        pytest.param(
            BASE.replace("run", methods=("lc", "tc"), aiding=("dvl", "depth", "mag", "usbl")).replace(
                "usbl", interval_s=2.0
            ),
            {4, 1, 3},
            id="dvl-depth-mag-usbl",
        ),
        pytest.param(
            BASE.replace("run", methods=("lc", "tc"), rpm_fallback=True).replace(
                "dvl",
                outages=(Outage((1, 2, 3, 4), 5.0, 12.0),),
                water_track="both",
                current_states="random-walk",
            ),
            {4, 3},
            id="water-track-rpm",
        ),
    ],
)
def test_the_hook_sees_every_correction_as_a_function_of_the_state(monkeypatch, config, widths) -> None:
    hook, plain, checked = _checked(monkeypatch, config)
    assert widths <= set(hook.rows), hook.rows
    assert hook.worst < SLOPE_TOLERANCE, hook.worst
    for method, res in plain.items():
        for name in ("pos_err_m", "vel_err_mps", "att_err_deg", "nees", "pos_sigma_m", "nees_block"):
            np.testing.assert_array_equal(getattr(checked[method], name), getattr(res, name))
