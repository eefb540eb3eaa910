"""The `rail-mj` command: a thin layer over the Python API.

Exit status: 0 success; 1 the reader of standard output went away (`| head`: nothing
printed, as Unix tools end); 2 bad input (layout, arguments, output path); 3 a run that
cannot be done or that diverged, or a full disk; 130 Ctrl-C, 143 SIGTERM, 129 SIGHUP.
Every failure is one line on stderr, and so is every warning (a legal value far outside
railway practice: rail_mj.layout.practice).

MuJoCo, numba and scipy take seconds to load: each command imports what it uses, so
`--help` and a bad layout answer at once.

options.py     failures, exit statuses and the checks every command shares
run.py         generate, run
curving.py     curving
stability.py   eigen, critical-speed, root-locus, bifurcation
studies.py     sweep, map
contact.py     contact, creep, profile, conicity, contact-geometry
track.py       track
response.py    response
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading

import click

from rail_mj.cli import contact, curving, response, run, stability, studies, track
from rail_mj.cli.options import EXIT_BAD_INPUT, EXIT_RUN_FAILED, Failure

# What click itself returns when standard output's reader has gone: the output was cut short.
EXIT_PIPE_CLOSED = 1


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="rail-mj")
def cli():
    """Railway bogies on rails in MuJoCo: describe a vehicle in a layout file (TOML),
    generate its MuJoCo model, run it, and review the run in Rerun."""


COMMANDS = (
    run.generate_cmd,
    run.run_cmd,
    curving.curving_cmd,
    stability.eigen_cmd,
    stability.critical_speed_cmd,
    stability.root_locus_cmd,
    stability.bifurcation_cmd,
    studies.sweep_cmd,
    studies.map_cmd,
    contact.contact_cmd,
    contact.creep_cmd,
    contact.profile_cmd,
    contact.conicity_cmd,
    contact.contact_geometry_cmd,
    track.track_cmd,
    response.response_cmd,
)
for command in COMMANDS:
    cli.add_command(command)


class Stopped(BaseException):
    """A SIGTERM or SIGHUP: unwinds like Ctrl-C, so that no temporary output is left behind."""

    def __init__(self, number: int) -> None:
        super().__init__(number)
        self.number = number


def _stop(number: int, frame: object) -> None:
    raise Stopped(number)


@contextlib.contextmanager
def _stoppable():
    """SIGTERM and SIGHUP raise Stopped for the length of the command (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = {n: signal.signal(n, _stop) for n in (signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    finally:
        for number, handler in before.items():
            signal.signal(number, handler)


def main(argv: list[str] | None = None) -> int:
    with _stoppable():
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    try:
        cli.main(args=argv, prog_name="rail-mj", standalone_mode=False)
    except Stopped as e:
        click.echo(f"rail-mj: stopped by {signal.Signals(e.number).name}", err=True)
        return 128 + e.number
    except Failure as e:
        click.echo(f"rail-mj: error: {e}", err=True)
        return e.status
    except click.exceptions.Abort:
        click.echo("rail-mj: interrupted", err=True)
        return 130
    except click.exceptions.NoArgsIsHelpError as e:  # `rail-mj` alone: the help, as --help
        click.echo(e.ctx.get_help())
        return 0
    except click.ClickException as e:
        click.echo(f"rail-mj: error: {e.format_message()} (see rail-mj --help)", err=True)
        return EXIT_BAD_INPUT
    except BrokenPipeError:  # the reader of standard output went away (`| head`)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_PIPE_CLOSED
    except SystemExit as e:  # click's own end of a broken pipe (sys.exit(1)), its stdout made quiet
        if e.code == 1:
            return EXIT_PIPE_CLOSED
        raise
    except MemoryError:
        click.echo("rail-mj: error: out of memory: shorten --distance or use fewer speeds", err=True)
        return EXIT_RUN_FAILED
    except Exception as e:
        why = " ".join(str(e).split()) or "no message"
        click.echo(
            f"rail-mj: error: unexpected {type(e).__name__}: {why} (a bug in rail-mj: please "
            f"report it with the command line)",
            err=True,
        )
        return EXIT_RUN_FAILED
    return 0


if __name__ == "__main__":
    sys.exit(main())
