"""An input with several problems is refused for the first one in the reader's order.

`layout_from_dict` reads one table at a time and resolves what tables leave to each other as
soon as it can; which line a file with two mistakes gets is part of the interface. The oracle:
the lines rail-mj 0.1's single reader function gave for the same inputs (each case breaks two
tables; fixing the reported one leaves the other's line).
"""

from __future__ import annotations

import pytest
from test_given_and_derived import CONTACT, EXPLICIT

from rail_mj.layout import LayoutError, layout_from_dict

CONTACT_LAW = {"law": "polach", "friction": 0.3}
NO_LOAD = {k: v for k, v in EXPLICIT["wheelset"].items() if k != "wheel_load"}
COEFFICIENTS = {"f11": 1e7, "f22": 9e6}

CASES = {
    # [creep]'s stray keys are reported after [contact] (and everything read before it).
    "creep-stray-key-after-contact": (
        {"creep": {**CONTACT_LAW, "f12": 1.0}, "contact": {**CONTACT, "poisson_ratio": 0.9}},
        "contact.poisson_ratio: must be <= 0.5, got 0.9",
        "creep.f12: unknown key",
    ),
    "creep-stray-key-after-carbody": (
        {"creep": {**COEFFICIENTS, "f12": 1.0}, "carbody": None},
        "carbody: missing (required)",
        "creep.f12: unknown key",
    ),
    # The wheel load is resolved (and refused missing) before [contact] is read.
    "wheel-load-before-contact": (
        {"wheelset": NO_LOAD, "creep": CONTACT_LAW, "contact": {**CONTACT, "poisson_ratio": 0.9}},
        "wheelset.wheel_load: missing: [contact] needs the wheel load, and a fixed car body without mass "
        "gives no weight to share; give it in N",
        "contact.poisson_ratio: must be <= 0.5, got 0.9",
    ),
    "flange-before-stray-top-level-key": (
        {"creep": COEFFICIENTS, "flange": {}, "zzz": 1},
        'flange: flange contact needs a saturating creep law: set creep.law to "shen-hedrick-elkins", '
        '"polach" or "fastsim" and creep.friction',
        "zzz: unknown key",
    ),
    "creep-before-primary": (
        {"creep": {**COEFFICIENTS, "law": "polach"}, "primary": {"lateral_stiffness": -1.0}},
        "creep.friction: missing (required)",
        "primary.lateral_stiffness: must be >= 0, got -1",
    ),
}


def layout(tables: dict) -> dict:
    out = {**EXPLICIT, **tables}
    return {k: v for k, v in out.items() if v is not None}


def refusal(data: dict) -> str:
    with pytest.raises(LayoutError) as e:
        layout_from_dict(data, source="x.toml")
    return str(e.value)


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_first_problem_in_reading_order_is_reported(case):
    tables, first, _ = CASES[case]
    assert refusal(layout(tables)) == f"x.toml: {first}"


def test_and_the_second_once_the_first_is_fixed():
    fixes = {
        "creep-stray-key-after-contact": {"contact": CONTACT},
        "creep-stray-key-after-carbody": {"carbody": EXPLICIT["carbody"]},
        "wheel-load-before-contact": {"wheelset": EXPLICIT["wheelset"]},
        "flange-before-stray-top-level-key": {"creep": {**COEFFICIENTS, **CONTACT_LAW}},
        "creep-before-primary": {"creep": {**COEFFICIENTS, **CONTACT_LAW}},
    }
    for case, (tables, _, second) in CASES.items():
        assert refusal(layout({**tables, **fixes[case]})) == f"x.toml: {second}", case
