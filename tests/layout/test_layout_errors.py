"""Bad input to `rail-mj` is refused cleanly.

The rule (see rail_mj/cli/main.py and rail_mj/layout/reader.py): bad input -- TOML syntax, an
unknown or missing key, a wrong type, mass <= 0, negative stiffness, conicity not in
(0, 0.5], overlapping positions ... -- exits with status 2 and one clear line on stderr
naming the file, the key and what is wrong. Never a traceback, never a half-written
output.

Each bad case takes a valid layout (below, checked valid by
`test_base_layouts_are_valid`) and breaks exactly one thing. None of them simulates:
the layout is refused before any model is built.
"""

from __future__ import annotations

import traceback
from pathlib import Path

import pytest

from rail_mj.cli import main
from rail_mj.layout import load_layout

# A bogie vehicle: [bogie] + [secondary], car body held fixed (as models/bogie/bogie.toml).
BOGIE = """\
name = "bogie"

[wheelset]
mass = 1813.0
inertia = [1120.0, 112.0, 1120.0]
rolling_radius = 0.46
contact_half_spacing = 0.75
conicity = 0.15
flangeway_clearance = 0.008

[creep]
f11 = 10.0e6
f22 = 9.0e6

[primary]
lateral_stiffness = 7.768e6
yaw_stiffness = 62.78e6
lateral_damping = 4.0e3

[bogie]
mass = 2615.0
inertia = [1722.0, 1476.0, 3067.0]
wheelset_positions = [1.28, -1.28]

[secondary]
lateral_stiffness = 320.0e3
yaw_stiffness = 320.0e3
lateral_damping = 64.0e3

[carbody]
fixed = true
bogie_positions = [0.0]
"""

# A two-axle wagon: no bogie, wheelsets hang from a free car body (as models/wagon/wagon.toml).
WAGON = """\
name = "wagon"

[wheelset]
mass = 1250.0
inertia = [700.0, 100.0, 700.0]
rolling_radius = 0.46
contact_half_spacing = 0.75
conicity = 0.15
flangeway_clearance = 0.008

[creep]
f11 = 10.0e6
f22 = 9.0e6

[primary]
lateral_stiffness = 1.0e6
yaw_stiffness = 4.0e6
lateral_damping = 20.0e3

[carbody]
fixed = false
mass = 20000.0
inertia = [20.0e3, 1.8e5, 1.8e5]
wheelset_positions = [3.0, -3.0]
"""

BASES = {"bogie": BOGIE, "wagon": WAGON}

SECONDARY_BLOCK = """\
[secondary]
lateral_stiffness = 320.0e3
yaw_stiffness = 320.0e3
lateral_damping = 64.0e3
"""


def broken(base: str, old: str, new: str) -> str:
    """`base` with the one occurrence of `old` replaced by `new`."""
    assert base.count(old) == 1, f"{old!r} must occur exactly once in the base layout"
    return base.replace(old, new)


def case(id, text, key, what):
    """One bad layout: `key` and one of `what` (a str or a tuple of alternatives)
    must both appear in the error line."""
    return pytest.param(text, key, what if isinstance(what, tuple) else (what,), id=id)


HUGE_INT = "1" + "0" * 400  # a valid TOML integer too large for a float

