"""`rail-mj eigen`, `critical-speed`, `root-locus` and `bifurcation`: a layout's stability,
linear (its eigenvalues against speed) and nonlinear (its limit cycles)."""

from __future__ import annotations

import json
import math

import click

from rail_mj.cli.options import (
    EXIT_BAD_INPUT,
    EXIT_RUN_FAILED,
    Failure,
    check_outputs,
    check_speed,
    check_speed_range,
    csv_beside,
    layout_of,
    span_of,
    status_line,
    uses_stdout,
    warn,
    written,
)
from rail_mj.layout import Layout
from rail_mj.practice import RANGES
from rail_mj.studies.span import LOCUS


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


# m/s: the eigen and time searches' top speed when no --vmax is given.
DEFAULT_VMAX = 150.0


def _warn_record(result) -> None:
    """A warning when a nonlinear search started above the table of practice's usual speeds."""
    linear = result.linear_critical_speed
    usual = RANGES["speed"].usual[1]
    if linear is not None and 1.1 * linear > usual:
        warn(
            f"the limit cycle was started at {1.1 * linear:.1f} m/s, 1.1 times the linear critical speed, beyond "
            f"{RANGES['speed'].practice} ({usual:g} m/s; docs/practice.md)"
        )


@click.command("eigen")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--speed", type=float, required=True, help="Forward speed, m/s.")
@click.option("--json", "as_json", is_flag=True, help="Print the modes as JSON.")
@_amplitude_option
def eigen_cmd(layout, speed, as_json, amplitude):
    """Eigenvalues and modes of LAYOUT linearised at SPEED, least damped first."""
    lay = layout_of(layout)
    check_speed("--speed", speed)
    stability = _stability(lay, amplitude)
    modes = stability.modes(speed)
    oscillatory = [m for m in modes if m.oscillatory]
    aperiodic = [m.eigenvalue.real for m in modes if not m.oscillatory]
    if as_json:
        click.echo(
            json.dumps(
                {
                    "speed_m_per_s": speed,
                    "stable": not any(m.growing for m in modes),
                    "neutral": [m.name for m in modes if m.neutral],
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
    neutral = [m.name for m in modes if m.neutral]
    if neutral:  # rail_mj.analysis.stability.NEUTRAL
        click.echo(f"neutral (undamped, to round-off): {', '.join(neutral)}")
    unstable = [m.name for m in modes if m.growing]
    click.echo(f"unstable at {speed:g} m/s: {', '.join(unstable)}" if unstable else f"stable at {speed:g} m/s")


def _check_step(step: float | None) -> float:
    """--step, or the one step every nonlinear critical speed uses (not imported before
    it is needed: it comes with MuJoCo and numba)."""
    if step is None:
        from rail_mj.analysis.bifurcation import STEP

        return STEP
    lo, hi = RANGES["bifurcation.step"].refuse
    if not (math.isfinite(step) and lo <= step <= hi):
        raise Failure(f"--step must be between {lo:g} and {hi:g}, got {step}", EXIT_BAD_INPUT)
    return step


def _check_deceleration(deceleration: float | None) -> float:
    """--deceleration, or the ramp's default; refused outside the table of practice, warned
    about outside its usual range."""
    if deceleration is None:
        from rail_mj.analysis.bifurcation import RAMP_DECELERATION

        return RAMP_DECELERATION
    limits = RANGES["ramp.deceleration"]
    problem = limits.check(deceleration) if math.isfinite(deceleration) else f"must be finite, got {deceleration}"
    if problem is not None:
        raise Failure(f"--deceleration {problem}", EXIT_BAD_INPUT)
    warning = limits.warning(deceleration)
    if warning is not None:
        warn(f"--deceleration {warning}")
    return deceleration


@click.command("critical-speed")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option(
    "--method",
    type=click.Choice(["eigen", "time", "nonlinear", "ramp"]),
    default="eigen",
    show_default=True,
    help="eigen: where the least-damped root crosses zero; time: simulations from a small "
    "disturbance; nonlinear: lower the speed in steps from hunting until the limit cycle dies; "
    "ramp: brake slowly from hunting until it dies (nonlinear and ramp need [flange] or "
    "[profiles] and a saturating creep law).",
)
@click.option("--vmin", type=float, default=5.0, show_default=True, help="Lowest speed searched, m/s.")
@click.option(
    "--vmax",
    type=float,
    help="Highest speed searched, m/s  [default: 150; nonlinear and ramp: the linear critical speed they "
    "start above is searched up to 320, the table of practice's limit]",
)
@click.option(
    "--step",
    type=float,
    help="nonlinear: the speed step down the limit cycle, a fraction of the speed (the "
    "nonlinear critical speed is known to within it)  [default: 0.02, "
    "rail_mj.analysis.bifurcation.STEP]",
)
@click.option(
    "--deceleration",
    type=float,
    help="ramp: the deceleration through the critical speed, m/s^2  [default: 0.1, "
    "rail_mj.analysis.bifurcation.RAMP_DECELERATION]",
)
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@_amplitude_option
def critical_speed_cmd(layout, method, vmin, vmax, step, deceleration, as_json, amplitude):
    """The lowest speed at which LAYOUT stops being stable, and the mode that sets it."""
    lay = layout_of(layout)
    if vmax is None and method in ("eigen", "time"):
        vmax = DEFAULT_VMAX
    check_speed_range(vmin, DEFAULT_VMAX if vmax is None else vmax)
    step = _check_step(step)
    if deceleration is not None and method != "ramp":
        raise Failure("--deceleration is for --method ramp", EXIT_BAD_INPUT)
    deceleration = _check_deceleration(deceleration)
    from rail_mj.simulation.runner import SimulationError

    stability = _stability(lay, amplitude)  # a model that does not compile fails here, with exit 2
    try:
        with status_line(f"critical speed ({method})") as progress:
            if method == "eigen":
                result = stability.critical_speed(vmin, vmax)
            elif method == "nonlinear":
                from rail_mj.analysis.bifurcation import nonlinear_critical_speed

                result, _ = nonlinear_critical_speed(lay, vmin, vmax, step, progress=progress, amplitude=amplitude)
            elif method == "ramp":
                from rail_mj.analysis.bifurcation import ramp_critical_speed

                result, _ = ramp_critical_speed(lay, vmin, vmax, deceleration, progress=progress, amplitude=amplitude)
            else:
                from rail_mj.analysis.stability import time_critical_speed

                result = time_critical_speed(lay, vmin, vmax, progress=progress)
    except SimulationError as e:
        raise Failure(str(e), EXIT_RUN_FAILED) from None
    except ValueError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    _warn_record(result)
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
        if len(result.unstable_ranges) > 1 or (result.unstable_ranges and result.unstable_ranges[0][1] < result.vmax):
            spans = "; ".join(f"{a:.1f}-{b:.1f}" for a, b in result.unstable_ranges)
            click.echo(f"unstable ranges (m/s): {spans}")


@click.command("root-locus")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--speeds", required=True, help="A:B:N, N speeds from A to B m/s.")
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False), help="The plot, PNG.")
@click.option(
    "--csv", "csv_path", type=click.Path(dir_okay=False), help="The data as CSV [default: the plot's name with .csv]."
)
@_amplitude_option
def root_locus_cmd(layout, speeds, out, csv_path, amplitude):
    """Frequency and damping of every mode of LAYOUT against speed, critical speed marked."""
    lay = layout_of(layout)
    vs = span_of("--speeds", speeds, LOCUS).values()
    csv_path = csv_beside(out, csv_path, "the plot and the data")
    check_outputs(layout, [("-o", out), ("--csv", csv_path)])
    from rail_mj.output.plots import locus_csv, root_locus, root_locus_png

    stability = _stability(lay, amplitude)
    with status_line("root locus") as progress:
        rows = root_locus(stability, vs, progress)
        critical = stability.critical_speed(vs[0], vs[-1])
    with written([csv_path, out]) as (csv_tmp, png_tmp):
        csv_tmp.write_bytes(locus_csv(rows))
        png_tmp.write_bytes(root_locus_png(rows, critical, lay.name))
    err = uses_stdout(out, csv_path)
    click.echo(f"plot: {out}\ndata: {csv_path}", err=err)
    if critical.critical_speed is not None:
        click.echo(
            f"critical speed {critical.critical_speed:.2f} m/s: {critical.mode}{_linearised(stability)}", err=err
        )
    else:
        click.echo(critical.note, err=err)


@click.command("bifurcation")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False), help="The diagram, PNG.")
@click.option(
    "--csv", "csv_path", type=click.Path(dir_okay=False), help="The data as CSV [default: the plot's name with .csv]."
)
@click.option("--vmin", type=float, default=5.0, show_default=True, help="Lowest speed, m/s.")
@click.option(
    "--vmax",
    type=float,
    help="Highest speed, m/s  [default: none, the linear critical speed the branches start above is "
    "searched up to 320, the table of practice's limit]",
)
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
    lay = layout_of(layout)
    check_speed_range(vmin, DEFAULT_VMAX if vmax is None else vmax)
    step = _check_step(step)
    csv_path = csv_beside(out, csv_path, "the plot and the data")
    check_outputs(layout, [("-o", out), ("--csv", csv_path)])
    from rail_mj.analysis.bifurcation import bifurcation
    from rail_mj.output.plots import bifurcation_csv, bifurcation_png
    from rail_mj.simulation.runner import SimulationError

    _stability(lay, amplitude)
    try:
        with status_line("bifurcation") as progress:
            critical, down, up = bifurcation(lay, vmin, vmax, step, progress=progress, amplitude=amplitude)
    except ValueError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    except SimulationError as e:
        raise Failure(str(e), EXIT_RUN_FAILED) from None
    if down is None:
        raise Failure(f"{layout}: {critical.note}", EXIT_RUN_FAILED)
    _warn_record(critical)
    with written([csv_path, out]) as (csv_tmp, png_tmp):
        csv_tmp.write_bytes(bifurcation_csv([down, up]))
        png_tmp.write_bytes(bifurcation_png(critical, down, up, lay.wheelset.flangeway_clearance, lay.name))
    err = uses_stdout(out, csv_path)
    click.echo(f"plot: {out}\ndata: {csv_path}", err=err)
    nonlinear = (
        f"{critical.critical_speed:.2f} m/s (speed lowered in {step:.0%} steps)"
        if critical.critical_speed
        else f"none: {critical.note}"
    )
    click.echo(f"linear critical speed {critical.linear_critical_speed:.2f} m/s; nonlinear {nonlinear}", err=err)
