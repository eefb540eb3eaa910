"""The `rail-mj` command: a thin layer over the Python API.

Exit status: 0 success; 2 bad input (layout, arguments, output path); 3 a run that
cannot be done or that diverged. Every failure is one line on stderr, and so is every
warning (a legal value far outside railway practice: rail_mj.layout.practice).

MuJoCo, numba and scipy take seconds to load: each command imports what it uses, so
`--help` and a bad layout answer at once.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
from pathlib import Path

import click

from rail_mj.files import STDOUT, is_special, staged
from rail_mj.layout import LAWS, MAX_MAGNITUDE, Layout, LayoutError, load_layout
from rail_mj.layout.practice import RANGES, max_initial_yaw

EXIT_BAD_INPUT = 2
EXIT_RUN_FAILED = 3


class Failure(Exception):
    def __init__(self, message: str, status: int):
        super().__init__(message)
        self.status = status


def _layout(path: str) -> Layout:
    """The checked layout; its warnings, one line each, on stderr."""
    try:
        layout = load_layout(path)
    except LayoutError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    for warning in layout.warnings:
        _warn(warning)
    return layout


def _warn(text: str) -> None:
    click.echo(f"rail-mj: warning: {text}", err=True)


def _speed(option: str, value: float) -> float:
    """A forward speed from the command line: positive, and not beyond any railway."""
    return _positive(option, value, "speed")


def _positive(option: str, value: float, key: str) -> float:
    """A positive number from the command line within RANGES[key], with a warning outside
    railway practice."""
    if not (math.isfinite(value) and value > 0):
        raise Failure(f"{option} must be a positive number, got {value}", EXIT_BAD_INPUT)
    error = RANGES[key].check(value)
    if error:
        raise Failure(f"{option} {error}", EXIT_BAD_INPUT)
    warning = RANGES[key].warning(value)
    if warning:
        _warn(f"{option}: {warning}")
    return value


def _speed_range(vmin: float, vmax: float) -> None:
    if not (math.isfinite(vmin) and math.isfinite(vmax) and 0 < vmin < vmax):
        raise Failure(f"need 0 < --vmin < --vmax, got {vmin} and {vmax}", EXIT_BAD_INPUT)
    error = RANGES["speed"].check(vmax)
    if error:
        raise Failure(f"--vmax {error}", EXIT_BAD_INPUT)


@contextlib.contextmanager
def _status(label: str):
    """A one-line progress display on a terminal's stderr (nothing elsewhere): yields the
    function that shows a new status, or None."""
    if not sys.stderr.isatty():
        yield None
        return
    width = 0

    def show(text: str) -> None:
        nonlocal width
        line = f"{label}: {text}"
        click.echo("\r" + line.ljust(width), err=True, nl=False)
        width = len(line)

    try:
        yield show
    finally:
        if width:
            click.echo("\r" + " " * width + "\r", err=True, nl=False)


def _uses_stdout(*paths) -> bool:
    return any(p == STDOUT for p in paths)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="rail-mj")
def cli():
    """Railway bogies on rails in MuJoCo: describe a vehicle in a layout file (TOML),
    generate its MuJoCo model, run it, and review the run in Rerun."""


@cli.command("generate")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option(
    "-o",
    "--out",
    "out_dir",
    required=True,
    type=click.Path(file_okay=False),
    help="Folder for <name>.xml, scene.xml and assets/.",
)
def generate_cmd(layout, out_dir):
    """Generate the MJCF model of LAYOUT."""
    from rail_mj.vehicle.mjcf import generate

    lay = _layout(layout)
    _check_outputs(layout, [("-o", out_dir)], folders=True)
    try:
        written = generate(lay, out_dir)
    except ValueError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    except OSError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    for path in written:
        click.echo(str(path))


def _check_outputs(
    layout: str | None, outputs: list[tuple[str, str | None]], folders: bool = False, source: str = "the layout file"
) -> None:
    """Refuse, before any work, outputs that cannot or must not be written: a folder
    given for a file, the input (`layout`, called `source`) itself, two outputs on one path
    (or on standard output), an unwritable place. `-` is standard output; a FIFO or a
    device is written through."""
    try:
        _check_output_paths(layout, outputs, folders, source)
    except (OSError, RuntimeError) as e:  # a link in a circle, a path too long ...
        raise Failure(f"cannot use the output path: {e}", EXIT_BAD_INPUT) from None


def _check_output_paths(layout: str | None, outputs: list[tuple[str, str | None]], folders: bool, source: str) -> None:
    seen = {Path(layout).resolve(): source} if layout is not None else {}
    on_stdout = None
    for option, path in outputs:
        if path is None:
            continue
        if path == STDOUT:
            if folders:
                raise Failure(f"{option} -: needs a folder, not standard output", EXIT_BAD_INPUT)
            if on_stdout:
                raise Failure(f"{option} -: standard output already takes {on_stdout}", EXIT_BAD_INPUT)
            on_stdout = option
            continue
        target = Path(path)
        if not folders and target.is_dir():
            raise Failure(f"{option} {path}: is a folder, expected a file name", EXIT_BAD_INPUT)
        real = target.resolve()
        if real in seen:
            raise Failure(f"{option} {path}: would overwrite {seen[real]}", EXIT_BAD_INPUT)
        if is_special(path):  # a FIFO or a device: written through, never replaced
            if not os.access(path, os.W_OK):
                raise Failure(f"{option} {path}: cannot write to it", EXIT_BAD_INPUT)
            continue
        seen[real] = option
        existing = real.parent if not folders else real
        while not existing.exists():
            existing = existing.parent
        if not existing.is_dir() or not os.access(existing, os.W_OK):
            raise Failure(f"{option} {path}: cannot write in {existing}", EXIT_BAD_INPUT)


@cli.command("run")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--speed", type=float, required=True, help="Forward speed, m/s.")
@click.option("--distance", type=float, required=True, help="Distance to run, m.")
@click.option(
    "--initial-lateral",
    type=float,
    default=0.002,
    show_default=True,
    help="Start with the whole vehicle shifted left by this much, m.",
)
@click.option(
    "--initial-yaw",
    type=float,
    default=0.0,
    show_default=True,
    help="Start with every wheelset yawed nose-left by this much, rad.",
)
@click.option("--rrd", type=click.Path(dir_okay=False), help="Write a Rerun recording here.")
@click.option(
    "--rrd-rate",
    default="auto",
    show_default=True,
    help="Samples per second in the recording: auto (chosen from the motion), a number, or full (every sample).",
)
@click.option("--out", type=click.Path(dir_okay=False), help="Write the samples as CSV here.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def run_cmd(layout, speed, distance, initial_lateral, initial_yaw, rrd, rrd_rate, out, as_json):
    """Run LAYOUT at constant speed on straight track and summarise each wheelset's motion.

    Outputs may be `-` (standard output; the summary then goes to stderr), a FIFO or a
    device: they are written through, never replaced."""
    lay = _layout(layout)
    _speed("--speed", speed)
    if not (math.isfinite(distance) and distance > 0):
        raise Failure(f"--distance must be a positive number, got {distance}", EXIT_BAD_INPUT)
    _check_disturbance(lay, initial_lateral, initial_yaw)
    rate = _recording_rate(rrd_rate)
    _check_outputs(layout, [("--out", out), ("--rrd", rrd)])
    from rail_mj.analysis import summary
    from rail_mj.output.samples import csv_bytes
    from rail_mj.simulation.runner import SimulationError

    try:
        run = _simulate_with_progress(lay, speed, distance, initial_lateral, initial_yaw)
    except SimulationError as e:
        raise Failure(str(e), EXIT_RUN_FAILED) from None
    except ValueError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    result = summary(run)
    outputs = [p for p in (out, rrd) if p]
    try:
        with staged(outputs) as temps:  # both or neither
            for tmp, path in zip(temps, outputs):
                if path == out:
                    tmp.write_bytes(csv_bytes(run))
                else:
                    from rail_mj.output.recording import recorded_samples, sample_rate, save_recording

                    save_recording(run, tmp, rate)
                    keep = recorded_samples(run, rate)
                    result["rrd_rate_per_s"] = sample_rate(run) / (keep[1] - keep[0]) if len(keep) > 1 else None
    except OSError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    if out:
        result["csv"] = out
    if rrd:
        result["rrd"] = rrd
    to_stderr = _uses_stdout(out, rrd)
    if as_json:
        click.echo(json.dumps(result, indent=2), err=to_stderr)
    else:
        _print_summary(result, to_stderr)


def _recording_rate(text: str) -> float | None:
    """--rrd-rate: None (auto), math.inf (full) or a positive number of samples/s."""
    if text == "auto":
        return None
    if text == "full":
        return math.inf
    try:
        rate = float(text)
    except ValueError:
        rate = math.nan
    if not (math.isfinite(rate) and rate > 0):
        raise Failure(
            f"--rrd-rate must be auto, full or a positive number of samples per second, got {text!r}", EXIT_BAD_INPUT
        )
    return rate


def _check_disturbance(layout: Layout, lateral: float, yaw: float) -> None:
    """Refuse a start the wheelsets cannot have on the rails: shifted past the flangeway
    clearance (the flange would start inside the rail), or yawed so far that the flange
    fronts cross the rails."""
    w = layout.wheelset
    for option, value in (("--initial-lateral", lateral), ("--initial-yaw", yaw)):
        if not math.isfinite(value):
            raise Failure(f"{option} must be a finite number, got {value}", EXIT_BAD_INPUT)
    if abs(lateral) > w.flangeway_clearance:
        raise Failure(
            f"--initial-lateral {lateral:g} m: a wheelset shifted past its flangeway "
            f"clearance ({w.flangeway_clearance:g} m) would start with its flange inside the "
            f"rail; give at most {w.flangeway_clearance:g} m",
            EXIT_BAD_INPUT,
        )
    limit = max_initial_yaw(w.rolling_radius, w.flangeway_clearance)
    if abs(yaw) > limit:
        raise Failure(
            f"--initial-yaw {yaw:g} rad: yawed more than {limit:.3g} rad, a wheelset's "
            f"flange fronts would cross the rails (clearance {w.flangeway_clearance:g} m); "
            f"angles of attack on track are a few mrad",
            EXIT_BAD_INPUT,
        )


def _simulate_with_progress(lay, speed, distance, initial_lateral, initial_yaw):
    from rail_mj.simulation.runner import simulate

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
    """`value` formatted by `spec`, or a dash as wide for a value there is not."""
    if value is None:
        return format("-", spec.rstrip("efgEFG").split(".")[0])
    return format(value, spec)


def _print_summary(result: dict, err: bool = False) -> None:
    def say(text: str) -> None:
        click.echo(text, err=err)

    say(
        f"{result['layout']}: {result['distance_m']:g} m at {result['speed_m_per_s']:g} m/s "
        f"({result['duration_s']:.3g} s, timestep {result['timestep_s']:.3g} s)"
    )
    say("wheelset  max|y| (mm)  end|y| (mm)  growth (1/s)  frequency (Hz)  wavelength (m)")
    for w in result["wheelsets"]:
        line = (
            f"{w['wheelset']:>8}  {w['max_abs_lateral_m'] * 1e3:>11.3f}  "
            f"{w['final_abs_lateral_m'] * 1e3:>11.3f}  {_fmt(w['growth_rate_per_s'], '>12.4f')}  "
            f"{_fmt(w['frequency_hz'], '>14.4f')}  {_fmt(w['wavelength_m'], '>14.3f')}"
        )
        if w["decayed"]:
            line += f"  decayed by {w['decayed_by_s']:.3g} s ({w['decayed_by_m']:.4g} m)"
        say(line)
    if any(w["decayed"] for w in result["wheelsets"]):
        say(
            "decayed: |y| below 5 % of its largest value from then to the end; growth, frequency and "
            "wavelength are those of the motion before"
        )
    h = result.get("hunting")
    if h is not None:
        worst = max(h["max_rms_n"])
        say(
            f"hunting (EN 14363, rms Sigma Y over 100 m, band-passed at {h['frequency_hz']:.2f} +/- 2 Hz): "
            f"{'YES' if h['hunting'] else 'no'}, largest {worst / 1e3:.1f} kN against a limit of "
            f"{h['limit_n'] / 1e3:.1f} kN"
        )
    elif result.get("hunting_note"):
        say(f"hunting (EN 14363): not assessed, {result['hunting_note']}")
    if result.get("largest_y_over_q") is not None:
        at, low = result["largest_y_over_q_at"], result["smallest_wheel_load_at"]
        exceeded = "EXCEEDS the limit " if result["y_over_q_exceeded"] else "limit "
        line = (
            f"wheel loads ({result['wheel_loads_from']}): largest Y/Q {result['largest_y_over_q']:.3f} over "
            f"{result['y_over_q_window_m']:g} m ({exceeded}{result['y_over_q_limit']:g}; peak "
            f"{result['largest_y_over_q_peak']:.3f}), wheelset {at['wheelset']} {at['wheel']} at "
            f"x = {at['x_m']:.4g} m"
        )
        if result["wheel_loads_from"] != "static share":
            line += (
                f"; smallest Q {result['smallest_wheel_load_n'] / 1e3:.1f} kN (wheelset {low['wheelset']} "
                f"{low['wheel']} at x = {low['x_m']:.4g} m)"
            )
        say(line)
    if "csv" in result:
        say(f"samples: {result['csv']}")
    if "rrd" in result:
        rate = result.get("rrd_rate_per_s")
        at = f", {rate:.4g} samples/s" if rate else ""
        say(f"recording: {result['rrd']}{at}  (open it with: rerun {result['rrd']})")


def _stability(layout: Layout, amplitude: float | None = None):
    from rail_mj.analysis.stability import Stability

    try:
        return Stability(layout, amplitude)
    except ValueError as e:  # the model does not compile, or the amplitude is not for it
        raise Failure(
            f"--amplitude: {e}" if amplitude is not None and "amplitude" in str(e) else str(e), EXIT_BAD_INPUT
        ) from None


def _amplitude_option(command):
    """--amplitude: where a profiled contact is linearised."""
    return click.option(
        "--amplitude",
        type=float,
        default=None,
        help="For a layout with [profiles]: linearise the contact at this lateral amplitude, mm, as "
        "practitioners do (the equivalent conicity there, EN 15302)  [default: 3]",
    )(command)


def _linearised(stability) -> str:
    """' (contact linearised at ...)' for a profiled layout, else ''."""
    text = stability.describe()
    return f" ({text})" if text else ""


@cli.command("eigen")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--speed", type=float, required=True, help="Forward speed, m/s.")
@click.option("--json", "as_json", is_flag=True, help="Print the modes as JSON.")
@_amplitude_option
def eigen_cmd(layout, speed, as_json, amplitude):
    """Eigenvalues and modes of LAYOUT linearised at SPEED, least damped first."""
    lay = _layout(layout)
    _speed("--speed", speed)
    stability = _stability(lay, amplitude)
    modes = stability.modes(speed)
    oscillatory = [m for m in modes if m.oscillatory]
    aperiodic = [m.eigenvalue.real for m in modes if not m.oscillatory]
    if as_json:
        click.echo(
            json.dumps(
                {
                    "speed_m_per_s": speed,
                    "stable": all(m.eigenvalue.real < 0 for m in modes),
                    "modes": [m.as_dict() for m in oscillatory],
                    "aperiodic_roots": aperiodic,
                    "amplitude_mm": stability.amplitude,
                    "equivalent_conicity": stability.equivalent_conicity,
                },
                indent=2,
            )
        )
        return
    if stability.amplitude is not None:
        click.echo(f"{lay.name}: {stability.describe()}")
    click.echo(f"{'mode':<46} {'f (Hz)':>8} {'zeta':>8} {'real (1/s)':>11} {'imag (rad/s)':>12}  participation")
    for m in oscillatory:
        bodies = sorted(m.participation.items(), key=lambda kv: -kv[1])
        part = ", ".join(f"{b} {s:.0%}" for b, s in bodies if s >= 0.05)
        click.echo(
            f"{m.name:<46} {m.frequency:>8.3f} {m.damping_ratio:>8.4f} {m.eigenvalue.real:>11.4f} "
            f"{m.eigenvalue.imag:>12.4f}  {part}"
        )
    if aperiodic:
        click.echo(f"aperiodic roots (1/s): {', '.join(f'{r:.4g}' for r in sorted(aperiodic, reverse=True))}")
    unstable = [m.name for m in modes if m.eigenvalue.real >= 0]
    click.echo(f"unstable at {speed:g} m/s: {', '.join(unstable)}" if unstable else f"stable at {speed:g} m/s")


def _check_step(step: float | None) -> float:
    """--step, or the one step every nonlinear critical speed uses (not imported before
    it is needed: it comes with MuJoCo and numba)."""
    if step is None:
        from rail_mj.analysis.bifurcation import STEP

        return STEP
    if not (math.isfinite(step) and 0.001 <= step <= 0.2):
        raise Failure(f"--step must be between 0.001 and 0.2, got {step}", EXIT_BAD_INPUT)
    return step


@cli.command("critical-speed")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option(
    "--method",
    type=click.Choice(["eigen", "time", "nonlinear"]),
    default="eigen",
    show_default=True,
    help="eigen: where the least-damped root crosses zero; time: simulations from a small "
    "disturbance; nonlinear: lower the speed from hunting until the limit cycle dies "
    "(needs [flange] and a saturating creep law).",
)
@click.option("--vmin", type=float, default=5.0, show_default=True, help="Lowest speed searched, m/s.")
@click.option("--vmax", type=float, default=150.0, show_default=True, help="Highest speed searched, m/s.")
@click.option(
    "--step",
    type=float,
    help="nonlinear: the speed step down the limit cycle, a fraction of the speed (the "
    "nonlinear critical speed is known to within it)  [default: 0.02, "
    "rail_mj.analysis.bifurcation.STEP]",
)
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@_amplitude_option
def critical_speed_cmd(layout, method, vmin, vmax, step, as_json, amplitude):
    """The lowest speed at which LAYOUT stops being stable, and the mode that sets it."""
    lay = _layout(layout)
    _speed_range(vmin, vmax)
    step = _check_step(step)
    from rail_mj.simulation.runner import SimulationError

    stability = _stability(lay, amplitude)  # a model that does not compile fails here, with exit 2
    try:
        with _status(f"critical speed ({method})") as progress:
            if method == "eigen":
                result = stability.critical_speed(vmin, vmax)
            elif method == "nonlinear":
                from rail_mj.analysis.bifurcation import nonlinear_critical_speed

                result, _ = nonlinear_critical_speed(lay, vmin, vmax, step, progress=progress, amplitude=amplitude)
            else:
                from rail_mj.analysis.stability import time_critical_speed

                result = time_critical_speed(lay, vmin, vmax, progress=progress)
    except SimulationError as e:
        raise Failure(str(e), EXIT_RUN_FAILED) from None
    except ValueError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    if as_json:
        click.echo(json.dumps(result.as_dict(), indent=2))
    elif result.critical_speed is None:
        click.echo(f"no critical speed ({result.method}): {result.note}")
        if result.linear_critical_speed is not None:
            click.echo(f"linear critical speed: {result.linear_critical_speed:.2f} m/s")
    else:
        click.echo(
            f"critical speed ({result.method}): {result.critical_speed:.2f} m/s "
            f"({result.critical_speed * 3.6:.1f} km/h), {result.frequency:.3f} Hz, {result.mode}"
            + (_linearised(stability) if result.method == "eigen" else "")
        )
        if result.linear_critical_speed is not None:
            click.echo(f"linear critical speed: {result.linear_critical_speed:.2f} m/s; {result.note}")
        if len(result.unstable_ranges) > 1 or (result.unstable_ranges and result.unstable_ranges[0][1] < vmax):
            spans = "; ".join(f"{a:.1f}-{b:.1f}" for a, b in result.unstable_ranges)
            click.echo(f"unstable ranges (m/s): {spans}")


def _speeds(text: str) -> list[float]:
    """--speeds A:B:N of root-locus: N >= 2 speeds from A < B."""
    a, b, n = _range("--speeds", text)
    if not (a < b and n >= 2):
        raise Failure(f"--speeds A:B:N needs A < B and N >= 2, got {text!r}", EXIT_BAD_INPUT)
    return [a + (b - a) * k / (n - 1) for k in range(n)]


@cli.command("root-locus")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--speeds", required=True, help="A:B:N, N speeds from A to B m/s.")
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False), help="The plot, PNG.")
@click.option(
    "--csv", "csv_path", type=click.Path(dir_okay=False), help="The data as CSV [default: the plot's name with .csv]."
)
@_amplitude_option
def root_locus_cmd(layout, speeds, out, csv_path, amplitude):
    """Frequency and damping of every mode of LAYOUT against speed, critical speed marked."""
    lay = _layout(layout)
    vs = _speeds(speeds)
    csv_path = csv_path or (STDOUT if out == STDOUT else str(Path(out).with_suffix(".csv")))
    if csv_path == STDOUT and out == STDOUT:
        raise Failure("-o - needs --csv FILE: the plot and the data cannot both go to standard output", EXIT_BAD_INPUT)
    _check_outputs(layout, [("-o", out), ("--csv", csv_path)])
    from rail_mj.output.plots import locus_csv, root_locus, root_locus_png

    stability = _stability(lay, amplitude)
    with _status("root locus") as progress:
        rows = root_locus(stability, vs, progress)
        critical = stability.critical_speed(vs[0], vs[-1])
    try:
        with staged([csv_path, out]) as (csv_tmp, png_tmp):
            csv_tmp.write_bytes(locus_csv(rows))
            png_tmp.write_bytes(root_locus_png(rows, critical, lay.name))
    except OSError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    err = _uses_stdout(out, csv_path)
    click.echo(f"plot: {out}\ndata: {csv_path}", err=err)
    if critical.critical_speed is not None:
        click.echo(
            f"critical speed {critical.critical_speed:.2f} m/s: {critical.mode}{_linearised(stability)}", err=err
        )
    else:
        click.echo(critical.note, err=err)


@cli.command("bifurcation")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False), help="The diagram, PNG.")
@click.option(
    "--csv", "csv_path", type=click.Path(dir_okay=False), help="The data as CSV [default: the plot's name with .csv]."
)
@click.option("--vmin", type=float, default=5.0, show_default=True, help="Lowest speed, m/s.")
@click.option("--vmax", type=float, default=150.0, show_default=True, help="Highest speed, m/s.")
@click.option(
    "--step",
    type=float,
    help="The speed step along both branches, a fraction of the speed: the same procedure "
    "and step as critical-speed --method nonlinear  [default: 0.02, "
    "rail_mj.analysis.bifurcation.STEP]",
)
@_amplitude_option
def bifurcation_cmd(layout, out, csv_path, vmin, vmax, step, amplitude):
    """Limit-cycle amplitude of LAYOUT against speed: both branches, both critical speeds."""
    lay = _layout(layout)
    _speed_range(vmin, vmax)
    step = _check_step(step)
    csv_path = csv_path or (STDOUT if out == STDOUT else str(Path(out).with_suffix(".csv")))
    if csv_path == STDOUT and out == STDOUT:
        raise Failure("-o - needs --csv FILE: the plot and the data cannot both go to standard output", EXIT_BAD_INPUT)
    _check_outputs(layout, [("-o", out), ("--csv", csv_path)])
    from rail_mj.analysis.bifurcation import bifurcation
    from rail_mj.output.plots import bifurcation_csv, bifurcation_png
    from rail_mj.simulation.runner import SimulationError

    _stability(lay, amplitude)
    try:
        with _status("bifurcation") as progress:
            critical, down, up = bifurcation(lay, vmin, vmax, step, progress=progress, amplitude=amplitude)
    except ValueError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    except SimulationError as e:
        raise Failure(str(e), EXIT_RUN_FAILED) from None
    if down is None:
        raise Failure(f"{layout}: {critical.note}", EXIT_RUN_FAILED)
    try:
        with staged([csv_path, out]) as (csv_tmp, png_tmp):
            csv_tmp.write_bytes(bifurcation_csv([down, up]))
            png_tmp.write_bytes(bifurcation_png(critical, down, up, lay.wheelset.flangeway_clearance, lay.name))
    except OSError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    err = _uses_stdout(out, csv_path)
    click.echo(f"plot: {out}\ndata: {csv_path}", err=err)
    nonlinear = (
        f"{critical.critical_speed:.2f} m/s (speed lowered in {step:.0%} steps)"
        if critical.critical_speed
        else f"none: {critical.note}"
    )
    click.echo(f"linear critical speed {critical.linear_critical_speed:.2f} m/s; nonlinear {nonlinear}", err=err)


@cli.command("sweep")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option(
    "--speeds",
    required=True,
    help="A:B:N. run: every one of N speeds from A to B m/s is a case; eigen, time, nonlinear: "
    "the range the critical speed is searched in, N scan points.",
)
@click.option(
    "--set",
    "sets",
    multiple=True,
    metavar="KEY=VALUE",
    help="A layout key set for every case, e.g. creep.friction=0.2 (repeatable).",
)
@click.option(
    "--grid",
    "grids",
    multiple=True,
    metavar="KEY=A:B:N[:log]",
    help="A layout key varied over N values, e.g. wheelset.conicity=0.05:0.3:6 (repeatable: "
    "every combination is a case).",
)
@click.option(
    "--method",
    type=click.Choice(["run", "eigen", "time", "nonlinear"]),
    default="run",
    show_default=True,
    help="run: a simulation and its summary per case; eigen, time, nonlinear: "
    "a critical speed per case (as critical-speed --method).",
)
@click.option("--distance", type=float, default=1000.0, show_default=True, help="run: distance of each run, m.")
@click.option("--workers", type=int, help="Threads on this machine [default: every core].")
@click.option("--scheduler", help="Address of a Dask distributed scheduler to run the cases on instead.")
@click.option(
    "--rrd-dir", type=click.Path(file_okay=False), help="run: write a Rerun recording of each case into this folder."
)
@click.option(
    "-o",
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="The table, .csv or .parquet. Run again, the same sweep keeps its finished rows.",
)
@click.option("--json", "as_json", is_flag=True, help="Print a summary as JSON.")
def sweep_cmd(layout, speeds, sets, grids, method, distance, workers, scheduler, rrd_dir, out, as_json):
    """Run LAYOUT over speeds and layout parameters: one row per case, in a table."""
    _layout(layout)
    a, b, n = _range("--speeds", speeds)
    _check_executor(workers, scheduler)
    if Path(out).suffix not in (".csv", ".parquet"):
        raise Failure(f"-o {out}: the table must be .csv or .parquet", EXIT_BAD_INPUT)
    _check_outputs(layout, [("-o", out)])
    if rrd_dir:
        _check_outputs(layout, [("--rrd-dir", rrd_dir)], folders=True)
    from rail_mj.studies.sweep import SweepError, summarise, sweep

    try:
        with _status("sweep") as show:

            def progress(done, total, row):
                if show is not None:
                    show(f"{done}/{total}, last: case {row['case']} {row['status']}")

            table = sweep(
                layout,
                (a, b, n),
                sets=sets,
                grids=grids,
                method=method,
                distance=distance,
                workers=workers,
                scheduler=scheduler,
                out=out,
                recordings=rrd_dir,
                progress=progress,
            )
    except SweepError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    except OSError as e:
        raise Failure(f"-o {out}: {e.strerror or e}", EXIT_BAD_INPUT) from None
    result = summarise(table)
    result["table"] = out
    if as_json:
        click.echo(json.dumps(result, indent=2))
        return
    counts = ", ".join(f"{k} {v}" for k, v in result["by_status"].items() if v)
    click.echo(f"{result['cases']} cases ({counts}), {result['wall_time_s']:.1f} s of computing: {out}")
    for bracket in result.get("brackets", []):
        where = ", ".join(f"{k} = {v:g}" for k, v in bracket.items() if k != "critical_speed_bracket_m_per_s")
        span = bracket["critical_speed_bracket_m_per_s"]
        found = f"between {span[0]:g} and {span[1]:g} m/s" if span else "not within the speeds run"
        click.echo(f"the motion stops decaying {found}" + (f" ({where})" if where else ""))


def _check_executor(workers: int | None, scheduler: str | None) -> None:
    if workers is not None and scheduler is not None:
        raise Failure("give --workers or --scheduler, not both", EXIT_BAD_INPUT)
    if workers is not None and not 1 <= workers <= 1024:
        raise Failure(f"--workers must be between 1 and 1024, got {workers}", EXIT_BAD_INPUT)


def _triple(option: str, text: str, unit: str) -> tuple[float, float, int]:
    """A:B:N as numbers, unchecked."""
    try:
        a, b, n = text.split(":")
        return float(a), float(b), int(n)
    except ValueError:
        raise Failure(f"{option} must be A:B:N (from A to B {unit} in N steps), got {text!r}", EXIT_BAD_INPUT) from None


def _range(option: str, text: str) -> tuple[float, float, int]:
    """A:B:N for speeds: 0 < A <= B, not beyond any railway."""
    a, b, n = _triple(option, text, "m/s")
    if not (math.isfinite(a) and math.isfinite(b) and 0 < a <= b and 1 <= n <= 100_000):
        raise Failure(f"{option} A:B:N needs 0 < A <= B and 1 <= N <= 100000, got {text!r}", EXIT_BAD_INPUT)
    error = RANGES["speed"].check(b)
    if error:
        raise Failure(f"{option}: B {error}", EXIT_BAD_INPUT)
    return a, b, n


@cli.command("map")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--x", "x_axis", required=True, metavar="KEY=A:B:N[:log]", help="The parameter along x.")
@click.option("--y", "y_axis", required=True, metavar="KEY=A:B:N[:log]", help="The parameter along y.")
@click.option(
    "--method",
    type=click.Choice(["eigen", "nonlinear"]),
    default="eigen",
    show_default=True,
    help="The critical speed mapped: linear (eigen) or nonlinear.",
)
@click.option(
    "--speeds", default="5:150:60", show_default=True, help="A:B:N, the speed range searched, m/s, with N scan points."
)
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE", help="A layout key set everywhere.")
@click.option("--workers", type=int, help="Threads on this machine [default: every core].")
@click.option("--scheduler", help="Address of a Dask distributed scheduler to run the cells on instead.")
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False), help="The map, PNG.")
@click.option(
    "--csv", "csv_path", type=click.Path(dir_okay=False), help="The table as CSV [default: the map's name with .csv]."
)
def map_cmd(layout, x_axis, y_axis, method, speeds, sets, workers, scheduler, out, csv_path):
    """The critical speed of LAYOUT as a map over two layout parameters."""
    lay = _layout(layout)
    a, b, n = _range("--speeds", speeds)
    csv_path = csv_path or (STDOUT if out == STDOUT else str(Path(out).with_suffix(".csv")))
    if csv_path == STDOUT and out == STDOUT:
        raise Failure("-o - needs --csv FILE: the map and the table cannot both go to standard output", EXIT_BAD_INPUT)
    _check_executor(workers, scheduler)
    _check_outputs(layout, [("-o", out), ("--csv", csv_path)])
    from rail_mj.output.plots import stability_map_png
    from rail_mj.studies.sweep import SweepError, parse_assignment, sweep

    try:
        keys = [parse_assignment(text, option)[0] for option, text in (("--x", x_axis), ("--y", y_axis))]
        if keys[0] == keys[1]:
            raise SweepError(f"--x and --y both vary {keys[0]}")
        with _status("map") as show:

            def progress(done, total, row):
                if show is not None:
                    show(f"{done}/{total} cells")

            table = sweep(
                layout,
                (a, b, n),
                sets=sets,
                grids=(x_axis, y_axis),
                method=method,
                workers=workers,
                scheduler=scheduler,
                progress=progress,
            )
    except SweepError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    import io

    import pyarrow.csv as pacsv

    try:
        with staged([csv_path, out]) as (csv_tmp, png_tmp):
            buffer = io.BytesIO()
            pacsv.write_csv(table, buffer)
            csv_tmp.write_bytes(buffer.getvalue())
            png_tmp.write_bytes(
                stability_map_png(
                    table, keys[0], keys[1], x_axis.endswith(":log"), y_axis.endswith(":log"), method, lay.name
                )
            )
    except OSError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    err = _uses_stdout(out, csv_path)
    rows = table.to_pylist()
    found = [r["critical_speed_m_per_s"] for r in rows if r["critical_speed_m_per_s"] is not None]
    unstable = sum(r["outcome"] == "unstable" for r in rows)
    stable = sum(r["outcome"] == "stable" for r in rows)
    other = len(rows) - len(found) - unstable - stable
    click.echo(f"map: {out}\ndata: {csv_path}", err=err)
    span = f"critical speed from {min(found):.1f} to {max(found):.1f} m/s" if found else "no critical speed"
    click.echo(
        f"{span} over {len(rows)} cells; {unstable} unstable from {a:g} m/s, {stable} stable to "
        f"{b:g} m/s, {other} other (see the table's status and note)",
        err=err,
    )


@cli.command("contact")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def contact_cmd(layout, as_json):
    """The Hertz contact ellipse and Kalker creep coefficients of LAYOUT's [contact]."""
    from rail_mj.layout import contact_patch_of

    lay = _layout(layout)
    if lay.profiles is not None:
        raise Failure(
            f"{layout}: contact: on [profiles] each contact point has its own ellipse; "
            f"rail-mj contact-geometry tabulates the points",
            EXIT_BAD_INPUT,
        )
    if lay.contact is None:
        raise Failure(f"{layout}: contact: no [contact] table; the layout gives f11..f33 itself", EXIT_BAD_INPUT)
    result = contact_patch_of(lay).as_dict()
    if as_json:
        click.echo(json.dumps(result, indent=2))
        return
    r = result
    click.echo(f"{lay.name}: wheel load {r['normal_load_n'] / 1e3:.2f} kN")
    click.echo(
        f"Hertz ellipse: a = {r['a_m'] * 1e3:.3f} mm (rolling), b = {r['b_m'] * 1e3:.3f} mm, "
        f"a/b = {r['a_over_b']:.4f}, peak pressure {r['peak_pressure_pa'] / 1e6:.0f} MPa"
    )
    click.echo(f"Kalker: C11 {r['C11']:.3f}, C22 {r['C22']:.3f}, C23 {r['C23']:.3f}, C33 {r['C33']:.3f}")
    click.echo(
        f"creep coefficients: f11 {r['f11'] / 1e6:.3f} MN, f22 {r['f22'] / 1e6:.3f} MN, "
        f"f23 {r['f23'] / 1e3:.3f} kN m, f33 {r['f33']:.2f} N m^2"
    )