BAD_LAYOUTS = [
    # --- TOML syntax
    case("toml-syntax-double-equals", broken(BOGIE, "mass = 1813.0", "mass = = 1813.0"), "line 4", "not valid TOML"),
    case("toml-syntax-unclosed-table", broken(BOGIE, "[creep]", "[creep"), "not valid TOML", "Expected ']'"),
    case("toml-duplicate-key", broken(BOGIE, "f22 = 9.0e6", "f22 = 9.0e6\nf22 = 8.0e6"), "not valid TOML", "overwrite"),
    case("invalid-utf8", b'name = "bogie\xff\xfe"\n', "cannot read", ("utf-8", "decode")),
    case("empty-file", "", "name", "missing"),
    # --- unknown keys
    case(
        "unknown-top-level-key",
        broken(BOGIE, 'name = "bogie"', 'name = "bogie"\ncolour = "red"'),
        "colour",
        "unknown key",
    ),
    case("unknown-top-level-table", BOGIE + "\n[track]\ngauge = 1.435\n", "track", "unknown key"),
    case(
        "typo-in-table-required-key",
        broken(BOGIE, "mass = 1813.0", "mas = 1813.0"),
        "wheelset.mas",
        ("missing", "unknown key"),
    ),
    case(
        "typo-in-table-optional-key",
        broken(BOGIE, "lateral_damping = 4.0e3", "lateral_dampin = 4.0e3"),
        "primary.lateral_dampin",
        "unknown key",
    ),
    case("unknown-key-in-creep", broken(BOGIE, "f22 = 9.0e6", "f22 = 9.0e6\nf12 = 1.0e6"), "creep.f12", "unknown key"),
    # --- missing keys and tables
    case("missing-wheelset-mass", broken(BOGIE, "mass = 1813.0\n", ""), "wheelset.mass", "missing"),
    case("missing-name", broken(BOGIE, 'name = "bogie"\n', ""), "name", "missing"),
    case("missing-creep-table", broken(BOGIE, "[creep]\nf11 = 10.0e6\nf22 = 9.0e6\n", ""), "creep", "missing"),
    case(
        "missing-primary-yaw-stiffness",
        broken(WAGON, "yaw_stiffness = 4.0e6\n", ""),
        "primary.yaw_stiffness",
        "missing",
    ),
    case(
        "missing-carbody-positions",
        broken(WAGON, "wheelset_positions = [3.0, -3.0]\n", ""),
        "carbody.wheelset_positions",
        "missing",
    ),
    # --- wrong types
    case(
        "string-for-number",
        broken(BOGIE, "conicity = 0.15", 'conicity = "0.15"'),
        "wheelset.conicity",
        "must be a number",
    ),
    case(
        "boolean-for-number",
        broken(BOGIE, "rolling_radius = 0.46", "rolling_radius = true"),
        "wheelset.rolling_radius",
        "must be a number",
    ),
    case(
        "inertia-two-entries",
        broken(BOGIE, "inertia = [1120.0, 112.0, 1120.0]", "inertia = [1120.0, 112.0]"),
        "wheelset.inertia",
        "3 numbers",
    ),
    case(
        "inertia-negative-entry",
        broken(BOGIE, "inertia = [1722.0, 1476.0, 3067.0]", "inertia = [1722.0, -1476.0, 3067.0]"),
        "bogie.inertia",
        "positive",
    ),
    case(
        "table-is-a-number",
        broken(
            broken(BOGIE, "[creep]\nf11 = 10.0e6\nf22 = 9.0e6\n", ""), 'name = "bogie"', 'name = "bogie"\ncreep = 5'
        ),
        "creep",
        "must be a table",
    ),
    case("fixed-not-boolean", broken(BOGIE, "fixed = true", 'fixed = "yes"'), "carbody.fixed", "true or false"),
    case(
        "positions-not-a-list",
        broken(BOGIE, "wheelset_positions = [1.28, -1.28]", "wheelset_positions = 1.28"),
        "bogie.wheelset_positions",
        "list",
    ),
    case("nan-conicity", broken(BOGIE, "conicity = 0.15", "conicity = nan"), "wheelset.conicity", "finite"),
    case(
        "huge-integer-mass",
        broken(BOGIE, "mass = 1813.0", f"mass = {HUGE_INT}"),
        "wheelset.mass",
        ("finite", "too large"),
    ),
    case(
        "huge-integer-inertia",
        broken(BOGIE, "inertia = [1120.0, 112.0, 1120.0]", f"inertia = [{HUGE_INT}, 112.0, 1120.0]"),
        "wheelset.inertia",
        ("finite", "too large", "positive number"),
    ),
    case(
        "integer-beyond-python-digit-limit",
        broken(BOGIE, "mass = 1813.0", "mass = 1" + "0" * 5000),
        "not valid TOML",
        "digits",
    ),
    # --- out-of-range numbers
    case("wheelset-mass-zero", broken(BOGIE, "mass = 1813.0", "mass = 0.0"), "wheelset.mass", "> 0"),
    case("bogie-mass-negative", broken(BOGIE, "mass = 2615.0", "mass = -2615.0"), "bogie.mass", "> 0"),
    case("carbody-mass-zero", broken(WAGON, "mass = 20000.0", "mass = 0"), "carbody.mass", "> 0"),
    case(
        "negative-primary-stiffness",
        broken(BOGIE, "lateral_stiffness = 7.768e6", "lateral_stiffness = -7.768e6"),
        "primary.lateral_stiffness",
        ">= 0",
    ),
    case(
        "negative-secondary-yaw-stiffness",
        broken(BOGIE, "yaw_stiffness = 320.0e3", "yaw_stiffness = -1.0"),
        "secondary.yaw_stiffness",
        ">= 0",
    ),
    case(
        "negative-damping",
        broken(WAGON, "lateral_damping = 20.0e3", "lateral_damping = -1.0"),
        "primary.lateral_damping",
        ">= 0",
    ),
    case("conicity-zero", broken(BOGIE, "conicity = 0.15", "conicity = 0.0"), "wheelset.conicity", "> 0"),
    case("conicity-0.6", broken(BOGIE, "conicity = 0.15", "conicity = 0.6"), "wheelset.conicity", "<= 0.5"),
    case("creep-f22-zero", broken(BOGIE, "f22 = 9.0e6", "f22 = 0.0"), "creep.f22", "> 0"),
    case(
        "rolling-radius-in-mm",
        broken(BOGIE, "rolling_radius = 0.46", "rolling_radius = 460.0"),
        "wheelset.rolling_radius",
        "units",
    ),
    # --- positions
    case(
        "bogie-wheelsets-overlap",
        broken(BOGIE, "wheelset_positions = [1.28, -1.28]", "wheelset_positions = [0.4, -0.4]"),
        "bogie.wheelset_positions",
        "overlap",
    ),
    case(
        "wagon-wheelsets-overlap",
        broken(WAGON, "wheelset_positions = [3.0, -3.0]", "wheelset_positions = [0.3, -0.3]"),
        "carbody.wheelset_positions",
        "overlap",
    ),
    case(
        "bogies-overlap",
        broken(BOGIE, "bogie_positions = [0.0]", "bogie_positions = [1.5, -1.5]"),
        "carbody.bogie_positions",
        "overlap",
    ),
    case(
        "positions-trailing-first",
        broken(BOGIE, "wheelset_positions = [1.28, -1.28]", "wheelset_positions = [-1.28, 1.28]"),
        "bogie.wheelset_positions",
        "leading",
    ),
    case(
        "positions-empty",
        broken(WAGON, "wheelset_positions = [3.0, -3.0]", "wheelset_positions = []"),
        "carbody.wheelset_positions",
        "non-empty",
    ),
    case(
        "positions-hold-a-string",
        broken(WAGON, "wheelset_positions = [3.0, -3.0]", 'wheelset_positions = [3.0, "-3.0"]'),
        "carbody.wheelset_positions",
        "numbers only",
    ),
    # --- structure
    case("bogie-without-secondary", broken(BOGIE, SECONDARY_BLOCK, ""), "secondary", "needs [secondary]"),
    case(
        "secondary-without-bogie",
        broken(WAGON, "[carbody]", SECONDARY_BLOCK + "\n[carbody]"),
        "secondary",
        "without [bogie]",
    ),
    case(
        "bogie-positions-without-bogie",
        broken(WAGON, "wheelset_positions = [3.0, -3.0]", "wheelset_positions = [3.0, -3.0]\nbogie_positions = [0.0]"),
        "carbody.bogie_positions",
        "without a [bogie]",
    ),
    case(
        "carbody-wheelset-positions-with-bogie",
        broken(BOGIE, "bogie_positions = [0.0]", "bogie_positions = [0.0]\nwheelset_positions = [0.0]"),
        "carbody.wheelset_positions",
        "not allowed with [bogie]",
    ),
    case(
        "carbody-free-without-mass",
        broken(BOGIE, "fixed = true", "fixed = false\ninertia = [1.0e4, 1.0e5, 1.0e5]"),
        "carbody.mass",
        "missing",
    ),
    case(
        "carbody-free-without-inertia",
        broken(WAGON, "inertia = [20.0e3, 1.8e5, 1.8e5]\n", ""),
        "carbody.inertia",
        "missing",
    ),
    # --- names (the name becomes a file name in `generate`)
    case("name-with-space", broken(BOGIE, 'name = "bogie"', 'name = "my bogie"'), "name", "letters"),
    case("name-with-slash", broken(BOGIE, 'name = "bogie"', 'name = "../bogie"'), "name", "letters"),
    case("name-with-trailing-newline", broken(BOGIE, 'name = "bogie"', 'name = "bogie\\n"'), "name", "letters"),
    case("name-empty", broken(BOGIE, 'name = "bogie"', 'name = ""'), "name", "letters"),
    case("name-not-a-string", broken(BOGIE, 'name = "bogie"', "name = 7"), "name", "letters"),
]


