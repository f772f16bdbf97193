"""The Series tab: any recorded series picked into a time plot or an XY plot, its picks typed
or made with the buttons, unknown names said."""

from __future__ import annotations

import pytest

from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser
SERIES_PLOTS_JS = (
    "Array.from(document.querySelectorAll('.js-plotly-plot'))"
    ".filter(p => p.layout && p.layout.title && String(p.layout.title.text || '').startsWith('Series against'))"
    ".map(p => ({title: p.layout.title.text, traces: (p._fullData || []).map(t => [t.name, (t.y || []).length]),"
    " height: p.getBoundingClientRect().height}))"
)


def _plots(tab) -> dict[str, list]:
    return {p["title"]: p["traces"] for p in tab.page.evaluate(SERIES_PLOTS_JS)}


@pytest.mark.parametrize("size", [(1600, 1000), (1280, 800)])
def test_series_picked_into_a_time_plot_and_an_xy_plot(browser, server_url, size) -> None:
    """Given a 20 s run of LC and TC, when the user picks LC's velocity error and TC's DVL NIS into
    the time plot with the button, and LC's estimated east and north into the XY plot, then the
    time plot draws both series with their points (two panels: m/s and none) and the XY plot LC's
    track; the picks ride in the page's address, and a tab opened there shows them; a name the
    run lacks, typed in, is said in the tab's note and not drawn."""
    from tests.browser.conftest import THROTTLE_FRAMES, Tab

    ctx = browser.new_context(viewport={"width": size[0], "height": size[1]})
    ctx.add_init_script(THROTTLE_FRAMES)
    try:
        tab = Tab(ctx.new_page(), server_url)
        tab.type_into("Duration [s]", "20")
        tab.set_methods({"LC", "TC"})
        tab.page.get_by_role("button", name="Run", exact=True).click()
        tab.notification("Run complete").wait_for(timeout=120000)
        tab.page.get_by_role("tab", name="Series").click()
        tab.choose("Series", "lc/vel_err_mps")
        tab.page.get_by_role("button", name="Add to time plot", exact=True).click()
        tab.choose("Series", "tc/dvl/nis")
        tab.page.get_by_role("button", name="Add to time plot", exact=True).click()
        tab.page.wait_for_function(
            f"(() => {{ const p = {SERIES_PLOTS_JS}.find(p => p.title === 'Series against time');"
            " return p && p.traces.length === 2; })()",
            timeout=20000,
        )
        traces = dict(_plots(tab)["Series against time"])
        assert traces["lc/vel_err_mps"] == 201 and traces["tc/dvl/nis"] > 15, traces
        assert tab.field("Time plot").input_value() == "lc/vel_err_mps, tc/dvl/nis"

        tab.choose("Series", "lc/est_east_m")
        tab.page.get_by_role("button", name="X axis", exact=True).click()
        tab.choose("Series", "lc/est_north_m")
        tab.page.get_by_role("button", name="Add to Y", exact=True).click()
        tab.page.wait_for_function(
            f"(() => {{ const p = {SERIES_PLOTS_JS}.find(p => p.title === 'Series against series');"
            " return p && p.traces.length === 1; })()",
            timeout=20000,
        )
        assert dict(_plots(tab)["Series against series"]) == {"lc/est_north_m": 201}
        assert tab.field("XY plot").input_value() == "lc/est_east_m; lc/est_north_m"
        tab.page.screenshot(path=str(ARTIFACTS / f"series-{size[0]}.png"))
        # the picks ride in the page's address: a new tab opened there shows them
        tab.page.wait_for_function("location.search.includes('xy=lc/est_east_m')", timeout=20000)
        address = tab.page.url
        assert "series=lc/vel_err_mps,%20tc/dvl/nis" in address, address
        if size == (1600, 1000):
            other = Tab(ctx.new_page(), address)
            other.page.get_by_role("tab", name="Series").click()
            other.page.wait_for_function(
                "Array.from(document.querySelectorAll('input')).some(i => i.value === 'lc/est_east_m; lc/est_north_m')",
                timeout=30000,
            )
            assert other.field("Time plot").input_value() == "lc/vel_err_mps, tc/dvl/nis"
            other.page.close()

        tab.type_into("Time plot", "lc/vel_err_mps, lc/nope_m")
        tab.field("Time plot").press("Enter")
        tab.page.get_by_text("Not in this run", exact=False).wait_for(timeout=20000)
        assert "lc/nope_m" in tab.page.get_by_text("Not in this run", exact=False).inner_text()
        tab.page.wait_for_function(
            f"(() => {{ const p = {SERIES_PLOTS_JS}.find(p => p.title === 'Series against time');"
            " return p && p.traces.length === 1; })()",
            timeout=20000,
        )
    finally:
        ctx.close()
