"""Speed benchmarks: figures for README.md, measured here and never in a timed test.

    python tools/benchmark.py

Times (best of several repeats, wall clock, one process):
- the eigen critical speed of the shipped coach (target: well under 2 s);
- a root locus of 50 speeds of the coach (target: under 5 s);
- one simulation step of the coach, bare and with the creep callback (RK4 calls it
  four times a step), as a ratio measured in the same run;
- start-up: `rail-mj --help` and a layout error, each a new process, against the bare
  interpreter and against importing what a run needs (target: under 0.5 s).
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

from rail_mj.forces import CreepForces, installed
from rail_mj.layout import load_layout
from rail_mj.model import Vehicle
from rail_mj.plots import root_locus
from rail_mj.runner import simulate
from rail_mj.stability import Stability

COACH = Path(__file__).resolve().parent.parent / "models" / "manchester-coach" / "manchester-coach.toml"


def best(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def process(*args: str) -> None:
    subprocess.run([sys.executable, *args], capture_output=True, check=False)


def start_up() -> list[tuple[str, float]]:
    """Wall time of new processes: what a user waits for before the first line."""
    with tempfile.TemporaryDirectory() as folder:
        bad = Path(folder) / "bad.toml"
        bad.write_text('name = "bad"\n')  # no [wheelset]: a layout error
        return [
            ("`python -c pass` (the interpreter alone)", best(lambda: process("-c", "pass"), 5)),
            ("`rail-mj --help`", best(lambda: process("-m", "rail_mj.cli", "--help"), 5)),
            ("`rail-mj run` on a layout with an error", best(
                lambda: process("-m", "rail_mj.cli", "run", str(bad), "--speed", "30", "--distance", "10"), 5)),
            ("importing what a run needs (MuJoCo, numba, scipy)", best(
                lambda: process("-c", "import rail_mj.runner, rail_mj.analysis, scipy.signal"), 3)),
        ]


def main() -> None:
    starts = start_up()
    layout = load_layout(COACH)
    critical = best(lambda: Stability(layout).critical_speed(), 5)
    locus = best(lambda: root_locus(Stability(layout), np.linspace(5.0, 150.0, 50)), 3)

    vehicle = Vehicle(layout)
    model, data = vehicle.model, mujoco.MjData(vehicle.model)
    model.opt.timestep = 1e-3
    n = 5000
    bare = best(lambda: mujoco.mj_step(model, data, nstep=n), 3) / n
    with installed(CreepForces(model, vehicle.wheelset_names, 40.0)):
        creep = best(lambda: mujoco.mj_step(model, data, nstep=n), 3) / n
    run = best(lambda: simulate(layout, 40.0, 400.0, 0.002), 3)

    print("| benchmark (shipped coach, 14 dof) | time |")
    print("|---|---|")
    print(f"| eigen critical speed (`rail-mj critical-speed`) | {critical:.2f} s |")
    print(f"| root locus, 50 speeds | {locus:.2f} s |")
    print(f"| one RK4 step, bare MuJoCo | {bare * 1e6:.1f} µs |")
    print(f"| one RK4 step with creep forces (4 callbacks) | {creep * 1e6:.1f} µs ({creep / bare:.1f}x bare) |")
    print(f"| `simulate`: 400 m at 40 m/s (10 s, 10 000 steps) | {run:.2f} s |")
    print()
    print("| start-up (a new process each) | time |")
    print("|---|---|")
    for name, seconds in starts:
        print(f"| {name} | {seconds:.2f} s ({seconds / starts[0][1]:.1f}x the interpreter) |")


if __name__ == "__main__":
    main()