def call(argv: list[str], capsys) -> tuple[int, str, str]:
    """Run the CLI in-process; an exception escaping `main` is a traceback, a failure."""
    try:
        status = main(argv)
    except BaseException as e:
        pytest.fail(
            f"rail-mj {' '.join(argv)} raised instead of exiting cleanly:\n" + "".join(traceback.format_exception(e))
        )
    out, err = capsys.readouterr()
    return status, out, err


def one_line(err: str) -> str:
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].strip(), f"expected one non-empty line on stderr, got {err!r}"
    assert "Traceback" not in err
    return lines[0]


def assert_mentions(line: str, key: str, what: tuple[str, ...]) -> None:
    assert key in line, f"{key!r} not named in {line!r}"
    assert any(w in line for w in what), f"none of {what!r} in {line!r}"


def nothing_written(tmp_path: Path, keep: set[Path]) -> None:
    out, gen = tmp_path / "out.csv", tmp_path / "gen"
    assert not out.exists(), "run wrote out.csv despite the error"
    assert not gen.exists() or not any(gen.iterdir()), f"generate wrote {sorted(gen.rglob('*'))}"
    stray = set(tmp_path.iterdir()) - keep - {gen}
    assert not stray, f"left behind: {sorted(stray)}"


def run_argv(path: Path, tmp_path: Path) -> list[str]:
    return ["run", str(path), "--speed", "30", "--distance", "10", "--out", str(tmp_path / "out.csv")]


