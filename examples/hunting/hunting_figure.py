"""What hunting looks like: the shipped bogie on its limit cycle, drawn from one run.

    python examples/hunting/hunting_figure.py [--out DIR]

Runs the shipped bogie (Polach saturation, flange contact) at 1.1 times its linear
critical speed from a 2 mm disturbance and draws examples/hunting/hunting_bogie.png: the
leading wheelset's lateral displacement over the whole run (growth onto the flanges),
then the last 40 m: both wheelsets' displacement and yaw, and the sum of guiding forces
with EN 14363's band-passed sliding rms against its limit.
"""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rail_mj.analysis import hunting_limit, hunting_rms
from rail_mj.analysis.stability import Stability
from rail_mj.files import atomic_write
from rail_mj.layout import load_layout
from rail_mj.simulation.runner import simulate

BOGIE = Path(__file__).resolve().parents[2] / "models" / "bogie" / "bogie.toml"
ZOOM = 40.0  # m at the end of the run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent))
    args = parser.parse_args()
    layout = load_layout(BOGIE)
    linear = Stability(layout).critical_speed().critical_speed
    speed = 1.1 * linear
    run = simulate(layout, speed, 1000.0, 0.002)
    clearance = layout.wheelset.flangeway_clearance * 1e3
    guiding = run.guiding_forces()
    rms = hunting_rms(run, guiding)[1]
    limit = hunting_limit(2.0 * layout.wheelset.wheel_load)

    fig, axes = plt.subplots(4, 1, figsize=(10, 10), layout="constrained")
    axes[0].plot(run.x, run.y[:, 0] * 1e3, lw=0.6)
    axes[0].set(
        ylabel="wheelset 1 y (mm)",
        title=f"bogie at {speed:.1f} m/s (1.1 x its linear critical speed {linear:.1f} m/s), from a 2 mm disturbance",
    )
    zoom = run.x >= run.x[-1] - ZOOM
    for i in range(run.n_wheelsets):
        color = f"C{i}"
        axes[1].plot(run.x[zoom], run.y[zoom, i] * 1e3, color=color, label=f"wheelset {i + 1}")
        axes[2].plot(run.x[zoom], run.psi[zoom, i] * 1e3, color=color, label=f"wheelset {i + 1}")
        axes[3].plot(run.x[zoom], guiding[zoom, i] / 1e3, color=color, lw=0.7, label=f"ΣY, wheelset {i + 1}")
        axes[3].plot(run.x[zoom], rms[zoom, i] / 1e3, color=color, lw=2.5, label="its rms over 100 m, band-passed")
    for ax in axes[:2]:
        for sign in (1, -1):
            ax.axhline(sign * clearance, color="grey", ls=":", lw=1)
    axes[1].set(ylabel="y (mm); clearance dotted")
    axes[2].set(ylabel="yaw psi (mrad)")
    axes[3].axhline(limit / 1e3, color="black", ls="--", label=f"EN 14363 limit {limit / 1e3:.1f} kN")
    low, high = axes[3].get_ylim()
    axes[3].set_ylim(low, high + 0.6 * (high - low))  # room for the legend
    axes[3].set(ylabel="sum of guiding forces (kN)", xlabel="distance travelled (m)")
    for ax in axes:
        ax.grid(alpha=0.3)
    for ax in axes[1:]:
        ax.legend(loc="upper right", fontsize=8, ncol=2)
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=100)
    plt.close(fig)
    atomic_write(Path(args.out) / "hunting_bogie.png", png.getvalue())
    print(
        f"bogie at {speed:.1f} m/s: wheelset 1 limit cycle {np.max(np.abs(run.y[zoom, 0])) * 1e3:.1f} mm, "
        f"rms Sigma Y up to {np.nanmax(rms) / 1e3:.1f} kN against {limit / 1e3:.1f} kN"
    )


if __name__ == "__main__":
    main()
