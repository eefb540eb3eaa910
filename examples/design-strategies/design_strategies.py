"""The seed article's two routes to a stable vehicle, worked on the shipped models.

    python examples/design-strategies/design_strategies.py [--out DIR]

1. Conicity: 1:20 (0.05) against 1:40 (0.025), and the shipped effective 0.15, on the
   bogie and the coach (the Shinkansen's change from 1:20 to 1:40).
2. Matsudaira's route: a stiffer primary yaw stiffness on the coach.
3. Wickens' route: a softer suspension with lateral damping on the two-axle wagon.

Every number printed, and every point plotted, is an eigen critical speed of the
model (rail_mj.analysis.stability); nothing is taken from text. Prints a Markdown table
(copied into README.md) and writes design_strategies.png.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rail_mj.analysis.stability import Stability
from rail_mj.files import atomic_write
from rail_mj.layout import load_layout

MODELS = Path(__file__).resolve().parents[2] / "models"
VMIN, VMAX = 5.0, 300.0


def layout(name: str):
    return load_layout(MODELS / name / f"{name}.toml")


def with_changes(base, **sections):
    """A copy of `base` with fields of its sections replaced: with_changes(l, wheelset={...})."""
    changes = {k: dataclasses.replace(getattr(base, k), **v) for k, v in sections.items()}
    return dataclasses.replace(base, **changes)


def critical(lay) -> tuple[float | None, str]:
    r = Stability(lay).critical_speed(VMIN, VMAX, points=80)
    return r.critical_speed, r.mode or r.note


def conicity_study():
    rows = []
    for name in ("bogie", "manchester-coach"):
        base = layout(name)
        for lam, label in ((0.05, "1:20"), (0.025, "1:40"), (0.15, "0.15 (shipped)")):
            vc, mode = critical(with_changes(base, wheelset={"conicity": lam}))
            rows.append((name, f"conicity {label}", vc, mode))
    return rows


def yaw_stiffness_sweep(values):
    base = layout("manchester-coach")
    out = {}
    for lam in (0.05, 0.15):
        out[lam] = [
            critical(with_changes(base, wheelset={"conicity": lam}, primary={"yaw_stiffness": k}))[0] for k in values
        ]
    return out


def wagon_damping_sweep(values):
    base = layout("wagon")
    out = {}
    for ky in (1.0e6, 0.25e6):
        out[ky] = [
            critical(with_changes(base, primary={"lateral_stiffness": ky, "lateral_damping": c}))[0] for c in values
        ]
    return out


def fmt(v):
    return "stable to 300 m/s" if v is None else f"{v:.1f} m/s ({v * 3.6:.0f} km/h)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent))
    args = parser.parse_args()

    rows = conicity_study()
    yaw = np.geomspace(2e6, 200e6, 25)
    damping = np.linspace(0.0, 100e3, 21)
    yaw_vc = yaw_stiffness_sweep(yaw)
    wagon_vc = wagon_damping_sweep(damping)
    base_coach = critical(layout("manchester-coach"))
    soft_coach = critical(with_changes(layout("manchester-coach"), primary={"yaw_stiffness": 5e6}))
    base_wagon = critical(layout("wagon"))
    wickens = critical(with_changes(layout("wagon"), primary={"lateral_stiffness": 0.25e6, "lateral_damping": 60e3}))

    print("| vehicle | change | eigen critical speed | mode at the threshold |")
    print("|---|---|---|---|")
    for name, change, vc, mode in rows:
        print(f"| {name} | {change} | {fmt(vc)} | {mode} |")
    print(f"| manchester-coach | soft primary yaw stiffness, 5 MN m/rad | {fmt(soft_coach[0])} | {soft_coach[1]} |")
    print(
        f"| manchester-coach | stiff primary yaw stiffness, 62.78 MN m/rad (shipped; Matsudaira) | {fmt(base_coach[0])} | {base_coach[1]} |"  # noqa: E501
    )
    print(f"| wagon | shipped: 1 MN/m, 20 kN s/m | {fmt(base_wagon[0])} | {base_wagon[1]} |")
    print(f"| wagon | 0.25 MN/m, 60 kN s/m (Wickens) | {fmt(wickens[0])} | {wickens[1]} |")

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 5), layout="constrained")
    for lam, vcs in yaw_vc.items():
        ax1.plot(yaw / 1e6, [np.nan if v is None else v for v in vcs], "o-", ms=3, label=f"conicity {lam:g}")
    ax1.axvline(62.78, color="grey", linestyle=":", label="shipped 62.78 MN m/rad")
    ax1.set(
        xscale="log",
        xlabel="primary yaw stiffness per wheelset (MN m/rad)",
        ylabel="eigen critical speed (m/s)",
        title="Coach: Matsudaira's route (stiffer yaw, lower conicity)",
    )
    ax1.grid(alpha=0.3, which="both")
    ax1.legend()
    for ky, vcs in wagon_vc.items():
        ax2.plot(
            damping / 1e3,
            [np.nan if v is None else v for v in vcs],
            "o-",
            ms=3,
            label=f"lateral stiffness {ky / 1e6:g} MN/m",
        )
    ax2.set(
        xlabel="lateral damping per wheelset (kN s/m)",
        ylabel="eigen critical speed (m/s)",
        title="Two-axle wagon: Wickens' route (soft, laterally damped)",
    )
    ax2.grid(alpha=0.3)
    ax2.legend()
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=100)
    path = Path(args.out) / "design_strategies.png"
    atomic_write(path, png.getvalue())
    print(f"\nfigure: {path}")


if __name__ == "__main__":
    main()
