"""app.dashboard.control_checks: every bad control named at once, each for its own fault, and none of them in
the page's address."""

from __future__ import annotations

import dataclasses

import pytest

from app.dashboard import links
from app.dashboard.control_checks import initial_controls, notification, problems, without_problems
from app.dashboard.inputs import Controls, config_from_controls


@pytest.fixture
def good() -> Controls:
    init = {k: v for k, v in initial_controls().items() if k in Controls.__dataclass_fields__}
    return Controls(**init, methods=("ins", "lc", "tc", "nsv", "elc"), beams=(1, 2, 3, 4),
                    outages=(("0", "0"),) * 4)


def test_good_controls_have_no_problem(good: Controls) -> None:
    assert problems(good) == {}
    config_from_controls(good)


def test_five_bad_fields_are_named_together_each_for_its_own_fault(good: Controls) -> None:
    bad = dataclasses.replace(good, duration="-5", seed="2.5", dropout="1.5", nsv_epsilon="foo", vb_nf="1e9")
    found = problems(bad)
    assert set(found) == {"Duration [s]", "Seed", "Dropout probability", "NSV epsilon [m^2/s^2]", "VB n_f"}
    assert found["Seed"] == "Seed: '2.5' is not a whole number (digits only)"
    assert found["Duration [s]"].startswith("Duration [s]: '-5' is out of range")
    text = notification(found)
    assert text.startswith("5 controls to fix: ") and all(m in text for m in found.values())


def test_a_fault_of_the_choices_is_named_once_not_against_every_field(good: Controls) -> None:
    two_beams_lc = dataclasses.replace(good, methods=("ins", "lc"), beams=(1, 2), seed="x")
    found = problems(two_beams_lc)
    assert set(found) == {"Seed"}                        # its own fault first; the choices' after it is fixed
    fixed = dataclasses.replace(two_beams_lc, seed="0")
    (message,) = problems(fixed).values()
    assert "LC needs three or more beams" in message


def test_an_outage_ending_before_it_starts_is_named_by_its_beam(good: Controls) -> None:
    outages = (("0", "0"), ("200", "50"), ("0", "0"), ("0", "0"))
    found = problems(dataclasses.replace(good, outages=outages))
    assert found == {"Beam 2 outage start": "Beam 2 outage ends (50 s) before it starts (200 s)"}


def test_a_bad_value_never_enters_the_address(good: Controls) -> None:
    bad = dataclasses.replace(good, seed="2.5", duration="99")
    safe = without_problems(bad, problems(bad))
    assert safe.seed == good.seed and safe.duration == "99"     # the bad field at its default, the good kept
    query = links.address(safe, ())
    assert "2.5" not in query and "99" in query
