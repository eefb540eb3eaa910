"""`rail-mj sweep` and `rail-mj map`: many variants of a layout, in a table or a stability map
(rail_mj.studies.sweep)."""

from __future__ import annotations

import json
from pathlib import Path

import click

from rail_mj.cli.options import (
    EXIT_BAD_INPUT,
    EXIT_RUN_FAILED,
    Failure,
    check_outputs,
    check_profile_outputs,
    csv_beside,
    layout_of,
    output_failure,
    span_of,
    status_line,
    track_of,
    uses_stdout,
    warn,
    written,
)
from rail_mj.studies.span import GRID, SPEEDS, Span


@click.command("sweep")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option(
    "--speeds",
    required=True,
    help="A:B:N. run: every one of N speeds from A to B m/s is a case; eigen, time, nonlinear: "
    "the range the critical speed is searched in, N scan points.",
)
@click.option(
    "--set",
    "sets",
    multiple=True,
    metavar="KEY=VALUE",
    help="A layout key set for every case, e.g. creep.friction=0.2 (repeatable).",
)
@click.option(
    "--grid",
    "grids",
    multiple=True,
    metavar="KEY=A:B:N[:log]",
    help="A layout key varied over N values, e.g. wheelset.conicity=0.05:0.3:6 (repeatable: "
    "every combination is a case).",
)
@click.option(
    "--method",
    type=click.Choice(["run", "eigen", "time", "nonlinear", "curving"]),
    default="run",
    show_default=True,
    help="run: a simulation and its summary per case; eigen, time, nonlinear: "
    "a critical speed per case (as critical-speed --method); curving: the steady state on a curve "
    "(keys track.radius, track.cant) at each speed (as rail-mj curving).",
)
@click.option("--distance", type=float, default=1000.0, show_default=True, help="run: distance of each run, m.")
@click.option(
    "--track",
    type=click.Path(dir_okay=False),
    help="run: a track file every run follows from its start (docs/track.md).",
)
@click.option("--workers", type=int, help="Threads on this machine [default: every core].")
@click.option("--scheduler", help="Address of a Dask distributed scheduler to run the cases on instead.")
@click.option(
    "--rrd-dir", type=click.Path(file_okay=False), help="run: write a Rerun recording of each case into this folder."
)
@click.option(
    "-o",
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="The table, .csv or .parquet. Run again, the same sweep keeps its finished rows.",
)
@click.option("--json", "as_json", is_flag=True, help="Print a summary as JSON.")
def sweep_cmd(layout, speeds, sets, grids, method, distance, track, workers, scheduler, rrd_dir, out, as_json):
    """Run LAYOUT over speeds and layout parameters: one row per case, in a table."""
    lay = layout_of(layout)
    speed_span = span_of("--speeds", speeds, SPEEDS)
    _check_executor(workers, scheduler)
    if Path(out).suffix not in (".csv", ".parquet"):
        raise Failure(f"-o {out}: the table must be .csv or .parquet", EXIT_BAD_INPUT)
    check_outputs(layout, [("-o", out)])
    check_profile_outputs(lay, [("-o", out)])
    if track is not None:
        check_outputs(track, [("-o", out)], source="the track file")
        track_of(track)  # its warnings, once
    if rrd_dir:
        check_outputs(layout, [("--rrd-dir", rrd_dir)], folders=True)
    from rail_mj.studies.sweep import BRACKET_KEYS, ClusterError, SweepError, describe, summarise, sweep_table

    try:
        with status_line("sweep") as show:

            def progress(done, total, row):
                if show is not None:
                    show(f"{done}/{total}, last: case {row['case']} {row['status']}")

            table = sweep_table(
                layout,
                (speed_span.a, speed_span.b, speed_span.n),
                sets=sets,
                grids=grids,
                method=method,
                distance=distance,
                workers=workers,
                scheduler=scheduler,
                out=out,
                recordings=rrd_dir,
                progress=progress,
                track=track,
                warn=warn,
            )
    except ClusterError as e:
        raise Failure(str(e), EXIT_RUN_FAILED) from None
    except SweepError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    except BrokenPipeError:
        raise
    except OSError as e:
        raise output_failure(e, f"-o {out}: {e.strerror or e}") from None
    result = summarise(table)
    result["table"] = out
    if as_json:
        click.echo(json.dumps(result, indent=2))
        return
    counts = ", ".join(f"{k} {v}" for k, v in result["by_status"].items() if v)
    click.echo(f"{result['cases']} cases ({counts}), {result['wall_time_s']:.1f} s of computing: {out}")
    for bracket in result.get("brackets", []):
        where = ", ".join(f"{k} = {_value(v)}" for k, v in bracket.items() if k not in BRACKET_KEYS)
        click.echo(describe(bracket) + (f" ({where})" if where else ""))
    over = result.get("over_seeds", [])
    if over:
        click.echo(
            "over the track's seeds (mean +/- spread): N_MV, Wz lateral, Wz vertical, Y/Q p99.85, |Sigma Y| p99.85 kN"
        )
    for entry in over:
        where = ", ".join(f"{k} = {_value(v)}" for k, v in entry.items() if not k.endswith(("_mean", "_spread")))
        cells = []
        for q, scale in (
            ("n_mv", 1),
            ("wz_lateral", 1),
            ("wz_vertical", 1),
            ("y_over_q_p99_85", 1),
            ("sum_y_p99_85_n", 1e3),
        ):
            mean, spread = entry[f"{q}_mean"], entry[f"{q}_spread"]
            cell = "-" if mean is None else f"{mean / scale:.3g}"
            if mean is not None and spread is not None:
                cell += f" +/- {spread / scale:.2g}"
            cells.append(cell)
        click.echo(f"  {where}: {', '.join(cells)}")


