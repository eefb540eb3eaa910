"""What turns a wheelset at a flange strike: the yaw moments of the rails, strike by strike.

    python examples/hunting/flange_strikes.py

Runs the shipped bogie and coach at 1.1 times their linear critical speed (on the
hunting limit cycle, Polach saturation and flange contact) and prints, for the leading
wheelset's strikes over the last 4 s, a Markdown table (copied into README.md): the yaw
angle on arrival and on leaving, and the mean yaw moments of the longitudinal creep
couple and of the flange force acting at its lead, all signed positive when they turn
the wheelset into the struck rail.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rail_mj.analysis import flange_strikes
from rail_mj.analysis.stability import Stability
from rail_mj.layout import load_layout
from rail_mj.simulation.runner import simulate

MODELS = Path(__file__).resolve().parents[2] / "models"
SETTLE, SAMPLE = 8.0, 4.0  # s on the limit cycle before sampling, and sampled


def main() -> None:
    print(
        "| vehicle | speed | strikes | yaw on arrival | yaw on leaving | creep couple | flange force at its lead | peak flange force |"  # noqa: E501
    )
    print("|---|---|---|---|---|---|---|---|")
    for name in ("bogie", "manchester-coach"):
        layout = load_layout(MODELS / name / f"{name}.toml")
        speed = 1.1 * Stability(layout).critical_speed().critical_speed
        run = simulate(layout, speed, speed * (SETTLE + SAMPLE), 2 * layout.wheelset.flangeway_clearance)
        forces = run.contact_forces()
        psi = run.psi[:, 0]
        rows = [(side, s, e) for i, s, e, side in flange_strikes(run) if i == 0 and run.t[s] >= SETTLE]
        arrive = np.mean([side * psi[s] for side, s, e in rows]) * 1e3
        leave = np.mean([side * psi[e - 1] for side, s, e in rows]) * 1e3
        couple = np.mean([side * forces.creep_couple[s:e, 0].mean() for side, s, e in rows]) / 1e3
        lead = np.mean([side * forces.flange_moment[s:e, 0].mean() for side, s, e in rows]) / 1e3
        peak = np.max(np.abs(forces.flange_lateral[run.t >= SETTLE, 0])) / 1e3
        print(
            f"| {name} | {speed:.1f} m/s | {len(rows)} | {arrive:+.1f} mrad | {leave:+.1f} mrad | "
            f"{couple:+.2f} kN m | {lead:+.2f} kN m | {peak:.0f} kN |"
        )


if __name__ == "__main__":
    main()
