"""`rail-mj contact`, `creep`, `profile`, `conicity` and `contact-geometry`: the wheel-rail
contact on its own, without a vehicle (rail_mj.contact)."""

from __future__ import annotations

import contextlib
import json
import math
from pathlib import Path

import click

from rail_mj.cli.options import (
    EXIT_BAD_INPUT,
    Failure,
    check_finite,
    check_outputs,
    check_positive,
    check_profile_outputs,
    layout_of,
    span_of,
    tables_of,
    uses_stdout,
    warn,
    written,
)
from rail_mj.files import STDOUT
from rail_mj.layout import LAWS, MAX_MAGNITUDE, Layout
from rail_mj.practice import RANGES
from rail_mj.studies.span import AMPLITUDES


@click.command("contact")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def contact_cmd(layout, as_json):
    """The Hertz contact ellipse and Kalker creep coefficients of LAYOUT's [contact]."""
    from rail_mj.layout import contact_patch_of

    if "profiles" in tables_of(layout):  # refused before its contact tables are built
        raise Failure(
            f"{layout}: contact: on [profiles] each contact point has its own ellipse; "
            f"rail-mj contact-geometry tabulates the points",
            EXIT_BAD_INPUT,
        )
    lay = layout_of(layout)
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


@click.command("creep")
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
@click.option(
    "--poisson",
    type=float,
    required=True,
    help="Poisson's ratio, {:g} to {:g} (steel: about 0.28).".format(*RANGES["contact.poisson_ratio"].refuse),
)
@click.option("--law", type=click.Choice(list(LAWS)), required=True, help="The creep law (docs/creep.md).")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def creep_cmd(semi_axes, normal_force, creepages, friction, shear_modulus, poisson, law, as_json):
    """The creep force and spin moment of one contact ellipse, by a creep law: Fx, Fy (N)
    and Mz (N m) of the rail on the wheel, Kalker's signs (Fx = -f11*xi for small xi).

    Kalker's coefficients C11..C33 come from his table at A/B and the Poisson's ratio (beyond
    A/B = 10, a flange's slender ellipse, his asymptotic expressions joined to the table), the
    linear coefficients as f11 = G*A*B*C11 and so on (docs/contact.md); fastsim is Kalker's
    FASTSIM on the ellipse, with his parabolic pressure (docs/creep.md)."""
    a, b = semi_axes
    xi, eta, phi = creepages
    _check_creep(a, b, normal_force, shear_modulus, xi, eta, phi, poisson, friction, law)
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
    mu = "" if limit is None else f", mu {friction:g} (mu*N {limit / 1e3:.4g} kN)"
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


def _check_creep(a, b, normal_force, shear_modulus, xi, eta, phi, poisson, friction, law) -> None:
    """Refuse inputs no contact has (rail_mj.layout.practice, `contact.*`), in the order given."""
    check_finite("--semi-axes", a, b)
    check_finite("--creepages", xi, eta, phi)
    for option, value in (("--normal-force", normal_force), ("--shear-modulus", shear_modulus)):
        check_finite(option, value)
        if not 0.0 < value <= MAX_MAGNITUDE:
            raise Failure(f"{option} must be positive and at most {MAX_MAGNITUDE:g}, got {value:g}", EXIT_BAD_INPUT)
    _check_semi_axes(a, b)
    _check_creepages(xi, eta, phi)
    check_finite("--poisson", poisson)
    lo, hi = RANGES["contact.poisson_ratio"].refuse
    if not lo <= poisson <= hi:
        raise Failure(f"--poisson must be between {lo:g} and {hi:g}, got {poisson:g}", EXIT_BAD_INPUT)
    if friction is None:
        if law != "linear":
            raise Failure(f"--friction: missing: the {law} law needs the friction coefficient", EXIT_BAD_INPUT)
    else:
        check_positive("--friction", friction, "creep.friction")


def _check_semi_axes(a: float, b: float) -> None:
    limits = RANGES["contact.semi_axis"]
    (lo, hi), unit = limits.refuse, limits.unit
    for value in (a, b):
        if not lo <= value <= hi:
            raise Failure(
                f"--semi-axes must be between {lo:g} and {hi:g} {unit}, got {value:g}; check the units ({unit})",
                EXIT_BAD_INPUT,
            )
    lo, hi = limits.usual
    unusual = [f"{v:g}" for v in dict.fromkeys((a, b)) if not lo <= v <= hi]
    if unusual:
        warn(f"--semi-axes: {' and '.join(unusual)} {unit} outside {limits.practice}, {lo:g}-{hi:g} {unit}")