def _value(v) -> str:
    """A parameter's value as the summary prints it: a number compactly, a name as it is."""
    return f"{v:g}" if isinstance(v, int | float) and not isinstance(v, bool) else str(v)


def _check_executor(workers: int | None, scheduler: str | None) -> None:
    if workers is not None and scheduler is not None:
        raise Failure("give --workers or --scheduler, not both", EXIT_BAD_INPUT)
    if workers is not None and not 1 <= workers <= 1024:
        raise Failure(f"--workers must be between 1 and 1024, got {workers}", EXIT_BAD_INPUT)


@click.command("map")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--x", "x_axis", required=True, metavar="KEY=A:B:N[:log]", help="The parameter along x.")
@click.option("--y", "y_axis", required=True, metavar="KEY=A:B:N[:log]", help="The parameter along y.")
@click.option(
    "--method",
    type=click.Choice(["eigen", "nonlinear"]),
    default="eigen",
    show_default=True,
    help="The critical speed mapped: linear (eigen) or nonlinear.",
)
@click.option(
    "--speeds", default="5:150:60", show_default=True, help="A:B:N, the speed range searched, m/s, with N scan points."
)
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE", help="A layout key set everywhere.")
@click.option("--workers", type=int, help="Threads on this machine [default: every core].")
@click.option("--scheduler", help="Address of a Dask distributed scheduler to run the cells on instead.")
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False), help="The map, PNG.")
@click.option(
    "--csv", "csv_path", type=click.Path(dir_okay=False), help="The table as CSV [default: the map's name with .csv]."
)
def map_cmd(layout, x_axis, y_axis, method, speeds, sets, workers, scheduler, out, csv_path):
    """The critical speed of LAYOUT as a map over two layout parameters."""
    lay = layout_of(layout)
    speed_span = span_of("--speeds", speeds, SPEEDS)
    csv_path = csv_beside(out, csv_path, "the map and the table")
    _check_executor(workers, scheduler)
    check_outputs(layout, [("-o", out), ("--csv", csv_path)])
    from rail_mj.output.plots import stability_map_png
    from rail_mj.studies.sweep import ClusterError, SweepError, parse_assignment, sweep_table

    axes = (("--x", x_axis), ("--y", y_axis))
    try:
        keys = [parse_assignment(text, option)[0] for option, text in axes]
        if keys[0] == keys[1]:
            raise SweepError(f"--x and --y both vary {keys[0]}")
        with status_line("map") as show:

            def progress(done, total, row):
                if show is not None:
                    show(f"{done}/{total} cells")

            table = sweep_table(
                layout,
                (speed_span.a, speed_span.b, speed_span.n),
                sets=sets,
                grids=(x_axis, y_axis),
                method=method,
                workers=workers,
                scheduler=scheduler,
                progress=progress,
            )
    except ClusterError as e:
        raise Failure(str(e), EXIT_RUN_FAILED) from None
    except SweepError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    x_log, y_log = (Span.parse(parse_assignment(text, option)[1], GRID, option).log for option, text in axes)
    import io

    import pyarrow.csv as pacsv

    with written([csv_path, out]) as (csv_tmp, png_tmp):
        buffer = io.BytesIO()
        pacsv.write_csv(table, buffer)
        csv_tmp.write_bytes(buffer.getvalue())
        png_tmp.write_bytes(stability_map_png(table, keys[0], keys[1], x_log, y_log, method, lay.name))
    err = uses_stdout(out, csv_path)
    rows = table.to_pylist()
    found = [r["critical_speed_m_per_s"] for r in rows if r["critical_speed_m_per_s"] is not None]
    unstable = sum(r["outcome"] == "unstable" for r in rows)
    stable = sum(r["outcome"] == "stable" for r in rows)
    other = len(rows) - len(found) - unstable - stable
    click.echo(f"map: {out}\ndata: {csv_path}", err=err)
    found_span = f"critical speed from {min(found):.1f} to {max(found):.1f} m/s" if found else "no critical speed"
    click.echo(
        f"{found_span} over {len(rows)} cells; {unstable} unstable from {speed_span.a:g} m/s, {stable} stable to "
        f"{speed_span.b:g} m/s, {other} other (see the table's status and note)",
        err=err,
    )
