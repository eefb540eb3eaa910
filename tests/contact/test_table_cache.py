"""Profiled layouts start fast: the contact geometry table, seconds to build, is kept on disk
under a key of everything it depends on, and a command that does not need it refuses first."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS, worn_coach_copy

import rail_mj.files
from rail_mj.cli import main
from rail_mj.contact import geometry
from rail_mj.layout import load_layout


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A cache folder of the test's own, and the in-process memo emptied around it."""
    folder = tmp_path / "cache"
    monkeypatch.setattr(rail_mj.files, "cache_folder", lambda kind: folder / kind)
    geometry._default_table.cache_clear()
    yield folder
    geometry._default_table.cache_clear()


def _builds(monkeypatch) -> list[int]:
    """Count the contact tables really computed from here on."""
    built: list[int] = []
    compute = geometry.contact_table

    def counted(source, ys=None):
        if ys is None and isinstance(source, geometry.Track):  # the table itself, not a lookup
            built.append(1)
        return compute(source, ys)

    monkeypatch.setattr(geometry, "contact_table", counted)
    return built


def test_a_second_command_reads_the_table_kept_and_gets_the_same_numbers(cache, tmp_path, monkeypatch):
    layout, _wheel = worn_coach_copy(tmp_path)
    built = _builds(monkeypatch)
    first = geometry.contact_table(load_layout(layout))
    assert built == [1] and len(list((cache / "contact").glob("*.npz"))) == 1
    geometry._default_table.cache_clear()  # a new process
    again = geometry.contact_table(load_layout(layout))
    assert built == [1]  # read, not built
    assert set(again.columns) == set(first.columns)
    for name, values in first.columns.items():
        np.testing.assert_array_equal(again.columns[name], values)  # bit for bit


@pytest.mark.parametrize(
    "change",
    ["profile file", "rail inclination", "gauge", "rolling radius"],
)
def test_anything_the_table_depends_on_makes_a_new_one(change, cache, tmp_path, monkeypatch):
    layout, wheel = worn_coach_copy(tmp_path)
    built = _builds(monkeypatch)
    load_layout(layout)
    geometry._default_table.cache_clear()
    text = layout.read_text()
    if change == "profile file":  # the same name, other contents: one point fewer
        wheel.write_text("\n".join(wheel.read_text().splitlines()[:-1]) + "\n")
    elif change == "rail inclination":
        layout.write_text(text.replace("rail_inclination = 0.025", "rail_inclination = 0.02", 1))
    elif change == "gauge":
        layout.write_text(text.replace("track_gauge = 1.435", "track_gauge = 1.437", 1))
    else:
        layout.write_text(text.replace("rolling_radius = 0.46", "rolling_radius = 0.45", 1))
    assert layout.read_text() != text or change == "profile file"
    load_layout(layout)
    assert built == [1, 1]
    assert len(list((cache / "contact").glob("*.npz"))) == 2


def test_a_damaged_table_kept_is_built_again_and_replaced(cache, tmp_path, monkeypatch):
    layout, _wheel = worn_coach_copy(tmp_path)
    built = _builds(monkeypatch)
    load_layout(layout)
    (kept,) = (cache / "contact").glob("*.npz")
    kept.write_bytes(kept.read_bytes()[:1000])  # a copy cut short
    geometry._default_table.cache_clear()
    load_layout(layout)
    assert built == [1, 1]
    assert rail_mj.files.cached_arrays("contact", kept.stem) is not None


def test_an_unwritable_cache_is_no_error(tmp_path, monkeypatch):
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    monkeypatch.setattr(rail_mj.files, "cache_folder", lambda kind: blocked / kind)
    geometry._default_table.cache_clear()
    layout, _wheel = worn_coach_copy(tmp_path)
    try:
        assert load_layout(layout).profiles is not None
    finally:
        geometry._default_table.cache_clear()


def test_contact_refuses_a_profiled_layout_before_building_its_tables(cache, monkeypatch, capsys):
    built = _builds(monkeypatch)
    status = main(["contact", str(MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and "on [profiles] each contact point" in err[0]
    assert built == []