# `rail-mj creep`: what a contact can be, and what it usually is (SI units).
SEMI_AXIS_RANGE = (1e-6, 1.0)  # m: far beyond any rolling contact either way
SEMI_AXIS_USUAL = (0.5e-3, 30e-3)  # m: wheel-rail contacts, tread to flange
MAX_CREEPAGE = 1.0  # beyond, the surfaces slide faster than they roll
MAX_SPIN = 1000.0  # rad/m: a radian per millimetre rolled


@cli.command("creep")
@click.option(
    "--semi-axes",
    nargs=2,
    type=float,
    required=True,
    metavar="A B",
    help="The contact ellipse's semi-axes, m: A along the rolling direction, B across it.",
)
@click.option("--normal-force", type=float, required=True, help="The wheel's normal load N, newtons.")
@click.option(
    "--creepages",
    nargs=3,
    type=float,
    required=True,
    metavar="XI ETA PHI",
    help="Longitudinal and lateral creepage (dimensionless) and spin (rad/m).",
)
@click.option("--friction", type=float, help="The friction coefficient mu (every law but linear).")
@click.option("--shear-modulus", type=float, required=True, help="G, Pa (steel: about 80e9).")
@click.option("--poisson", type=float, required=True, help="Poisson's ratio, 0 to 0.5 (steel: about 0.28).")
@click.option("--law", type=click.Choice(list(LAWS)), required=True, help="The creep law (docs/creep.md).")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def creep_cmd(semi_axes, normal_force, creepages, friction, shear_modulus, poisson, law, as_json):
    """The creep force and spin moment of one contact ellipse, by a creep law: Fx, Fy (N)
    and Mz (N m) of the rail on the wheel, Kalker's signs (Fx = -f11*xi for small xi).

    Kalker's coefficients C11..C33 come from his table at A/B and the Poisson's ratio, the
    linear coefficients as f11 = G*A*B*C11 and so on (docs/contact.md); fastsim is Kalker's
    FASTSIM on the ellipse, with his parabolic pressure (docs/creep.md)."""
    a, b = semi_axes
    xi, eta, phi = creepages
    _finite("--semi-axes", a, b)
    _finite("--creepages", xi, eta, phi)
    for option, value in (("--normal-force", normal_force), ("--shear-modulus", shear_modulus)):
        _finite(option, value)
        if not 0.0 < value <= MAX_MAGNITUDE:
            raise Failure(f"{option} must be positive and at most {MAX_MAGNITUDE:g}, got {value:g}", EXIT_BAD_INPUT)
    lo, hi = SEMI_AXIS_RANGE
    for value in (a, b):
        if not lo <= value <= hi:
            raise Failure(
                f"--semi-axes must be between {lo:g} and {hi:g} m, got {value:g}; check the units (m)", EXIT_BAD_INPUT
            )
    unusual = [f"{v:g}" for v in dict.fromkeys((a, b)) if not SEMI_AXIS_USUAL[0] <= v <= SEMI_AXIS_USUAL[1]]
    if unusual:
        _warn(
            f"--semi-axes: {' and '.join(unusual)} m outside wheel-rail contacts, {SEMI_AXIS_USUAL[0]:g}-"
            f"{SEMI_AXIS_USUAL[1]:g} m"
        )
    if not (abs(xi) <= MAX_CREEPAGE and abs(eta) <= MAX_CREEPAGE):
        raise Failure(
            f"--creepages XI and ETA must be within +/-{MAX_CREEPAGE:g} (beyond, the surfaces slide "
            f"faster than they roll), got {xi:g} and {eta:g}",
            EXIT_BAD_INPUT,
        )
    if not abs(phi) <= MAX_SPIN:
        raise Failure(f"--creepages PHI must be within +/-{MAX_SPIN:g} rad/m, got {phi:g}", EXIT_BAD_INPUT)
    _finite("--poisson", poisson)
    if not 0.0 <= poisson <= 0.5:
        raise Failure(f"--poisson must be between 0 and 0.5, got {poisson:g}", EXIT_BAD_INPUT)
    if friction is None:
        if law != "linear":
            raise Failure(f"--friction: missing: the {law} law needs the friction coefficient", EXIT_BAD_INPUT)
    else:
        _positive("--friction", friction, "creep.friction")
    from rail_mj.contact.creep import FASTSIM_ELEMENTS, FASTSIM_STRIPS, patch_forces
    from rail_mj.contact.hertz import ContactError, ellipse_patch

    try:
        patch = ellipse_patch(normal_force, a, b, shear_modulus=shear_modulus, poisson_ratio=poisson)
    except ContactError as e:
        raise Failure(f"--semi-axes: {e}", EXIT_BAD_INPUT) from None
    fx, fy, mz = patch_forces(patch, law, xi, eta, phi, friction)
    if not all(math.isfinite(v) for v in (fx, fy, mz)):
        raise Failure("these inputs give no finite force: check their units", EXIT_BAD_INPUT)
    limit = None if friction is None else friction * normal_force
    coefficients = patch.creep_coefficients
    result = {
        "law": law,
        "semi_axis_a_m": a,
        "semi_axis_b_m": b,
        "a_over_b": a / b,
        "normal_force_n": normal_force,
        "friction": friction,
        "shear_modulus_pa": shear_modulus,
        "poisson_ratio": poisson,
        "xi": xi,
        "eta": eta,
        "phi_rad_per_m": phi,
        **patch.C,
        **coefficients,
        "fx_n": fx,
        "fy_n": fy,
        "mz_nm": mz,
        "resultant_over_mu_n": None if limit is None else math.hypot(fx, fy) / limit,
    }
    if law == "fastsim":
        result["fastsim_grid"] = [FASTSIM_STRIPS, FASTSIM_ELEMENTS]  # strips, elements per strip
    if as_json:
        click.echo(json.dumps(result, indent=2))
        return
    mu = "" if friction is None else f", mu {friction:g} (mu*N {limit / 1e3:.4g} kN)"
    click.echo(
        f"{law}: ellipse a = {a * 1e3:.4g} mm (rolling) x b = {b * 1e3:.4g} mm (a/b {a / b:.4g}), "
        f"N = {normal_force / 1e3:.4g} kN{mu}, G = {shear_modulus / 1e9:.4g} GPa, nu = {poisson:g}"
    )
    click.echo(f"creepages: xi {xi:g}, eta {eta:g}, spin {phi:g} rad/m")
    c = coefficients
    click.echo(
        f"Kalker: C11 {patch.C['C11']:.4g}, C22 {patch.C['C22']:.4g}, C23 {patch.C['C23']:.4g}, "
        f"C33 {patch.C['C33']:.4g}; f11 {c['f11'] / 1e6:.4g} MN, f22 {c['f22'] / 1e6:.4g} MN, "
        f"f23 {c['f23'] / 1e3:.4g} kN m, f33 {c['f33']:.4g} N m^2"
    )
    share = "" if limit is None else f"  (|(Fx, Fy)| = {result['resultant_over_mu_n']:.4g} mu*N)"
    click.echo(f"Fx = {fx:.6g} N, Fy = {fy:.6g} N, Mz = {mz:.6g} N m{share}")


