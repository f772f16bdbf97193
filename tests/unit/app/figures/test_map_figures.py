"""The map (app.figures.map_figures): its ellipses are the k-sigma contours of the covariance,
its cursor traces sit at the cursor's epoch, its tracks are coloured by error or beam state on
request, and a method without a position state draws no ellipse."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from app.figures.map_figures import (
    BEAM_STATE_COLORS,
    MAP_META,
    SIGMAS,
    covariance_ne,
    cursor_traces,
    ellipse_ne,
    map_figure,
    map_tracks,
)
from tauvcore.engine.results import SERIES_FIELDS, MethodResult, UpdateRecord


def _result(method: str, T: int = 41, R: int = 2, with_cov: bool = True, beams: bool = True) -> MethodResult:
    t = np.linspace(0.0, 40.0, T)
    pos = np.zeros((T, R, 3))
    pos[:, :, 0] = 10.0 * np.sin(0.1 * t)[:, None] + np.arange(R)
    pos[:, :, 1] = 2.0 * t[:, None]
    cov = np.zeros((T, R, 3))
    cov[..., 0] = 1.0 + 0.1 * t[:, None]
    cov[..., 1] = 0.3
    cov[..., 2] = 2.0 + 0.05 * t[:, None]
    series = np.zeros((T, R))
    updates = {}
    if beams:
        U = 20
        available = np.ones((U, R, 4), bool)
        available[10:15, :, 2:] = False  # two beams out from 20 s to 28 s
        z = np.zeros((U, R, 3))
        f = np.zeros((U, R), bool)
        updates["dvl"] = UpdateRecord(np.arange(U) * 2.0, z, z, z, f.astype(float), f, f, ~f, z > 0, z > 0,
                                      f.astype(float), f.astype(int), f, beams_available=available)  # fmt: skip
    per_epoch: dict[str, Any] = {name: series for name in SERIES_FIELDS.values()}
    return MethodResult(
        method=method,
        t_s=t,
        **per_epoch,
        nees_block=np.zeros((T, R, 5)),
        est_pos_n=pos,
        diverged=np.zeros(R, bool),
        diverged_at_s=np.full(R, np.nan),
        p_floor_count=np.zeros(R, int),
        updates=updates,
        pos_cov_ne_m2=cov if with_cov else None,
    )


def _truth(T: int = 41) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 40.0, T)
    return t, np.stack([10.0 * np.sin(0.1 * t) + 0.5, 2.0 * t], axis=-1)


@pytest.mark.parametrize("k", SIGMAS)
def test_an_ellipse_is_the_k_sigma_contour_of_its_covariance(k: float) -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        A = rng.normal(size=(2, 2))
        P = A @ A.T + 0.01 * np.eye(2)
        pts = ellipse_ne(P, k)  # (n, 2): north, east
        q = np.einsum("ni,ij,nj->n", pts, np.linalg.inv(P), pts)
        np.testing.assert_allclose(q, k**2, rtol=1e-9, atol=0)
        np.testing.assert_allclose(pts[0], pts[-1], atol=1e-12)  # closed


def test_a_diagonal_covariance_gives_axis_aligned_semi_axes() -> None:
    P = np.diag([4.0, 0.25])  # sigma north 2 m, east 0.5 m
    for k in SIGMAS:
        pts = ellipse_ne(P, k, points=401)
        assert np.max(np.abs(pts[:, 0])) == pytest.approx(2.0 * k, rel=1e-12)
        assert np.max(np.abs(pts[:, 1])) == pytest.approx(0.5 * k, rel=1e-12)
        top = pts[np.argmax(pts[:, 0])]  # the northernmost point is due north of the centre
        assert abs(top[1]) < 1e-12
    np.testing.assert_array_equal(covariance_ne(np.array([4.0, 0.0, 0.25])), P)


def test_the_figure_validates_and_its_cursor_traces_are_at_the_cursor_epoch() -> None:
    results = {"lc": _result("lc"), "vkf": _result("vkf", with_cov=False)}
    tracks = map_tracks(results, run=1)
    truth_t, truth_ne = _truth()
    fig = map_figure(tracks, truth_t, truth_ne, t=20.4, key="run 1", validate=True)
    assert fig.to_plotly_json() == map_figure(tracks, truth_t, truth_ne, t=20.4, key="run 1").to_plotly_json()
    layout = fig.layout.to_plotly_json()
    assert layout["meta"]["tauv"] == MAP_META and layout["meta"]["key"] == "run 1"
    assert layout["yaxis"]["scaleanchor"] == "x" and layout["yaxis"]["scaleratio"] == 1
    data = fig.to_plotly_json()["data"]
    first = layout["meta"]["cursor"]
    assert len(data) - first == 1 + 3 * len(tracks)
    expected = cursor_traces(tracks, truth_t, truth_ne, 20.4)
    for trace, (x, y) in zip(data[first:], expected):
        np.testing.assert_array_equal(np.asarray(trace["x"], float), x)
        np.testing.assert_array_equal(np.asarray(trace["y"], float), y)
    # the LC 1-sigma ellipse at the epoch 20 s of run 2, about its estimate there
    lc = results["lc"]
    i = 20
    x, y = expected[1]
    centre = lc.est_pos_n[i, 1, :2]
    d = np.stack([np.asarray(y) - centre[0], np.asarray(x) - centre[1]], axis=-1)
    assert lc.pos_cov_ne_m2 is not None
    P = covariance_ne(lc.pos_cov_ne_m2[i, 1])
    np.testing.assert_allclose(np.einsum("ni,ij,nj->n", d, np.linalg.inv(P), d), 1.0, rtol=1e-9)
    assert expected[4] == ([], []) and expected[5] == ([], [])  # VKF: no position state, no ellipse
    assert expected[0] == ([truth_ne[20, 1]], [truth_ne[20, 0]])


def test_along_the_track_ellipses_every_n_seconds() -> None:
    tracks = map_tracks({"lc": _result("lc")})
    fig = map_figure(tracks, *_truth(), t=0.0, every_s=10.0)
    along = fig.to_plotly_json()["data"][2]
    outlines = sum(1 for v in along["x"] if v is None)
    assert outlines == 2 * 5  # 0, 10, 20, 30, 40 s: 1 and 3 sigma each


def test_colour_by_error_marks_the_horizontal_error_and_by_beams_the_beam_count() -> None:
    results = {"lc": _result("lc"), "tc": _result("tc")}
    truth_t, truth_ne = _truth()
    tracks = map_tracks(results)
    fig = map_figure(tracks, truth_t, truth_ne, t=5.0, colour_by="error")
    lc: Any = fig.data[1]  # plotly's stubs type an item as a figure
    err = np.linalg.norm(results["lc"].est_pos_n[:, 0, :2] - truth_ne, axis=-1)
    np.testing.assert_allclose(lc["marker"]["color"], err, rtol=1e-12)
    assert lc["marker"]["showscale"] and not fig.data[3]["marker"]["showscale"]
    beams: Any = map_figure(tracks, truth_t, truth_ne, t=5.0, colour_by="beam state").data[1]
    colors = beams["marker"]["color"]
    assert colors[0] == BEAM_STATE_COLORS[4] and colors[24] == BEAM_STATE_COLORS[2]  # 24 s: two beams out
    with pytest.raises(ValueError, match="colour_by"):
        map_figure(tracks, truth_t, truth_ne, t=0.0, colour_by="speed")


def test_events_lie_on_the_truth_s_track_with_their_words_and_times() -> None:
    """A scheduled outage (a span) is a broad stretch of the truth's track from its start to its
    end; two gate rejections (instants) are markers at the truth's positions then, carrying their
    times (a click goes there) and texts; each kind in the legend once; the cursor's traces last."""
    from tauvcore.eval.events import EVENT_KINDS, Event

    truth_t, truth_ne = _truth()
    events = [
        Event("outage", 10.0, 20.0, None, (3, 4), "scheduled DVL outage: beams 3,4 lost 10-20 s"),
        Event("rejection", 5.0, 5.0, "lc", (), "LC: DVL update rejected by the gate at 5 s"),
        Event("rejection", 30.0, 30.0, "lc", (), "LC: DVL update rejected by the gate at 30 s"),
    ]
    tracks = map_tracks({"lc": _result("lc")})
    plain = map_figure(tracks, truth_t, truth_ne, t=0.0)
    fig = map_figure(tracks, truth_t, truth_ne, t=0.0, events=events, validate=True)
    before, after = int(plain.layout["meta"]["cursor"]), int(fig.layout["meta"]["cursor"])
    marks: Any = fig.data[before:after]  # plotly's stubs type an item as a figure
    assert [m["name"] for m in marks] == [EVENT_KINDS["outage"], EVENT_KINDS["rejection"]]
    span, instants = marks
    north = np.interp([10.0, 20.0], truth_t, truth_ne[:, 0])
    east = np.interp([10.0, 20.0], truth_t, truth_ne[:, 1])
    np.testing.assert_allclose(np.asarray(span["y"])[[0, -1]], north, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(span["x"])[[0, -1]], east, rtol=1e-12)
    assert span["hovertext"] == events[0].text
    np.testing.assert_array_equal(instants["customdata"], [5.0, 30.0])
    assert list(instants["hovertext"]) == [events[1].text, events[2].text]
    np.testing.assert_allclose(instants["y"], np.interp([5.0, 30.0], truth_t, truth_ne[:, 0]), rtol=1e-12)
    # the cursor's traces stay last and are the same
    assert fig.to_plotly_json()["data"][after:] == plain.to_plotly_json()["data"][before:]


def test_the_view_fits_the_truth_and_the_aided_tracks_not_the_free_ins() -> None:
    """INS drifts kilometres away: the view opens on the truth and LC (8 % margin); INS alone is fitted."""
    truth_t, truth_ne = _truth()
    lc, ins = _result("lc"), _result("ins")
    ins.est_pos_n[:, :, :2] *= 100.0
    fig = map_figure(map_tracks({"ins": ins, "lc": lc}), truth_t, truth_ne, t=0.0).to_plotly_json()
    ne = np.concatenate([truth_ne, lc.est_pos_n[:, 0, :2]])
    lo, hi = ne.min(axis=0), ne.max(axis=0)
    pad = 0.08 * np.max(hi - lo)
    np.testing.assert_allclose(fig["layout"]["xaxis"]["range"], [lo[1] - pad, hi[1] + pad], rtol=1e-12)
    np.testing.assert_allclose(fig["layout"]["yaxis"]["range"], [lo[0] - pad, hi[0] + pad], rtol=1e-12)
    alone = map_figure(map_tracks({"ins": ins}), truth_t, truth_ne, t=0.0).to_plotly_json()
    assert alone["layout"]["xaxis"]["range"][1] > 50.0 * fig["layout"]["xaxis"]["range"][1]
