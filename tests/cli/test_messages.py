"""Small messages that must be right: a misspelt key named, a round-off centre printed as 0, a
viewer command that works from where the user stands."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from conftest import MODELS

from rail_mj.cli import main
from rail_mj.cli.run import _rerun
from rail_mj.layout import LayoutError, load_layout


def test_a_misspelt_required_key_is_named_beside_the_missing_one(tmp_path):
    text = (MODELS / "wagon" / "wagon.toml").read_text().replace("rolling_radius", "roling_radius")
    path = tmp_path / "typo.toml"
    path.write_text(text)
    with pytest.raises(LayoutError) as e:
        load_layout(path)
    message = str(e.value)
    assert "wheelset.rolling_radius: missing (required)" in message and "'roling_radius'" in message
    # A key that only looks a little alike is not offered.
    path.write_text(text.replace("roling_radius", "radius_of_the_wheel"))
    with pytest.raises(LayoutError) as e:
        load_layout(path)
    assert str(e.value).endswith("missing (required)")


def test_a_centre_at_round_off_is_printed_as_zero(capsys):
    layout = MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml"
    assert main(["conicity", str(layout), "--amplitudes", "2:4:2"]) == 0
    out = capsys.readouterr().out
    assert "centre y = 0 mm" in out and "e-" not in out.split(";")[1].split("\n")[0]


def test_the_viewer_hint_names_the_rerun_beside_this_python(monkeypatch):
    beside = Path(sys.executable).parent / "rerun"
    assert beside.exists()  # rerun-sdk installs its viewer's launcher there
    monkeypatch.setenv("PATH", "/usr/bin:/bin")  # an environment not activated
    assert Path(_rerun()).resolve() == beside.resolve()
    monkeypatch.setenv("PATH", f"{beside.parent}{os.pathsep}/usr/bin")
    assert _rerun() == "rerun"