def _finite(option: str, *values: float) -> None:
    if not all(math.isfinite(v) for v in values):
        shown = " ".join(f"{v:g}" for v in values)
        raise Failure(f"{option} must be finite, got {shown}", EXIT_BAD_INPUT)


@cli.command("profile")
@click.argument("profile", metavar="s1002|60e1|FILE")
@click.option(
    "-o",
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="The points as CSV (y_mm,z_mm; docs/profiles.md).",
)
@click.option("--png", type=click.Path(dir_okay=False), help="Draw the profile here.")
@click.option(
    "--kind",
    type=click.Choice(["wheel", "rail"]),
    help="What a CSV file holds [default: a rail if its highest point is inside its span].",
)
def profile_cmd(profile, out, png, kind):
    """Write a wheel or rail profile as CSV, and draw it: the standard S1002 wheel (EN 13715)
    or 60E1 rail (EN 13674-1), or a measured one (.csv, SIMPACK .prw or .prr)."""
    from rail_mj.contact import profiles

    is_standard = profile.lower() in ("s1002", "60e1")
    if not is_standard and Path(profile).suffix.lower() not in (".csv", ".prw", ".prr"):
        raise Failure(f"{profile}: not s1002, 60e1 or a profile file (.csv, SIMPACK .prw or .prr)", EXIT_BAD_INPUT)
    _check_outputs(None if is_standard else profile, [("-o", out), ("--png", png)], source="the profile file")
    try:
        shape = profiles.standard(profile) if is_standard else profiles.read_profile(profile, kind)
    except profiles.ProfileError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    if kind is not None and shape.kind != kind:
        raise Failure(f"{profile}: --kind {kind}, but it is a {shape.kind} profile", EXIT_BAD_INPUT)
    outputs = [p for p in (out, png) if p]
    try:
        with staged(outputs) as temps:  # both or neither
            temps[0].write_bytes(profiles.write_csv(shape))
            if png:
                from rail_mj.output.plots import profile_png

                temps[1].write_bytes(profile_png(shape))
    except OSError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    err = _uses_stdout(out, png)
    click.echo(
        f"{shape.name}: {shape.kind}, {len(shape.y)} points, y from {shape.y[0] * 1e3:.3f} to "
        f"{shape.y[-1] * 1e3:.3f} mm",
        err=err,
    )
    click.echo(f"points: {out}" + (f"\nplot: {png}" if png else ""), err=err)


