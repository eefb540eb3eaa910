"""[irregularities] in a track file, generated or measured, and `rail-mj track`, which writes
them as the measured CSV reads them: the round trip, the refusals, runs that refuse them."""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import DATA, MODELS

from rail_mj.cli import main
from rail_mj.layout import load_layout
from rail_mj.track import TrackError, load_track
from rail_mj.track.irregularities import CSV_COLUMNS, SPECTRA, band_variance

STRAIGHT = '[[section]]\nkind = "straight"\nlength = 1500.0\n'


def _track(tmp_path, irregularities: str):
    path = tmp_path / "track.toml"
    path.write_text(STRAIGHT + "\n[irregularities]\n" + irregularities)
    return path


def test_a_generated_track_written_and_read_back_as_measured_is_the_same(tmp_path, capsys):
    track = _track(tmp_path, 'spectrum = "erri-low"\nseed = 4\nscale = 1.5\n')
    out, png = tmp_path / "channels.csv", tmp_path / "channels.png"
    assert main(["track", str(track), "-o", str(out), "--png", str(png)]) == 0
    assert out.read_text().splitlines()[0] == ",".join(CSV_COLUMNS)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = capsys.readouterr().out
    assert "samples over" in summary and "rms (mm)" in summary
    generated = load_track(track).irregularities
    x, channels = generated.channels(1500.0)
    # The realised level's rms, past the fade-in, near the spectrum's: 1.5 x the band's rms.
    settled = x >= 50.0
    expected = 1.5 * band_variance(SPECTRA["erri-low"], "level") ** 0.5
    assert np.sqrt(np.mean(channels["level"][settled] ** 2)) == pytest.approx(expected, rel=0.3)
    measured_track = tmp_path / "measured.toml"
    measured_track.write_text(STRAIGHT + '\n[irregularities]\nfile = "channels.csv"\n')
    measured = load_track(measured_track).irregularities
    mx, mchannels = measured.channels(1500.0)
    np.testing.assert_allclose(mx, x, rtol=0, atol=1e-9)
    for name, values in channels.items():
        np.testing.assert_allclose(mchannels[name], values, rtol=1e-9, atol=1e-15)  # 10 digits in the CSV


@pytest.mark.parametrize(
    "irregularities, says",
    [
        ('spectrum = "erri-medium"\n', "irregularities.spectrum: must be one of"),
        ('spectrum = "erri-low"\nwavelengths = [150.0, 3.0]\n', "irregularities.wavelengths: need"),
        ('spectrum = "erri-low"\nseed = -1\n', "irregularities.seed: must be a whole number"),
        ('spectrum = "erri-low"\nscale = "big"\n', "irregularities.scale: must be a number"),
        ('spectrum = "erri-low"\nsede = 3\n', "irregularities.sede: unknown key"),
        ('spectrum = "erri-low"\nfile = "m.csv"\n', "a spectrum (generated) or a file (measured), one of them"),
        ("", "a spectrum (generated) or a file (measured), one of them"),
        ('file = "missing.csv"\n', "irregularities.file: missing.csv: cannot read"),
    ],
)
def test_a_bad_irregularities_table_is_refused_in_one_line(irregularities, says, tmp_path):
    with pytest.raises(TrackError) as caught:
        load_track(_track(tmp_path, irregularities))
    assert says in str(caught.value) and "\n" not in str(caught.value)


@pytest.mark.parametrize(
    "csv, says",
    [
        ("x,alignment_mm,level_mm,cross_level_mm,gauge_mm\n0,0,0,0,0\n1,0,0,0,0\n", "the header must be"),
        (",".join(CSV_COLUMNS) + "\n0,0,0,0,0\n0,1,1,1,1\n", "x_m must increase"),
        (",".join(CSV_COLUMNS) + "\n0,0,0,0,0\n1,0,nan,0,0\n", "line 3: need 5 finite numbers"),
        (",".join(CSV_COLUMNS) + "\n0,0,0,0,0\n", "at least two rows"),
    ],
)
def test_a_bad_measured_file_is_refused_naming_the_line(csv, says, tmp_path):
    (tmp_path / "m.csv").write_text(csv)
    with pytest.raises(TrackError, match=None) as caught:
        load_track(_track(tmp_path, 'file = "m.csv"\n'))
    assert says in str(caught.value)


def test_the_command_refuses_a_track_without_irregularities_and_writing_over_its_measurements(tmp_path, capsys):
    plain = tmp_path / "plain.toml"
    plain.write_text(STRAIGHT)
    assert main(["track", str(plain), "-o", str(tmp_path / "c.csv")]) == 2
    assert "no [irregularities]" in capsys.readouterr().err
    (tmp_path / "m.csv").write_text(",".join(CSV_COLUMNS) + "\n0,0,0,0,0\n10,1,1,1,1\n")
    track = _track(tmp_path, 'file = "m.csv"\n')
    assert main(["track", str(track), "-o", str(tmp_path / "m.csv")]) == 2
    assert "is the measured file" in capsys.readouterr().err
    assert (tmp_path / "m.csv").read_text().endswith("10,1,1,1,1\n")


