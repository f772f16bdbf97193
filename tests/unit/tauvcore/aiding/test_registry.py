"""The method registry (tauvcore.aiding.registry) and its worked example, ``cv`` (constant body
velocity, tauvcore.aiding.cv; docs/adding_a_method.md): every registered model's H against a
central finite difference of its ``predict``; a registered method offered by the configuration;
end to end, a short run whose results hold it beside the others (its own update records, a finite
NEES), the runs of the other methods unchanged by its presence, and its position error bounded
where the standalone INS drifts away."""

import dataclasses

import numpy as np
import pytest

from tauvcore.aiding.cv import CV_RATE_HZ, ConstantVelocity
from tauvcore.aiding.fusion_method import FusionMethod
from tauvcore.aiding.registry import REGISTRY
from tauvcore.config import ALL_METHODS, RUN_METHODS, Config
from tauvcore.engine.mission import run_streaming
from tauvcore.eval.consistency import method_consistency
from tauvcore.filter.eskf import Nominal, inject
from tauvcore.filter.layout import STATE, NavState
from tauvcore.geo.rotations import C_nb_from_euler, mv

EPS = 1e-6


def _random_nominal(rng: np.random.Generator, batch: tuple[int, ...]) -> Nominal:
    euler = rng.uniform(-0.5, 0.5, batch + (3,)) * np.array([1.0, 1.0, 6.0])
    C = C_nb_from_euler(euler)
    vel_b = rng.normal(0.0, 2.0, batch + (3,))
    nav = NavState(pos_n=rng.normal(0.0, 50.0, batch + (3,)), vel_n=mv(C, vel_b), C_nb=C)
    return Nominal(nav=nav, accel_bias=rng.normal(0.0, 5e-3, batch + (3,)), gyro_bias=rng.normal(0.0, 1e-3, batch + (3,)),
                   dvl_bias=rng.normal(0.0, 5e-3, batch + (4,)), dvl_sf=rng.normal(0.0, 7e-3, batch))


def test_cv_is_registered_and_run_methods_takes_it() -> None:
    assert "cv" in REGISTRY and REGISTRY["cv"].rate_hz == CV_RATE_HZ
    assert "cv" in RUN_METHODS and "cv" not in ALL_METHODS    # not one of the papers' methods
    assert Config().replace("run", methods=("cv",)).run.methods == ("cv",)


def test_the_cli_and_the_dashboard_offer_a_registered_method(capsys, tmp_path) -> None:
    """`tauv run --method cv` runs it (its summary in --help), the dashboard's controls and a
    page's address take it, and it has a colour of its own."""
    import json

    from app.cli import main
    from app.dashboard import inputs, links
    from app.figures.shared import METHOD_COLORS, REGISTERED_COLORS

    out_json = tmp_path / "cv.json"
    assert main(["run", "--method", "lc,cv", "--duration", "20", "--json", str(out_json)]) == 0
    data = json.loads(out_json.read_text())
    assert set(data["results"]) == {"lc", "cv"}
    assert data["results"]["cv"]["pos_err_m"][-1] < 50.0             # aided: the free INS drifts further
    assert "CV" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    assert REGISTRY["cv"].summary.split()[0] in " ".join(capsys.readouterr().out.split())
    from tests.unit.app.dashboard.test_links import DEFAULTS

    config, _ = inputs.config_from_controls(dataclasses.replace(DEFAULTS, methods=("ins", "cv")))
    assert config.run.methods == ("ins", "cv")
    assert inputs.METHOD_HINTS["cv"] == REGISTRY["cv"].summary
    link = links.parse("?m=lc,cv", (inputs.SIMULATION,))
    assert link.problems == () and link.values["methods"] == ("lc", "cv")
    assert METHOD_COLORS["cv"] == REGISTERED_COLORS[0] and list(METHOD_COLORS.values()).count(METHOD_COLORS["cv"]) == 1


@pytest.mark.parametrize("name", list(REGISTRY))
def test_registered_H_matches_finite_difference_of_predict(name: str) -> None:
    model = REGISTRY[name].model(Config())
    rng = np.random.default_rng(sum(map(ord, name)))
    nom = _random_nominal(rng, (2,))
    setup = model.prepare((2,))
    H = model.measure(nom).H
    H_fd = np.zeros_like(H)
    for j in range(STATE.dim):
        dx = np.zeros((2, STATE.dim))
        dx[:, j] = EPS
        H_fd[..., j] = (model.predict(inject(nom, dx), setup) - model.predict(inject(nom, -dx), setup)) / (2 * EPS)
    np.testing.assert_allclose(H, H_fd, rtol=0, atol=1e-8)


