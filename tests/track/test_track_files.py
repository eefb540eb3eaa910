"""Track files (rail_mj/track/reader.py): the shipped example, TOML and CSV describing the same
geometry giving the same Track, every refusal as its one line, and the warnings.

The rule is the layout's (tests/layout/test_layout_errors.py): a track that cannot be used is
refused with one line naming the file, the section (or the CSV line) and what is wrong; a legal
value far from practice, or a step between sections with no transition, is one warning line in
Track.warnings, with the source of its threshold (rail_mj.practice).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from conftest import MODELS

import rail_mj
from rail_mj.track import Track, TrackError, load_track, track_from_csv, track_from_dict
from rail_mj.units import GRAVITY

EXAMPLE = MODELS / "tracks" / "curve-600.toml"
HEADER = "x_m,curvature_1_per_m,cant_m\n"


def sections(*tables):
    return {"section": list(tables)}


def straight(length=100.0):
    return {"kind": "straight", "length": length}


def transition(length=50.0):
    return {"kind": "transition", "length": length}


def curve(radius=600.0, cant=0.15, length=100.0):
    return {"kind": "curve", "length": length, "radius": radius, "cant": cant}


def test_the_shipped_example():
    """models/tracks/curve-600.toml is what its README says: 900 m, no warnings; balance speed
    sqrt(g R d/1.5) = 24.3 m/s (87 km/h); at 120 km/h the cant deficiency 11.8 V^2/R - d = 133 mm
    (to practice's rounding of 11.8) and the uncompensated acceleration 0.862 m/s^2 in the track
    plane (0.871, g I/1.5, in the small angles); cant
    raised 1.5 mm per metre along the transitions; the tangent turned through
    (300 + 100)/600 rad = 38.2 degrees."""
    track = load_track(EXAMPLE)
    assert track.warnings == ()
    assert track.length == 900.0
    assert [(s.kind, s.start, s.end) for s in track.sections] == [
        ("straight", 0.0, 200.0),
        ("transition", 200.0, 300.0),
        ("curve", 300.0, 600.0),
        ("transition", 600.0, 700.0),
        ("straight", 700.0, 900.0),
    ]
    (c,) = track.curves
    assert (c.radius, c.cant) == (600.0, 0.15)
    assert math.sqrt(GRAVITY * 600.0 * 0.15 / 1.5) == pytest.approx(24.26, abs=0.005)
    deficiency = float(track.cant_deficiency(450.0, 120 / 3.6)) * 1e3
    practice = 11.8 * 120**2 / 600 - 150  # mm; its 11.8 is 1500/(3.6^2 g) = 11.798 rounded
    assert deficiency - practice == pytest.approx((1500 / (3.6**2 * GRAVITY) - 11.8) * 120**2 / 600, abs=1e-9)
    assert round(deficiency) == 133
    assert float(track.uncompensated_acceleration(450.0, 120 / 3.6)) == pytest.approx(0.862, abs=5e-4)
    assert (float(track.cant(250.0)) - float(track.cant(249.0))) * 1e3 == pytest.approx(1.5, abs=1e-12)
    assert math.degrees(float(track.heading(900.0))) == pytest.approx(38.197, abs=1e-3)
    assert rail_mj.load_track(EXAMPLE) == track  # the public API's name


def write_csv(track: Track, extra=()) -> str:
    """The design table of a track without steps: a row at every boundary (and at `extra`)."""
    xs = sorted({0.0, *(s.end for s in track.sections), *extra})
    return HEADER + "".join(f"{x!r},{float(track.curvature(x))!r},{float(track.cant(x))!r}\n" for x in xs)


@pytest.mark.parametrize(
    "data",
    [
        sections(straight(200.0), transition(100.0), curve(600.0, 0.15, 300.0), transition(100.0), straight(200.0)),
        sections(transition(80.0), curve(-450.0, 0.12, 200.0), transition(90.0), curve(-1500.0, 0.04), transition()),
        sections(curve(800.0, 0.1), transition(120.0), curve(-800.0, 0.1), transition(), straight()),
    ],
    ids=["example", "right-compound", "reverse"],
)
def test_csv_and_toml_give_the_same_track(data, tmp_path):
    """The same design geometry as TOML sections and as a CSV with a row at every boundary (and
    rows inside curves and straights, joined back into one section) is the same Track: the same
    sections, hence the same numbers everywhere, position included."""
    toml = track_from_dict(data, "track.toml")
    path = tmp_path / "track.csv"
    path.write_text("# design geometry\n" + write_csv(toml, extra=[s.start + s.length / 3 for s in toml.curves]))
    csv = load_track(path)
    assert csv == toml and csv.warnings == () == toml.warnings
    x = np.linspace(-10.0, toml.length + 10.0, 1001)
    for f in ("curvature", "cant", "heading", "xy"):
        assert np.array_equal(getattr(csv, f)(x), getattr(toml, f)(x)), f


def test_a_transition_at_either_end_runs_from_and_to_a_straight():
    """A track may start or end with a transition: from a level straight, to a level straight."""
    track = track_from_dict(sections(transition(100.0), curve(-500.0, 0.1), transition(50.0)))
    first, _, last = track.sections
    assert (first.curvature_start, first.cant_start, first.curvature_end, first.cant_end) == (0.0, 0.0, -1 / 500, -0.1)
    assert (last.curvature_start, last.cant_start, last.curvature_end, last.cant_end) == (-1 / 500, -0.1, 0.0, 0.0)
    assert track.warnings == ()


WHERE = "track.toml: section 1 (curve)"
RADIUS = "(tighter than trams run; a 2.5 m wheelbase would turn through 0.25 rad)"
CANT = "(200 mm, the most any standard-gauge track is canted)"

REFUSED = [
    ({}, "track.toml: section: missing: a track is [[section]] tables, in order, at least one"),
    (sections(), "track.toml: section: empty: a track needs at least one [[section]]"),
    (
        {"section": straight()},
        "track.toml: section: is one [section] table: give each as an array entry, [[section]], in order",
    ),
    ({"section": 3}, "track.toml: section: must be [[section]] tables, got 3"),
    ({"sections": [straight()]}, "track.toml: sections: unknown key (a track file is [[section]] tables, in order)"),
    (sections("x"), "track.toml: section 1: must be a table, got a string"),
    (sections({"length": 1.0}), "track.toml: section 1: kind missing: one of 'straight', 'transition', 'curve'"),
    (
        sections({"kind": "spiral", "length": 1.0}),
        "track.toml: section 1: kind: must be one of 'straight', 'transition', 'curve', got 'spiral'",
    ),
    (
        sections({"kind": "straight"}),
        "track.toml: section 1 (straight): length missing: every section has its length (m)",
    ),
    (sections(straight(0.0)), "track.toml: section 1 (straight): length: must be > 0 m, got 0"),
    (sections(straight(-3.0)), "track.toml: section 1 (straight): length: must be > 0 m, got -3"),
    (sections(straight(math.nan)), "track.toml: section 1 (straight): length: must be finite, got nan"),
    (sections(straight(math.inf)), "track.toml: section 1 (straight): length: must be finite, got inf"),
    (sections(straight(10**400)), "track.toml: section 1 (straight): length: must be finite, got inf"),
    (sections(straight("10")), "track.toml: section 1 (straight): length: must be a number, got a string"),
    (sections(straight(True)), "track.toml: section 1 (straight): length: must be a number, got a boolean"),
    (
        sections(straight(), straight(2e7)),
        "track.toml: the track is 2.00001e+07 m long, more than 1e+07 m: check the units (m)",
    ),
    (
        sections({"kind": "curve", "length": 100.0}),
        f"{WHERE}: radius missing: a curve needs its radius (m; positive turns left, negative right)",
    ),
    (sections(curve(5.0)), f"{WHERE}: radius: must be at least 10 m {RADIUS}, got 5; check the units (m)"),
    (sections(curve(0.0)), f"{WHERE}: radius: must be at least 10 m {RADIUS}, got 0; check the units (m)"),
    (
        sections(curve(-5.0)),
        f"{WHERE}: radius (its size; negative turns right): must be at least 10 m {RADIUS}, got 5; check the units (m)",
    ),
    (sections(curve(math.inf)), f"{WHERE}: radius: must be finite, got inf"),
    (sections(curve("600")), f"{WHERE}: radius: must be a number, got a string"),
    (
        sections(curve(cant=0.25)),
        f"{WHERE}: cant: must be between -0.2 and 0.2 m {CANT}, got 0.25; check the units (m)",
    ),
    (
        sections(curve(cant=-0.25)),
        f"{WHERE}: cant: must be between -0.2 and 0.2 m {CANT}, got -0.25; check the units (m)",
    ),
    (sections(curve(cant=150)), f"{WHERE}: cant: must be between -0.2 and 0.2 m {CANT}, got 150; check the units (m)"),
    (sections(curve(cant=math.nan)), f"{WHERE}: cant: must be finite, got nan"),
    (
        sections({**straight(), "cant": 0.1}),
        "track.toml: section 1 (straight): cant: not used: a straight is level and has no radius "
        "(only a curve has radius and cant)",
    ),
    (
        sections({**transition(), "radius": 300.0}),
        "track.toml: section 1 (transition): radius: not used: a transition takes its curvature and cant "
        "from the sections either side",
    ),
    (
        sections({**straight(), "lenght": 3}),
        "track.toml: section 1 (straight): lenght: unknown key (a straight has kind, length)",
    ),
    (
        sections({**curve(), "superelevation": 0.1}),
        f"{WHERE}: superelevation: unknown key (a curve has kind, length, radius, cant)",
    ),
    (
        sections(straight(), transition(), transition(), curve()),
        "track.toml: section 3 (transition): follows a transition: a transition runs between two sections of "
        "constant curvature and cant (straights or curves)",
    ),
]


@pytest.mark.parametrize(("data", "message"), REFUSED, ids=[m.split(": ", 1)[1][:60] for _, m in REFUSED])
def test_refused_in_one_line(data, message):
    with pytest.raises(TrackError) as e:
        track_from_dict(data, "track.toml")
    assert str(e.value) == message
    assert "\n" not in str(e.value)


PRACTICE = "EN 13803's least radius on tracks that different vehicles use"
BALLASTED = "EN 13803's 180 mm on ballasted track; negative only on turnouts off canted curves"
KICK = "with no transition between: the vehicle is kicked; EN 13803 runs curvature and cant up along a transition"

WARNED = [
    (sections(curve(120.0, 0.1)), [f"{WHERE}: radius: 120 m is outside railway practice, 150 m or more ({PRACTICE})"]),
    (
        sections(curve(-120.0, 0.1)),
        [
            f"{WHERE}: radius (its size; negative turns right): 120 m is outside railway practice, "
            f"150 m or more ({PRACTICE})"
        ],
    ),
    (sections(curve(cant=0.19)), [f"{WHERE}: cant: 0.19 m is outside railway practice, 0-0.18 m ({BALLASTED})"]),
    (sections(curve(cant=-0.05)), [f"{WHERE}: cant: -0.05 m is outside railway practice, 0-0.18 m ({BALLASTED})"]),
    (
        sections(straight(), curve(600.0, 0.15)),
        [
            "track.toml: section 1 (straight) to section 2 (curve): curvature steps by 0.00166667 1/m (the lateral "
            "acceleration by V^2 times it, 1.29 m/s^2 at 100 km/h) and cant steps by 150 mm (the track twists in no "
            f"length) {KICK}"
        ],
    ),
    (
        sections(curve(600.0, 0.1), curve(600.0, 0.15)),
        [
            "track.toml: section 1 (curve) to section 2 (curve): cant steps by 50 mm (the track twists in no "
            f"length) {KICK}"
        ],
    ),
    (
        sections(curve(600.0, 0.0), curve(-600.0, 0.0), straight()),
        [
            "track.toml: section 1 (curve) to section 2 (curve): curvature steps by -0.00333333 1/m (the lateral "
            f"acceleration by V^2 times it, 2.57 m/s^2 at 100 km/h) {KICK}",
            "track.toml: section 2 (curve) to section 3 (straight): curvature steps by 0.00166667 1/m (the lateral "
            f"acceleration by V^2 times it, 1.29 m/s^2 at 100 km/h) {KICK}",
        ],
    ),
    # Below the thresholds of rail_mj.practice: rounding, not a step.
    (sections(curve(600.0, 0.1), curve(600.0004, 0.1009)), []),
    # With transitions between, or starting in the curve: no step anywhere.
    (sections(curve(), transition(), straight(), transition(), curve(-300.0, 0.16)), []),
]


@pytest.mark.parametrize(("data", "warnings"), WARNED)
def test_warned_in_one_line_each(data, warnings):
    track = track_from_dict(data, "track.toml")
    assert list(track.warnings) == warnings


CSV_WHERE = "track.csv: line 3"
CSV_REFUSED = [
    ("", "track.csv: empty: a track CSV has a header (x_m, curvature_1_per_m, cant_m) and rows"),
    ("# only a comment\n\n", "track.csv: empty: a track CSV has a header (x_m, curvature_1_per_m, cant_m) and rows"),
    (
        "x_m,curvature_1_per_m\n0,0\n",
        "track.csv: line 1: column cant_m missing: a track CSV has the columns x_m, curvature_1_per_m, cant_m "
        "(is the first line the header?)",
    ),
    (
        "0,0,0\n10,0,0\n",
        "track.csv: line 1: unknown column '0': a track CSV has the columns x_m, curvature_1_per_m, cant_m",
    ),
    (
        "x_m,curvature_1_per_m,cant_mm\n",
        "track.csv: line 1: unknown column 'cant_mm': a track CSV has the columns x_m, curvature_1_per_m, cant_m",
    ),
    ("x_m,x_m,cant_m\n", "track.csv: line 1: column x_m given twice"),
    (HEADER, "track.csv: 0 rows: a track CSV needs two or more, x_m from 0 to its end"),
    (HEADER + "0,0,0\n", "track.csv: 1 row: a track CSV needs two or more, x_m from 0 to its end"),
    (HEADER + "0,0,0\n10,0\n", f"{CSV_WHERE}: 2 values for the 3 columns of the header"),
    (HEADER + "0,0,0\n10,abc,0\n", f"{CSV_WHERE}: curvature_1_per_m: not a number: 'abc'"),
    (HEADER + "0,0,0\n10,0,\n", f"{CSV_WHERE}: cant_m: not a number: ''"),
    (HEADER + "0,0,0\n10,nan,0\n", f"{CSV_WHERE}: curvature_1_per_m: must be finite, got 'nan'"),
    (HEADER + "0,0,0\n-inf,0,0\n", f"{CSV_WHERE}: x_m: must be finite, got '-inf'"),
    (HEADER + "5,0,0\n10,0,0\n", "track.csv: line 2: x_m must start at 0 (the track's start), got 5"),
    (HEADER + "0,0,0\n10,0,0\n10,0,0\n", "track.csv: line 4: x_m must increase from row to row: 10 after 10"),
    (HEADER + "0,0,0\n10,0,0\n5,0,0\n", "track.csv: line 4: x_m must increase from row to row: 5 after 10"),
    (HEADER + "0,0,0\n2e7,0,0\n", f"{CSV_WHERE}: x_m: 2e+07 m is more than 1e+07 m: check the units (m)"),
    (
        HEADER + "0,0,0\n10,-0.2,0\n",
        f"{CSV_WHERE}: curvature_1_per_m -0.2 is a radius of 5 m: must be at least 10 m {RADIUS}, got 5; "
        "check the units (m)",
    ),
    (
        HEADER + "0,0,0\n10,0.001,-0.3\n",
        f"{CSV_WHERE}: cant_m: must be between -0.2 and 0.2 m {CANT}, got -0.3; check the units (m)",
    ),
]


@pytest.mark.parametrize(("text", "message"), CSV_REFUSED, ids=[m.split(": ", 1)[1][:60] for _, m in CSV_REFUSED])
def test_csv_refused_in_one_line(text, message):
    with pytest.raises(TrackError) as e:
        track_from_csv(text, "track.csv")
    assert str(e.value) == message


def test_csv_warnings_and_sections():
    """The tightest radius and the largest cant outside practice, once each; cant of the other
    sign than the curvature (a right curve given positive cant, as if cant_m were outer over
    inner) is warned about with the convention. Columns in any order, spaces and comments
    allowed; rows of one constant curvature and cant are one section."""
    text = (
        "# a right curve given cant as outer over inner\n"
        "curvature_1_per_m, x_m, cant_m\n"
        " 0, 0, 0\n"
        "-0.008, 50, 0.19\n"
        "-0.008, 60, 0.19\n"
        "-0.008, 80, 0.19\n"
        "0, 120, 0\n"
    )
    track = track_from_csv(text, "track.csv")
    assert [(s.kind, s.start, s.length) for s in track.sections] == [
        ("transition", 0.0, 50.0),
        ("curve", 50.0, 30.0),
        ("transition", 80.0, 40.0),
    ]
    assert track.curves[0].radius == -125.0
    assert list(track.warnings) == [
        "track.csv: line 4: curvature_1_per_m -0.008, a radius of 125 m is outside railway practice, 150 m or "
        f"more ({PRACTICE})",
        f"track.csv: line 4: cant_m: 0.19 m is outside railway practice, 0-0.18 m ({BALLASTED})",
        "track.csv: line 4: cant_m 0.19 raises the inner rail of a curve of curvature -0.008 1/m (negative cant, "
        "found only on turnouts off canted curves): cant_m is signed as curvature_1_per_m, positive raising the "
        "right rail, the outer rail of a left curve",
    ]


def test_files(tmp_path):
    """load_track reads by suffix; anything else, an unreadable file or bad TOML is one line."""
    toml = tmp_path / "t.toml"
    toml.write_text('[[section]]\nkind = "curve"\nlength = 10\nradius = 300\n')
    assert load_track(toml).curves[0].radius == 300.0
    (tmp_path / "t.txt").write_text("")
    for path, message in [
        (tmp_path / "t.txt", "a track file is .toml (sections) or .csv (x_m, curvature_1_per_m, cant_m), got .txt"),
        (tmp_path / "missing.toml", "cannot read: No such file or directory"),
    ]:
        with pytest.raises(TrackError, match=f"^{re.escape(f'{path}: {message}')}"):
            load_track(path)
    toml.write_text("[[section]\n")
    with pytest.raises(TrackError, match=f"^{re.escape(str(toml))}: not valid TOML: "):
        load_track(toml)
    (tmp_path / "t.csv").write_bytes(b"\xff\xfe")
    with pytest.raises(TrackError, match=r"t\.csv: cannot read: "):
        load_track(tmp_path / "t.csv")
