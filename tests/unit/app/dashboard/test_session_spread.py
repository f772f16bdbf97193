"""The Spread tab's room (app/dashboard/session_spread.py) with stand-in handles: the hint for a
single run, a note while a Monte Carlo runs, its three plots once its results are final, the
same results drawn once, and the chosen method's runs redrawn alone."""

from __future__ import annotations

import threading
import types

import numpy as np

from app.dashboard.session_spread import RUNNING_NOTE, SINGLE_RUN_HINT, SpreadTab
from app.figures.shared import SENT_CURSOR_S, TIME_META
from tauvcore.engine.results import BLOCK_DIMS, SERIES_FIELDS, MethodResult


def _result(method: str, runs: int, epochs: int = 30) -> MethodResult:
    t_s = np.linspace(0.0, 3.0, epochs)
    series = np.outer(1.0 + np.arange(epochs), 1.0 + np.arange(runs))
    return MethodResult(
        method=method, t_s=t_s, **{name: series.copy() for name in SERIES_FIELDS.values()},
        nees_block=np.ones((epochs, runs, len(BLOCK_DIMS) - 1)), est_pos_n=np.zeros((epochs, runs, 3)),
        diverged=np.zeros(runs, bool), diverged_at_s=np.full(runs, np.nan), p_floor_count=np.zeros(runs, int))


class _Plot:
    def __init__(self) -> None:
        self.visible, self.aspect, self.sent = False, 0.9, []

    @property
    def figure(self):
        return self.sent[-1]

    @figure.setter
    def figure(self, figure) -> None:
        self.sent.append(figure)


class _Dropdown:
    def __init__(self) -> None:
        self.options, self._value, self.visible, self.callbacks = ("lc",), "lc", False, []

    @property
    def value(self) -> str:
        return self._value

    @value.setter
    def value(self, value: str) -> None:   # viser calls the callbacks at once
        if value != self._value:
            self._value = value
            for cb in self.callbacks:
                cb(None)


def _tab() -> SpreadTab:
    tab = SpreadTab.__new__(SpreadTab)
    tab.state = types.SimpleNamespace(cursor_t=1.0, draw_lock=threading.RLock())
    tab.note = types.SimpleNamespace(content=SINGLE_RUN_HINT)
    tab.method = _Dropdown()
    tab.runs_plot, tab.final_plot, tab.nees_plot = _Plot(), _Plot(), _Plot()
    tab.plots = (tab.runs_plot, tab.final_plot, tab.nees_plot)
    tab.drawn, tab.choosing, tab.chosen = None, False, None
    tab.method.callbacks.append(lambda _: tab._method_chosen())
    return tab


def test_a_single_run_shows_the_hint_and_no_plot():
    tab = _tab()
    tab.show({"lc": _result("lc", 1)}, live=False)
    assert tab.note.content == SINGLE_RUN_HINT
    assert not any(p.visible or p.sent for p in tab.plots) and not tab.method.visible


def test_a_running_monte_carlo_waits_for_its_final_results():
    tab = _tab()
    tab.show({"lc": _result("lc", 5)}, live=True)
    assert tab.note.content == RUNNING_NOTE.format(runs=5)
    assert not any(p.visible or p.sent for p in tab.plots)


def test_final_results_draw_the_three_plots_once_and_a_method_choice_redraws_its_runs_alone():
    tab = _tab()
    results = {"tc": _result("tc", 4), "vb": _result("vb", 4)}
    tab.show(results, live=False)
    assert all(p.visible and len(p.sent) == 1 for p in tab.plots) and tab.method.visible
    assert tab.method.options == ("tc", "vb") and tab.method.value == "tc"
    assert tab.runs_plot.figure.layout.title.text.startswith("TC: spread of 4 runs")
    assert "4 runs" in tab.final_plot.figure.layout.title.text
    # the time plots carry the cursor at the sent time (the page puts it at the slider's) and the time tag
    assert tab.nees_plot.figure.layout.shapes[0].x0 == SENT_CURSOR_S and tab.nees_plot.figure.layout.meta == TIME_META
    assert not tab.final_plot.figure.layout.shapes               # none on the histograms
    tab.show(results, live=False)                                # the same results: nothing sent again
    assert all(len(p.sent) == 1 for p in tab.plots)
    tab.method.value = "vb"
    assert tab.runs_plot.figure.layout.title.text.startswith("VB: spread")
    assert [len(p.sent) for p in tab.plots] == [2, 1, 1]
    tab.show({"ins": _result("ins", 4), "tc": _result("tc", 4), "vb": _result("vb", 4)}, live=False)
    assert tab.method.value == "vb"                              # the user's pick kept across runs
    tab.chosen = None
    tab.show({"ins": _result("ins", 3), "tc": _result("tc", 3)}, live=False)
    assert tab.method.value == "tc"                              # else the first aided method, not INS
    tab.show({"tc": _result("tc", 1)}, live=False)               # then a single run: the hint again
    assert tab.note.content == SINGLE_RUN_HINT and not any(p.visible for p in tab.plots)
