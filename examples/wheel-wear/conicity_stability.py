"""Critical speed against equivalent conicity: the Manchester coach on real profiles.

    python examples/wheel-wear/conicity_stability.py [--out DIR] [--nonlinear]

The coach on S1002 wheels and 60E1 rails (models/manchester-coach-s1002) and on the worn
wheel (models/manchester-coach-worn), with the track varied as practitioners vary it: the
rails' inclination (1:40, 1:20) and the gauge (1432-1438 mm), each pair's equivalent
conicity at 3 mm (EN 15302) against its linear critical speed linearised there (rail_mj.
stability); and the new pair linearised at 1-6 mm (one pair seen at several amplitudes).
The line is the same coach on a cone of conicity λ with the centred contact's creep
coefficients: the kinematic link that profiles only imitate. With --nonlinear, also each
pair's nonlinear critical speed on the whole tables (a few minutes).

Every number printed, and every point plotted, is computed here; nothing is taken from text.
Prints a Markdown table (copied into README.md) and writes critical_speed_conicity.png.
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

from rail_mj.analysis.bifurcation import nonlinear_critical_speed
from rail_mj.analysis.stability import Stability
from rail_mj.files import atomic_write
from rail_mj.layout import load_layout

MODELS = Path(__file__).resolve().parents[2] / "models"
VMIN, VMAX = 20.0, 250.0


def coach(name: str):
    return load_layout(MODELS / name / f"{name}.toml")


def on_track(layout, **profiles):
    """The layout with its [profiles] changed (the loaded layout's derived values kept: the
    contact tables are made from the profiles themselves)."""
    return dataclasses.replace(layout, profiles=dataclasses.replace(layout.profiles, **profiles))


def linear(layout, amplitude: float = 3.0) -> tuple[float, float | None, str]:
    s = Stability(layout, amplitude)
    r = s.critical_speed(VMIN, VMAX, points=60)
    return s.equivalent_conicity, r.critical_speed, r.mode or r.note


def cone_line(base, conicities):
    """The same coach on cones: no profiles, the centred contact's f11..f33."""
    cone = dataclasses.replace(base, profiles=None, wheelset=dataclasses.replace(base.wheelset, conicity=0.1))
    out = []
    for lam in conicities:
        layout = dataclasses.replace(cone, wheelset=dataclasses.replace(cone.wheelset, conicity=float(lam)))
        out.append(Stability(layout).critical_speed(VMIN, VMAX, points=60).critical_speed)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    parser.add_argument("--nonlinear", action="store_true", help="also the nonlinear critical speeds")
    args = parser.parse_args()

    new, worn = coach("manchester-coach-s1002"), coach("manchester-coach-worn")
    pairs = [
        ("new S1002, 1:40, 1435 mm", new),
        ("new S1002, 1:20, 1435 mm", on_track(new, rail_inclination=0.05)),
        ("new S1002, 1:40, 1432 mm", on_track(new, track_gauge=1.432)),
        ("new S1002, 1:40, 1438 mm", on_track(new, track_gauge=1.438)),
        ("worn S1002, 1:40, 1435 mm", worn),
    ]
    rows = []
    for label, layout in pairs:
        lam, vc, mode = linear(layout)
        vn = outcome = None
        if args.nonlinear:
            result = nonlinear_critical_speed(layout, VMIN, VMAX)[0]
            vn, outcome = result.critical_speed, result.outcome
        rows.append((label, lam, vc, mode, vn, outcome))
        print(f"{label}: λe(3 mm) = {lam:.3f}, linear Vc = {vc} ({mode}), nonlinear = {vn} ({outcome})", flush=True)
    amplitudes = [1.0, 1.5, 2.0, 3.0, 4.0, 6.0]
    sweep = [(a, *linear(new, a)[:2]) for a in amplitudes]
    for a, lam, vc in sweep:
        print(f"new pair at {a:g} mm: λe = {lam:.3f}, linear Vc = {vc}", flush=True)
    lams = np.linspace(0.05, 0.5, 19)
    line = cone_line(new, lams)

    fig, ax = plt.subplots(figsize=(7.5, 4.8), dpi=120)
    ax.plot(
        lams,
        [np.nan if v is None else v for v in line],
        color="0.6",
        lw=1.5,
        label="the same coach on cones (centred contact's creep coefficients)",
    )
    ax.plot(
        [s[1] for s in sweep],
        [np.nan if s[2] is None else s[2] for s in sweep],
        "s--",
        color="tab:blue",
        ms=5,
        label="new S1002/60E1 1:40, linearised at 1-6 mm",
    )
    for a, lam, vc in sweep:
        if vc is not None:
            ax.annotate(f"{a:g} mm", (lam, vc), textcoords="offset points", xytext=(6, 4), fontsize=7, color="tab:blue")
    markers = iter("oDv^P")
    for label, lam, vc, _, vn, _ in rows:
        m = next(markers)
        ax.plot([lam], [vc], m, color="tab:red", ms=7, label=f"{label} (3 mm)")
        if vn is not None:
            ax.plot([lam], [vn], m, color="tab:red", ms=7, mfc="none")
    ax.set_xlabel("equivalent conicity λe (EN 15302)")
    ax.set_ylabel("critical speed (m/s)")
    title = "Manchester coach: critical speed against equivalent conicity"
    ax.set_title(title + ("\n(filled: linear; open: nonlinear)" if args.nonlinear else ""), fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out / "critical_speed_conicity.png", buf.getvalue())

    print(
        "\n| wheel and track | λe at 3 mm | linear critical speed (m/s), mode |"
        + (" nonlinear critical speed (m/s) |" if args.nonlinear else "")
    )
    print("|---|---|---|" + ("---|" if args.nonlinear else ""))
    for label, lam, vc, mode, vn, outcome in rows:
        cells = f"| {label} | {lam:.3f} | {vc:.1f}, {mode} |" if vc else f"| {label} | {lam:.3f} | stable to {VMAX:g} |"
        if args.nonlinear:
            cells += (
                f" {vn:.1f} |"
                if vn
                else " the linear one: no limit cycle below it |"
                if outcome == "linear"
                else f" none ({outcome}) |"
            )
        print(cells)


if __name__ == "__main__":
    main()