def _check_creepages(xi: float, eta: float, phi: float) -> None:
    creepage, spin = RANGES["contact.creepage"], RANGES["contact.spin"]
    lo, hi = creepage.refuse
    if not (lo <= xi <= hi and lo <= eta <= hi):
        raise Failure(
            f"--creepages XI and ETA must be within +/-{hi:g} ({creepage.why}), got {xi:g} and {eta:g}",
            EXIT_BAD_INPUT,
        )
    lo, hi = spin.refuse
    if not lo <= phi <= hi:
        raise Failure(f"--creepages PHI must be within +/-{hi:g} {spin.unit}, got {phi:g}", EXIT_BAD_INPUT)


@click.command("profile")
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
    check_outputs(None if is_standard else profile, [("-o", out), ("--png", png)], source="the profile file")
    try:
        shape = profiles.standard(profile) if is_standard else profiles.read_profile(profile, kind)
    except profiles.ProfileError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    if kind is not None and shape.kind != kind:
        raise Failure(f"{profile}: --kind {kind}, but it is a {shape.kind} profile", EXIT_BAD_INPUT)
    outputs = [p for p in (out, png) if p]
    with written(outputs) as temps:  # both or neither
        temps[0].write_bytes(profiles.write_csv(shape))
        if png:
            from rail_mj.output.plots import profile_png

            temps[1].write_bytes(profile_png(shape))
    err = uses_stdout(out, png)
    click.echo(
        f"{shape.name}: {shape.kind}, {len(shape.y)} points, y from {shape.y[0] * 1e3:.3f} to "
        f"{shape.y[-1] * 1e3:.3f} mm",
        err=err,
    )
    click.echo(f"points: {out}" + (f"\nplot: {png}" if png else ""), err=err)


# mm: a centre or dead-band end closer to 0 than this (a nanometre) is printed as 0.
CENTRE_ROUND_OFF = 1e-6


@click.command("conicity")
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
    check_outputs(source, [("--png", png)])
    from rail_mj.contact.conicity import (
        DEFAULT_AMPLITUDES,
        QUOTED_AMPLITUDE,
        ConicityError,
        DeltaR,
        equivalent_conicity,
    )

    try:
        if layout is not None:
            lay = layout_of(layout)
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
        with written([png]) as (tmp,):
            tmp.write_bytes(picture)
    err = uses_stdout(png)
    finite = [float(v) if math.isfinite(v) else None for v in values]
    if as_json:
        click.echo(json.dumps({"amplitude_mm": [float(a) for a in wanted], "equivalent_conicity": finite}), err=err)
        return
    # The centre is found by bisection to round-off: 2.8e-76 mm is a centre at 0.
    a, b = (0.0 if abs(v) < CENTRE_ROUND_OFF else v for v in delta_r.centre)
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


@click.command("contact-geometry")
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
    check_outputs(layout, [("-o", out), ("--png", png)])
    lay = layout_of(layout)
    check_profile_outputs(lay, [("-o", out), ("--png", png)])
    if lay.profiles is None:
        raise Failure(
            f"{layout}: profiles: no [profiles] table: contact geometry needs wheel and rail "
            f"profiles (docs/geometry.md)",
            EXIT_BAD_INPUT,
        )
    table = _contact_table(lay)
    outputs = [p for p in (out, png) if p]
    with written(outputs) as temps:  # both or neither
        temps[0].write_bytes(table.to_csv())
        if png:
            from rail_mj.output.plots import contact_geometry_png

            cone = None if lay.wheelset.conicity is None else lay.wheelset.conicity
            temps[1].write_bytes(contact_geometry_png(table, lay.name, cone))
    err = uses_stdout(out, png)

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
    span = span_of("--amplitudes", text, AMPLITUDES)
    from rail_mj.contact.conicity import MIN_AMPLITUDE

    if span.a < MIN_AMPLITUDE:
        raise Failure(f"--amplitudes: the smallest amplitude is {MIN_AMPLITUDE:g} mm, got {span.a:g}", EXIT_BAD_INPUT)
    return span.values()
