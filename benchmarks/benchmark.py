"""Speed benchmarks: figures for README.md, measured here and never in a timed test.

    python benchmarks/benchmark.py

Times (best of several repeats, wall clock, one process, side by side in one run):
- the eigen critical speed of the shipped coach; a root locus of 50 speeds;
- one RK4 step of the coach, bare, with the native creep callback (target: at most
  1.3x bare) and with the Python one; one coach's step in a model of eight, and the numba
  peer's step (CPU time of the calling thread: the floor of a batch's cost);
- one coach run, 1 km at 60 m/s (target: under 0.3 s);
- the 64-speed sweep of the coach, 20-100 m/s, 1 km each, on every core (target: under
  10 s), and a 20 x 20 eigen stability map (target: under 20 s);
- the peers, what a user writes instead (benchmarks/peer_solve_ivp.py, benchmarks/peer_numba.py),
  per vehicle-km against rail-mj; the batches (rail-mj's sweep, its runs alone, the numba
  peer's as written and with its speeds dealt out evenly to the cores) taken in turn,
  wall clock and CPU time (the machine is shared: each the best of its turns);
- start-up: `rail-mj --help` and a layout error, each a new process, against the bare
  interpreter and against importing what a run needs (target: under 0.5 s);
- a ten-car train (models/two-coaches' coach and coupling, ten times over): one RK4 step with
  the native callback, and a `simulate` run of 10 s, against real time on one core (target:
  at least 10x faster than real time);
- the spatial coach against the planar one (docs/spatial.md), one RK4 step each with the
  native creep callback and the same law, their steps alternating, CPU time of the calling
  thread (target: the spatial step at most 3x the planar one), and a `simulate` run of 1 km
  each: on cones (tests/data/manchester-coach-spatial.toml given models/manchester-coach's
  contact, against it) and on S1002/60E1 (models/manchester-coach-spatial against
  models/manchester-coach-s1002).

    python benchmarks/benchmark.py --spatial   # only the spatial coach against the planar one

- the curve's cost (docs/track.md): one RK4 step of the coach (planar, spatial on cones, the
  S1002/60E1 coach) with the native callback on straight track against the same vehicle in the
  600 m curve of models/tracks/curve-600.toml, their steps alternating, CPU time of the calling
  thread, the spread of the ratio over the repeats (target: the curve adds at most 15 %).

    python benchmarks/benchmark.py --curve     # only the curve's cost

- the irregularities' cost (docs/irregularities.md): one RK4 step of the same vehicles with the native
  callback at 55 m/s with no track, on a straight track file (its odometer) and on the same track
  with ERRI-high irregularities (models/tracks/erri-high-5km.toml), the three alternating, from a
  moving state (the vehicle shifted 2 mm, 1 km along the track; the irregular one's motion its own),
  CPU time of the calling thread, the spread of the ratios over the repeats (target: the
  irregularities add at most 15 %).

    python benchmarks/benchmark.py --irregular # only the irregularities' cost

- ten kilometres of irregular track (issue 21): the spatial coach on S1002/60E1 over 10 km of
  ERRI-high track at 55 m/s, `simulate` (its stepping, one thread: CPU time of the process) three
  times, against the 182 s it simulates (target: at least 20x faster than real time on one core),
  the same run from the command line as a user runs it (`rail-mj run ... --track`, with its summary,
  wall and CPU time of the child) and the peak memory of each (ru_maxrss).

    python benchmarks/benchmark.py --ten-km    # only the 10 km run

- the batch against the numba peer, every ratio from interleaved samples (issue 19): one RK4 step
  of the numba peer, of a coach in a model of eight bare and with the native callback, all three
  from a moving state (2 s past the 2 mm start), in turn, CPU time of the calling thread, eleven
  turns, each turn's ratios and their spread; the 64-speed sweep from the command line as a user
  runs it (`rail-mj sweep`, a new process) against the peer's batch (a new process too), in turn
  five times, wall and CPU time and peak memory of each child, both sides' sources compiled to
  bytecode first (`byte_compiled`); FASTSIM against Polach on one 1 km run, in turn.

    python benchmarks/benchmark.py --batch     # only the interleaved batch figures

- scaling (issue 19): a coach's step in models of 1 to 16 coaches, and a train's step at 1 to 10
  cars, every model in turn from a moving state, CPU time of the calling thread, best of seven turns;
  16 coach runs on one thread and on two.

    python benchmarks/benchmark.py --scaling   # only the scaling figures
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

from rail_mj.analysis.stability import Stability
from rail_mj.layout import layout_from_dict, load_layout
from rail_mj.output.plots import root_locus
from rail_mj.simulation import native
from rail_mj.simulation.batch import PACK, simulate_many
from rail_mj.simulation.callback import CreepForces, installed
from rail_mj.simulation.run import Request
from rail_mj.simulation.runner import prepare, simulate
from rail_mj.studies.sweep import sweep_table
from rail_mj.vehicle.spec import Vehicle

sys.path.insert(0, str(Path(__file__).resolve().parent))
import peer_numba
import peer_solve_ivp

ROOT = Path(__file__).resolve().parent.parent
COACH = ROOT / "models" / "manchester-coach" / "manchester-coach.toml"
S1002 = ROOT / "models" / "manchester-coach-s1002" / "manchester-coach-s1002.toml"
SPATIAL = ROOT / "models" / "manchester-coach-spatial" / "manchester-coach-spatial.toml"
SPATIAL_CONED = ROOT / "tests" / "data" / "manchester-coach-spatial.toml"
SPEEDS = (20.0, 100.0, 64)  # the batch: 64 runs of 1 km, 20-100 m/s
VEHICLE_KM = 64.0


def best(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def single_peers() -> list[tuple[str, float]]:
    """(name, s per vehicle-km) of the peers of one run in tools/."""
    rows = []
    for method in peer_solve_ivp.METHODS:
        seconds, km = peer_solve_ivp.time_run(method)
        rows.append((f"`solve_ivp` {method}, numpy right-hand side (`benchmarks/peer_solve_ivp.py`)", seconds / km))
    seconds, km = peer_numba.time_single()
    rows.append(("a planar RK4 compiled with numba, one run (`benchmarks/peer_numba.py`)", seconds / km))
    return rows


def batches(layout, turns: int = 5) -> dict[str, tuple[float, float]]:
    """{name: (wall s, CPU s) per vehicle-km} of the batches, taken in turn `turns` times."""
    speeds = np.linspace(*SPEEDS)
    runs = {
        "sweep": lambda: sweep_table(COACH, SPEEDS),
        "runs": lambda: simulate_many(
            [Request(layout, v, 1000.0, 0.002) for v in speeds], threads=peer_numba.threads()
        ),
        "peer": lambda: peer_numba.time_batch(repeats=1),
        "balanced": lambda: peer_numba.time_batch(repeats=1, balanced=True),
    }
    sweep_table(COACH, (20.0, 100.0, 4), distance=50.0)  # compiled and warm
    peer_numba.time_batch(repeats=1, distance=10.0)
    times: dict[str, list[tuple[float, float]]] = {name: [] for name in runs}
    for _ in range(turns):
        for name, fn in runs.items():
            wall, cpu = time.perf_counter(), time.process_time()
            fn()
            times[name].append(((time.perf_counter() - wall) / VEHICLE_KM, (time.process_time() - cpu) / VEHICLE_KM))
    return {name: (min(w for w, _ in t), min(c for _, c in t)) for name, t in times.items()}


def packed_steps(layout, n: int = 4000, repeats: int = 7) -> tuple[float, float]:
    """CPU seconds of one coach's RK4 step in a model of PACK coaches (20-100 m/s, from the
    2 mm start), bare and with the native creep callback, alternating (best of each)."""
    from rail_mj.simulation.stepping import Pack, Running, stepping  # the runner's own packing and options

    runs = [Running(k, prepare(Request(layout, v, 1000.0, 0.002))) for k, v in enumerate(np.linspace(20, 100, PACK))]
    pack = Pack(runs)
    model, data = pack.model, pack.data
    mujoco.mj_setState(model, data, pack.state, pack.STATE)

    def per_coach() -> float:
        started = time.thread_time()
        mujoco.mj_step(model, data, nstep=n)
        return (time.thread_time() - started) / n / PACK

    bare, fast = [], []
    with stepping():
        for _ in range(repeats):
            bare.append(per_coach())
            with native.installed():
                fast.append(per_coach())
    return min(bare), min(fast)


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
            (
                "`rail-mj run` on a layout with an error",
                best(lambda: process("-m", "rail_mj.cli", "run", str(bad), "--speed", "30", "--distance", "10"), 5),
            ),
            (
                "importing what a run needs (MuJoCo, numba, scipy)",
                best(lambda: process("-c", "import rail_mj.simulation.runner, rail_mj.analysis, scipy.signal"), 3),
            ),
        ]


def ten_car_train(n: int = 10):
    """models/two-coaches lengthened to `n` coaches (ten unless told), each coupled to the next alike."""
    import tomllib

    from rail_mj.layout import layout_from_dict

    data = tomllib.loads((COACH.parent.parent / "two-coaches" / "two-coaches.toml").read_text())
    pitch = data["car"][0]["position"] - data["car"][1]["position"]
    axle = data["train"]["bogie_positions"][0] - data["car"][0]["position"]  # a bogie from its body's centre
    centres = [(n - 1) * pitch / 2 - k * pitch for k in range(n)]
    data["name"] = f"{n}-coaches"
    data["train"]["bogie_positions"] = [c + s for c in centres for s in (axle, -axle)]
    data["car"] = [{**data["car"][0], "position": c, "bogies": [2 * k + 1, 2 * k + 2]} for k, c in enumerate(centres)]
    data["coupling"] = [{**data["coupling"][0], "cars": [k + 1, k + 2]} for k in range(n - 1)]
    return layout_from_dict(data, f"{n} coaches (benchmarks/benchmark.py)")


def train_speed(n: int = 3000) -> tuple[float, float, int]:
    """The ten-car train: (one RK4 step with the native callback, s; a simulate run of 10 s
    at 60 m/s, wall s; degrees of freedom)."""
    from rail_mj.simulation.stepping import Pack, Running

    train = ten_car_train()
    # The model `simulate` steps: the train's own without its drawn shapes and tendons, its
    # suspension summed in the callback (Vehicle.springs_in_callback).
    pack = Pack([Running(0, prepare(Request(train, 60.0, 600.0, 0.002)))], alone=True)
    model, data = pack.model, pack.data
    mujoco.mj_setState(model, data, pack.state, pack.STATE)
    model.opt.timestep = 1e-3
    with native.installed():
        step = best(lambda: mujoco.mj_step(model, data, nstep=n), 5) / n
    simulate(train, 60.0, 60.0, 0.002)
    run = best(lambda: simulate(train, 60.0, 600.0, 0.002), 3)
    return step, run, model.nv


def cpu_per_step(model, data, n: int) -> float:
    """CPU seconds of the calling thread per step, over `n` steps."""
    started = time.thread_time()
    mujoco.mj_step(model, data, nstep=n)
    return (time.thread_time() - started) / n


def spatial_coned():
    """tests/data/manchester-coach-spatial.toml with the contact of the planar coach
    (models/manchester-coach): its creep law and friction, flange and flangeway clearance (the
    test layout has linear creep and no flange). Bodies and suspension are the same coach."""
    import tomllib

    planar = tomllib.loads(COACH.read_text())
    data = tomllib.loads(SPATIAL_CONED.read_text())
    data["wheelset"]["flangeway_clearance"] = planar["wheelset"]["flangeway_clearance"]
    data["creep"], data["flange"] = planar["creep"], planar["flange"]
    return layout_from_dict(data, f"{SPATIAL_CONED.name} with {COACH.name}'s contact (benchmarks/benchmark.py)")


def spatial_against_planar(speed: float = 40.0, n: int = 3000, repeats: int = 11):
    """The spatial coach against the planar one, on cones and on profiles: per pair
    (name, nv of each, the runner's timestep of each, [planar, spatial] RK4 step with the
    native creep callback, CPU s; [planar, spatial] bare step, CPU s; [planar, spatial]
    `simulate` of 1 km at 60 m/s, wall s). Each model at the runner's timestep at `speed`, from
    its 2 mm start; the four steppings of a pair alternate, best of each: the machine is shared,
    so the steps are timed in CPU time of the calling thread (a step's cost, not the
    neighbours' share of the cores)."""
    pairs = [
        ("on cones", load_layout(COACH), spatial_coned()),
        ("on S1002/60E1", load_layout(S1002), load_layout(SPATIAL)),
    ]
    rows = []
    for name, *layouts in pairs:
        models, steps = [], []
        for layout in layouts:
            prepared = prepare(Request(layout, speed, 1000.0, 0.002))
            model = prepared.vehicle.model
            model.opt.timestep = prepared.timestep
            data = mujoco.MjData(model)
            data.qpos[prepared.vehicle.root_lateral_dofs] = 0.002
            models.append((model, data))
            steps.append(prepared.timestep)
        fast, bare = [[], []], [[], []]
        for _ in range(repeats):
            for k, (model, data) in enumerate(models):
                bare[k].append(cpu_per_step(model, data, n))
                with native.installed():
                    fast[k].append(cpu_per_step(model, data, n))
        for layout in layouts:
            simulate(layout, 60.0, 60.0, 0.002)  # compiled and warm
        runs = [[], []]
        for _ in range(3):
            for k, layout in enumerate(layouts):
                runs[k].append(best(lambda layout=layout: simulate(layout, 60.0, 1000.0, 0.002), 1))
        rows.append(
            (
                name,
                [m.nv for m, _ in models],
                steps,
                [min(t) for t in fast],
                [min(t) for t in bare],
                [min(t) for t in runs],
            )
        )
    return rows


def print_spatial(rows) -> None:
    print(
        "| the spatial coach against the planar one, 40 m/s, same law (Polach, mu 0.3); steps in CPU time "
        "| planar | spatial | spatial / planar |"
    )
    print("|---|---|---|---|")
    for name, nv, steps, fast, bare, runs in rows:
        print(
            f"| {name} ({nv[0]} and {nv[1]} dof; the runner's step {steps[0] * 1e3:.3g} and "
            f"{steps[1] * 1e3:.3g} ms): one RK4 step with the native creep callback | {fast[0] * 1e6:.1f} µs "
            f"| {fast[1] * 1e6:.1f} µs | {fast[1] / fast[0]:.2f}x (target: at most 3x) |"
        )
        print(
            f"| {name}: one RK4 step, bare MuJoCo | {bare[0] * 1e6:.1f} µs | {bare[1] * 1e6:.1f} µs "
            f"| {bare[1] / bare[0]:.2f}x |"
        )
        print(f"| {name}: `simulate`, 1 km at 60 m/s | {runs[0]:.2f} s | {runs[1]:.2f} s | {runs[1] / runs[0]:.2f}x |")


def _coaches():
    """The three coaches whose step the curve's and the irregularities' costs are measured on."""
    return (
        ("planar coach", load_layout(COACH)),
        ("spatial coach on cones", spatial_coned()),
        ("coach on S1002/60E1", load_layout(S1002)),
    )


def _stepped(layout, speed: float, tracks, station: float, n: int, repeats: int):
    """The vehicle on each of `tracks` (None: no track) at the runner's timestep and `speed`, shifted
    2 mm and, on a track, at `station` moving along it; their steps alternating, `repeats` times `n`
    steps each: (nv, CPU s per step of each repeat, per track)."""
    from rail_mj.vehicle.block import set_speed

    timestep = prepare(Request(layout, speed, 1000.0, 0.002)).timestep
    models = []
    for on in tracks:
        vehicle = Vehicle(layout, on)
        model = vehicle.model
        model.opt.timestep = timestep
        set_speed(model, speed)
        data = mujoco.MjData(model)
        data.qpos[vehicle.root_lateral_dofs] = 0.002
        if on is not None:
            odometer = model.joint("odometer")
            data.qpos[odometer.qposadr[0]] = station
            data.qvel[odometer.dofadr[0]] = speed
        models.append((model, data))
    times: list[list[float]] = [[] for _ in models]
    with native.installed():
        for _ in range(repeats):
            for k, (model, data) in enumerate(models):
                times[k].append(cpu_per_step(model, data, n))
    return models[0][0].nv, [np.array(t) for t in times]


def curve_cost(speed: float = 30.0, n: int = 3000, repeats: int = 11):
    """Per vehicle (name, nv, the straight step and the curved step, CPU s, best of each; the
    ratios of the repeats' pairs, min and max): the same vehicle and timestep, on straight
    track and in the constant part of curve-600 with its odometer, their steps alternating."""
    from rail_mj.track import load_track

    track = load_track(ROOT / "models" / "tracks" / "curve-600.toml")
    rows = []
    for name, layout in _coaches():
        # In the curve's constant part, 400 m along the track.
        nv, (straight, curved) = _stepped(layout, speed, (None, track), 400.0, n, repeats)
        ratios = curved / straight
        rows.append((name, nv, straight.min(), curved.min(), ratios.min(), ratios.max()))
    return rows


def irregular_cost(speed: float = 55.0, n: int = 3000, repeats: int = 11):
    """Per vehicle (name, nv, the step with no track, on the straight track file, on its irregular
    twin, CPU s, best of each; the ratios irregular/straight and irregular/none of the repeats, min
    and max)."""
    import dataclasses

    from rail_mj.track import load_track

    irregular = load_track(ROOT / "models" / "tracks" / "erri-high-5km.toml")
    plain = dataclasses.replace(irregular, irregularities=None)
    rows = []
    for name, layout in _coaches():
        nv, (none, straight, rough) = _stepped(layout, speed, (None, plain, irregular), 1000.0, n, repeats)
        rows.append((name, nv, none.min(), straight.min(), rough.min(), rough / straight, rough / none))
    return rows


def print_irregular(rows) -> None:
    print(
        "| one RK4 step with the native creep callback, CPU time | no track | straight track file "
        "| ERRI-high on it | irregular / straight | irregular / no track |"
    )
    print("|---|---|---|---|---|---|")
    for name, nv, none, plain, rough, over_plain, over_none in rows:
        print(
            f"| {name} ({nv} dof) | {none * 1e6:.1f} µs | {plain * 1e6:.1f} µs | {rough * 1e6:.1f} µs "
            f"| {rough / plain:.2f}x (pairs {over_plain.min():.2f}-{over_plain.max():.2f}) "
            f"| {rough / none:.2f}x (pairs {over_none.min():.2f}-{over_none.max():.2f}) |"
        )


def ten_km(speed: float = 55.0, distance: float = 10_000.0, repeats: int = 3):
    """The spatial coach over 10 km of ERRI-high track: per `simulate` of the repeats its CPU and wall
    time (s), the simulated time (s) and this process's peak memory (MB) after them; then the command
    line's wall and CPU time and peak memory (MB), a child process."""
    import resource

    from rail_mj.track import load_track

    with tempfile.TemporaryDirectory() as folder:
        five = (ROOT / "models" / "tracks" / "erri-high-5km.toml").read_text()
        track_file = Path(folder) / "erri-high-10km.toml"
        track_file.write_text(five.replace("length = 5100.0", f"length = {distance + 100.0}"))
        track = load_track(track_file)
        layout = load_layout(SPATIAL)
        simulate(layout, speed, 100.0, initial_lateral=0.0, track=track)  # compiled and cached
        runs = []
        for _ in range(repeats):
            cpu, wall = time.process_time(), time.perf_counter()
            run = simulate(layout, speed, distance, initial_lateral=0.0, track=track)
            runs.append((time.process_time() - cpu, time.perf_counter() - wall, float(run.t[-1])))
            del run
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        command = [str(Path(sys.executable).parent / "rail-mj"), "run", str(SPATIAL), "--speed", str(speed)]
        command += ["--distance", str(distance), "--track", str(track_file), "--initial-lateral", "0"]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        wall = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True)
        wall = time.perf_counter() - wall
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cli_cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        return runs, peak, (wall, cli_cpu, after.ru_maxrss / 1024)


