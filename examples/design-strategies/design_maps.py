"""The seed's two design strategies at a glance: stability maps of the shipped models.

    python examples/design-strategies/design_maps.py [--out DIR]

1. The coach: conicity (1:40 to worn treads) against primary yaw stiffness (Matsudaira's
   stiff yaw), 20 x 20 eigen critical speeds.
2. The two-axle wagon: primary lateral stiffness against lateral damping (Wickens' soft,
   damped suspension), 20 x 20.

Each map is `rail-mj map` (rail_mj.studies.sweep with the eigen method); every cell is an eigen
critical speed of the model. Writes map_coach.png and map_wagon.png and prints what the
README quotes.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from rail_mj.files import atomic_write
from rail_mj.output.plots import stability_map_png
from rail_mj.studies.sweep import sweep_table

MODELS = Path(__file__).resolve().parents[2] / "models"
MAPS = [
    (
        "coach",
        MODELS / "manchester-coach" / "manchester-coach.toml",
        "wheelset.conicity=0.025:0.4:20",
        "primary.yaw_stiffness=2e6:100e6:20:log",
    ),
    (
        "wagon",
        MODELS / "wagon" / "wagon.toml",
        "primary.lateral_stiffness=0.1e6:2e6:20:log",
        "primary.lateral_damping=0:80e3:20",
    ),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent))
    args = parser.parse_args()
    for name, layout, x, y in MAPS:
        started = time.perf_counter()
        table = sweep_table(layout, (5.0, 300.0, 60), grids=[x, y], method="eigen")
        took = time.perf_counter() - started
        keys = [x.split("=")[0], y.split("=")[0]]
        atomic_write(
            Path(args.out) / f"map_{name}.png",
            stability_map_png(table, *keys, x.endswith(":log"), y.endswith(":log"), "eigen", name),
        )
        rows = table.to_pylist()
        found = [r for r in rows if r["critical_speed_m_per_s"] is not None]
        unstable = sum(r["outcome"] == "unstable" for r in rows)
        low = min(found, key=lambda r: r["critical_speed_m_per_s"])
        high = max(found, key=lambda r: r["critical_speed_m_per_s"])
        print(
            f"{name}: {len(rows)} cells in {took:.1f} s; critical speed "
            f"{low['critical_speed_m_per_s']:.1f} m/s at {keys[0]} {low[keys[0]]:.4g}, {keys[1]} {low[keys[1]]:.4g} "
            f"to {high['critical_speed_m_per_s']:.1f} m/s at {keys[0]} {high[keys[0]]:.4g}, "
            f"{keys[1]} {high[keys[1]]:.4g}; {unstable} cells unstable from 5 m/s, "
            f"{len(rows) - len(found) - unstable} stable to 300 m/s; "
            f"modes: {sorted({r['mode'] for r in found})}"
        )


if __name__ == "__main__":
    main()
