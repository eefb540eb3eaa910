"""The `rail-mj` command: a thin layer over the Python API.

Exit status: 0 success; 2 bad input (layout, arguments, output path); 3 a run that
cannot be done or that diverged. Every failure is one line on stderr.
"""

from __future__ import annotations

import io
import json
import math
import sys
from pathlib import Path

import click
import numpy as np

from rail_mj.analysis import summary
from rail_mj.layout import LayoutError, load_layout
from rail_mj.model import atomic_write, generate
from rail_mj.runner import Run, SimulationError, simulate

EXIT_BAD_INPUT = 2
EXIT_RUN_FAILED = 3


class Failure(Exception):
    def __init__(self, message: str, status: int):
        super().__init__(message)
        self.status = status


def _layout(path: str):
    try:
        return load_layout(path)
    except LayoutError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="rail-mj")
def cli():
    """Railway bogies on rails in MuJoCo: describe a vehicle in a layout file (TOML),
    generate its MuJoCo model, run it, and review the run in Rerun."""


@cli.command("generate")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Folder for <name>.xml, scene.xml and assets/.")
def generate_cmd(layout, out_dir):
    """Generate the MJCF model of LAYOUT."""
    lay = _layout(layout)
    try:
        written = generate(lay, out_dir)
    except ValueError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    except OSError as e:
        raise Failure(f"cannot write to {out_dir}: {e.strerror or e}", EXIT_BAD_INPUT) from None
    for path in written:
        click.echo(str(path))


def _csv_bytes(run: Run) -> bytes:
    names, values = run.table()
    buf = io.StringIO()
    np.savetxt(buf, values, delimiter=",", header=",".join(names), comments="", fmt="%.10g")
    return buf.getvalue().encode()


def _check_output(path: str | None, option: str) -> None:
    if path is not None and Path(path).is_dir():
        raise Failure(f"{option} {path}: is a folder, expected a file name", EXIT_BAD_INPUT)


@cli.command("run")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--speed", type=float, required=True, help="Forward speed, m/s.")
@click.option("--distance", type=float, required=True, help="Distance to run, m.")
@click.option("--initial-lateral", type=float, default=0.002, show_default=True,
              help="Start with the whole vehicle shifted left by this much, m.")
@click.option("--initial-yaw", type=float, default=0.0, show_default=True,
              help="Start with every wheelset yawed nose-left by this much, rad.")
@click.option("--rrd", type=click.Path(dir_okay=False), help="Write a Rerun recording here.")
@click.option("--out", type=click.Path(dir_okay=False), help="Write the samples as CSV here.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def run_cmd(layout, speed, distance, initial_lateral, initial_yaw, rrd, out, as_json):
    """Run LAYOUT at constant speed on straight track and summarise each wheelset's motion."""
    for option, value in (("--speed", speed), ("--distance", distance)):
        if not (math.isfinite(value) and value > 0):
            raise Failure(f"{option} must be a positive number, got {value}", EXIT_BAD_INPUT)
    for option, value in (("--initial-lateral", initial_lateral), ("--initial-yaw", initial_yaw)):
        if not math.isfinite(value):
            raise Failure(f"{option} must be a finite number, got {value}", EXIT_BAD_INPUT)
    lay = _layout(layout)
    _check_output(rrd, "--rrd")
    _check_output(out, "--out")
    try:
        run = _simulate_with_progress(lay, speed, distance, initial_lateral, initial_yaw)
    except SimulationError as e:
        raise Failure(str(e), EXIT_RUN_FAILED) from None
    except ValueError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    result = summary(run)
    try:
        if out:
            atomic_write(Path(out), _csv_bytes(run))
            result["csv"] = out
        if rrd:
            from rail_mj.recording import write_recording  # rerun is slow to import

            write_recording(run, rrd)
            result["rrd"] = rrd
    except OSError as e:
        raise Failure(f"cannot write output: {e.strerror or e}: {e.filename or ''}", EXIT_BAD_INPUT) from None
    if as_json:
        click.echo(json.dumps(result, indent=2))
    else:
        _print_summary(result)


def _simulate_with_progress(lay, speed, distance, initial_lateral, initial_yaw) -> Run:
    if not sys.stderr.isatty():
        return simulate(lay, speed, distance, initial_lateral, initial_yaw)
    with click.progressbar(length=1000, label=f"{lay.name} at {speed:g} m/s", file=sys.stderr) as bar:
        done = [0]

        def progress(fraction: float) -> None:
            step = int(fraction * 1000)
            if step > done[0]:
                bar.update(step - done[0])
                done[0] = step

        return simulate(lay, speed, distance, initial_lateral, initial_yaw, progress=progress)


def _fmt(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def _print_summary(result: dict) -> None:
    click.echo(
        f"{result['layout']}: {result['distance_m']:g} m at {result['speed_m_per_s']:g} m/s "
        f"({result['duration_s']:.3g} s, timestep {result['timestep_s']:.3g} s)"
    )
    click.echo("wheelset  max|y| (mm)  growth (1/s)  frequency (Hz)  wavelength (m)")
    for w in result["wheelsets"]:
        click.echo(
            f"{w['wheelset']:>8}  {w['max_abs_lateral_m'] * 1e3:>11.3f}  "
            f"{_fmt(w['growth_rate_per_s'], '>12.4f')}  {_fmt(w['frequency_hz'], '>14.4f')}  "
            f"{_fmt(w['wavelength_m'], '>14.3f')}"
        )
    if "csv" in result:
        click.echo(f"samples: {result['csv']}")
    if "rrd" in result:
        click.echo(f"recording: {result['rrd']}  (open it with: rerun {result['rrd']})")


def main(argv: list[str] | None = None) -> int:
    try:
        cli.main(args=argv, prog_name="rail-mj", standalone_mode=False)
    except Failure as e:
        click.echo(f"rail-mj: error: {e}", err=True)
        return e.status
    except click.exceptions.Abort:
        click.echo("rail-mj: interrupted", err=True)
        return 130
    except click.ClickException as e:
        click.echo(f"rail-mj: error: {e.format_message()} (see rail-mj --help)", err=True)
        return EXIT_BAD_INPUT
    return 0


if __name__ == "__main__":
    sys.exit(main())