def print_ten_km(result) -> None:
    runs, peak, (wall, cpu, cli_peak) = result
    simulated = runs[0][2]
    factors = [t / c for c, _, t in runs]
    best_cpu, fastest_wall = min(c for c, _, _ in runs), min(w for _, w, _ in runs)
    print(
        "| 10 km of ERRI-high track, spatial coach on S1002/60E1 at 55 m/s | CPU | wall "
        "| faster than real time | peak memory |"
    )
    print("|---|---|---|---|---|")
    print(
        f"| `simulate`, best of {len(runs)} ({simulated:.0f} s simulated) | {best_cpu:.2f} s | {fastest_wall:.2f} s "
        f"| {simulated / best_cpu:.1f}x (runs {min(factors):.1f}-{max(factors):.1f}x; target: at least 20x) "
        f"| {peak:.0f} MB |"
    )
    print(
        f"| `rail-mj run ... --track`, with its summary | {cpu:.2f} s | {wall:.2f} s | {simulated / wall:.1f}x "
        f"| {cli_peak:.0f} MB |"
    )


def interleaved_steps(layout, n: int = 3000, repeats: int = 11):
    """Per turn, in order: the numba peer's RK4 step, a coach's bare step in a model of PACK coaches and
    the same with the native creep callback, each from a moving state (2 s past the 2 mm start) and
    timed in CPU time of the calling thread, s. Arrays (turns, 3)."""
    from rail_mj.simulation.stepping import Pack, Running, stepping

    vehicle = peer_numba.coach()
    arrays = peer_numba._arrays(vehicle)
    rows = np.zeros((n + 1, vehicle.wheelsets.size))
    moving = peer_numba.initial_state(vehicle, 0.002)
    peer_numba._run(arrays, peer_numba.SPEED, moving, peer_numba.TIMESTEP, 2000, 2000, rows[:2], rows[:2].copy())
    runs = [Running(k, prepare(Request(layout, v, 1000.0, 0.002))) for k, v in enumerate(np.linspace(20, 100, PACK))]
    pack = Pack(runs)
    model, data = pack.model, pack.data
    mujoco.mj_setState(model, data, pack.state, pack.STATE)
    with native.installed():
        mujoco.mj_step(model, data, nstep=2000)
    state = np.empty(mujoco.mj_stateSize(model, pack.STATE))
    mujoco.mj_getState(model, data, state, pack.STATE)

    def peer() -> float:
        start = moving.copy()
        started = time.thread_time()
        peer_numba._run(arrays, peer_numba.SPEED, start, peer_numba.TIMESTEP, n, 1, rows, rows.copy())
        return (time.thread_time() - started) / n

    def coach() -> float:
        mujoco.mj_setState(model, data, state, pack.STATE)
        started = time.thread_time()
        mujoco.mj_step(model, data, nstep=n)
        return (time.thread_time() - started) / n / PACK

    peer()
    out = []
    with stepping():
        for _ in range(repeats):
            bare = coach()
            with native.installed():
                fast = coach()
            out.append((peer(), bare, fast))
    return np.array(out)


