"""Nonlinear critical speed and bifurcation diagrams of the shipped bogie and coach.

    python examples/nonlinear-critical-speed/nonlinear_examples.py [--out DIR]

Both layouts carry Polach saturation and flange contact; the bogie is run once more with
Polach's falling friction. Prints a Markdown table (copied into README.md) and writes
bifurcation_<name>.png for the shipped layouts. Takes a few minutes.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from rail_mj.analysis.bifurcation import STEP, bifurcation
from rail_mj.files import atomic_write
from rail_mj.layout import load_layout
from rail_mj.output.plots import bifurcation_png

MODELS = Path(__file__).resolve().parents[2] / "models"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent))
    args = parser.parse_args()
    print(f"speed lowered in steps of {STEP:.0%}")
    print("| vehicle | linear critical speed | nonlinear critical speed (2 % steps) | limit cycle at 1.1 x linear |")
    print("|---|---|---|---|")
    bogie = load_layout(MODELS / "bogie" / "bogie.toml")
    # Polach's falling friction with illustrative values (mu falls from 0.3 towards 0.12).
    falling = dataclasses.replace(
        bogie, creep=dataclasses.replace(bogie.creep, falling_friction_ratio=0.4, falling_friction_rate=0.6)
    )
    cases = [
        ("bogie", bogie),
        ("manchester-coach", load_layout(MODELS / "manchester-coach" / "manchester-coach.toml")),
        ("bogie, falling friction A 0.4, B 0.6 s/m", falling),
    ]
    for name, layout in cases:
        critical, down, up = bifurcation(layout)  # the one procedure and step (bifurcation.STEP)
        if layout is not falling:
            atomic_write(
                Path(args.out) / f"bifurcation_{name}.png",
                bifurcation_png(critical, down, up, layout.wheelset.flangeway_clearance, name),
            )
        print(
            f"| {name} | {critical.linear_critical_speed:.1f} m/s | {critical.critical_speed:.1f} m/s "
            f"({critical.mode}, {critical.frequency:.2f} Hz) | {down.amplitudes[0] * 1e3:.1f} mm at "
            f"{down.speeds[0]:.1f} m/s |"
        )


if __name__ == "__main__":
    main()
