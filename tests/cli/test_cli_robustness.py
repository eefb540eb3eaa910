"""The command line as a newcomer meets it: outputs that never destroy what is there,
no traceback whatever the arguments, plausibility checks, honest summaries, start-up.

Special files are made in a temporary folder (FIFOs, symbolic links), never in /dev.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS, worn_coach_copy

from rail_mj.cli import main
from rail_mj.practice import RANGES, max_initial_yaw

WHEELSET = MODELS / "wheelset" / "wheelset.toml"
BOGIE = MODELS / "bogie" / "bogie.toml"
COACH = MODELS / "manchester-coach" / "manchester-coach.toml"
SHORT_RUN = ["--speed", "30", "--distance", "3"]


def run(argv, capsys):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def one_line(text: str) -> str:
    """The one error (or warning) line of stderr; any other line must be a warning."""
    lines = text.strip().splitlines()
    errors = [line for line in lines if not line.startswith("rail-mj: warning: ")] or lines
    assert len(errors) == 1, f"expected one line, got {lines!r}"
    return errors[0]


# --- 1. outputs never destroy what is there ------------------------------------------


def test_output_through_a_symlink_replaces_its_target_and_keeps_the_link(tmp_path, capsys):
    target = tmp_path / "data" / "run.csv"
    target.parent.mkdir()
    target.write_text("old\n")
    link = tmp_path / "latest.csv"
    link.symlink_to(target)
    status, _out, err = run(["run", WHEELSET, *SHORT_RUN, "--out", link], capsys)
    assert status == 0, err
    assert link.is_symlink() and link.resolve() == target
    assert target.read_text().startswith("t,x,y1,psi1")
    assert not list(tmp_path.rglob(".*.tmp"))


def test_output_through_a_dangling_symlink_creates_its_target(tmp_path, capsys):
    link = tmp_path / "run.rrd"
    link.symlink_to(tmp_path / "recording.rrd")
    status, _out, err = run(["run", WHEELSET, *SHORT_RUN, "--rrd", link], capsys)
    assert status == 0, err
    assert link.is_symlink() and (tmp_path / "recording.rrd").stat().st_size > 0


def test_output_into_a_fifo_is_written_through_and_the_fifo_stays(tmp_path, capsys):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    received = []
    reader = threading.Thread(target=lambda: received.append(fifo.read_bytes()))
    reader.start()
    status, _out, err = run(["run", WHEELSET, *SHORT_RUN, "--out", fifo], capsys)
    reader.join(timeout=60)
    assert status == 0, err
    assert fifo.is_fifo()
    assert received and received[0].decode().startswith("t,x,y1,psi1")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe"]


def test_dash_is_standard_output_and_the_summary_moves_to_stderr(capsys):
    status, out, err = run(["run", WHEELSET, *SHORT_RUN, "--out", "-"], capsys)
    assert status == 0, err
    assert out.startswith("t,x,y1,psi1,")
    data = np.loadtxt(out.splitlines(), delimiter=",", skiprows=1)
    assert data.shape[0] > 10 and data[-1, 1] >= 3.0
    assert "wheelset" in err and "samples: -" in err


def test_standard_output_takes_one_output_only(tmp_path, capsys):
    status, out, err = run(["run", WHEELSET, *SHORT_RUN, "--out", "-", "--rrd", "-"], capsys)
    assert status == 2 and "standard output" in one_line(err)
    assert out == ""


def test_all_or_nothing_still_holds_for_regular_files_beside_a_fifo(tmp_path, capsys):
    """A regular output that cannot be written takes the others with it, FIFO included:
    nothing is written into the FIFO before every regular file is ready."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    status, _out, err = run(["run", WHEELSET, *SHORT_RUN, "--out", fifo, "--rrd", "/proc/run.rrd"], capsys)
    assert status == 2 and "/proc/run.rrd" in one_line(err)
    assert fifo.is_fifo() and sorted(p.name for p in tmp_path.iterdir()) == ["pipe"]