# A child's own peak memory: its VmHWM when it exits. Not os.wait4's ru_maxrss: Linux carries the
# parent's high-water mark into a child that is spawned (vfork) and execs, so every child of a
# 390 MB benchmark would report at least 390 MB.
_PEAK = """import atexit, os, runpy, sys
def peak():
    with open(os.environ["RAIL_MJ_PEAK"], "w") as f:
        f.write(next(line.split()[1] for line in open("/proc/self/status") if line.startswith("VmHWM")))
atexit.register(peak)
if sys.argv[1] == "-c":
    sys.argv = sys.argv[1:]
    exec(compile(os.environ["RAIL_MJ_CODE"], "-c", "exec"), {"__name__": "__main__"})
else:
    sys.argv = sys.argv[1:]
    runpy.run_path(sys.argv[0], run_name="__main__")
"""


def _child(command: list[str]) -> tuple[float, float, float]:
    """A new process's wall and CPU time (s) (os.wait4) and peak memory (MB, its VmHWM): `command`
    a Python script and its arguments, or [python, "-c", code]."""
    import os

    with tempfile.TemporaryDirectory() as folder:
        peak = Path(folder) / "peak"
        env = {**os.environ, "RAIL_MJ_PEAK": str(peak)}
        if command[1:2] == ["-c"]:
            env["RAIL_MJ_CODE"] = command[2]
            args = [sys.executable, "-c", _PEAK, "-c", *command[3:]]
        else:
            args = [sys.executable, "-c", _PEAK, *command]
        wall = time.perf_counter()
        child = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
        _, status, usage = os.wait4(child.pid, 0)
        wall = time.perf_counter() - wall
        child.returncode = os.waitstatus_to_exitcode(status)
        if child.returncode != 0:
            raise RuntimeError(f"{command[:3]} failed: {child.stderr.read().decode()[-300:] if child.stderr else ''}")
        return wall, usage.ru_utime + usage.ru_stime, int(peak.read_text()) / 1024


