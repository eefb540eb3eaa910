"""The worked studies of examples/ run, draw their figures, and README.md still quotes what they print.

Every Markdown table row a study prints is its own computation from the shipped models; README.md
copies those tables, so a change to the physics that moves one number fails here until the README
is brought up to date (by running the study again). The studies that take tens of seconds or
minutes are marked slow: CI runs them (`pytest -m slow`, .ci/run), a quick local run may leave
them out with `-m "not slow"`.
"""

from __future__ import annotations

import subprocess
import sys

import pytest
from conftest import ROOT

EXAMPLES = ROOT / "examples"
README = (ROOT / "README.md").read_text()

# (script, figures it draws, does it take --out); the slow ones below.
STUDIES = [
    ("design-strategies/design_strategies.py", ["design_strategies.png"], True),
    ("hunting/hunting_figure.py", ["hunting_bogie.png"], True),
    ("hunting/flange_strikes.py", [], False),
    ("train-snaking/snaking_figure.py", ["snaking_articulated.png"], True),
    ("stability-curving/tradeoff.py", ["tradeoff.png"], True),
    pytest.param("design-strategies/design_maps.py", ["map_coach.png", "map_wagon.png"], True, marks=pytest.mark.slow),
    pytest.param("ride-comfort/ride_comfort.py", ["ride_comfort.png"], True, marks=pytest.mark.slow),
    pytest.param("wheel-wear/conicity_figure.py", ["conicity_wear.png"], True, marks=pytest.mark.slow),
    pytest.param("wheel-wear/conicity_stability.py", ["critical_speed_conicity.png"], True, marks=pytest.mark.slow),
    pytest.param(
        "nonlinear-critical-speed/nonlinear_examples.py",
        ["bifurcation_bogie.png", "bifurcation_manchester-coach.png"],
        True,
        marks=pytest.mark.slow,
    ),
]


@pytest.mark.parametrize(("script", "figures", "takes_out"), STUDIES)
def test_a_study_runs_and_the_readme_quotes_its_tables(script, figures, takes_out, tmp_path):
    command = [sys.executable, str(EXAMPLES / script)] + (["--out", str(tmp_path)] if takes_out else [])
    result = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=900, check=False)
    assert result.returncode == 0, result.stderr[-3000:]
    for figure in figures:
        assert (tmp_path / figure).stat().st_size > 10_000, figure
    rows = [line for line in result.stdout.splitlines() if line.startswith("|") and "---" not in line]
    stale = [row for row in rows if row not in README]
    assert not stale, "README.md no longer quotes these rows the study prints:\n" + "\n".join(stale)


def test_every_study_is_listed_with_a_readme():
    scripts = {p.relative_to(EXAMPLES).as_posix() for p in EXAMPLES.glob("*/*.py")}
    listed = {(s.values[0] if hasattr(s, "values") else s[0]) for s in STUDIES}
    assert scripts == listed
    index = (EXAMPLES / "README.md").read_text()
    for folder in {p.parent for p in EXAMPLES.glob("*/*.py")}:
        assert (folder / "README.md").is_file(), folder
        assert f"]({folder.name}/)" in index, folder.name