def generate_argv(path: Path, tmp_path: Path) -> list[str]:
    return ["generate", str(path), "-o", str(tmp_path / "gen")]


@pytest.mark.parametrize("name", sorted(BASES))
def test_base_layouts_are_valid(name, tmp_path):
    """Each bad case breaks one thing in a layout that is otherwise fine."""
    path = tmp_path / f"{name}.toml"
    path.write_text(BASES[name])
    assert load_layout(path).name == name


@pytest.mark.parametrize("text, key, what", BAD_LAYOUTS)
@pytest.mark.parametrize("command", ["run", "generate"])
def test_bad_layout(command, text, key, what, tmp_path, capsys):
    path = tmp_path / "layout.toml"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    argv = (run_argv if command == "run" else generate_argv)(path, tmp_path)

    status, out, err = call(argv, capsys)

    line = one_line(err)
    assert status == 2, f"status {status}, stderr {err!r}"
    assert str(path) in line, f"file not named in {line!r}"
    assert_mentions(line, key, what)
    assert out == ""
    nothing_written(tmp_path, keep={path})


@pytest.mark.parametrize("command", ["run", "generate"])
def test_missing_layout_file(command, tmp_path, capsys):
    path = tmp_path / "no-such-layout.toml"
    argv = (run_argv if command == "run" else generate_argv)(path, tmp_path)

    status, out, err = call(argv, capsys)

    line = one_line(err)
    assert status == 2
    assert str(path) in line
    assert_mentions(line, "cannot read", ("No such file",))
    assert out == ""
    nothing_written(tmp_path, keep=set())