def byte_compiled() -> None:
    """Compile rail-mj's and the peers' sources to bytecode, as an installation does: an editable
    install leaves it to the first import, and where PYTHONDONTWRITEBYTECODE is set (this
    workplace's machines) every new process would compile them again (rail-mj's 0.1 s of CPU,
    a command's, not a run's). Both sides are timed with their bytecode, warm, as a user's
    second command runs."""
    import compileall

    import rail_mj

    for folder in (Path(rail_mj.__file__).parent, Path(__file__).resolve().parent):
        compileall.compile_dir(str(folder), quiet=1)


def interleaved_batches(turns: int = 5):
    """The 64-speed sweep from the command line and the numba peer's batch, each a new process, in
    turn: per turn (wall, CPU s, peak MB) of each."""
    rail_mj = str(Path(sys.executable).parent / "rail-mj")
    peer = [sys.executable, "-c", f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
            "import peer_numba; peer_numba.time_batch(repeats=1)"]  # fmt: skip
    out = []
    byte_compiled()
    with tempfile.TemporaryDirectory() as folder:
        table = Path(folder) / "sweep.csv"
        sweep = [rail_mj, "sweep", str(COACH), "--speeds", "20:100:64", "--distance", "1000", "-o", str(table)]
        _child(sweep[:4] + ["20:100:2", "--distance", "50", "-o", str(table)])  # compiled and warm
        table.unlink()
        _child(peer)
        for _ in range(turns):
            ours = _child(sweep)
            table.unlink()
            out.append((ours, _child(peer)))
    return out


