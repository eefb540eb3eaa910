"""The seed's closing trade-off, worked: fast on the straight, or round sharp curves.

    python examples/stability-curving/tradeoff.py [--out DIR]

"You can make a vehicle run fast on straight track without hunting, or you can make it go round
sharp curves without derailing, but achieving both at the same time is more difficult." For the
shipped bogie and coach, over the primary yaw stiffness (per wheelset) and the wheels' conicity:
the eigen critical speed on straight track (rail_mj.analysis.stability) against the leading
wheelset's angle of attack in steady curving (rail_mj.analysis.curving.steady_curving) in a 600 m
curve at 30 m/s and a 1200 m curve at 40 m/s, both with 150 mm of cant (79 and 54 mm of cant
deficiency), and the wear number T-gamma of its outer wheel in the 600 m curve (the energy its creep
dissipates per metre rolled, N). Every number printed and every point drawn is the model's own. Prints the Markdown
table quoted in README.md and draws tradeoff.png: one panel per vehicle, the designs that no other
beats on both counts (the Pareto front) joined, the shipped design ringed.
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

from rail_mj.analysis.curving import steady_curving
from rail_mj.analysis.stability import Stability
from rail_mj.files import atomic_write
from rail_mj.layout import load_layout

MODELS = Path(__file__).resolve().parents[2] / "models"
VMIN, VMAX = 5.0, 300.0
YAW_STIFFNESS = np.geomspace(1e6, 1e8, 7)  # N m/rad per wheelset; the shipped 62.78e6 is among them below
CONICITY = (0.05, 0.15, 0.3)
CURVES = ((600.0, 30.0), (1200.0, 40.0))  # radius m, speed m/s
CANT = 0.15  # m


def design(base, yaw_stiffness: float, conicity: float):
    return dataclasses.replace(
        base,
        primary=dataclasses.replace(base.primary, yaw_stiffness=yaw_stiffness),
        wheelset=dataclasses.replace(base.wheelset, conicity=conicity),
    )


def evaluate(lay) -> tuple[float | None, list[float], float, float]:
    """The critical speed on straight track, the leading wheelset's angle of attack (rad) in each
    curve, and in the first its lateral displacement towards the outer rail (m) and its outer
    wheel's wear number T-gamma (N)."""
    vc = Stability(lay).critical_speed(VMIN, VMAX, points=80).critical_speed
    leading = [steady_curving(lay, r, v, CANT)["wheelsets"][0] for r, v in CURVES]
    # A left curve (positive radius): the outer rail is the right one, the wheel's second entry.
    outer_wear = leading[0]["wear_number_n"][1]
    return vc, [w["angle_of_attack_rad"] for w in leading], -leading[0]["lateral_m"], outer_wear


def pareto(points: np.ndarray) -> np.ndarray:
    """Indices of the points (critical speed, angle of attack) no other beats on both: higher and lower."""
    keep = []
    for i, (v, a) in enumerate(points):
        if not any((v2 >= v and a2 <= a) and (v2 > v or a2 < a) for v2, a2 in points):
            keep.append(i)
    return np.array(sorted(keep, key=lambda i: points[i, 0]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent))
    args = parser.parse_args()
    fig, axes = plt.subplots(1, 2, figsize=(12, 5), constrained_layout=True)
    print(
        "| vehicle | primary yaw stiffness | conicity | critical speed | angle of attack, 600 m at 30 m/s "
        "| 1200 m at 40 m/s | outward, 600 m | Tγ outer wheel, 600 m |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for ax, name in zip(axes, ("bogie", "manchester-coach")):
        base = load_layout(MODELS / name / f"{name}.toml")
        shipped = (base.primary.yaw_stiffness, base.wheelset.conicity)
        stiffness = np.unique(np.append(YAW_STIFFNESS, shipped[0]))
        results = {}
        for lam in CONICITY:
            for k in stiffness:
                results[(k, lam)] = evaluate(design(base, k, lam))
        points = np.array([(vc if vc is not None else VMAX, attack[0] * 1e3) for vc, attack, _, _ in results.values()])
        for lam, marker in zip(CONICITY, "os^"):
            xs = [results[(k, lam)][0] or VMAX for k in stiffness]
            ys = [results[(k, lam)][1][0] * 1e3 for k in stiffness]
            ax.plot(xs, ys, marker=marker, ls=":", label=f"conicity {lam:g}")
        front = pareto(points)
        ax.plot(points[front, 0], points[front, 1], "k-", lw=2, alpha=0.4, label="Pareto front")
        vc, attack, _, _ = results[shipped]
        ax.plot([vc], [attack[0] * 1e3], "o", ms=16, mfc="none", mec="red", mew=2, label="shipped design")
        ax.set_xlabel("critical speed on straight track (m/s)")
        ax.set_ylabel("leading wheelset's angle of attack, 600 m curve (mrad)")
        ax.set_title(f"{name}: yaw stiffness 1-100 MN m/rad along each line", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        for (k, lam), (vc, attack, outward, wear) in results.items():
            if lam == shipped[1] or k == shipped[0]:
                speed = "stable to 300 m/s" if vc is None else f"{vc:.1f} m/s"
                print(
                    f"| {name} | {k / 1e6:.3g} MN m/rad | {lam:g} | {speed} | {attack[0] * 1e3:.2f} mrad "
                    f"| {attack[1] * 1e3:.2f} mrad | {outward * 1e3:.1f} mm | {wear:.1f} N |"
                )
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    atomic_write(Path(args.out) / "tradeoff.png", buf.getvalue())


if __name__ == "__main__":
    main()