def test_cv_measurement_is_the_cruise_velocity() -> None:
    model = ConstantVelocity.from_config(Config().replace("trajectory", speed_mps=1.5))
    nom = _random_nominal(np.random.default_rng(1), (3,))
    meas = model.measure(nom)
    np.testing.assert_array_equal(meas.z, np.broadcast_to([1.5, 0.0, 0.0], (3, 3)))
    np.testing.assert_allclose(meas.innovation, meas.z - nom.vel_b)
    assert meas.valid.all() and np.all(np.linalg.eigvalsh(meas.R) > 0)


@pytest.mark.parametrize(("field", "value"), [("name", "lc"), ("name", "Cv"), ("source", "dvl"), ("rate_hz", 0.0)])
def test_fusion_method_refuses_bad_entries(field: str, value: object) -> None:
    good = {"name": "new", "source": "new", "rate_hz": 1.0, "model": ConstantVelocity.from_config, "summary": "x"}
    with pytest.raises(ValueError, match=field):
        FusionMethod(**{**good, field: value})


def test_cv_runs_end_to_end_beside_the_other_methods() -> None:
    """Given the figure eight with DVL and depth, when INS, LC and CV run side by side for 60 s,
    then CV's results carry its 60 pseudo-measurement records (no DVL), a finite NEES, a position
    error far below the INS's; and INS's and LC's results are those of a run without CV (to round-off)."""
    base = Config().replace("trajectory", name="figure8", duration_s=60.0).replace("run", aiding=("dvl", "depth"))
    with_cv = run_streaming(base.replace("run", methods=("ins", "cv", "lc")), np.random.default_rng(4))
    without = run_streaming(base.replace("run", methods=("ins", "lc")), np.random.default_rng(4))
    assert list(with_cv) == ["ins", "cv", "lc"]
    cv = with_cv["cv"]
    assert set(cv.updates) == {"cv", "depth"}
    record = cv.updates["cv"]
    assert record.t_s.size == 60 and record.fused.all() and record.z.shape == (60, 1, 3)
    consistency = method_consistency(cv)
    assert all(np.isfinite(s.per_dim) for s in consistency.nees.values())
    assert np.isfinite(cv.nees).all() and not cv.diverged.any()
    assert 0.0 < consistency.nis["cv"].per_dof < 3.0
    assert cv.pos_err_m[-1, 0] < 0.2 * with_cv["ins"].pos_err_m[-1, 0]
    for method in ("ins", "lc"):          # the same, to round-off (the bank's batch differs)
        np.testing.assert_allclose(with_cv[method].pos_err_m, without[method].pos_err_m, rtol=1e-9)
        np.testing.assert_allclose(with_cv[method].nees, without[method].nees, rtol=1e-9)


@pytest.mark.parametrize("which", ["name", "source"])
def test_a_method_may_not_take_an_aiding_source_s_name(which: str, monkeypatch) -> None:
    """A registered method's records would mix with the source's (MethodResult.updates): every
    registered aiding source's name and table are refused, the plug-ins' as the built-in ones'
    (those FusionMethod itself refuses, RESERVED, aside)."""
    import sys
    import types

    from tauvcore.aiding import registry
    from tauvcore.aiding.fusion_method import RESERVED
    from tauvcore.aiding.sources import SOURCES

    taken = sorted({*SOURCES, *(s.table for s in SOURCES.values())} - set(RESERVED))
    assert {"usbl", "echo", "attitude"} <= set(taken)
    for name in taken:
        good = {"name": "mine", "source": "mine_fix", "rate_hz": 1.0, "model": ConstantVelocity.from_config,
                "summary": "x"}
        module = types.ModuleType("tauvcore.aiding.mine")
        module.METHOD = FusionMethod(**{**good, which: name})  # type: ignore[attr-defined]
        monkeypatch.setitem(sys.modules, "tauvcore.aiding.mine", module)
        with pytest.raises(ValueError, match="an aiding source's name"):
            registry._load(("mine",))
