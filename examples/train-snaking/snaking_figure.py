"""The articulated set's snaking against its inter-car yaw damping (README, "Trains").

    python examples/train-snaking/snaking_figure.py [--out DIR]

For models/articulated-set with every [[coupling]]'s yaw_damping set in turn to each value
below: the snaking mode (car bodies yawing in alternation, rail_mj.analysis.train_modes) at SPEED, its
frequency and damping ratio, and the eigen critical speed with the mode that crosses, on
the shipped conicity (0.15) and on a low one (LOW_CONICITY), where the end car bodies join the
bogies' hunting. Every
number is the MuJoCo model's (rail_mj.analysis.stability). Prints a Markdown table (copied into
README.md) and writes snaking_articulated.png.
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
from rail_mj.analysis.train_modes import SNAKING
from rail_mj.files import atomic_write
from rail_mj.layout import load_layout

MODELS = Path(__file__).resolve().parents[2] / "models"
SPEED = 50.0  # m/s, where the snaking mode is read
DAMPING = (0.0, 5e4, 1e5, 2e5, 4e5, 8e5, 1.6e6, 3.2e6)  # N m s/rad per coupling
VMIN, VMAX = 5.0, 150.0
LOW_CONICITY = 0.02


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    args = parser.parse_args()
    base = load_layout(MODELS / "articulated-set" / "articulated-set.toml")
    rows = []
    for c in DAMPING:
        train = dataclasses.replace(
            base.train, couplings=tuple(dataclasses.replace(k, yaw_damping=c) for k in base.train.couplings)
        )
        layout = dataclasses.replace(base, train=train)
        analysis = Stability(layout)
        snaking = next((m for m in analysis.modes(SPEED) if m.name == SNAKING), None)
        critical = analysis.critical_speed(VMIN, VMAX)
        low = Stability(
            dataclasses.replace(layout, wheelset=dataclasses.replace(layout.wheelset, conicity=LOW_CONICITY))
        ).critical_speed(VMIN, VMAX)
        rows.append(
            (
                c,
                snaking.frequency if snaking else np.nan,
                snaking.damping_ratio if snaking else np.nan,
                critical.critical_speed or np.nan,
                low.critical_speed or np.nan,
                critical.mode or critical.note,
                low.mode or low.note,
            )
        )
    print(
        f"| inter-car yaw damping (kN m s/rad) | snaking at {SPEED:g} m/s: f (Hz) | damping ratio "
        f"| critical speed (m/s), conicity {base.wheelset.conicity:g} | conicity {LOW_CONICITY:g} |"
    )
    print("|---|---|---|---|---|")
    for c, f, zeta, vc, vlow, _mode, _low_mode in rows:
        # A root no longer oscillating is overdamped: say so, not "0 Hz".
        cells = f"{f:.3f} | {zeta:.3f}" if f > 0 else "— | overdamped"
        print(f"| {c / 1e3:g} | {cells} | {vc:.2f} | {vlow:.2f} |")
    print(f"modes at the critical speed: {sorted({r[5] for r in rows})}, {sorted({r[6] for r in rows})}")
    c, f, zeta, vc, vlow = (np.array([r[k] for r in rows]) for k in range(5))
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.4, 6.0), sharex=True)
    x = np.maximum(c / 1e3, 10.0)  # zero drawn at the axis' left end
    top.semilogx(x, zeta, "o-", color="C3")
    top.set_ylabel(f"snaking damping ratio at {SPEED:g} m/s")
    top.set_title("articulated-set: car bodies yawing in alternation")
    top.grid(True, which="both", alpha=0.3)
    bottom.semilogx(x, vc, "s-", color="C0", label=f"conicity {base.wheelset.conicity:g}")
    bottom.semilogx(x, vlow, "^-", color="C2", label=f"conicity {LOW_CONICITY:g}")
    bottom.legend()
    bottom.set_ylabel("eigen critical speed (m/s)")
    bottom.set_xlabel("inter-car yaw damping per coupling, kN m s/rad (leftmost point: none)")
    bottom.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out / "snaking_articulated.png", buffer.getvalue())
    print(f"figure: {args.out / 'snaking_articulated.png'}")


if __name__ == "__main__":
    main()
