"""The README's Python section is a notebook session that runs: every line of it, its
outputs compared by doctest, from a folder that holds the repository's models."""

from __future__ import annotations

import doctest
import re

from conftest import MODELS

README = MODELS.parent / "README.md"


def test_the_readme_python_session_runs_as_written(tmp_path, monkeypatch):
    text = README.read_text()
    section = text[text.index("## Python API") :]
    session = re.search(r"```python\n(.*?)```", section, re.S)
    assert session is not None and ">>> import rail_mj" in session.group(1)
    (tmp_path / "models").symlink_to(MODELS)
    monkeypatch.chdir(tmp_path)
    parser = doctest.DocTestParser()
    test = parser.get_doctest(session.group(1), {}, "README.md: Python API", str(README), 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.attempted >= 10 and result.failed == 0, result
    assert (tmp_path / "bogie.rrd").stat().st_size > 0
    assert (tmp_path / "out" / "bogie" / "scene.xml").is_file()


def test_the_package_lists_its_public_names_and_version():
    import rail_mj

    names = dir(rail_mj)
    for name in ("load_layout", "simulate", "sweep", "summary", "Run", "write_recording", "__version__"):
        assert name in names
    assert all(hasattr(rail_mj, name) for name in rail_mj.__all__)
    assert re.fullmatch(r"\d+\.\d+\.\d+", rail_mj.__version__)
