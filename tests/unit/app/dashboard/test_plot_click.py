"""The "Go to [s]" field that a plot click writes (app.dashboard.plot_click): what it accepts, what it
refuses with the field and the value named, and the page script's locator."""

from __future__ import annotations

import json

import pytest

from app.dashboard import plot_click
from app.dashboard.plot_click import GO_TO_LABEL, parse_go_to_s


@pytest.mark.parametrize(
    ("text", "t_max_s", "expected"),
    [
        ("12.5", 100.0, 12.5),
        (" 0 ", 100.0, 0.0),
        ("1e2", 250.0, 100.0),
        ("-3", 100.0, 0.0),       # before the start: the start
        ("400", 250.0, 250.0),    # beyond what was run: its end
        ("", 100.0, None),        # an emptied field: nothing to do
        ("   ", 100.0, None),
        ("12.5 ", 100.0, 12.5),   # the script adds a space every other click
    ],
)
def test_a_time_is_read_and_kept_within_what_was_run(text: str, t_max_s: float, expected: float | None) -> None:
    assert parse_go_to_s(text, t_max_s) == expected


@pytest.mark.parametrize("text", ["abc", "nan", "inf", "-inf", "1,5", "12 s"])
def test_anything_but_a_finite_time_is_refused_naming_the_field_and_the_value(text: str) -> None:
    with pytest.raises(ValueError) as caught:
        parse_go_to_s(text, 100.0)
    message = str(caught.value)
    assert message.startswith(GO_TO_LABEL) and repr(text.strip()) in message


def test_the_script_finds_the_field_by_its_label_and_listens_to_every_plot() -> None:
    source = plot_click.script()
    assert "__XPATH__" not in source
    xpath = json.loads(source.split("const XPATH = ", 1)[1].split(";\n", 1)[0])
    assert f'normalize-space()="{GO_TO_LABEL}"' in xpath
    assert "plotly_click" in source and ".js-plotly-plot" in source