# --- 2. no traceback, whatever the arguments -----------------------------------------

HOSTILE = [
    # run: absurd speeds and distances, and disturbances off the rails
    ["run", WHEELSET, "--speed", "5000", "--distance", "100"],
    ["run", WHEELSET, "--speed", "1e6", "--distance", "10"],
    ["run", WHEELSET, "--speed", "1e-300", "--distance", "10"],
    ["run", WHEELSET, "--speed", "30", "--distance", "1e30"],
    ["run", WHEELSET, "--speed", "30", "--distance", "1e-9"],
    ["run", WHEELSET, "--speed", "300", "--distance", "100"],
    ["run", BOGIE, "--speed", "50", "--distance", "50", "--initial-yaw", "3"],
    ["run", BOGIE, "--speed", "50", "--distance", "50", "--initial-yaw", "-inf"],
    ["run", BOGIE, "--speed", "50", "--distance", "50", "--initial-lateral", "0.071"],
    ["run", BOGIE, "--speed", "-0", "--distance", "50"],
    ["run", BOGIE, "--speed", "30"],
    ["run", BOGIE, "--speed", "30", "--distance", "5", "--out", ""],
    ["run", "/nonexistent/layout.toml", "--speed", "30", "--distance", "5"],
    ["run", MODELS, "--speed", "30", "--distance", "5"],
    # eigen
    ["eigen", WHEELSET, "--speed", "1e9"],
    ["eigen", WHEELSET, "--speed", "nan"],
    ["eigen", WHEELSET, "--speed", "-1"],
    ["eigen", WHEELSET, "--speed", "1e-300"],
    # critical speed
    ["critical-speed", WHEELSET, "--vmin", "0", "--vmax", "10"],
    ["critical-speed", WHEELSET, "--vmin", "5", "--vmax", "1e9"],
    ["critical-speed", WHEELSET, "--vmin", "50", "--vmax", "5"],
    ["critical-speed", WHEELSET, "--method", "nonlinear", "--step", "5"],
    ["critical-speed", WHEELSET, "--method", "nonlinear", "--step", "nan"],
    ["critical-speed", MODELS / "wagon" / "wagon.toml", "--method", "nonlinear"],
    ["critical-speed", WHEELSET, "--method", "warp"],
    ["critical-speed", WHEELSET, "--method", "ramp", "--deceleration", "0"],
    ["critical-speed", WHEELSET, "--method", "ramp", "--deceleration", "nan"],
    ["critical-speed", WHEELSET, "--method", "ramp", "--deceleration", "50"],
    ["critical-speed", MODELS / "wagon" / "wagon.toml", "--method", "ramp"],
    ["critical-speed", WHEELSET, "--deceleration", "0.1"],
    # speed profiles
    ["run", BOGIE, "--distance", "5"],
    ["run", BOGIE, "--speed", "30", "--speed-profile", "0:30", "--distance", "5"],
    ["run", BOGIE, "--speed-profile", "0:30,0:40", "--distance", "5"],
    ["run", BOGIE, "--speed-profile", "0:30,10:-1", "--distance", "5"],
    ["run", BOGIE, "--speed-profile", "0:30,10", "--distance", "5"],
    ["run", BOGIE, "--speed-profile", "0:30,10:1e-300", "--distance", "5"],
    # --amplitude: for profiled layouts only, within the contact tables
    ["eigen", WHEELSET, "--speed", "30", "--amplitude", "3"],
    ["eigen", MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml", "--speed", "30", "--amplitude", "nan"],
    ["critical-speed", MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml", "--amplitude", "-1"],
    [
        "root-locus",
        MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml",
        "--speeds",
        "20:80:3",
        "-o",
        "l.png",
        "--amplitude",
        "1e9",
    ],
    # root locus and bifurcation
    ["root-locus", WHEELSET, "--speeds", "1:1e9:3", "-o", "locus.png"],
    ["root-locus", WHEELSET, "--speeds", "a:b:c", "-o", "locus.png"],
    ["root-locus", WHEELSET, "--speeds", "5:10:1", "-o", "locus.png"],
    ["root-locus", WHEELSET, "--speeds", "5:10:3", "-o", "-", "--csv", "-"],
    ["bifurcation", WHEELSET, "-o", "b.png", "--step", "0"],
    ["bifurcation", WHEELSET, "-o", "b.png", "--vmax", "inf"],
    ["bifurcation", MODELS / "wagon" / "wagon.toml", "-o", "b.png"],
    # sweeps and maps
    ["sweep", WHEELSET, "--speeds", "30:40:2", "--grid", "primary.yaw_stifness=1:2:2", "-o", "s.csv"],
    ["sweep", WHEELSET, "--speeds", "30:40:2", "--grid", "wheelset.conicity=a:b:c", "-o", "s.csv"],
    ["sweep", WHEELSET, "--speeds", "30:40:2", "--set", "wheelset", "-o", "s.csv"],
    ["sweep", WHEELSET, "--speeds", "30:40:2", "--set", "wheelset.mass.x=1", "-o", "s.csv"],
    ["sweep", WHEELSET, "--speeds", "30:40:2", "--workers", "0", "-o", "s.csv"],
    ["sweep", WHEELSET, "--speeds", "30:40:2", "--scheduler", "", "-o", "s.csv"],
    # track: not a track, no such file, a layout given as a track, an output that is a folder
    ["track", "missing.toml", "-o", "c.csv"],
    ["track", WHEELSET, "-o", "c.csv"],
    ["track", MODELS / "tracks" / "curve-600.toml", "-o", "c.csv"],
    ["track", MODELS / "tracks" / "curve-600.toml", "-o", "/proc/c.csv"],
    ["track", MODELS / "tracks" / "curve-600.toml"],
    # response: no speed, a bad one, a folder for the plot, a layout for a track, a curve without irregularities
    ["response", WHEELSET, "-o", "r.png"],
    ["response", WHEELSET, "--speed", "-3", "-o", "r.png"],
    ["response", WHEELSET, "--speed", "30", "-o", "."],
    ["response", WHEELSET, "--speed", "30", "--track", WHEELSET, "-o", "r.png"],
    ["response", WHEELSET, "--speed", "30", "--track", MODELS / "tracks" / "curve-600.toml", "-o", "r.png"],
    ["response", WHEELSET, "--speed", "30", "--inputs", ",", "-o", "r.png"],
    ["response", WHEELSET, "--speed", "30", "--frequencies", "1:2", "-o", "r.png"],
    ["sweep", WHEELSET, "--speeds", "30:40:2", "-o", "s.xlsx"],
    ["sweep", WHEELSET, "--speeds", "5:150:1", "--method", "eigen", "-o", "s.csv"],
    ["map", WHEELSET, "--x", "wheelset.conicity=0.1:0.2:2", "--y", "wheelset.conicity=0.1:0.2:2", "-o", "m.png"],
    [
        "map",
        WHEELSET,
        "--x",
        "wheelset.conicity=0.1:0.2:2",
        "--y",
        "primary.yaw_stiffness=1e6:2e6:2",
        "--method",
        "nonlinear",
        "-o",
        "m.png",
    ],
    ["map", WHEELSET, "--x", "conicity", "--y", "primary.yaw_stiffness=1e6:2e6:2", "-o", "m.png"],
    # profiles and conicity
    ["profile", "s1003", "-o", "p.csv"],
    ["profile", WHEELSET, "-o", "p.csv"],
    ["profile", "s1002", "-o", "-", "--png", "-"],
    ["conicity"],
    ["conicity", WHEELSET, "--amplitudes", "0:0:0"],
    ["conicity", "--delta-r", WHEELSET],
    # one contact patch's creep forces
    [
        "creep",
        "--semi-axes",
        "-0.007",
        "0.005",
        "--normal-force",
        "1e5",
        "--creepages",
        "0.001",
        "0",
        "0",
        "--friction",
        "0.3",
        "--shear-modulus",
        "8e10",
        "--poisson",
        "0.28",
        "--law",
        "fastsim",
    ],
    [
        "creep",
        "--semi-axes",
        "0.007",
        "0.0001",
        "--normal-force",
        "1e5",
        "--creepages",
        "0.001",
        "0",
        "0",
        "--friction",
        "0.3",
        "--shear-modulus",
        "8e10",
        "--poisson",
        "0.28",
        "--law",
        "polach",
    ],
    [
        "creep",
        "--semi-axes",
        "nan",
        "0.005",
        "--normal-force",
        "1e5",
        "--creepages",
        "0.001",
        "0",
        "0",
        "--friction",
        "0.3",
        "--shear-modulus",
        "8e10",
        "--poisson",
        "0.28",
        "--law",
        "fastsim",
    ],
    [
        "creep",
        "--semi-axes",
        "0.007",
        "0.005",
        "--normal-force",
        "1e5",
        "--creepages",
        "0.001",
        "0",
        "0",
        "--friction",
        "0.3",
        "--shear-modulus",
        "8e10",
        "--poisson",
        "0.7",
        "--law",
        "linear",
    ],
    [
        "creep",
        "--semi-axes",
        "0.007",
        "0.005",
        "--normal-force",
        "1e5",
        "--creepages",
        "0.001",
        "0",
        "0",
        "--friction",
        "-0.3",
        "--shear-modulus",
        "8e10",
        "--poisson",
        "0.28",
        "--law",
        "fastsim",
    ],
    [
        "creep",
        "--semi-axes",
        "0.007",
        "0.005",
        "--normal-force",
        "1e5",
        "--creepages",
        "0.001",
        "0",
        "0",
        "--shear-modulus",
        "8e10",
        "--poisson",
        "0.28",
        "--law",
        "shen-hedrick-elkins",
    ],
    [
        "creep",
        "--semi-axes",
        "0.007",
        "0.005",
        "--normal-force",
        "inf",
        "--creepages",
        "1e308",
        "0",
        "-1e308",
        "--friction",
        "0.3",
        "--shear-modulus",
        "1e300",
        "--poisson",
        "0.28",
        "--law",
        "fastsim",
    ],
    [
        "creep",
        "--semi-axes",
        "1e-6",
        "1e-6",
        "--normal-force",
        "1e15",
        "--creepages",
        "1",
        "-1",
        "1000",
        "--friction",
        "2",
        "--shear-modulus",
        "1e15",
        "--poisson",
        "0.5",
        "--law",
        "fastsim",
    ],
    [
        "creep",
        "--semi-axes",
        "1",
        "1",
        "--normal-force",
        "1e-300",
        "--creepages",
        "1",
        "-1",
        "-1000",
        "--friction",
        "0.01",
        "--shear-modulus",
        "1e-300",
        "--poisson",
        "0",
        "--law",
        "polach",
        "--json",
    ],
    [
        "creep",
        "--semi-axes",
        "0.007",
        "--normal-force",
        "1e5",
        "--creepages",
        "0.001",
        "0",
        "0",
        "--friction",
        "0.3",
        "--shear-modulus",
        "8e10",
        "--poisson",
        "0.28",
        "--law",
        "fastsim",
    ],
    [
        "creep",
        "--semi-axes",
        "0.007",
        "0.005",
        "--normal-force",
        "1e5",
        "--creepages",
        "0.001",
        "0",
        "0",
        "--friction",
        "0.3",
        "--shear-modulus",
        "8e10",
        "--poisson",
        "0.28",
        "--law",
        "coulomb",
    ],
    ["creep", "--semi-axes", "0.007", "0.005", "--law", "fastsim"],
    # the rest
    ["contact", WHEELSET],
    ["generate", WHEELSET, "-o", "-"],
    ["generate", WHEELSET],
    ["no-such-command"],
    [],
]


@pytest.mark.parametrize("argv", HOSTILE, ids=lambda a: " ".join(str(x) for x in a)[-60:] or "none")
def test_hostile_arguments_end_in_one_line_and_a_known_status(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    status, out, err = run(argv, capsys)
    assert status in (0, 2, 3), f"status {status}: {err!r}"
    assert "Traceback" not in out + err
    assert "unexpected" not in err, err  # the last line of defence was not needed
    if status:
        assert one_line(err).startswith("rail-mj: error: ")
        assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_a_large_initial_yaw_is_refused_and_named(capsys):
    status, _out, err = run(["run", BOGIE, "--speed", "50", "--distance", "50", "--initial-yaw", "3"], capsys)
    line = one_line(err)
    assert status == 2 and "--initial-yaw" in line and "critical speed" not in line


def test_a_derailment_from_a_stable_speed_blames_the_start(tmp_path):
    """Through the Python API a violent start can still throw a stable vehicle off the
    rails: the message blames the start, not the speed."""
    from rail_mj import load_layout, simulate
    from rail_mj.simulation.run import Derailed

    with pytest.raises(Derailed, match=r"stable.*start") as e:
        simulate(load_layout(BOGIE), speed=40.0, distance=50.0, initial_lateral=0.0, initial_yaw=3.0)
    assert "above this vehicle's critical speed" not in str(e.value)


def test_the_en14363_criterion_at_the_edges_of_its_range():
    """The shortest run it applies to at the highest speed gets a verdict; a shorter one
    says why it gets none (these raised from inside scipy's filter once)."""
    from rail_mj import load_layout, simulate
    from rail_mj.analysis import summary

    result = summary(simulate(load_layout(BOGIE), speed=300.0, distance=100.0, initial_lateral=0.0001))
    assert result["hunting_note"] is None and np.all(np.isfinite(result["hunting"]["max_rms_n"]))
    result = summary(simulate(load_layout(BOGIE), speed=30.0, distance=20.0, initial_lateral=0.0))
    assert result["hunting"] is None and "100 m" in result["hunting_note"]


# --- 3. plausibility -----------------------------------------------------------------


def _layout_with(tmp_path, old: str, new: str) -> Path:
    text = BOGIE.read_text()
    assert old in text
    path = tmp_path / "layout.toml"
    path.write_text(text.replace(old, new))
    return path


@pytest.mark.parametrize(
    "old, new, key",
    [
        ("flangeway_clearance = 0.008", "flangeway_clearance = 0.5", "wheelset.flangeway_clearance"),
        ("contact_half_spacing = 0.75", "contact_half_spacing = 50.0", "wheelset.contact_half_spacing"),
        ("rolling_radius = 0.46", "rolling_radius = 0.001", "wheelset.rolling_radius"),
        ("mass = 1813.0", "mass = 0.001", "wheelset.inertia"),
    ],
)
def test_impossible_layout_values_are_refused_naming_key_and_range(old, new, key, tmp_path, capsys):
    path = _layout_with(tmp_path, old, new)
    status, _out, err = run(["generate", path, "-o", tmp_path / "gen"], capsys)
    line = one_line(err)
    assert status == 2 and key in line
    assert "between" in line or "radius of gyration" in line
    assert not (tmp_path / "gen").exists()


def test_unusual_layout_values_are_warned_about_on_one_line(tmp_path, capsys):
    path = _layout_with(tmp_path, "rolling_radius = 0.46", "rolling_radius = 0.1")
    status, _out, err = run(["generate", path, "-o", tmp_path / "gen"], capsys)
    line = one_line(err)
    assert status == 0
    assert line.startswith("rail-mj: warning: ") and "wheelset.rolling_radius" in line
    assert "railway practice" in line and "0.16-0.65 m" in line


def test_initial_lateral_past_the_clearance_is_refused(tmp_path, capsys):
    path = _layout_with(tmp_path, "flangeway_clearance = 0.008", "flangeway_clearance = 0.007")
    status, _out, err = run(["run", path, "--speed", "30", "--distance", "10", "--initial-lateral", "0.071"], capsys)
    line = one_line(err)
    assert status == 2 and "--initial-lateral" in line and "0.007" in line


@pytest.mark.parametrize(
    "argv",
    [
        ["run", WHEELSET, "--speed", "1000", "--distance", "10"],
        ["eigen", WHEELSET, "--speed", "1e9"],
    ],
)
def test_speeds_beyond_any_railway_are_refused(argv, capsys):
    status, _out, err = run(argv, capsys)
    line = one_line(err)
    assert status == 2 and "--speed" in line and "160 m/s" in line


def test_speeds_past_the_record_are_warned_about(capsys):
    status, _out, err = run(["eigen", WHEELSET, "--speed", "200"], capsys)
    assert status == 0
    assert one_line(err).startswith("rail-mj: warning: --speed: 200 m/s is outside railway practice")


def test_the_yaw_limit_is_the_flange_geometry():
    """clearance / lead of the flange front: sqrt(0.488^2 - 0.46^2) = sqrt(0.026544) = 0.16292 m for r0 = 0.46."""
    assert max_initial_yaw(0.46, 0.008) == pytest.approx(0.008 / 0.16292, rel=1e-4)
    assert RANGES["speed"].check(160.0) is None and RANGES["speed"].warning(160.0) is None


CREEP = [
    "creep",
    "--semi-axes",
    "0.007",
    "0.005",
    "--normal-force",
    "1e5",
    "--friction",
    "0.3",
    "--shear-modulus",
    "8e10",
    "--poisson",
    "0.28",
    "--law",
    "fastsim",
]


@pytest.mark.parametrize(
    "key, narrower, argv, message",
    [
        (
            "contact.semi_axis",
            ((1e-3, 0.006), (1e-3, 0.006)),
            [*CREEP, "--creepages", "0", "0", "0"],
            "--semi-axes must be between 0.001 and 0.006 m, got 0.007",
        ),
        (
            "contact.creepage",
            ((-0.5, 0.5), (-0.5, 0.5)),
            [*CREEP, "--creepages", "0.6", "0", "0"],
            "--creepages XI and ETA must be within +/-0.5",
        ),
        ("contact.spin", ((-10.0, 10.0), (-10.0, 10.0)), [*CREEP, "--creepages", "0", "0", "20"], "within +/-10 rad/m"),
        (
            "contact.poisson_ratio",
            ((0.1, 0.25), (0.1, 0.25)),
            [*CREEP, "--creepages", "0", "0", "0"],
            "--poisson must be between 0.1 and 0.25, got 0.28",
        ),
        (
            "bifurcation.step",
            ((0.01, 0.1), (0.01, 0.1)),
            ["critical-speed", WHEELSET, "--method", "nonlinear", "--step", "0.005"],
            "--step must be between 0.01 and 0.1, got 0.005",
        ),
    ],
)
def test_the_command_line_takes_its_physical_ranges_from_the_table_of_practice(
    key, narrower, argv, message, monkeypatch, capsys
):
    """Narrow a range in rail_mj.layout.practice and the command refuses what it then excludes."""
    import dataclasses

    refuse, usual = narrower
    monkeypatch.setitem(RANGES, key, dataclasses.replace(RANGES[key], refuse=refuse, usual=usual))
    status, _out, err = run(argv, capsys)
    assert status == 2 and message in one_line(err)


# --- 5. honest summaries -------------------------------------------------------------


def test_a_decayed_motion_says_when_and_keeps_the_frequency_of_the_motion_itself(capsys):
    """The coach at 40 m/s: the 2 mm start dies within a second; what is left (the car
    body's slow sway, a thousandth of it) must not be reported as the motion."""
    status, out, err = run(["run", COACH, "--speed", "40", "--distance", "200", "--json"], capsys)
    assert status == 0, err
    result = json.loads(out)
    for w in result["wheelsets"]:
        assert w["decayed"] and w["decayed_by_m"] < 60.0
        assert w["final_abs_lateral_m"] < 0.05 * w["max_abs_lateral_m"]
        if w["frequency_hz"] is not None:
            assert w["frequency_hz"] > 1.5  # the wheelsets' own (kinematic) motion, not the body's
            assert w["growth_rate_per_s"] < 0
    text_status = main(["run", str(COACH), "--speed", "40", "--distance", "200"])
    assert text_status == 0 and "decayed by" in capsys.readouterr().out


def test_a_limit_cycle_is_not_called_decayed(capsys):
    status, out, err = run(["run", BOGIE, "--speed", "90", "--distance", "300", "--json"], capsys)
    assert status == 0, err
    result = json.loads(out)
    assert not any(w["decayed"] for w in result["wheelsets"])
    assert result["hunting"]["hunting"] is True


# --- 7. start-up -----------------------------------------------------------------------


def test_help_and_layout_errors_load_no_heavy_library(tmp_path):
    """`rail-mj --help` and a layout error must not wait for MuJoCo, numba, scipy or rerun
    (benchmarks/benchmark.py measures the time)."""
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n')
    probe = (
        "import sys; from rail_mj.cli import main\n"
        f"statuses = [main(['--help']), main(['run', {str(bad)!r}, '--speed', '30', '--distance', '5'])]\n"
        "heavy = sorted(m for m in ('mujoco', 'numba', 'scipy', 'rerun', 'trimesh', 'matplotlib', 'numpy')"
        " if m in sys.modules)\n"
        "print(statuses, heavy)\n"
    )
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert result.stdout.strip().splitlines()[-1] == "[0, 2] []"


def test_a_run_without_a_recording_loads_neither_rerun_nor_matplotlib_nor_trimesh():
    """A run asked for its summary alone does not pay for the recording's or the plots' libraries
    (rerun alone is 0.3 s, the recording module 1.3 s with what it pulls in), nor, once its wheel
    mesh is kept on disk by a first command, for trimesh (0.5 s)."""
    probe = (
        "import sys; from rail_mj.cli import main\n"
        f"status = main(['run', {str(WHEELSET)!r}, '--speed', '30', '--distance', '5'])\n"
        "heavy = ('rerun', 'matplotlib', 'trimesh', 'rail_mj.output.recording')\n"
        "print(status, sorted(m for m in heavy if m in sys.modules))\n"
    )
    for _ in range(2):  # the first may make the mesh
        result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert result.stdout.strip().splitlines()[-1] == "0 []"


@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_an_input_that_is_not_a_regular_file_is_refused_without_reading_it(kind, tmp_path, capsys):
    """A FIFO would block the reader forever and /dev/zero never ends: both refused in one line,
    unopened (the test would hang otherwise)."""
    if kind == "fifo":
        path = tmp_path / "layout.toml"
        os.mkfifo(path)
    else:
        path = Path("/dev/zero")
    status, _out, err = run(["run", path, "--speed", "30", "--distance", "5"], capsys)
    assert status == 2 and "not a regular file" in one_line(err)
    status, _out, err = run(["conicity", "--delta-r", path], capsys)
    assert status == 2 and "not a regular file" in one_line(err)


@pytest.mark.parametrize("law", ["[1]", "{a = 1}", "1"])
def test_a_creep_law_that_is_not_a_name_is_refused_in_one_line(law, tmp_path, capsys):
    text = WHEELSET.read_text().replace("f22 = 10.0e6\n", f"f22 = 10.0e6\nlaw = {law}\n")
    path = tmp_path / "law.toml"
    path.write_text(text)
    status, _out, err = run(["run", path, "--speed", "30", "--distance", "5"], capsys)
    assert status == 2 and "creep.law: must be one of linear" in one_line(err)


def test_a_recording_rate_below_one_sample_a_run_keeps_the_ends(tmp_path, capsys):
    rrd = tmp_path / "low.rrd"
    status, _out, err = run(
        ["run", WHEELSET, "--speed", "30", "--distance", "5", "--rrd", rrd, "--rrd-rate", "1e-308"], capsys
    )
    assert status == 0 and "Warning" not in err and rrd.stat().st_size > 0


@pytest.mark.parametrize(
    "key, value, says",
    [
        ("young_modulus", "1e-300", "contact.young_modulus: must be between"),
        ("young_modulus", "1e-3", "contact.young_modulus: must be between"),
        ("rail_transverse_radius", "1e-300", "contact.rail_transverse_radius: must be between"),
    ],
)
def test_a_contact_no_rail_has_is_refused_in_one_line(key, value, says, tmp_path, capsys):
    """[contact] values that reached the unexpected-error handler (exit 3), or, at 1e-3 Pa, gave a
    360 m Hertz ellipse without a word: refused by the table of practice."""
    text = WHEELSET.read_text().replace("conicity = 0.1\n", "conicity = 0.1\nwheel_load = 60e3\n")
    text = text.replace("f11 = 10.0e6\n", "").replace("f22 = 10.0e6\n", "")
    contact = {"young_modulus": "210e9", "poisson_ratio": "0.28", "rail_transverse_radius": "0.3"} | {key: value}
    path = tmp_path / "contact.toml"
    path.write_text(text + "[contact]\n" + "".join(f"{k} = {v}\n" for k, v in contact.items()))
    status, _out, err = run(["run", path, "--speed", "30", "--distance", "5"], capsys)
    assert status == 2 and says in one_line(err)


def test_arrays_nested_a_thousand_deep_are_refused_in_one_line(tmp_path, capsys):
    path = tmp_path / "deep.toml"
    path.write_text('name = "w"\nx = ' + "[" * 1000 + "]" * 1000 + "\n")
    status, _out, err = run(["run", path, "--speed", "30", "--distance", "5"], capsys)
    assert status == 2 and "nested too deeply" in one_line(err)


@pytest.mark.parametrize("name", ["wheelset.xml", "scene.xml", "assets/layout.toml"])
def test_generate_never_writes_over_its_own_layout(name, tmp_path, capsys):
    """A layout named as one of the files generate writes into -o DIR: refused, the layout intact."""
    path = tmp_path / name
    path.parent.mkdir(exist_ok=True)
    text = WHEELSET.read_text()
    path.write_text(text)
    status, _out, err = run(["generate", path, "-o", tmp_path], capsys)
    assert status == 2 and "would overwrite the layout file" in one_line(err)
    assert path.read_text() == text


@pytest.mark.parametrize(
    "argv",
    [
        ["contact-geometry", "{layout}", "-o", "{wheel}"],
        ["run", "{layout}", "--speed", "30", "--distance", "5", "--out", "{wheel}"],
        ["sweep", "{layout}", "--speeds", "30:40:2", "-o", "{wheel}"],
    ],
    ids=["contact-geometry", "run", "sweep"],
)
def test_no_output_is_a_profile_file_the_layout_reads(argv, tmp_path, capsys):
    layout, wheel = worn_coach_copy(tmp_path)
    before = wheel.read_bytes()
    argv = [a.format(layout=layout, wheel=wheel) for a in argv]
    if argv[0] == "sweep":  # a sweep's table is .csv: the profile file is one
        assert wheel.suffix == ".csv"
    status, _out, err = run(argv, capsys)
    assert status == 2 and "would overwrite the wheel profile file" in one_line(err)
    assert wheel.read_bytes() == before
