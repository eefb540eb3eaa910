"""`rail-mj track`: a track file's irregularities, written as measured ones are read and drawn."""

from __future__ import annotations

from pathlib import Path

import click

from rail_mj.cli.options import EXIT_BAD_INPUT, Failure, check_outputs, track_of, uses_stdout, written


@click.command("track")
@click.argument("track", type=click.Path(dir_okay=False))
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False), help="Write the channels here (CSV).")
@click.option("--png", type=click.Path(dir_okay=False), help="Draw the channels and their spectra here.")
def track_cmd(track, out, png):
    """The irregularities of TRACK's [irregularities] along it: x_m, alignment_mm, level_mm,
    cross_level_mm, gauge_mm (the measured CSV's columns), generated from the spectrum with its
    seed, or as measured."""
    check_outputs(track, [("-o", out), ("--png", png)])
    the_track = track_of(track)
    assert the_track is not None
    if the_track.irregularities is None:
        raise Failure(f"{track}: no [irregularities]: give a spectrum or a measured file there", EXIT_BAD_INPUT)

    from rail_mj.track.irregularities import channels_csv, spectrum

    irregular = the_track.irregularities
    if irregular.file is not None:
        measured = (Path(track).parent / irregular.file).resolve()
        for option, path in (("-o", out), ("--png", png)):
            if path and Path(path).resolve() == measured:
                raise Failure(f"{option} {path}: is the measured file {track} reads: write elsewhere", EXIT_BAD_INPUT)
    x, channels = irregular.channels(the_track.length)
    outputs = [p for p in (out, png) if p]
    with written(outputs) as temps:  # both or neither
        temps[0].write_bytes(channels_csv(x, channels))
        if png:
            from rail_mj.output.plots import irregularities_png

            spec = None if irregular.spectrum is None else spectrum(irregular.spectrum)
            what = irregular.file if spec is None else f"{spec.name}, seed {irregular.seed}, x{irregular.scale:g}"
            title = f"Irregularities of {track} ({what})"
            temps[1].write_bytes(irregularities_png(x, channels, title, spec, irregular.wavelengths))
    err = uses_stdout(out, png)
    rms = ", ".join(
        f"{c} {float((v[x >= min(50.0, x[-1])] ** 2).mean()) ** 0.5 * 1e3:.3f}" for c, v in channels.items()
    )
    click.echo(f"{len(x)} samples over {x[-1]:g} m; rms (mm) {rms}", err=err)
    click.echo(f"channels: {out}" + (f"\nplot: {png}" if png else ""), err=err)
