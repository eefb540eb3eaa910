"""Sweeps and maps: brackets against the eigenvalues, resuming, failures, executors."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time

import pytest
from conftest import MODELS, worn_coach_copy

from rail_mj.analysis.stability import Stability
from rail_mj.cli import main
from rail_mj.layout import load_layout
from rail_mj.studies import sweep as sweep_module
from rail_mj.studies.sweep import Journal, SweepError, plan, summarise, sweep_table

WHEELSET = MODELS / "wheelset" / "wheelset.toml"  # linear creep, no flange: Vc = 57.50 m/s
BOGIE = MODELS / "bogie" / "bogie.toml"


def results(table) -> list[dict]:
    """The rows without their wall times (which no two runs share)."""
    return [{k: v for k, v in row.items() if k != "wall_time_s"} for row in table.to_pylist()]


def test_the_bracket_of_a_run_sweep_contains_the_eigen_critical_speed():
    table = sweep_table(WHEELSET, (45.0, 70.0, 6), distance=400.0)
    (bracket,) = summarise(table)["brackets"]
    low, high = bracket["critical_speed_bracket_m_per_s"]
    critical = Stability(load_layout(WHEELSET)).critical_speed().critical_speed
    assert low < critical < high and high - low == pytest.approx(5.0)


def test_threads_and_one_worker_give_identical_tables():
    args = dict(speeds=(30.0, 90.0, 5), grids=["primary.yaw_stiffness=1e6:4e6:2"], distance=150.0)
    one = sweep_table(WHEELSET, workers=1, **args)
    two = sweep_table(WHEELSET, workers=2, **args)
    assert results(one) == results(two)
    assert one.num_rows == 10 and one.column_names[:3] == ["case", "primary.yaw_stiffness", "speed_m_per_s"]


def test_a_broken_case_is_failed_and_the_rest_finish(monkeypatch):
    real = sweep_module._summarise_run

    def broken(case, layout, run):
        if case.speed == 40.0:
            raise RuntimeError("deliberately broken")
        return real(case, layout, run)

    monkeypatch.setattr(sweep_module, "_summarise_run", broken)
    rows = sweep_table(WHEELSET, (30.0, 50.0, 3), distance=100.0).to_pylist()
    assert [r["status"] for r in rows] == ["ok", "failed", "ok"]
    assert rows[1]["message"] == "RuntimeError: deliberately broken"
    assert rows[0]["max_abs_lateral_m"] > 0 and rows[2]["max_abs_lateral_m"] > 0


def test_bad_values_are_refused_per_case_and_unknown_keys_stop_the_sweep():
    rows = sweep_table(WHEELSET, (30.0, 30.0, 1), grids=["wheelset.conicity=-0.1:0.2:4"], distance=60.0).to_pylist()
    assert [r["status"] for r in rows] == ["refused", "ok", "ok", "ok"]
    assert "wheelset.conicity" in rows[0]["message"]
    with pytest.raises(SweepError, match="yaw_stifness"):
        plan(WHEELSET, (30.0, 30.0, 1), grids=["primary.yaw_stifness=1:2:2"])


def test_resuming_keeps_every_written_row_and_runs_only_the_rest(tmp_path):
    """A sweep killed mid-way (SIGKILL), and a journal line cut short by it: the same sweep
    again runs exactly the cases without a row, and keeps the others as they were."""
    out = tmp_path / "sweep.csv"
    command = [
        sys.executable,
        "-m",
        "rail_mj.cli",
        "sweep",
        str(WHEELSET),
        "--speeds",
        "20:59:40",
        "--distance",
        "1500",
        "--workers",
        "1",
        "-o",
        str(out),
    ]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    journal = Journal(out)
    deadline = time.monotonic() + 120
    while len(journal.read()) < 1 and time.monotonic() < deadline and process.poll() is None:
        time.sleep(0.05)
    process.send_signal(signal.SIGKILL)
    process.wait()
    written = journal.read()
    assert 1 <= len(written) < 40, "the sweep was not caught mid-way"
    assert not out.exists()
    with open(journal.path, "a") as f:  # a kill in the middle of a write
        f.write('{"case": 99, "speed_m_')
    ran = []
    table = sweep_table(
        WHEELSET,
        (20.0, 59.0, 40),
        distance=1500.0,
        workers=1,
        out=out,
        progress=lambda done, total, row: ran.append(row["case"]),
    )
    assert sorted(ran + [r["case"] for r in written]) == list(range(40))  # nothing lost, nothing twice
    kept = {r["case"]: r for r in table.to_pylist()}
    for row in written:
        assert kept[row["case"]] == row
    assert not journal.path.exists() and out.exists()
    again = []
    sweep_table(WHEELSET, (20.0, 59.0, 40), distance=1500.0, out=out, progress=lambda *a: again.append(a))
    assert again == []  # finished: nothing runs


def test_an_output_of_another_sweep_is_not_overwritten(tmp_path):
    out = tmp_path / "sweep.parquet"
    sweep_table(WHEELSET, (30.0, 40.0, 2), distance=50.0, out=out)
    before = out.read_bytes()
    with pytest.raises(SweepError, match="another sweep"):
        sweep_table(WHEELSET, (30.0, 45.0, 2), distance=50.0, out=out)
    assert out.read_bytes() == before


def test_a_dask_cluster_gives_the_local_table():
    import distributed

    args = dict(speeds=(30.0, 70.0, 3), grids=["wheelset.conicity=0.05:0.1:2"], distance=100.0)
    local = sweep_table(WHEELSET, **args)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True, dashboard_address=None) as cluster:
        remote = sweep_table(WHEELSET, scheduler=cluster.scheduler_address, **args)
    assert results(remote) == results(local)


def test_critical_speed_sweeps_match_the_critical_speed_command(capsys):
    table = sweep_table(WHEELSET, (5.0, 150.0, 60), method="eigen", grids=["wheelset.conicity=0.1:0.2:2"])
    rows = table.to_pylist()
    assert main(["critical-speed", str(WHEELSET), "--json"]) == 0
    assert rows[0]["critical_speed_m_per_s"] == json.loads(capsys.readouterr().out)["critical_speed"]
    assert rows[1]["critical_speed_m_per_s"] < rows[0]["critical_speed_m_per_s"]  # higher conicity


def test_cli_sweep_and_map(tmp_path, capsys):
    out = tmp_path / "s.csv"
    assert main(["sweep", str(WHEELSET), "--speeds", "50:65:4", "--distance", "300", "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["cases"] == 4 and summary["by_status"]["failed"] == 0
    assert summary["brackets"][0]["critical_speed_bracket_m_per_s"] == [55.0, 60.0]
    png, csv = tmp_path / "map.png", tmp_path / "map.csv"
    assert (
        main(
            [
                "map",
                str(BOGIE),
                "--x",
                "wheelset.conicity=0.05:0.3:3",
                "--y",
                "primary.yaw_stiffness=5e6:60e6:3:log",
                "-o",
                str(png),
            ]
        )
        == 0
    )
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    lines = csv.read_text().splitlines()
    assert len(lines) == 10 and '"wheelset.conicity","primary.yaw_stiffness"' in lines[0]
    assert main(["sweep", str(WHEELSET), "--speeds", "50:65:4", "-o", str(tmp_path / "s.xlsx")]) == 2
    assert (
        main(
            [
                "map",
                str(BOGIE),
                "--x",
                "wheelset.conicity=0.05:0.3:3",
                "--y",
                "wheelset.conicity=0.1:0.2:2",
                "-o",
                str(png),
            ]
        )
        == 2
    )


def test_one_recording_per_run_case(tmp_path):
    folder = tmp_path / "recordings"
    table = sweep_table(WHEELSET, (30.0, 40.0, 2), distance=40.0, recordings=folder)
    assert table.column("status").to_pylist() == ["ok", "ok"]
    assert sorted(p.name for p in folder.iterdir()) == ["case-00000.rrd", "case-00001.rrd"]
    assert all(p.stat().st_size > 0 for p in folder.iterdir())


def test_a_journal_cut_short_twice_still_resumes(tmp_path):
    """A kill mid-write leaves half a line: opening the journal drops it (its case runs again),
    so a second kill mid-write leaves the journal as readable as the first."""
    journal = Journal(tmp_path / "s.csv")
    with journal:
        journal.append({"case": 0, "case_key": "a"})
    written = [0]
    for cut, next_case in (('{"case": 1, "ca', 3), ('{"case": 2', 4)):
        with open(journal.path, "a") as f:
            f.write(cut)
        assert [r["case"] for r in journal.read()] == written
        with journal:
            journal.append({"case": next_case, "case_key": str(next_case)})
        written.append(next_case)
        assert [r["case"] for r in journal.read()] == written


def test_a_sweep_output_must_be_a_regular_file(tmp_path):
    import os

    fifo = tmp_path / "s.csv"
    os.mkfifo(fifo)
    with pytest.raises(SweepError, match="regular file"):
        sweep_table(WHEELSET, (30.0, 40.0, 2), distance=50.0, out=fifo)
    damaged = tmp_path / "d.parquet"
    damaged.write_bytes(b"not parquet")
    with pytest.raises(SweepError, match="not a sweep table"):
        sweep_table(WHEELSET, (30.0, 40.0, 2), distance=50.0, out=damaged)


def test_a_case_key_changes_with_the_profile_file_it_reads(tmp_path):
    """The layout names its wheel profile's file; a resumed sweep keys its cases by that file's
    contents too, so new contents under the old name are new cases, the same contents the same."""
    layout, wheel = worn_coach_copy(tmp_path)
    keys = [c.key for c in plan(layout, (30.0, 40.0, 2))]
    assert [c.key for c in plan(layout, (30.0, 40.0, 2))] == keys
    lines = wheel.read_text().splitlines()
    wheel.write_text("\n".join(lines[:-1]) + "\n")  # one point fewer: another wheel
    changed = [c.key for c in plan(layout, (30.0, 40.0, 2))]
    assert len(set(changed)) == 2 and not set(changed) & set(keys)


@pytest.mark.parametrize(
    "bad", [b"42", b"null", b"[]", b"\xff\xfe not utf-8", b'{"case": 0, "case_key": 7}', b"{not json"]
)
def test_a_journal_line_that_is_no_row_is_set_aside_and_the_rest_resumes(bad, tmp_path, capsys):
    """A sweep's journal with one good row and then a bad line: the bad one is named by its line
    number on stderr and its case runs again; the good row is kept as it was (its wall time too)."""
    out = tmp_path / "sweep.csv"
    sweep_table(WHEELSET, (30.0, 40.0, 2), distance=20.0, out=out)
    first = sweep_module.read_table(out)[0]
    out.unlink()
    journal = Journal(out)
    journal.path.write_bytes(json.dumps(first).encode() + b"\n" + bad + b"\n\n")
    argv = ["sweep", str(WHEELSET), "--speeds", "30:40:2", "--distance", "20", "-o", str(out)]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert f"{journal.path}: line 2 " in err and "set aside, its case runs again" in err
    rows = sweep_module.read_table(out)
    assert len(rows) == 2 and rows[0] == first


def test_a_grid_past_the_largest_sweep_is_refused_before_it_is_planned(monkeypatch, tmp_path, capsys):
    """Three grids of 1e5 values each are 1e15 cases: one line at once (the grid points are never
    listed: itertools.product is not reached), from the API and the command line alike."""

    def never(*_):
        raise AssertionError("the grid points were listed")

    monkeypatch.setattr(sweep_module.itertools, "product", never)
    grids = [f"{key}=1e5:1e7:100000" for key in ("primary.yaw_stiffness", "primary.lateral_stiffness")]
    grids.append("secondary.yaw_damping=1e4:1e6:100000")
    with pytest.raises(SweepError, match=r"^1e\+15 cases \(1e\+15 grid points x 1 speed\) is more than the 1,000,000"):
        plan(BOGIE, (30.0, 30.0, 1), grids=grids)
    argv = ["sweep", str(BOGIE), "--speeds", "30:30:1", "-o", str(tmp_path / "s.csv")]
    argv += [a for g in grids for a in ("--grid", g)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is more than the 1,000,000 a sweep may have" in err[0]


def test_the_records_floor_is_a_lower_bound_of_a_runs_record_and_within_two_of_it():
    """`records_floor` is what a sweep run here refuses by: it must never exceed what a run
    really keeps (the arrays of Run that grow with its samples), and is within a factor of two
    of it for a single wheelset and a coach (a body per wheelset is the floor)."""
    import numpy as np

    from rail_mj.simulation.runner import simulate

    for path in (WHEELSET, MODELS / "manchester-coach" / "manchester-coach.toml"):
        layout = load_layout(path)
        run = simulate(layout, 40.0, 20.0, 0.002)
        n = len(run.t)
        kept = sum(v.nbytes for v in vars(run).values() if isinstance(v, np.ndarray) and v.shape[:1] == (n,))
        floor = sweep_module.records_floor(layout.n_wheelsets, 20.0, 40.0)
        assert floor <= kept <= 2 * floor, (path.name, floor, kept)


def test_runs_whose_records_exceed_the_memory_are_refused_in_one_line_unless_on_a_cluster(
    monkeypatch, tmp_path, capsys
):
    """64 runs of 10 km on a machine given 1 GB: 16 stepped at once (two threads of a pack of
    eight) are refused, naming the memory needed and had; the same plan for a cluster (nothing held
    here) is made, and so is one stepping a single run at a time of a short one."""
    monkeypatch.setattr(sweep_module, "memory_bytes", lambda: 2**30)
    with pytest.raises(SweepError, match=r"^the runs' records need at least [0-9.]+ GB \(16 runs of 10000 m"):
        plan(BOGIE, (5.0, 150.0, 64), distance=10_000.0, held_at_once=16)
    # The floor of the slowest run alone, 2000 s at 1 kHz of 30 floats, is 0.45 GB: one fits.
    assert len(plan(BOGIE, (5.0, 150.0, 64), distance=10_000.0, held_at_once=1)) == 64
    assert len(plan(BOGIE, (5.0, 150.0, 64), distance=10_000.0, held_at_once=None)) == 64
    assert len(plan(BOGIE, (5.0, 150.0, 64), distance=10.0)) == 64  # a short one fits
    out = tmp_path / "s.csv"
    argv = ["sweep", str(BOGIE), "--speeds", "5:150:64", "--distance", "10000", "--workers", "2"]
    assert main([*argv, "-o", str(out)]) == 2
    assert not list(tmp_path.iterdir())
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "more than this machine's 1 GB" in err[0]


# --- a cluster that fails ends the sweep in one line, in a stated time -----------------------


def _server(reply: bytes):
    """A TCP server on a free local port that takes connections and sends `reply` (nothing:
    it swallows them), never speaking Dask; closed at the end of the test by its socket."""
    import socket
    import threading

    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen()
    held = []

    def serve():
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            held.append(conn)
            if reply:
                conn.sendall(reply)

    threading.Thread(target=serve, daemon=True).start()
    return listener, held, f"tcp://127.0.0.1:{listener.getsockname()[1]}"


@pytest.mark.parametrize(
    "reply, says",
    [
        (b"", r": nothing there answered as a Dask scheduler within 1 s$"),
        # Dask reads the reply's first bytes as a frame length: terabytes, a MemoryError.
        (b"HTTP/1.0 200 OK\r\nContent-Type: text/html\r\n\r\n<html>not dask</html>" * 50, r": it answered, but not as"),
    ],
)
def test_a_server_that_is_no_dask_scheduler_is_named_within_the_connect_timeout(reply, says, monkeypatch):
    """A server that swallows the connection, and one that answers in another protocol (HTTP):
    neither completes Dask's handshake, and both are named within the connect timeout."""
    monkeypatch.setattr(sweep_module, "CONNECT_TIMEOUT", 1.0)
    listener, held, address = _server(reply)
    started = time.monotonic()
    try:
        with pytest.raises(SweepError, match=says):
            sweep_table(WHEELSET, (30.0, 40.0, 2), distance=20.0, scheduler=address)
    finally:
        for conn in [listener, *held]:
            conn.close()
    assert time.monotonic() - started < 1.0 + 1.0 + 5.0  # the timeout, the join's margin, the import


