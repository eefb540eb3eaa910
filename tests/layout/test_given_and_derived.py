"""A layout keeps what the user wrote (`Layout.given`) beside the numbers it derived (`Layout.derived`).

The oracles: the layout file itself for `given`; for each derived number, the function of
rail_mj.contact.derived that computes it, called on the layout's own parts, equal to the last bit
(the shipped models' MJCF, compared byte for byte by tests/vehicle/test_models.py, hold the
same); the static wheel load by hand, from the masses in the file.
"""

from __future__ import annotations

import copy
import dataclasses
import pickle
import tomllib

import pytest
from conftest import MODELS, PROFILES_TOML, SHIPPED, linear_text

from rail_mj.contact import derived as derive
from rail_mj.layout import LayoutError, layout_from_dict, load_layout
from rail_mj.layout.reader import Derived, Given, GivenCreep, GivenWheelset, Layout
from rail_mj.units import GRAVITY

COEFFICIENTS = ("f11", "f22", "f23", "f33")

# A bogie under a fixed body that gives every number itself: nothing is derived.
EXPLICIT = {
    "name": "explicit",
    "wheelset": {
        "mass": 1813.0,
        "inertia": [1120.0, 112.0, 1120.0],
        "rolling_radius": 0.46,
        "contact_half_spacing": 0.75,
        "conicity": 0.15,
        "flangeway_clearance": 0.008,
        "wheel_load": 55e3,
    },
    "creep": {"f11": 10e6, "f22": 9e6, "f23": 1e3, "f33": 10.0, "law": "polach", "friction": 0.3},
    "primary": {"lateral_stiffness": 7.768e6, "yaw_stiffness": 62.78e6},
    "bogie": {"mass": 2615.0, "inertia": [1722.0, 1476.0, 3067.0], "wheelset_positions": [1.28, -1.28]},
    "secondary": {"lateral_stiffness": 320e3, "yaw_stiffness": 320e3},
    "carbody": {"fixed": True, "bogie_positions": [0.0]},
}
CONTACT = {"young_modulus": 210e9, "poisson_ratio": 0.28, "rail_transverse_radius": 0.3}


def with_(base: dict, **tables) -> dict:
    """`base` with some tables changed; a table given as None is removed."""
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
    for key, value in tables.items():
        if value is None:
            out.pop(key, None)
        else:
            out[key] = value
    return out


