"""Outputs all or nothing, together, whatever stops the command: a reader of standard
output that goes away, a full disk, SIGTERM, SIGKILL. Full disks are made in a temporary
folder (a file-size limit on the process; a small tmpfs where a user namespace allows it),
never with /dev/full.
"""

from __future__ import annotations

import os
import resource
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import MODELS

import rail_mj.files
from rail_mj.cli import main

WHEELSET = MODELS / "wheelset" / "wheelset.toml"
COACH = MODELS / "manchester-coach" / "manchester-coach.toml"
SHORT_RUN = ["--speed", "30", "--distance", "3"]
# 200 m at 30 m/s: about 400 kB of CSV, past any pipe's buffer (64 kB on Linux).
LONG_RUN = ["--speed", "30", "--distance", "200"]


def run(argv, capsys):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def command(*argv) -> list[str]:
    return [sys.executable, "-m", "rail_mj", *map(str, argv)]


def test_a_reader_that_goes_away_ends_the_command_quietly(tmp_path):
    """`--out - | head -1`: status 1 (the output was cut short), nothing on stderr."""
    proc = subprocess.Popen(
        command("run", WHEELSET, *LONG_RUN, "--out", "-"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=tmp_path,
    )
    assert proc.stdout is not None and proc.stderr is not None
    with proc:
        first = proc.stdout.readline()
        proc.stdout.close()
        err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 1, err
    assert first.startswith(b"t,x,y1,psi1")
    assert err == ""


def _limited(limit: int):
    """A child whose files cannot grow past `limit` bytes: writes past it fail with EFBIG,
    as on a full disk (SIGXFSZ ignored, so the write fails instead of killing the process)."""

    def start() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return start


@pytest.mark.parametrize("outputs", [["--rrd", "run.rrd"], ["--out", "run.csv", "--rrd", "run.rrd"]])
def test_no_room_for_an_output_is_one_line_exit_3_and_nothing_written(outputs, tmp_path):
    (tmp_path / "run.csv").write_text("old\n")  # an old output of the pair stays as it was
    # Once without the limit: numba's cache, cold in a fresh checkout, is then written, not
    # refused (its files are larger than the limit).
    subprocess.run(command("run", WHEELSET, *SHORT_RUN), capture_output=True, check=True, cwd=tmp_path)
    proc = subprocess.run(
        command("run", WHEELSET, *LONG_RUN, *outputs),
        capture_output=True,
        check=False,
        text=True,
        cwd=tmp_path,
        preexec_fn=_limited(64 * 1024),
        timeout=300,
    )
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 3, proc.stderr
    assert len(lines) == 1 and lines[0].startswith("rail-mj: error: cannot write "), lines
    assert "File too large" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv"]
    assert (tmp_path / "run.csv").read_text() == "old\n"


def _can_mount_tmpfs() -> bool:
    if shutil.which("unshare") is None:
        return False
    probe = subprocess.run(
        ["unshare", "-rm", "sh", "-c", "mount -t tmpfs -o size=64k tmpfs /mnt 2>/dev/null || exit 1"],
        capture_output=True,
        check=False,
    )
    return probe.returncode == 0


@pytest.mark.skipif(not _can_mount_tmpfs(), reason="no user namespace to mount a small tmpfs in")
def test_a_full_filesystem_is_one_line_exit_3_and_nothing_written(tmp_path):
    """A 500 kB tmpfs mounted on a temporary folder; the coach's recording of 600 m needs
    about 2 MB."""
    disk = tmp_path / "disk"
    disk.mkdir()
    # The command's status and then what the disk holds, read before the namespace ends.
    script = 'mount -t tmpfs -o size=500k tmpfs "$0" || exit 99; "$@"; echo "status $?"; ls -A "$0"'
    proc = subprocess.run(
        ["unshare", "-rm", "sh", "-c", script, str(disk)]
        + command("run", COACH, "--speed", "50", "--distance", "600", "--rrd", disk / "run.rrd"),
        capture_output=True,
        check=False,
        text=True,
        timeout=300,
    )
    assert proc.stdout.splitlines() == ["status 3"], proc.stdout + proc.stderr
    assert proc.stderr.strip().splitlines() == [
        f"rail-mj: error: cannot write {disk / 'run.rrd'}: No space left on device"
    ]


def test_sigterm_while_outputs_are_written_leaves_none_of_them(tmp_path, capsys, monkeypatch):
    from rail_mj.output import samples

    csv_bytes = samples.csv_bytes

    def terminated_meanwhile(run):
        data = csv_bytes(run)
        signal.raise_signal(signal.SIGTERM)
        return data

    monkeypatch.setattr(samples, "csv_bytes", terminated_meanwhile)
    status, _out, err = run(
        ["run", WHEELSET, *SHORT_RUN, "--rrd", tmp_path / "run.rrd", "--out", tmp_path / "run.csv"], capsys
    )
    assert status == 128 + signal.SIGTERM
    assert err.strip() == "rail-mj: stopped by SIGTERM"
    assert list(tmp_path.iterdir()) == []


def test_a_signal_between_two_renames_waits_until_the_set_is_in_place(tmp_path, capsys, monkeypatch):
    """The set of outputs is renamed together: a SIGTERM that arrives after the first rename
    acts only once the second is done, so the folder holds the new pair, never half of it."""
    (tmp_path / "run.csv").write_text("old\n")
    (tmp_path / "run.rrd").write_text("old\n")
    replace = os.replace
    renamed: list[str] = []

    def signalled_after_the_first(source, target):
        replace(source, target)
        if Path(target).parent != tmp_path:  # another library's rename (numba's cache, say)
            return
        renamed.append(Path(target).name)
        if len(renamed) == 1:
            signal.raise_signal(signal.SIGTERM)

    monkeypatch.setattr(rail_mj.files.os, "replace", signalled_after_the_first)
    status, _out, err = run(
        ["run", WHEELSET, *SHORT_RUN, "--out", tmp_path / "run.csv", "--rrd", tmp_path / "run.rrd"], capsys
    )
    assert status == 128 + signal.SIGTERM, err
    assert renamed == ["run.csv", "run.rrd"]
    assert (tmp_path / "run.csv").read_text().startswith("t,x,y1,psi1")
    assert (tmp_path / "run.rrd").read_bytes()[:4] == b"RRF2"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv", "run.rrd"]


def _dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_a_killed_writers_temporary_files_are_removed_by_the_next(tmp_path, capsys, monkeypatch):
    """SIGKILL cannot be caught: its `.NAME.PID.XXXXXXXX.tmp` stays until the next write into
    its folder, which removes those whose process is gone, of any output, and keeps a live one's
    (it may be writing) and files that only look alike."""
    monkeypatch.setattr(rail_mj.files, "_CLEANED", set())  # as in a new process
    dead, alive = _dead_pid(), os.getpid()
    stale = [tmp_path / f".run.csv.{dead}.k1ll3d00.tmp", tmp_path / f".results.2024.csv.{dead}.abc_1234.tmp"]
    kept = [
        tmp_path / f".run.csv.{alive}.w0rk1ng0.tmp",  # a live writer's
        tmp_path / f".results.2024.csv.{alive}.abc_1234.tmp",  # a live one's, a dotted name
        tmp_path / f".run.csv.{dead}.tmp",  # not one of rail-mj's: no random part
        tmp_path / "notes.2024.tmp",
    ]
    for path in stale + kept:
        path.write_text("half a run")
    status, _out, err = run(["run", WHEELSET, *SHORT_RUN, "--out", tmp_path / "run.csv"], capsys)
    assert status == 0, err
    assert not any(p.exists() for p in stale)
    assert all(p.exists() for p in kept)
    assert (tmp_path / "run.csv").read_text().startswith("t,x,y1,psi1")