def test_a_cluster_without_workers_ends_the_sweep_after_the_stated_time(monkeypatch, tmp_path):
    import distributed

    monkeypatch.setattr(sweep_module, "WORKERLESS_TIMEOUT", 2.0)
    out = tmp_path / "s.csv"
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as cluster:
        started = time.monotonic()
        with pytest.raises(sweep_module.ClusterError, match=r"has had no worker for 2 s"):
            sweep_table(WHEELSET, (30.0, 40.0, 2), distance=20.0, scheduler=cluster.scheduler_address, out=out)
        assert time.monotonic() - started < 2.0 + 3 * sweep_module.POLL + 5.0
    assert not out.exists()


def test_a_scheduler_killed_while_the_sweep_waits_on_it_ends_it_in_one_line_exit_3(tmp_path, capsys):
    """A `dask scheduler` with the sweep's tasks queued (no worker to take them), killed two
    seconds in: the sweep ends at once with one line (not "unexpected FutureCancelledError"), exit 3."""
    import socket
    import threading

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    scheduler = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--port", str(port), "--no-dashboard"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        address = f"tcp://127.0.0.1:{port}"
        for _ in range(100):  # until it listens
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            time.sleep(0.1)
        threading.Timer(2.0, scheduler.kill).start()
        started = time.monotonic()
        argv = ["sweep", str(WHEELSET), "--speeds", "30:40:2", "--distance", "20"]
        status = main([*argv, "--scheduler", address, "-o", str(tmp_path / "s.csv")])
        elapsed = time.monotonic() - started
    finally:
        scheduler.kill()
        scheduler.wait()
    lines = capsys.readouterr().err.strip().splitlines()
    assert status == 3
    assert len(lines) == 1 and "the scheduler went away" in lines[0], lines
    assert elapsed < 2.0 + 10.0