def test_a_run_on_an_irregular_track_runs_and_one_it_cannot_model_is_refused_in_a_line(tmp_path, capsys):
    track = _track(tmp_path, 'spectrum = "erri-low"\n')
    argv = ["run", str(MODELS / "wheelset" / "wheelset.toml"), "--speed", "30", "--distance", "100"]
    assert main([*argv, "--track", str(track)]) == 0
    capsys.readouterr()
    # A spatial vehicle without gravity has no wheel loads for the rails' level to change.
    layout = (DATA / "manchester-coach-spatial.toml").read_text().replace("[spatial]", "[spatial]\ngravity = false")
    weightless = tmp_path / "weightless.toml"
    weightless.write_text(layout)
    assert main(["run", str(weightless), "--speed", "30", "--distance", "100", "--track", str(track)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "without gravity on an irregular track" in err[0]


def test_a_sweep_plans_an_irregular_track(tmp_path):
    from rail_mj.studies.sweep import plan

    track = _track(tmp_path, 'spectrum = "erri-low"\n')
    planned = plan(MODELS / "wheelset" / "wheelset.toml", (30.0, 40.0, 2), distance=100.0, track=track)
    assert len(planned) == 2 and all(case.track is not None and case.track.irregularities for case in planned)


def test_the_shipped_irregular_track_is_what_its_readme_says():
    """models/tracks/erri-high-5km.toml: 5.1 km, ERRI-high over 3-150 m, rms alignment 3.53 mm, level
    4.69, cross level 2.98, gauge 0.46 (the band integrals, to the README's three digits); its grid's
    variances (before the fade-in) within 1.1e-4 of them."""
    from rail_mj.track.irregularities import CHANNELS, realised_variance

    track = load_track(MODELS / "tracks" / "erri-high-5km.toml")
    assert track.length == 5100.0 and track.irregularities.spectrum == "erri-high"
    spec = SPECTRA["erri-high"]
    for channel, rms_mm in zip(CHANNELS, (3.53, 4.69, 2.98, 0.46)):
        assert band_variance(spec, channel) ** 0.5 * 1e3 == pytest.approx(rms_mm, abs=0.005)
        assert realised_variance(spec, channel, track.length) == pytest.approx(band_variance(spec, channel), rel=1.1e-4)


def test_a_sweep_varies_the_seed_spectrum_and_scale_of_its_track(tmp_path):
    """irregularities.seed/.spectrum/.scale as --set and --grid keys: each case on its own realisation
    (its key says which), the base track's band kept; a key that cannot apply is refused in one line."""
    from rail_mj.studies.sweep import SweepError, plan

    layout = MODELS / "manchester-coach" / "manchester-coach.toml"
    track = _track(tmp_path, 'spectrum = "erri-low"\nwavelengths = [3.0, 70.0]\n')
    cases = plan(
        layout,
        (30.0, 30.0, 1),
        distance=100.0,
        track=track,
        sets=["irregularities.scale=0.5"],
        grids=["irregularities.seed=1:3:3", "irregularities.spectrum=erri-low,erri-high"],
    )
    assert len(cases) == 6 and len({c.key for c in cases}) == 6
    got = {(c.track.irregularities.seed, c.track.irregularities.spectrum) for c in cases}
    assert got == {(s, n) for s in (1, 2, 3) for n in ("erri-low", "erri-high")}
    assert all(c.track.irregularities.scale == 0.5 and c.track.irregularities.wavelengths == (3.0, 70.0) for c in cases)
    refusals = [
        (dict(grids=["irregularities.seed=1:2:3"]), "must be a whole number"),
        (dict(grids=["irregularities.spectrum=erri-low,fra-9"]), "must be one of"),
        (dict(sets=["irregularities.scale=-1"]), "must be a number >= 0"),
        (dict(sets=["irregularities.seed=2"], track=None), "needs --track FILE with [irregularities]"),
    ]
    for kwargs, message in refusals:
        options = {"distance": 100.0, "track": track, **kwargs}
        with pytest.raises(SweepError, match=re.escape(message)):
            plan(layout, (30.0, 30.0, 1), **options)
    (tmp_path / "m.csv").write_text(",".join(CSV_COLUMNS) + "\n0,0,0,0,0\n2000,1,1,1,1\n")
    measured = tmp_path / "measured.toml"
    measured.write_text(STRAIGHT + '\n[irregularities]\nfile = "m.csv"\n')
    with pytest.raises(SweepError, match="are measured"):
        plan(layout, (30.0, 30.0, 1), distance=100.0, track=measured, sets=["irregularities.seed=2"])


def test_a_sweep_over_seeds_gives_ride_columns_and_their_spread(tmp_path):
    """The coach at one speed on three realisations of ERRI-low: each row has N_MV, Wz, Y/Q and Sigma Y
    (as the run's summary has them), and the summary their mean and sample spread over the seeds."""
    from rail_mj.analysis import summary
    from rail_mj.simulation.runner import simulate
    from rail_mj.studies.sweep import summarise, sweep_table

    layout = MODELS / "manchester-coach" / "manchester-coach.toml"
    path = _track(tmp_path, 'spectrum = "erri-low"\n')
    table = sweep_table(layout, (40.0, 40.0, 1), distance=280.0, track=path, grids=["irregularities.seed=1:3:3"])
    rows = table.to_pylist()
    assert [r["status"] for r in rows] == ["ok"] * 3
    one = summary(simulate(load_layout(layout), 40.0, 280.0, track=load_track(path)))
    first = next(r for r in rows if r["irregularities.seed"] == 1)
    assert first["n_mv"] == pytest.approx(max(p["n_mv"] for p in one["ride"]["points"]), rel=1e-12)
    (entry,) = summarise(table)["over_seeds"]
    values = np.array([r["n_mv"] for r in rows])
    assert entry["seeds"] == 3 and entry["n_mv_mean"] == pytest.approx(values.mean(), rel=1e-12)
    assert entry["n_mv_spread"] == pytest.approx(values.std(ddof=1), rel=1e-12) and entry["n_mv_spread"] > 0