def long_sweep() -> tuple[float, float, float]:
    """The 64-speed coach sweep of 10 km runs from the command line, a new process: its wall and
    CPU time (s) and peak memory (MB): the memory a sweep holds as its cases get long."""
    rail_mj = str(Path(sys.executable).parent / "rail-mj")
    with tempfile.TemporaryDirectory() as folder:
        table = Path(folder) / "sweep.csv"
        return _child([rail_mj, "sweep", str(COACH), "--speeds", "20:100:64", "--distance", "10000", "-o", str(table)])


def short_runs(repeats: int = 5) -> list[tuple[float, float, float]]:
    """A warm `rail-mj run` of the coach over 100 m at 40 m/s, a new process each time (the first,
    which may compile, left out): (wall s, CPU s, peak MB) of each, start-up and summary included."""
    rail_mj = str(Path(sys.executable).parent / "rail-mj")
    command = [rail_mj, "run", str(COACH), "--speed", "40", "--distance", "100"]
    byte_compiled()
    _child(command)
    return [_child(command) for _ in range(repeats)]


def fastsim_cost(repeats: int = 3):
    """One coach run of 1 km at 60 m/s with Polach's law and with FASTSIM, in turn: CPU s of each, per turn."""
    import tomllib

    data = tomllib.loads(COACH.read_text())
    # Both on the same Hertz ellipses, which FASTSIM needs (README's [contact] example: rail crown 0.30 m).
    data["contact"] = {"young_modulus": 210e9, "poisson_ratio": 0.28, "rail_transverse_radius": 0.30}
    laws = {}
    for law in ("polach", "fastsim"):
        creep = {"law": law, "friction": data["creep"]["friction"]}
        laws[law] = layout_from_dict({**data, "creep": creep}, source=f"coach with {law}")
        simulate(laws[law], 60.0, 20.0, 0.002)
    out = []
    for _ in range(repeats):
        turn = []
        for law in ("polach", "fastsim"):
            started = time.process_time()
            simulate(laws[law], 60.0, 1000.0, 0.002)
            turn.append(time.process_time() - started)
        out.append(tuple(turn))
    return np.array(out)