@pytest.mark.parametrize(
    "speeds, grids, says",
    [
        ((30.0, 40.0, 2.5), {}, "N a whole number"),
        (("a", 40.0, 2), {}, "give (A, B, N)"),
        ((30.0, 40.0, 2), {"primary.yaw_stiffness": [1e6, 1e6]}, "a value is given twice"),
        ((30.0, 40.0, 2), {"primary.yaw_stiffness": []}, "at least one finite number"),
        ((30.0, 40.0, 2), {"primary.yaw_stiffness": "nonsense"}, "A:B:N"),
    ],
)
def test_python_values_that_make_no_sweep_are_refused_in_one_line(speeds, grids, says):
    with pytest.raises(SweepError, match=re.escape(says)):
        plan(BOGIE, speeds, grids=grids)


def test_python_values_give_the_cases_the_command_lines_texts_give():
    """`grids` and `sets` as dicts of Python values, a `Layout` read from a file, and "A:B:N":
    the same cases, keys included, as the texts the command line passes."""
    texts = plan(BOGIE, (30.0, 40.0, 2), sets=["creep.law=polach"], grids=["primary.yaw_stiffness=1e6:4e6:2"])
    values = plan(
        load_layout(BOGIE), "30:40:2", sets={"creep.law": "polach"}, grids={"primary.yaw_stiffness": [1e6, 4e6]}
    )
    assert [c.key for c in values] == [c.key for c in texts] and len(texts) == 4


