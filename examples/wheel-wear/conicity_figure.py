"""Wheel wear and equivalent conicity: new and worn S1002 on 60E1, drawn and tabulated.

    python examples/wheel-wear/conicity_figure.py [--out DIR]

Computes the rigid contact geometry (rail_mj.contact.geometry, -10 to +10 mm in 0.05 mm steps) and
EN 15302's equivalent conicity (rail_mj.contact.conicity, the integration method) for three wheel-rail
pairs on standard gauge (1435 mm, flange backs 1360 mm):

- new S1002 (EN 13715) on 60E1 (EN 13674-1) inclined 1:40,
- the same on rails inclined 1:20,
- the worn S1002 of tools/worn_profile.py (models/manchester-coach-worn/assets/s1002_worn.csv)
  on 60E1 at 1:40,

draws examples/wheel-wear/conicity_wear.png (the wheels, their rolling-radius differences Δr(y) and
λe against amplitude from 0.5 to 10 mm) and prints the Markdown table of λe at 1, 3 and 5 mm
that README.md quotes. About 20 s.
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rail_mj.contact import geometry as G
from rail_mj.contact import profiles as P
from rail_mj.contact.conicity import equivalent_conicity
from rail_mj.files import atomic_write

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))  # the worn wheel: a maintenance tool makes it
import worn_profile

AMPLITUDES = np.round(np.arange(0.5, 10.0 + 1e-9, 0.1), 10)  # mm
QUOTED = (1.0, 3.0, 5.0)  # mm: the README's table


def pairs() -> list[tuple[str, G.Track]]:
    new, rail = P.s1002(), P.rail_60e1()
    worn = P.read_profile(worn_profile.OUT / f"{worn_profile.NAME}.csv", "wheel")
    return [
        ("new S1002, 60E1 at 1:40", G.Track(new, rail, rail_inclination=1 / 40)),
        ("new S1002, 60E1 at 1:20", G.Track(new, rail, rail_inclination=1 / 20)),
        (f"worn S1002 ({worn_profile.DEPTH:g} mm), 60E1 at 1:40", G.Track(worn, rail, rail_inclination=1 / 40)),
    ]


def flange_from(table: G.ContactTable) -> float:
    """The smallest shift (mm) with the left wheel on its flange (contact angle above 1 rad)."""
    return float(table.y[(table.y > 0) & (table.contact_angle_left > 1.0)].min() * 1e3)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent))
    args = parser.parse_args()

    results = []
    for name, track in pairs():
        table = G.contact_table(track)
        delta_r = G.delta_r(table)
        lam = equivalent_conicity(delta_r, AMPLITUDES)
        quoted = equivalent_conicity(delta_r, QUOTED)
        results.append((name, track, table, lam, quoted))

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), layout="constrained")
    # The wheels across the tread, and the wear depth.
    s = np.linspace(-40.0, 45.0, 1701)
    new_z = -P.s1002_radius(s)
    worn = results[2][1].wheel
    axes[0].plot(s, new_z, color="C0", label="new S1002")
    axes[0].plot(s, worn.height(s * 1e-3) * 1e3, color="C2", label="worn")
    axes[0].set(
        xlabel="S across the wheel from the taping line (mm, + outer face)",
        ylabel="z = -(r - r0) (mm)",
        title="the wheels (flange root at left)",
    )
    axes[0].set_ylim(-8.0, 2.5)
    wear = axes[0].twinx()
    wear.fill_between(s, worn_profile.wear_depth(s), color="C2", alpha=0.15, lw=0)
    wear.set_ylim(0.0, 4 * worn_profile.DEPTH)
    wear.set_ylabel("wear depth w (mm, shaded)")
    axes[0].legend(loc="upper left", fontsize=8)
    for k, (name, _, table, lam, quoted) in enumerate(results):
        color = ("C0", "C1", "C2")[k]
        axes[1].plot(table.y * 1e3, table.delta_r * 1e3, color=color, lw=1.2, label=name)
        axes[2].plot(AMPLITUDES, lam, color=color, lw=1.5, label=f"{name}: {quoted[1]:.3f} at 3 mm")
    axes[1].set(
        xlabel="lateral shift y (mm)",
        ylabel="Δr = r_left - r_right (mm)",
        title="rolling-radius difference (flange contact off scale)",
        ylim=(-5.0, 5.0),
    )
    axes[1].legend(loc="upper left", fontsize=8)
    axes[2].axvline(3.0, color="grey", ls=":", lw=1)
    axes[2].set(
        xlabel="amplitude ŷ (mm)",
        ylabel="equivalent conicity λe",
        title="EN 15302 equivalent conicity (integration)",
        xlim=(0.0, 10.0),
    )
    axes[2].set_ylim(0.0, max(float(np.nanmax(r[3])) for r in results) * 1.05)
    axes[2].legend(loc="upper left", fontsize=8)
    for ax in axes:
        ax.grid(alpha=0.3)
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=100)
    plt.close(fig)
    atomic_write(Path(args.out) / "conicity_wear.png", png.getvalue())

    print("| wheel and rail | λe at 1 mm | λe at 3 mm | λe at 5 mm | flange contact from |")
    print("|---|---|---|---|---|")
    for name, _, table, _, quoted in results:
        print(f"| {name} | {quoted[0]:.3f} | {quoted[1]:.3f} | {quoted[2]:.3f} | y = {flange_from(table):.2f} mm |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