def print_batch() -> None:
    import resource

    steps = interleaved_steps(load_layout(COACH))
    print(
        "| one RK4 step of the coach from a moving state, CPU time, 11 turns | best µs "
        "| per turn / the peer's: median (min-max) |"
    )
    print("|---|---|---|")
    names = (
        "the numba peer's whole step (creep law included)",
        "a coach in a model of 8, bare MuJoCo",
        "a coach in a model of 8, native creep callback",
    )
    for k, name in enumerate(names):
        ratio = steps[:, k] / steps[:, 0]
        spread = f"{np.median(ratio):.2f} ({ratio.min():.2f}-{ratio.max():.2f})"
        print(f"| {name} | {steps[:, k].min() * 1e6:.2f} | {spread} |")
    print(f"(this process's peak memory: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB)")
    print()
    turns = interleaved_batches()
    print(
        "| 64 speeds 20-100 m/s, 1 km each, both cores, a new process each, per vehicle-km "
        "| wall s, best (range) | CPU s, best (range) | peak memory |"
    )
    print("|---|---|---|---|")
    names = ("`rail-mj sweep` (runs and summary rows, start-up included)", "the numba RK4 peer's batch, as written")
    for k, name in enumerate(names):
        wall = [t[k][0] / VEHICLE_KM for t in turns]
        cpu = [t[k][1] / VEHICLE_KM for t in turns]
        peak = max(t[k][2] for t in turns)
        cells = f"{min(wall):.3f} ({min(wall):.3f}-{max(wall):.3f}) | {min(cpu):.3f} ({min(cpu):.3f}-{max(cpu):.3f})"
        print(f"| {name} | {cells} | {peak:.0f} MB |")
    wall = [t[0][0] / t[1][0] for t in turns]
    cpu = [t[0][1] / t[1][1] for t in turns]
    print(f"| sweep / peer, per turn | {min(wall):.2f}-{max(wall):.2f}x | {min(cpu):.2f}-{max(cpu):.2f}x | |")
    print()
    wall, cpu, peak = long_sweep()
    runs = short_runs()
    walls = [r[0] for r in runs]
    print("| from the command line, a new process each | wall | CPU | peak memory |")
    print("|---|---|---|---|")
    print(f"| `rail-mj sweep`, 64 speeds 20-100 m/s, 10 km each, both cores | {wall:.0f} s | {cpu:.0f} s ", end="")
    print(f"| {peak:.0f} MB |")
    print(
        f"| `rail-mj run` of the coach, 100 m at 40 m/s, warm, best of {len(runs)} (range) "
        f"| {min(walls):.2f} s ({min(walls):.2f}-{max(walls):.2f} s) | {min(r[1] for r in runs):.2f} s "
        f"| {max(r[2] for r in runs):.0f} MB |"
    )
    print()
    laws = fastsim_cost()
    ratio = laws[:, 1] / laws[:, 0]
    print("| one coach run, 1 km at 60 m/s, CPU | Polach | FASTSIM | FASTSIM / Polach, per turn |")
    print("|---|---|---|---|")
    best_of = f"{laws[:, 0].min():.2f} s | {laws[:, 1].min():.2f} s"
    print(f"| best of {len(laws)} | {best_of} | {ratio.min():.1f}-{ratio.max():.1f}x |")