@pytest.fixture(scope="module")
def on_profiles() -> Layout:
    return load_layout(MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml")


def test_a_layout_on_profiles_keeps_what_was_written_beside_what_they_give(on_profiles):
    layout = on_profiles
    given, r0 = layout.given, layout.wheelset.rolling_radius
    assert isinstance(given, Given) and layout.profiles is not None
    # Left out of the file: None as given, the profiles' numbers in the layout.
    assert given.wheelset.conicity is None and given.wheelset.flangeway_clearance is None
    assert given.wheelset.wheel_load is None
    assert all(getattr(given.creep, f) is None for f in COEFFICIENTS)
    assert layout.wheelset.conicity == derive.profiles_conicity(layout.profiles, r0)
    assert layout.wheelset.flangeway_clearance == derive.flange_shift(layout.profiles, r0)
    assert dataclasses.asdict(layout.creep) == {
        **derive.profiles_kalker(
            layout.profiles, layout.wheelset, layout.contact, layout.creep.law, layout.creep.friction
        ),
        **{k: v for k, v in dataclasses.asdict(given.creep).items() if k not in COEFFICIENTS},
    }
    # ... and each one named with its source, in the order derived.
    assert dict(layout.derived) == {
        "wheelset.conicity": derive.PROFILES_CONICITY,
        "wheelset.flangeway_clearance": derive.PROFILES_FLANGE_SHIFT,
        "wheelset.wheel_load": derive.STATIC_WHEEL_LOAD,
        **{f"creep.{f}": derive.PROFILES_KALKER for f in COEFFICIENTS},
    }
    assert layout.derived["wheelset.conicity"] == "equivalent conicity of the profiles at 3 mm (EN 15302)"
    # What was written is as written.
    written = tomllib.loads((MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml").read_text())
    assert given.creep.law == written["creep"]["law"] and given.creep.friction == written["creep"]["friction"]
    assert given.wheelset.mass == written["wheelset"]["mass"]


def test_a_layout_that_gives_every_number_has_nothing_derived():
    layout = layout_from_dict(EXPLICIT)
    assert not layout.derived and len(layout.derived) == 0 and dict(layout.derived) == {}
    assert layout.given is not None
    # Given and used alike, field by field.
    assert dataclasses.asdict(layout.given.wheelset) == dataclasses.asdict(layout.wheelset)
    assert dataclasses.asdict(layout.given.creep) == dataclasses.asdict(layout.creep)
    assert layout.wheelset.wheel_load == 55e3 and layout.creep.f23 == 1e3


def test_a_default_wheel_load_is_recorded_as_derived():
    data = with_(
        EXPLICIT,
        carbody={"fixed": False, "mass": 32000.0, "inertia": [56800.0, 1.97e6, 1.97e6], "bogie_positions": [9.5, -9.5]},
    )
    del data["wheelset"]["wheel_load"]
    layout = layout_from_dict(data)
    assert layout.given.wheelset.wheel_load is None
    assert dict(layout.derived) == {"wheelset.wheel_load": derive.STATIC_WHEEL_LOAD}
    # By hand: car body and two frames over four wheelsets, each wheelset's own weight, two wheels.
    assert layout.wheelset.wheel_load == GRAVITY * ((32000.0 + (2615.0 + 2615.0)) / 4 + 1813.0) / 2
    # A fixed body without mass gives no weight: nothing to derive, nothing derived.
    data = with_(EXPLICIT, creep={"f11": 10e6, "f22": 9e6})
    del data["wheelset"]["wheel_load"]
    layout = layout_from_dict(data)
    assert layout.wheelset.wheel_load is None and not layout.derived


def test_the_creep_coefficients_of_contact_are_derived_and_the_given_ones_none():
    data = with_(EXPLICIT, creep={"law": "polach", "friction": 0.3}, contact=CONTACT)
    layout = layout_from_dict(data)
    from rail_mj.layout import contact_patch_of

    assert all(getattr(layout.given.creep, f) is None for f in COEFFICIENTS)
    assert {f: getattr(layout.creep, f) for f in COEFFICIENTS} == contact_patch_of(layout).creep_coefficients
    assert {f: getattr(layout.creep, f) for f in COEFFICIENTS} == derive.contact_kalker(
        layout.contact, 55e3, layout.wheelset.rolling_radius
    )
    assert dict(layout.derived) == {f"creep.{f}": derive.CONTACT_KALKER for f in COEFFICIENTS}
    # The wheel load it was computed at is the given one, so it is not derived.
    assert layout.given.wheelset.wheel_load == layout.wheelset.wheel_load == 55e3


def test_numbers_given_on_profiles_stay_in_given_and_the_profiles_replace_those_they_give(tmp_path):
    """On profiles a given conicity is kept (the dynamics do not use it), a given flangeway
    clearance and f11..f33 are replaced by the profiles' (each with its warning)."""
    text = linear_text("manchester-coach") + PROFILES_TOML  # [flange] is the profiles' on them
    path = tmp_path / "coach.toml"
    path.write_text(text)
    layout = load_layout(path)
    written = tomllib.loads(text)
    given = layout.given
    assert given.wheelset.conicity == written["wheelset"]["conicity"] == layout.wheelset.conicity
    assert given.wheelset.flangeway_clearance == written["wheelset"]["flangeway_clearance"]
    assert layout.wheelset.flangeway_clearance == derive.flange_shift(layout.profiles, 0.46) != 0.008
    assert given.creep.f11 == written["creep"]["f11"] != layout.creep.f11
    assert "wheelset.conicity" not in layout.derived
    assert layout.derived["wheelset.flangeway_clearance"] == derive.PROFILES_FLANGE_SHIFT
    assert layout.derived["creep.f11"] == derive.PROFILES_KALKER
    assert sum("not used" in w for w in layout.warnings) == 3  # conicity, clearance, f11..f33


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_given_is_the_file_and_what_it_leaves_out_is_derived(path):
    """Every shipped layout: `given` holds the file's [wheelset] and [creep] keys as written;
    a number given as None is derived; a number not derived is the given one."""
    layout, written = load_layout(path), tomllib.loads(path.read_text())
    assert layout.given is not None
    for table, given, used in (
        ("wheelset", layout.given.wheelset, layout.wheelset),
        ("creep", layout.given.creep, layout.creep),
    ):
        for key, value in written.get(table, {}).items():
            expected = tuple(value) if isinstance(value, list) else value
            assert getattr(given, key) == expected, f"{table}.{key}"
        for field in dataclasses.fields(given):
            key, value = f"{table}.{field.name}", getattr(given, field.name)
            if value is None and getattr(used, field.name) is not None:
                assert key in layout.derived, key
            if key not in layout.derived:
                assert getattr(used, field.name) == value, key
    assert set(layout.derived) <= {"wheelset.conicity", "wheelset.flangeway_clearance", "wheelset.wheel_load"} | {
        f"creep.{f}" for f in COEFFICIENTS
    }


def test_replace_round_trips(on_profiles):
    for layout in (on_profiles, layout_from_dict(EXPLICIT)):
        again = dataclasses.replace(layout)
        assert again == layout and hash(again) == hash(layout)
        assert again.given == layout.given and again.derived == layout.derived
        assert again.wheelset == layout.wheelset and again.creep == layout.creep
    # A changed number is the layout's; given and derived stay as read (they describe the file).
    changed = dataclasses.replace(on_profiles, wheelset=dataclasses.replace(on_profiles.wheelset, conicity=0.2))
    assert changed.wheelset.conicity == 0.2 and changed != on_profiles
    assert changed.given == on_profiles.given and changed.derived == on_profiles.derived
    # given and derived take no part in comparisons: the same vehicle is the same layout.
    assert dataclasses.replace(on_profiles, given=None, derived=Derived()) == on_profiles
    # Pickled (a sweep's workers) and copied, all of it comes back.
    for copied in (pickle.loads(pickle.dumps(on_profiles)), copy.deepcopy(on_profiles)):
        assert copied == on_profiles and copied.given == on_profiles.given and copied.derived == on_profiles.derived
    # The records themselves replace like any frozen dataclass.
    given = on_profiles.given
    assert (
        dataclasses.replace(given, wheelset=dataclasses.replace(given.wheelset, conicity=0.1)).wheelset.conicity == 0.1
    )


def test_a_layout_built_by_hand_has_no_given_and_nothing_derived():
    read = layout_from_dict(EXPLICIT)
    by_hand = Layout(read.name, read.wheelset, read.creep, read.primary, read.carbody, read.bogie, read.secondary)
    assert by_hand.given is None and not by_hand.derived
    assert by_hand == read


def test_derived_is_a_read_only_mapping_in_the_order_derived():
    d = Derived((("wheelset.wheel_load", "a"), ("creep.f11", "b")))
    assert list(d) == ["wheelset.wheel_load", "creep.f11"] and list(d.values()) == ["a", "b"]
    assert d["creep.f11"] == "b" and d.get("wheelset.conicity") is None and "creep.f11" in d
    with pytest.raises(KeyError):
        d["wheelset.conicity"]
    assert d == Derived((("wheelset.wheel_load", "a"), ("creep.f11", "b"))) and hash(d) == hash(Derived(d.sources))
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.sources = ()  # type: ignore[misc]


def test_given_records_are_typed_and_frozen(on_profiles):
    assert isinstance(on_profiles.given.wheelset, GivenWheelset)
    assert isinstance(on_profiles.given.creep, GivenCreep)
    assert on_profiles.given.creep.coefficients() is None
    assert layout_from_dict(EXPLICIT).given.creep.coefficients() == {"f11": 10e6, "f22": 9e6, "f23": 1e3, "f33": 10.0}
    with pytest.raises(dataclasses.FrozenInstanceError):
        on_profiles.given.wheelset.conicity = 0.1  # type: ignore[misc]


def test_a_refused_layout_still_says_one_line(tmp_path):
    """Deriving is no new way to fail: a [contact] with no load to work at is refused as before."""
    data = with_(EXPLICIT, creep={"law": "polach", "friction": 0.3}, contact=CONTACT)
    del data["wheelset"]["wheel_load"]
    with pytest.raises(LayoutError) as e:
        layout_from_dict(data, source="x.toml")
    assert str(e.value) == (
        "x.toml: wheelset.wheel_load: missing: [contact] needs the wheel load, and a fixed car body without "
        "mass gives no weight to share; give it in N"
    )


def test_flangeless_wheels_are_held_at_the_end_of_the_table_and_say_so(tmp_path):
    """A coned test wheel without flange (1:20, as a CSV profile): its clearance is the end of
    the contact table, 10 mm, and `derived` says that no flange touched."""
    ys = [-60.0 + 0.5 * i for i in range(261)]
    (tmp_path / "cone.csv").write_text("y_mm,z_mm\n" + "".join(f"{y:.3f},{0.05 * y:.6f}\n" for y in ys))
    text = (MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml").read_text()
    (tmp_path / "cone.toml").write_text(text.replace('wheel = "s1002"', 'wheel = "cone.csv"'))
    layout = load_layout(tmp_path / "cone.toml")
    assert layout.wheelset.flangeway_clearance == 0.01 and layout.given.wheelset.flangeway_clearance is None
    assert layout.derived["wheelset.flangeway_clearance"] == derive.PROFILES_NO_FLANGE
    assert layout.wheelset.conicity == pytest.approx(0.05, rel=0.1)  # the cone's, nearly
