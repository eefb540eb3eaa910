"""`rail-mj curving`: the steady state of a vehicle on constant curves (rail_mj.analysis.curving)."""

from __future__ import annotations

import json

import click

from rail_mj.cli.options import (
    EXIT_BAD_INPUT,
    EXIT_RUN_FAILED,
    Failure,
    check_speed,
    layout_of,
    span_of,
    warn,
    warn_deficiency,
)
from rail_mj.practice import RANGES
from rail_mj.studies.span import SPEEDS


@click.command("curving")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--radius", type=float, help="Curve radius, m (positive turns left, negative right).")
@click.option("--radii", help="Several radii, m, comma-separated: 300,600,1200.")
@click.option(
    "--cant", type=float, default=0.0, show_default=True, help="Cant, m: the outer rail over the inner over 1.5 m."
)
@click.option("--speed", type=float, help="Forward speed, m/s.")
@click.option("--speeds", help="Several speeds, m/s: A:B:N.")
@click.option("--json", "as_json", is_flag=True, help="Print the results as JSON (a list, one per radius and speed).")
def curving_cmd(layout, radius, radii, cant, speed, speeds, as_json):
    """The steady (quasi-static) state of LAYOUT on a constant curve, solved directly: per
    wheelset the lateral displacement, angle of attack, guiding force and each wheel's Q, Y,
    Y/Q and wear number Tgamma; each frame's and car body's displacement; the cant deficiency."""
    lay = layout_of(layout)
    radii_list = _radii(radius, radii)
    speed_list = _speeds(speed, speeds)
    error = RANGES["track.cant"].check(cant)
    if error:
        raise Failure(f"--cant {error}", EXIT_BAD_INPUT)
    warning = RANGES["track.cant"].warning(cant)
    if warning:
        warn(f"--cant: {warning}")
    from rail_mj.analysis.curving import CurvingError, steady_curving

    results = []
    for r in radii_list:
        for v in speed_list:
            try:
                # The cant is the outer rail's, on the side the curve turns away from.
                results.append(steady_curving(lay, r, v, cant if r > 0 else -cant))
            except CurvingError as e:
                raise Failure(str(e), EXIT_RUN_FAILED) from None
            except ValueError as e:
                raise Failure(str(e), EXIT_BAD_INPUT) from None
    for result in results:
        warn_deficiency(
            f"{result['radius_m']:g} m curve at {result['speed_m_per_s']:g} m/s", result["cant_deficiency_mm"]
        )
    if as_json:
        click.echo(json.dumps(results, indent=2))
        return
    for result in results:
        _print(result)


def _radii(radius: float | None, radii: str | None) -> list[float]:
    if (radius is None) == (radii is None):
        raise Failure("give one of --radius R or --radii R1,R2,...", EXIT_BAD_INPUT)
    if radius is not None:
        values = [radius]
    else:
        assert radii is not None
        try:
            values = [float(text) for text in radii.split(",")]
        except ValueError:
            raise Failure(f"--radii must be numbers separated by commas, got {radii!r}", EXIT_BAD_INPUT) from None
    for value in values:
        error = RANGES["track.radius"].check(abs(value))
        if error:
            raise Failure(f"--radius {error}", EXIT_BAD_INPUT)
        warning = RANGES["track.radius"].warning(abs(value))
        if warning:
            warn(f"--radius: {warning}")
    return values


def _speeds(speed: float | None, speeds: str | None) -> list[float]:
    if (speed is None) == (speeds is None):
        raise Failure("give one of --speed V or --speeds A:B:N", EXIT_BAD_INPUT)
    if speed is not None:
        return [check_speed("--speed", speed)]
    assert speeds is not None
    return [float(v) for v in span_of("--speeds", speeds, SPEEDS).values()]


def _print(result: dict) -> None:
    click.echo(
        f"{result['layout']} on a {result['radius_m']:g} m curve, cant {result['cant_m'] * 1e3:g} mm, at "
        f"{result['speed_m_per_s']:g} m/s: cant deficiency {result['cant_deficiency_mm']:.0f} mm "
        f"({result['uncompensated_acceleration_m_per_s2']:.2f} m/s^2)"
    )
    click.echo(
        "wheelset  y (mm)  angle of attack (mrad)  Sigma Y (kN)  Q left/right (kN)  Y/Q left/right"
        "  Tgamma left/right (N)"
    )
    for w in result["wheelsets"]:
        q = "/".join(f"{v / 1e3:.1f}" for v in w["wheel_loads_n"])
        ratio = "/".join("-" if v is None else f"{v:.3f}" for v in w["y_over_q"])
        wear = "/".join(f"{v:.1f}" for v in w["wear_number_n"])
        click.echo(
            f"{w['wheelset']:>8}  {w['lateral_m'] * 1e3:>6.2f}  {w['angle_of_attack_rad'] * 1e3:>22.2f}"
            f"  {w['guiding_force_n'] / 1e3:>12.2f}  {q:>17}  {ratio:>14}  {wear:>21}"
        )
    for b in result["bodies"]:
        roll = f", roll {b['roll_rad'] * 1e3:.2f} mrad" if "roll_rad" in b else ""
        click.echo(f"{b['body']}: y {b['lateral_m'] * 1e3:.2f} mm, yaw {b['yaw_rad'] * 1e3:.3f} mrad{roll}")
