"""A worn S1002 wheel: the new profile less a band of tread (hollow) wear, written as files.

    python tools/worn_profile.py            # write the two files below
    python tools/worn_profile.py --check    # exit 1 if they differ from what this writes now
    python tools/worn_profile.py --report   # also: equivalent conicity on 60E1 1:40, new and worn

writes models/manchester-coach-worn/assets/s1002_worn.csv (y_mm,z_mm, the convention of
docs/profiles.md) and the same points as a SIMPACK wheel file, s1002_worn.prw.

The construction (docs/profiles.md, "A worn S1002"): the wheel's radius at S mm from the
taping line (positive towards the outer face) is EN 13715's r0 + F(S) less a wear depth

    w(S) = DEPTH * cos²(π (S - CENTRE) / (2 HALF_WIDTH))    for |S - CENTRE| < HALF_WIDTH
    w(S) = 0                                               elsewhere

a raised-cosine (Hann) band DEPTH = 0.8 mm deep at S = CENTRE = +5 mm, the running band around
the centred contact point (S = +3.2 mm on 60E1 at 1:40), falling smoothly (value and slope) to
nothing 30 mm either side: at S = -25 mm, where the flange root begins (S1002's throat section
starts at -26 mm), and at S = +35 mm, on the outer 1:15 cone. The flange, its root and the outer
face are S1002's to the last written digit. In the convention z = -(r - r0): z = -F(S) + w(S), in
the new wheel's frame (the flange back at -70 mm, the flange tip still at z = -28 mm; the flange
is w(0) = 0.75 mm higher above the worn taping line than it was above the new one).

What is assumed: the shape of the wear (a smooth, symmetric band) and its size; only the tread
wears, the rail stays a new 60E1. What follows from it (`--report`): the equivalent conicity at
3 mm rises from 0.177 to about 0.35.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from rail_mj.contact import profiles as P

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "models" / "manchester-coach-worn" / "assets"
NAME = "s1002_worn"

DEPTH = 0.8  # mm, the deepest wear
CENTRE = 5.0  # mm from the taping line, towards the outer face: the band's middle
HALF_WIDTH = 30.0  # mm: the band runs from CENTRE - HALF_WIDTH to CENTRE + HALF_WIDTH
STEP = 0.25  # mm between points across the tread (from the worn band's flange side on)
FLANGE_POINTS = 1001  # S1002's points (evenly along its length) kept on the flange side
DECIMALS = 6  # mm: the files' precision, 1 nm


def wear_depth(s_mm):
    """w(S): the radius lost at S mm from the taping line, mm (0 outside the band)."""
    s = np.asarray(s_mm, dtype=float)
    u = (s - CENTRE) / HALF_WIDTH
    return np.where(np.abs(u) < 1.0, DEPTH * np.cos(0.5 * math.pi * u) ** 2, 0.0)


def points_mm() -> tuple[np.ndarray, np.ndarray]:
    """(y, z) in mm, rounded to DECIMALS: S1002's own points (and its flange tip) on the
    flange side of the band, then every STEP mm to the outer face."""
    lo, hi = P.S1002_RANGE_MM
    flange = P.s1002(points=FLANGE_POINTS).y * 1e3
    flange = flange[flange < CENTRE - HALF_WIDTH - 0.5 * STEP]
    tip = -55.0  # the flange tip, S1002's lowest point (z = -28 mm): one of the points
    flange = np.sort(np.append(flange[np.abs(flange - tip) > 0.05], tip))
    tread = np.arange(CENTRE - HALF_WIDTH, hi + 0.5 * STEP, STEP)
    y = np.round(np.concatenate([flange, tread]), DECIMALS)
    y[0], y[-1] = lo, hi
    z = np.round(0.0 - P.s1002_radius(y) + wear_depth(y), DECIMALS) + 0.0  # + 0.0: no -0.0
    return y, z


def profile() -> P.Profile:
    """The worn wheel as a Profile (m), exactly what the files hold."""
    y, z = points_mm()
    return P.Profile("S1002 worn", P.WHEEL, y * 1e-3, z * 1e-3, "tools/worn_profile.py")


def _number(v: float) -> str:
    """v to DECIMALS places, trailing zeros dropped: 2.5, -28, 0."""
    text = f"{v:.{DECIMALS}f}".rstrip("0").rstrip(".")
    return "0" if text in ("", "-0") else text


def _header() -> list[str]:
    return [
        "S1002 (EN 13715) less a tread wear band: written by tools/worn_profile.py",
        f"w(S) = {DEPTH:g} mm * cos^2(pi (S - {CENTRE:g}) / {2 * HALF_WIDTH:g}) for |S - {CENTRE:g}| "
        f"< {HALF_WIDTH:g} mm, else 0; docs/profiles.md, 'A worn S1002'",
    ]


def csv_bytes() -> bytes:
    """y_mm,z_mm in rail-mj's convention (z up, a wheel's z = -(r - r0)), with '#' comments."""
    y, z = points_mm()
    lines = [f"# {h}" for h in _header()] + [P.CSV_HEADER]
    lines += [f"{_number(a)},{_number(b)}" for a, b in zip(y, z)]
    return ("\n".join(lines) + "\n").encode()


def prw_bytes() -> bytes:
    """The same points as a SIMPACK wheel profile: millimetres (units.len.f = 1000), SIMPACK's
    z down (the radius above r0), no other preprocessing flag."""
    y, z = points_mm()
    lines = [f"! {h}" for h in _header()]
    lines += [
        "header.begin",
        "  version = 1",
        "  type = 1  ! 0 rail, 1 wheel",
        "header.end",
        "spline.begin",
        "  approx.smooth = 0",
        "  units.len.f = 1000.0",
        "  point.begin",
        "    ! y z (mm, z down)",
    ]
    lines += [f"    {_number(a)} {_number(0.0 - b)}" for a, b in zip(y, z)]
    lines += ["  point.end", "spline.end"]
    return ("\n".join(lines) + "\n").encode()


def files() -> dict[Path, bytes]:
    return {OUT / f"{NAME}.csv": csv_bytes(), OUT / f"{NAME}.prw": prw_bytes()}


def report() -> None:
    """Equivalent conicity of the new and the worn wheel on 60E1 at 1:40, from the files."""
    from rail_mj.contact import geometry as G
    from rail_mj.contact.conicity import equivalent_conicity

    amplitudes = [1.0, 3.0, 5.0]
    for name, wheel in (("new S1002", P.s1002()), ("worn", P.read_profile(OUT / f"{NAME}.csv", "wheel"))):
        table = G.contact_table(G.Track(wheel, P.rail_60e1()))
        lam = equivalent_conicity(G.delta_r(table), amplitudes)
        flange = table.y[(table.y > 0) & (table.contact_angle_left > 1.0)]
        print(
            f"{name}: lambda_e at {', '.join(f'{a:g}' for a in amplitudes)} mm = "
            f"{', '.join(f'{v:.3f}' for v in lam)}; flange contact from y = {flange.min() * 1e3:.2f} mm "
            f"(0.05 mm table)"
        )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only compare, exit 1 if out of date")
    parser.add_argument("--report", action="store_true", help="print the equivalent conicities")
    args = parser.parse_args()
    stale = [path for path, data in files().items() if not path.is_file() or path.read_bytes() != data]
    if args.check:
        for path in stale:
            print(f"{path.relative_to(ROOT)} is out of date")
        return 1 if stale else 0
    for path, data in files().items():
        if path in stale:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
            print(path.relative_to(ROOT))
    if args.report:
        report()
    return 0


if __name__ == "__main__":
    sys.exit(main())
