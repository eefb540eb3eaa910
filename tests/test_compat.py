"""rail-mj 0.1's flat module paths still import, as the modules that now hold their code."""

from __future__ import annotations

import importlib

import pytest

import rail_mj
from rail_mj import _compat


@pytest.mark.parametrize("old", sorted(_compat.MOVED))
def test_a_moved_module_is_its_new_home(old):
    moved = importlib.import_module(f"rail_mj.{old}")
    new = importlib.import_module(f"rail_mj.{_compat.MOVED[old]}")
    public = [name for name in vars(new) if not name.startswith("__")]
    assert public and all(getattr(moved, name) is getattr(new, name) for name in public)


@pytest.mark.parametrize("old", sorted(_compat.SPLIT))
def test_a_split_module_forwards_every_name_of_its_parts(old):
    forward = importlib.import_module(f"rail_mj.{old}")
    for part in _compat.SPLIT[old]:
        new = importlib.import_module(f"rail_mj.{part}")
        for name in (n for n in vars(new) if not n.startswith("__")):
            assert hasattr(forward, name), f"rail_mj.{old}.{name} (from rail_mj.{part})"


def test_old_from_imports_of_the_readme_era_work():
    from rail_mj.model import Vehicle  # noqa: F401  (rail-mj 0.1)
    from rail_mj.runner import simulate

    assert simulate is rail_mj.simulate


def test_a_moved_module_named_like_a_function_is_still_the_function():
    """`import rail_mj.sweep` (a module in 0.1) must not hide the function `rail_mj.sweep`."""
    importlib.import_module("rail_mj.sweep")
    assert callable(rail_mj.sweep) and hasattr(rail_mj.sweep, "plan")