@cli.command("conicity")
@click.argument("layout", required=False, type=click.Path(dir_okay=False))
@click.option(
    "--delta-r",
    "delta_r_csv",
    type=click.Path(dir_okay=False),
    help="The rolling-radius difference r_left - r_right against the lateral shift y, as CSV "
    "with the header y_mm,delta_r_mm, y increasing.",
)
@click.option(
    "--amplitudes",
    help="A:B:N, N amplitudes from A to B mm  [default: 0.5 to 10 mm in 0.5 mm steps, as far as the data reach]",
)
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@click.option("--png", type=click.Path(dir_okay=False), help="Plot the equivalent conicity against amplitude here.")
def conicity_cmd(layout, delta_r_csv, amplitudes, as_json, png):
    """Equivalent conicity (EN 15302) against amplitude, from a Δr function (--delta-r) or
    LAYOUT: the Δr of its [profiles]' contact geometry, or else the cone of its
    wheelset.conicity.

    The amplitude is half the peak-to-peak lateral motion, about the centre where Δr
    vanishes (wheels of unequal diameters move it off y = 0). The method is the standard's
    reference one, integration of the nonlinear kinematic (Klingel) motion: docs/conicity.md."""
    if (layout is None) == (delta_r_csv is None):
        raise Failure("give LAYOUT or --delta-r FILE.csv" + (", not both" if layout else ""), EXIT_BAD_INPUT)
    wanted = _amplitudes(amplitudes) if amplitudes is not None else None
    source = layout or delta_r_csv
    with contextlib.suppress(OSError, RuntimeError):
        if png and png != STDOUT and Path(png).resolve() == Path(source).resolve():
            raise Failure(f"--png {png}: would overwrite the input {source}", EXIT_BAD_INPUT)
    _check_outputs(source, [("--png", png)])
    from rail_mj.contact.conicity import (
        DEFAULT_AMPLITUDES,
        QUOTED_AMPLITUDE,
        ConicityError,
        DeltaR,
        equivalent_conicity,
    )

    try:
        if layout is not None:
            lay = _layout(layout)
            spacing, r0 = 2e3 * lay.wheelset.contact_half_spacing, 1e3 * lay.wheelset.rolling_radius
            if lay.profiles is not None:
                delta_r = _delta_r_of_profiles(lay)
            else:
                reach = max(wanted or DEFAULT_AMPLITUDES)
                delta_r = DeltaR.cone(lay.wheelset.conicity, half_range=reach, centre=0.0)
        else:
            delta_r = DeltaR.read_csv(delta_r_csv)
            spacing, r0 = 1500.0, 460.0  # any: λe does not depend on them
        largest = delta_r.largest_amplitude()
        if wanted is None:
            wanted = [a for a in DEFAULT_AMPLITUDES if a <= largest * (1 + 1e-12)]
            if not wanted:
                raise Failure(
                    f"{source}: the data reach amplitudes up to {largest:.3g} mm only, below "
                    f"{DEFAULT_AMPLITUDES[0]:g} mm: give --amplitudes",
                    EXIT_BAD_INPUT,
                )
        elif max(wanted) > largest * (1 + 1e-12):
            raise Failure(
                f"--amplitudes: {max(wanted):g} mm is beyond {source}: the motion about its centre "
                f"stays within y from {delta_r.y_min:g} to {delta_r.y_max:g} mm only up to "
                f"{largest:.4g} mm",
                EXIT_BAD_INPUT,
            )
        values = equivalent_conicity(delta_r, wanted, e=spacing, r0=r0)
        quoted = None
        if largest >= QUOTED_AMPLITUDE:
            quoted = (QUOTED_AMPLITUDE, float(equivalent_conicity(delta_r, [QUOTED_AMPLITUDE], e=spacing, r0=r0)[0]))
        if png:
            from rail_mj.output.plots import conicity_png

            harmonic = [_harmonic_or_nan(delta_r, a) for a in wanted]
            picture = conicity_png(wanted, values, Path(source).name, harmonic, quoted)
    except ConicityError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    if png:
        try:
            with staged([png]) as (tmp,):
                tmp.write_bytes(picture)
        except OSError as e:
            raise Failure(str(e), EXIT_BAD_INPUT) from None
    err = _uses_stdout(png)
    finite = [float(v) if math.isfinite(v) else None for v in values]
    if as_json:
        click.echo(json.dumps({"amplitude_mm": [float(a) for a in wanted], "equivalent_conicity": finite}), err=err)
        return
    a, b = delta_r.centre
    centre = f"centre y = {a:.4g} mm" if a == b else f"dead band y from {a:.4g} to {b:.4g} mm"
    click.echo(f"equivalent conicity of {source} (EN 15302, integration of the Klingel equation); {centre}", err=err)
    click.echo(f"{'amplitude_mm':>12}  equivalent_conicity", err=err)
    for amp, value in zip(wanted, finite):
        click.echo(f"{amp:12.4g}  {'none (no periodic motion)' if value is None else f'{value:.5f}'}", err=err)
    if quoted is not None:
        click.echo(f"at {quoted[0]:g} mm: {quoted[1]:.4f}", err=err)
    if png:
        click.echo(f"plot: {png}", err=err)