@pytest.mark.parametrize(
    "values",
    [
        [None, None],
        [True, None, False],
        [3, None, -7, 2**62],
        [0.5, None, float("nan"), -1e300, float("inf")],
        [1, 2.5, None],
        [2**53, -(2**53), 0.5],  # ints exact as floats
        [2**53 + 1, 0.5],  # not exact: pa.array refuses it, and so does the table
        ["ok", None, "", "diverged: the timestep 1e-3 s", "ünïcode"],
        [1, None, 2**64],  # past int64: left to pa.array
        [True, 1],  # a mix: left to pa.array, which says so
        [],
    ],
)
def test_a_sweep_table_is_the_table_pa_table_makes(values):
    import pyarrow as pa
    import pyarrow.csv as pacsv

    from rail_mj.studies.sweep import to_table

    rows = [{"case": k, "value": v} for k, v in enumerate(values)]
    try:
        expected = pa.table({"case": [r["case"] for r in rows], "value": values})
    except (pa.ArrowException, OverflowError) as e:
        with pytest.raises(type(e)):
            to_table(rows, ["case", "value"])
        return
    got = to_table(rows[::-1], ["case", "value"])  # sorted by case
    assert got.schema == expected.schema
    assert got.column("value").is_null().equals(expected.column("value").is_null())
    written = []
    for table in (got, expected):  # as the sweep writes them, NaN included
        sink = pa.BufferOutputStream()
        pacsv.write_csv(table, sink)
        written.append(sink.getvalue().to_pybytes())
    assert written[0] == written[1]
