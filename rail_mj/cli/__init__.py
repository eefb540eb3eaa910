"""The `rail-mj` command: a thin layer over the Python API (`rail_mj.cli:main`).

main.py        the command group and its subcommands
"""

from rail_mj import _lazy
from rail_mj.cli.main import cli, main

__all__ = ["cli", "main"]
__getattr__, _dir = _lazy.exports(__name__, {}, fallback="main")


def __dir__() -> list[str]:
    return list(__all__)