def _contact_table(lay: Layout):
    """The contact geometry of a layout with [profiles]."""
    from rail_mj.contact.geometry import GeometryError, contact_table

    try:
        return contact_table(lay)
    except GeometryError as e:
        raise Failure(f"{lay.source}: profiles: {e}", EXIT_BAD_INPUT) from None


def _delta_r_of_profiles(lay: Layout):
    """Δr (mm) of a layout's wheel and rail profiles, from their contact geometry."""
    from rail_mj.contact.geometry import delta_r

    return delta_r(_contact_table(lay))


@cli.command("contact-geometry")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option(
    "-o",
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="The table as CSV: y_m, r_left_m, r_right_m, delta_r_m, contact_angle_left_rad, "
    "contact_angle_right_rad, roll_rad, then more (docs/geometry.md).",
)
@click.option(
    "--png",
    type=click.Path(dir_okay=False),
    help="Draw Δr(y), the contact angles and the contact points on the profiles here.",
)
def contact_geometry_cmd(layout, out, png):
    """The contact geometry of LAYOUT's wheel and rail profiles ([profiles]): a rigid
    wheelset shifted y from -10 to +10 mm at zero yaw, its roll, rolling radii and contact
    angles, contact points, curvatures and two-point contacts."""
    _check_outputs(layout, [("-o", out), ("--png", png)])
    lay = _layout(layout)
    if lay.profiles is None:
        raise Failure(
            f"{layout}: profiles: no [profiles] table: contact geometry needs wheel and rail "
            f"profiles (docs/geometry.md)",
            EXIT_BAD_INPUT,
        )
    table = _contact_table(lay)
    outputs = [p for p in (out, png) if p]
    try:
        with staged(outputs) as temps:  # both or neither
            temps[0].write_bytes(table.to_csv())
            if png:
                from rail_mj.output.plots import contact_geometry_png

                cone = None if lay.wheelset.conicity is None else lay.wheelset.conicity
                temps[1].write_bytes(contact_geometry_png(table, lay.name, cone))
    except OSError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    err = _uses_stdout(out, png)

    from rail_mj.contact.geometry import flange_contact_shift

    shift = flange_contact_shift(table)
    where = (
        f"flange contact from |y| = {shift * 1e3:.2f} mm" if shift is not None else "no flange contact within the range"
    )
    click.echo(
        f"{lay.name}: {len(table.y)} lateral shifts from {table.y[0] * 1e3:g} to {table.y[-1] * 1e3:g} mm; {where}",
        err=err,
    )
    click.echo(f"table: {out}" + (f"\nplot: {png}" if png else ""), err=err)