def _moving_pack(layouts, speeds):
    """A model of the runs of `layouts` at `speeds` (the runner's packing), 1 s past their 2 mm start."""
    from rail_mj.simulation.stepping import Pack, Running

    runs = [Running(k, prepare(Request(lay, v, 1000.0, 0.002))) for k, (lay, v) in enumerate(zip(layouts, speeds))]
    pack = Pack(runs)
    mujoco.mj_setState(pack.model, pack.data, pack.state, pack.STATE)
    with native.installed():
        mujoco.mj_step(pack.model, pack.data, nstep=1000)
    state = np.empty(mujoco.mj_stateSize(pack.model, pack.STATE))
    mujoco.mj_getState(pack.model, pack.data, state, pack.STATE)
    return pack, state


def scaling(n: int = 2000, repeats: int = 7):
    """What a step costs as a model holds more vehicles, as a train grows, and what threads give:
    (packs: [(vehicles, CPU s per vehicle-step, best)], trains: [(cars, dof, CPU s per step, per car)],
    threads: [(threads, wall s, CPU s)] of 16 coach runs of 500 m)."""
    from rail_mj.simulation.stepping import stepping

    coach = load_layout(COACH)
    sizes = (1, 2, 4, 8, 16)
    packs = {k: _moving_pack([coach] * k, np.linspace(30.0, 70.0, k)) for k in sizes}
    cars = (1, 2, 5, 10)
    trains = {c: _moving_pack([coach if c == 1 else ten_car_train(c)], [50.0]) for c in cars}
    cost: dict = {("pack", k): [] for k in sizes} | {("train", c): [] for c in cars}
    with stepping(), native.installed():
        for _ in range(repeats):  # every model in turn, each turn
            for key, (pack, state) in [(("pack", k), packs[k]) for k in sizes] + [
                (("train", c), trains[c]) for c in cars
            ]:
                mujoco.mj_setState(pack.model, pack.data, state, pack.STATE)
                cost[key].append(cpu_per_step(pack.model, pack.data, n))
    pack_rows = [(k, min(cost["pack", k]) / k) for k in sizes]
    train_rows = [(c, trains[c][0].model.nv, min(cost["train", c])) for c in cars]
    requests = [Request(coach, v, 500.0, 0.002) for v in np.linspace(30.0, 70.0, 16)]
    simulate_many(requests[:2], threads=1)
    thread_rows = []
    for threads in (1, 2):
        wall, cpu = time.perf_counter(), time.process_time()
        simulate_many(requests, threads=threads)
        thread_rows.append((threads, time.perf_counter() - wall, time.process_time() - cpu))
    return pack_rows, train_rows, thread_rows


def print_scaling(result) -> None:
    packs, trains, threads = result
    print("| coaches stepped in one model (30-70 m/s, moving) | CPU per coach-step | against one alone |")
    print("|---|---|---|")
    for k, per in packs:
        print(f"| {k} | {per * 1e6:.2f} µs | {per / packs[0][1]:.2f}x |")
    print()
    print("| a train of coaches (models/two-coaches' coach and coupling) | dof | CPU per step | per car |")
    print("|---|---|---|---|")
    for c, nv, step in trains:
        print(f"| {c} car{'s' if c > 1 else ''} | {nv} | {step * 1e6:.1f} µs | {step / c * 1e6:.1f} µs |")
    print()
    print("| 16 coach runs of 500 m (30-70 m/s), `simulate_many` | wall | CPU | speed-up |")
    print("|---|---|---|---|")
    for t, wall, cpu in threads:
        print(f"| {t} thread{'s' if t > 1 else ''} | {wall:.2f} s | {cpu:.2f} s | {threads[0][1] / wall:.2f}x |")


def print_curve(rows) -> None:
    print("| one RK4 step with the native creep callback, CPU time | straight | in a 600 m curve | curve / straight |")
    print("|---|---|---|---|")
    for name, nv, straight, curved, low, high in rows:
        print(
            f"| {name} ({nv} dof) | {straight * 1e6:.1f} µs | {curved * 1e6:.1f} µs | {curved / straight:.2f}x "
            f"(pairs {low:.2f}-{high:.2f}; target: at most 1.15x) |"
        )


