"""Ride comfort against speed: the spatial Manchester coach on ERRI low and high track, and with a soft
and a stiff secondary suspension.

    python examples/ride-comfort/ride_comfort.py [--out DIR]

Sweeps (rail_mj.studies.sweep, as `rail-mj sweep --track ... --grid irregularities.spectrum=...`) of the
shipped spatial coach (S1002 on 60E1, Polach's law) over 1.5 km of generated track at 30 to 60 m/s, two
realisations (seeds) of each track quality: EN 12299's mean comfort N_MV and Sperling's ride index Wz,
lateral and vertical, at the worst of the floor points (above each bogie and at the centre;
rail_mj.analysis.ride), and the 99.85 % percentile of Y/Q (2 m means, EN 14363). Then the same on ERRI
high with the secondary springs halved and doubled, laterally and vertically (the shipped 160 and 430
kN/m per side). Every number printed and every point drawn is the model's own. Prints the Markdown table
quoted in README.md and draws ride_comfort.png.

1.5 km at 30 m/s is 50 s of ride: ten of N_MV's 5 s blocks, where EN 12299 asks for 5 minutes (60).
Its 95th percentiles are therefore rough; the spread over the two seeds (their sample standard
deviation) says how rough.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rail_mj.studies.sweep import sweep_table

ROOT = Path(__file__).resolve().parents[2]
COACH = ROOT / "models" / "manchester-coach-spatial" / "manchester-coach-spatial.toml"
TRACK = ROOT / "models" / "tracks" / "erri-high-5km.toml"
SPEEDS = (30.0, 60.0, 4)  # m/s
DISTANCE = 1500.0  # m
SEEDS = "irregularities.seed=1:2:2"
SHIPPED = {"ky": 160e3, "kz": 430e3}  # N/m per side: models/manchester-coach-spatial
SECONDARY = {"shipped": 1.0, "soft": 0.5, "stiff": 2.0}
QUANTITIES = (("n_mv", "N_MV"), ("wz_lateral", "Wz lateral"), ("wz_vertical", "Wz vertical"))


def secondary(factor: float) -> list[str]:
    return [f"secondary.spring.{k}={v * factor:g}" for k, v in SHIPPED.items()]


def study() -> list[tuple[str, str, float, dict[str, tuple[float, float]]]]:
    """(secondary, track, speed, {quantity: (mean, spread over the seeds)}) for every variant."""
    out = []
    runs = [("shipped", spectrum) for spectrum in ("erri-low", "erri-high")]
    runs += [(name, "erri-high") for name in ("soft", "stiff")]
    for name, spectrum in runs:
        table = sweep_table(
            COACH,
            SPEEDS,
            sets=[f"irregularities.spectrum={spectrum}", *secondary(SECONDARY[name])],
            grids=[SEEDS],
            distance=DISTANCE,
            track=TRACK,
        )
        rows = table.to_pylist()
        bad = [r for r in rows if r["status"] != "ok"]
        if bad:
            raise SystemExit(f"{name} on {spectrum}: {bad[0]['message']}")
        for speed in sorted({r["speed_m_per_s"] for r in rows}):
            at = [r for r in rows if r["speed_m_per_s"] == speed]
            values = {}
            for key, _ in (*QUANTITIES, ("y_over_q_p99_85", "")):
                v = np.array([r[key] for r in at], dtype=float)
                values[key] = (float(v.mean()), float(v.std(ddof=1)))
            out.append((name, spectrum, speed, values))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent))
    args = parser.parse_args()
    results = study()
    print("| secondary | track | speed | N_MV | Wz lateral | Wz vertical | Y/Q p99.85 |")
    print("|---|---|---|---|---|---|---|")
    for name, spectrum, speed, v in results:
        cells = [f"{v[k][0]:.2f} ± {v[k][1]:.2f}" for k in ("n_mv", "wz_lateral", "wz_vertical", "y_over_q_p99_85")]
        print(f"| {name} | {spectrum} | {speed:g} m/s | " + " | ".join(cells) + " |")
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), layout="constrained")
    styles = {("shipped", "erri-low"): "C0--", ("shipped", "erri-high"): "C0-", ("soft", "erri-high"): "C2-",
              ("stiff", "erri-high"): "C3-"}  # fmt: skip
    for (name, spectrum), style in styles.items():
        mine = [r for r in results if r[0] == name and r[1] == spectrum]
        speeds = [r[2] for r in mine]
        for ax, (key, label) in zip(axes, QUANTITIES):
            mean = np.array([r[3][key][0] for r in mine])
            spread = np.array([r[3][key][1] for r in mine])
            ax.errorbar(speeds, mean, yerr=spread, fmt=style, marker="o", ms=4, capsize=3,
                        label=f"{spectrum}, {name} secondary")  # fmt: skip
            ax.set(xlabel="speed (m/s)", ylabel=label)
            ax.grid(alpha=0.3)
    for limit, text in ((1.5, "very comfortable"), (2.5, "comfortable"), (3.5, "medium")):
        axes[0].axhline(limit, color="grey", lw=0.7, ls=":")
        axes[0].text(30.5, limit, f"< {limit}: {text}", fontsize=7, va="bottom", color="grey")
    axes[0].legend(fontsize=8)
    fig.suptitle(
        f"Spatial Manchester coach (S1002/60E1), {DISTANCE / 1e3:g} km of generated track, mean ± spread over two seeds"
    )
    out = Path(args.out) / "ride_comfort.png"
    fig.savefig(out, dpi=110)
    print(f"figure: {out}")


if __name__ == "__main__":
    main()