@pytest.fixture
def valid_layout(tmp_path) -> Path:
    path = tmp_path / "layout.toml"
    path.write_text(BOGIE)
    return path


@pytest.mark.parametrize(
    "option, value",
    [
        pytest.param("--speed", "-5", id="speed-negative"),
        pytest.param("--speed", "0", id="speed-zero"),
        pytest.param("--speed", "abc", id="speed-not-a-number"),
        pytest.param("--speed", "nan", id="speed-nan"),
        pytest.param("--speed", "inf", id="speed-inf"),
        pytest.param("--distance", "0", id="distance-zero"),
        pytest.param("--distance", "-10", id="distance-negative"),
        pytest.param("--distance", "ten", id="distance-not-a-number"),
        pytest.param("--initial-lateral", "nan", id="initial-lateral-nan"),
        pytest.param("--initial-lateral", "0.5", id="initial-lateral-off-the-rails"),
        pytest.param("--initial-yaw", "x", id="initial-yaw-not-a-number"),
    ],
)
def test_bad_command_line_value(option, value, valid_layout, tmp_path, capsys):
    args = {"--speed": "30", "--distance": "10", option: value}
    argv = ["run", str(valid_layout), "--out", str(tmp_path / "out.csv")]
    for k, v in args.items():
        argv += [k, v]

    status, out, err = call(argv, capsys)

    line = one_line(err)
    assert status == 2, f"status {status} for {option} {value}: {out!r}"
    word = option.lstrip("-").replace("-", " ")  # the runner says "initial lateral"
    assert option in line or word in line, f"{option} not named in {line!r}"
    assert out == ""
    nothing_written(tmp_path, keep={valid_layout})


@pytest.mark.parametrize("missing", ["--speed", "--distance"])
def test_missing_required_option(missing, valid_layout, tmp_path, capsys):
    args = {"--speed": "30", "--distance": "10"}
    del args[missing]
    argv = ["run", str(valid_layout), "--out", str(tmp_path / "out.csv")]
    for k, v in args.items():
        argv += [k, v]

    status, _out, err = call(argv, capsys)

    line = one_line(err)
    assert status == 2
    assert missing in line
    nothing_written(tmp_path, keep={valid_layout})


def test_unknown_option(valid_layout, tmp_path, capsys):
    argv = run_argv(valid_layout, tmp_path) + ["--sped", "30"]
    status, _out, err = call(argv, capsys)
    line = one_line(err)
    assert status == 2
    assert "--sped" in line
    nothing_written(tmp_path, keep={valid_layout})


@pytest.mark.parametrize("option", ["--out", "--rrd"])
def test_output_is_an_existing_folder(option, valid_layout, tmp_path, capsys):
    folder = tmp_path / "results"
    folder.mkdir()
    argv = ["run", str(valid_layout), "--speed", "30", "--distance", "10", option, str(folder)]

    status, out, err = call(argv, capsys)

    line = one_line(err)
    assert status == 2, f"status {status}, stderr {err!r}"
    assert str(folder) in line
    assert out == ""
    assert not any(folder.iterdir()), "something was written into the folder"


def test_layout_is_a_folder(tmp_path, capsys):
    folder = tmp_path / "layout.toml"
    folder.mkdir()
    status, _out, err = call(run_argv(folder, tmp_path), capsys)
    line = one_line(err)
    assert status == 2
    assert str(folder) in line
    nothing_written(tmp_path, keep={folder})


def test_valid_layout_runs_and_generates(valid_layout, tmp_path, capsys):
    """The harness itself: the unbroken layout passes both commands and writes its output."""
    status, _out, err = call(run_argv(valid_layout, tmp_path), capsys)
    assert status == 0, err
    assert (tmp_path / "out.csv").read_text().startswith("t")

    status, _out, err = call(generate_argv(valid_layout, tmp_path), capsys)
    assert status == 0, err
    gen = tmp_path / "gen"
    assert {p.name for p in gen.iterdir()} >= {"bogie.xml", "scene.xml", "assets"}
    assert not list(gen.rglob(".*.tmp")), "temporary files left behind"