def main() -> None:
    byte_compiled()
    if "--spatial" in sys.argv[1:]:
        print_spatial(spatial_against_planar())
        return
    if "--curve" in sys.argv[1:]:
        print_curve(curve_cost())
        return
    if "--irregular" in sys.argv[1:]:
        print_irregular(irregular_cost())
        return
    if "--scaling" in sys.argv[1:]:
        print_scaling(scaling())
        return
    if "--batch" in sys.argv[1:]:
        print_batch()
        return
    if "--ten-km" in sys.argv[1:]:
        print_ten_km(ten_km())
        return
    starts = start_up()
    train_step, train_run, train_nv = train_speed()
    layout = load_layout(COACH)
    critical = best(lambda: Stability(layout).critical_speed(), 5)
    locus = best(lambda: root_locus(Stability(layout), np.linspace(5.0, 150.0, 50)), 3)

    vehicle = Vehicle(layout)
    model, data = vehicle.model, mujoco.MjData(vehicle.model)
    model.opt.timestep = 1e-3
    native.set_speed(model, 40.0)
    n = 5000
    # Bare and native steps alternate, best of each: the machine is shared, and a ratio of
    # two measurements taken seconds apart would measure the neighbours as well.
    bare_times, fast_times = [], []
    for _ in range(7):
        bare_times.append(best(lambda: mujoco.mj_step(model, data, nstep=n), 1) / n)
        with native.installed():
            fast_times.append(best(lambda: mujoco.mj_step(model, data, nstep=n), 1) / n)
    bare, fast = min(bare_times), min(fast_times)
    with installed(CreepForces(model, vehicle.wheelset_names, 40.0)):
        creep = best(lambda: mujoco.mj_step(model, data, nstep=n), 3) / n
    packed_bare, packed = packed_steps(layout)
    peer_step = peer_numba.step_time()
    run = best(lambda: simulate(layout, 40.0, 400.0, 0.002), 3)
    simulate(layout, 60.0, 1000.0, 0.002)
    km = best(lambda: simulate(layout, 60.0, 1000.0, 0.002), 5)
    batch = batches(layout)
    sweep_time = batch["sweep"][0] * VEHICLE_KM
    map_time = best(
        lambda: sweep_table(
            COACH,
            (5.0, 150.0, 60),
            method="eigen",
            grids=["wheelset.conicity=0.025:0.4:20", "primary.yaw_stiffness=2e6:100e6:20:log"],
        ),
        1,
    )
    peers = single_peers()
    spatial = spatial_against_planar()

    print("| benchmark (shipped coach, 14 dof) | time |")
    print("|---|---|")
    print(f"| eigen critical speed (`rail-mj critical-speed`) | {critical:.2f} s |")
    print(f"| root locus, 50 speeds | {locus:.2f} s |")
    print(f"| one RK4 step, bare MuJoCo | {bare * 1e6:.1f} µs |")
    print(f"| one RK4 step with the native creep callback | {fast * 1e6:.1f} µs ({fast / bare:.2f}x bare) |")
    print(
        f"| one RK4 step with the Python creep callback (4 calls) | {creep * 1e6:.1f} µs ({creep / bare:.1f}x bare) |"
    )
    print(f"| `simulate`: 400 m at 40 m/s (10 s, 10 000 steps) | {run:.2f} s |")
    print(f"| `simulate`: 1 km at 60 m/s | {km:.2f} s |")
    print(
        f"| `rail-mj sweep`: 64 speeds 20-100 m/s, 1 km each, every core | {sweep_time:.1f} s "
        f"({sweep_time / VEHICLE_KM:.3f} s per vehicle-km) |"
    )
    print(f"| `rail-mj map`: 20 x 20 eigen critical speeds | {map_time:.1f} s |")
    print()
    print("| one RK4 step of the coach, CPU time | µs | the peer's step times |")
    print("|---|---|---|")
    print(
        f"| the numba peer's whole step (`benchmarks/peer_numba.py`, creep law included) | {peer_step * 1e6:.2f} | 1 |"
    )
    print(
        f"| a coach in a model of {PACK}, bare MuJoCo (no creep forces) | {packed_bare * 1e6:.2f} | "
        f"{packed_bare / peer_step:.2f} |"
    )
    print(f"| a coach in a model of {PACK}, native creep callback | {packed * 1e6:.2f} | {packed / peer_step:.2f} |")
    print()
    print("| the coach, per vehicle-km (1 km at 60 m/s) | s | rail-mj is |")
    print("|---|---|---|")
    print(f"| rail-mj, one run (`simulate`) | {km:.3f} | |")
    for name, seconds in peers:
        print(
            f"| {name} | {seconds:.3f} | {seconds / km:.2f}x faster |"
            if seconds >= km
            else f"| {name} | {seconds:.3f} | {km / seconds:.2f}x slower |"
        )
    print()
    print(
        "| batch: 64 speeds 20-100 m/s, 1 km each, every core, per vehicle-km | wall s | CPU s "
        "| against the numba peer as written (wall, CPU) |"
    )
    print("|---|---|---|---|")
    names = {
        "sweep": "rail-mj, `sweep` (runs and their EN 14363 summary rows)",
        "runs": "rail-mj, the runs alone (`simulate_many`, no summaries)",
        "peer": "the numba RK4 peer, as written (`prange` over the speeds in order)",
        "balanced": "the numba RK4 peer, its speeds dealt out evenly to the cores",
    }
    peer = batch["peer"]
    for name, (wall, cpu) in batch.items():
        print(f"| {names[name]} | {wall:.3f} | {cpu:.3f} | {wall / peer[0]:.2f}x, {cpu / peer[1]:.2f}x |")
    print()
    print(f"| a ten-car train ({train_nv} dof), real time 10 s at 60 m/s | time | faster than real time |")
    print("|---|---|---|")
    print(
        f"| one RK4 step of 1 ms with the native creep callback | {train_step * 1e6:.0f} µs | "
        f"{1e-3 / train_step:.1f}x |"
    )
    print(f"| `simulate`: 600 m at 60 m/s (10 s) | {train_run:.2f} s | {10.0 / train_run:.1f}x |")
    print()
    print_spatial(spatial)
    print()
    print("| start-up (a new process each) | time |")
    print("|---|---|")
    for name, seconds in starts:
        print(f"| {name} | {seconds:.2f} s ({seconds / starts[0][1]:.1f}x the interpreter) |")


if __name__ == "__main__":
    main()