def _harmonic_or_nan(delta_r, amplitude: float) -> float:
    from rail_mj.contact.conicity import ConicityError, harmonic_conicity

    try:
        return harmonic_conicity(delta_r, amplitude)
    except ConicityError:  # the centre of the harmonic balance needs data past the ends
        return math.nan


def _amplitudes(text: str) -> list[float]:
    """--amplitudes A:B:N: N amplitudes from A to B mm, 0 < A <= B."""
    a, b, n = _triple("--amplitudes", text, "mm")
    from rail_mj.contact.conicity import MIN_AMPLITUDE

    if not (math.isfinite(a) and math.isfinite(b) and 0 < a <= b and 1 <= n <= 10_000 and (n > 1 or a == b)):
        raise Failure(
            f"--amplitudes A:B:N needs 0 < A <= B and 1 <= N <= 10000 (N = 1: A = B), got {text!r}", EXIT_BAD_INPUT
        )
    if a < MIN_AMPLITUDE:
        raise Failure(f"--amplitudes: the smallest amplitude is {MIN_AMPLITUDE:g} mm, got {a:g}", EXIT_BAD_INPUT)
    return [a + (b - a) * k / (n - 1) for k in range(n)] if n > 1 else [a]


def main(argv: list[str] | None = None) -> int:
    try:
        cli.main(args=argv, prog_name="rail-mj", standalone_mode=False)
    except Failure as e:
        click.echo(f"rail-mj: error: {e}", err=True)
        return e.status
    except click.exceptions.Abort:
        click.echo("rail-mj: interrupted", err=True)
        return 130
    except click.exceptions.NoArgsIsHelpError as e:  # `rail-mj` alone: the help, as --help
        click.echo(e.ctx.get_help())
        return 0
    except click.ClickException as e:
        click.echo(f"rail-mj: error: {e.format_message()} (see rail-mj --help)", err=True)
        return EXIT_BAD_INPUT
    except BrokenPipeError:  # the reader of standard output went away (`| head`)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except MemoryError:
        click.echo("rail-mj: error: out of memory: shorten --distance or use fewer speeds", err=True)
        return EXIT_RUN_FAILED
    except Exception as e:
        why = " ".join(str(e).split()) or "no message"
        click.echo(
            f"rail-mj: error: unexpected {type(e).__name__}: {why} (a bug in rail-mj: please "
            f"report it with the command line)",
            err=True,
        )
        return EXIT_RUN_FAILED
    return 0


if __name__ == "__main__":
    sys.exit(main())
