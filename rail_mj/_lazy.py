"""Lazy public names for the package and its subpackages (PEP 562).

A subpackage's `__init__` names what it offers and where each name lives; the module is
imported on first use, so that `import rail_mj`, `rail-mj --help` and a layout error do not
wait for MuJoCo, numba and scipy to load.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any


def exports(
    package: str, names: dict[str, str], fallback: str | None = None
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """`__getattr__` and `__dir__` for `package`: `names` maps each public name to the module
    (relative to the package) that defines it. `fallback`: a module whose every other
    attribute the package also forwards (a module's old path kept working)."""

    def __getattr__(name: str) -> Any:
        if name in names:
            return getattr(importlib.import_module(f"{package}.{names[name]}"), name)
        if fallback is not None and not name.startswith("__"):
            module = importlib.import_module(f"{package}.{fallback}")
            if hasattr(module, name):
                return getattr(module, name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(names)

    return __getattr__, __dir__
