"""The module paths of rail-mj 0.1 (one flat package), kept importable for one minor release.

rail-mj 0.2 arranged the package by its data flow (README.md, "How the code is laid out").
`import rail_mj.runner` and `from rail_mj.model import Vehicle` still work: each old path is
the module that now holds its code, or, for a module since split in parts, a module forwarding
every name it had to its part. New code uses the new paths; the test suite checks that
nothing in the repository uses an old one (tests/test_architecture.py). CHANGELOG.md lists
the moves.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import types

# Old module -> its new home. `rail_mj.layout`, `rail_mj.analysis`, `rail_mj.contact`,
# `rail_mj.cli`, `rail_mj.files` and `rail_mj.practice` (the table of practice, back at its 0.1
# path as a leaf below the track and the layout) are packages or modules of the same name today.
MOVED = {
    "profiles": "contact.profiles",
    "geometry": "contact.geometry",
    "conicity": "contact.conicity",
    "tables": "contact.tables",
    "creep": "contact.creep",
    "wheel": "vehicle.wheel",
    "loads": "vehicle.loads",
    "forces": "simulation.callback",
    "native": "simulation.native",
    "linear": "simulation.linear",
    "runner": "simulation.runner",
    "stability": "analysis.stability",
    "bifurcation": "analysis.bifurcation",
    "trains": "analysis.train_modes",
    "spatial": "analysis.spatial_modes",
    "recording": "output.recording",
    "plots": "output.plots",
    "sweep": "studies.sweep",
}

# Old modules split in parts -> the parts; a name in several is the first one's. The vehicle
# builder was rail_mj.model, then rail_mj.vehicle.model whole, before its split.
_VEHICLE = ("spec", "mjcf", "sensors", "statics", "spatial", "train", "planar", "looks", "joints", "rounding")
SPLIT = {
    "model": tuple(f"vehicle.{part}" for part in _VEHICLE),
    "vehicle.model": tuple(f"vehicle.{part}" for part in _VEHICLE),
}


# Old modules whose name is now also a public function of the package (`rail_mj.sweep(...)`):
# importing the old path sets the package's attribute to the module, so the module is
# given as a stand-in that is also that function.
CALLABLE = ("sweep", "bifurcation")


class _CallableModule(types.ModuleType):
    """A moved module that is also the function of its name."""

    def __init__(self, module: types.ModuleType, leaf: str) -> None:
        super().__init__(module.__name__, module.__doc__)
        self.__dict__.update(module.__dict__)
        object.__setattr__(self, "_target", module)
        object.__setattr__(self, "_leaf", leaf)

    def __call__(self, *args, **kwargs):
        return getattr(self._target, self._leaf)(*args, **kwargs)


class _Alias(importlib.abc.Loader):
    def __init__(self, target: str) -> None:
        self.target = target

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        module = importlib.import_module(self.target)
        self.spec = module.__spec__
        leaf = spec.name.rpartition(".")[2]
        return _CallableModule(module, leaf) if leaf in CALLABLE else module

    def exec_module(self, module: types.ModuleType) -> None:
        # Already executed: the old name is the new module. The import system has just
        # given it the old path's spec; it keeps its own.
        module.__spec__ = self.spec


class _Forward(importlib.abc.Loader):
    """An old module split in parts: a module of its own holding every name of its parts."""

    def __init__(self, parts: tuple[str, ...]) -> None:
        self.parts = parts

    def exec_module(self, module: types.ModuleType) -> None:
        targets = [importlib.import_module(part) for part in self.parts]
        module.__doc__ = f"{module.__name__}, moved: its names are those of {', '.join(self.parts)}."
        for target in reversed(targets):  # the first part that has a name gives it
            module.__dict__.update({k: v for k, v in vars(target).items() if not k.startswith("__")})


class _OldPaths(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname, path=None, target=None):
        package, _, old = fullname.partition(".")
        if package != "rail_mj":
            return None
        if old in MOVED:
            return importlib.machinery.ModuleSpec(fullname, _Alias(f"rail_mj.{MOVED[old]}"))
        if old in SPLIT:
            return importlib.machinery.ModuleSpec(fullname, _Forward(tuple(f"rail_mj.{p}" for p in SPLIT[old])))
        return None


def install() -> None:
    if not any(isinstance(f, _OldPaths) for f in sys.meta_path):
        sys.meta_path.append(_OldPaths())
