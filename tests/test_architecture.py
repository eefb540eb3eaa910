"""The package's shape: folders by the data flow, no cycles, a light top level, old paths only as shims.

README.md ("How the code is laid out") draws the tree; these tests hold the code to it.
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

import rail_mj
from rail_mj import _compat

PYTHON = sys.executable
# Folders in the order data flows through them; the leaves are below all of them.
FLOW = ("contact", "track", "layout", "vehicle", "simulation", "analysis", "output", "studies", "cli")
LEAVES = ("units", "numerics", "files", "compiled", "practice", "_lazy", "_compat", "__main__")


def test_import_contracts_hold():
    """import-linter's contracts in pyproject.toml: layers by the flow, no cycle between
    siblings, contact, track, layout and the table of practice free of MuJoCo. A lazy import counts as an import."""
    linter = Path(PYTHON).with_name("lint-imports")
    result = subprocess.run([str(linter)], cwd=ROOT, capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    assert "0 broken" in result.stdout


def test_the_package_has_the_folders_of_the_flow_and_nothing_else():
    """A module of the package is in one of the flow's folders or is one of the named leaves:
    a newcomer finds every file from the README's tree."""
    package = ROOT / "rail_mj"
    folders = {p.name for p in package.iterdir() if p.is_dir() and p.name != "__pycache__"}
    modules = {p.stem for p in package.glob("*.py")} - {"__init__"}
    assert folders == set(FLOW)
    assert modules == set(LEAVES)


def test_the_readme_tree_names_every_folder():
    """One line a folder in README.md's tree, in the order of the flow."""
    readme = (ROOT / "README.md").read_text()
    lines = [re.search(rf"^\s*[├└│─ ]*({name})/", readme, re.M) for name in FLOW]
    assert all(lines), [name for name, line in zip(FLOW, lines) if not line]
    starts = [line.start() for line in lines]
    assert starts == sorted(starts)


def _old_paths() -> set[str]:
    return {f"rail_mj.{old}" for old in (*_compat.MOVED, *_compat.SPLIT)}


def _imports(source: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(source.read_text(), str(source))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def test_nothing_in_the_repository_uses_an_old_module_path():
    """The old flat paths are for users' code; the repository itself uses the new homes
    (except the test that the shims work, tests/test_compat.py)."""
    old = _old_paths()
    sources = [
        *ROOT.glob("rail_mj/**/*.py"),
        *ROOT.glob("tests/**/*.py"),
        *ROOT.glob("tools/*.py"),
        *ROOT.glob("examples/**/*.py"),
        *ROOT.glob("benchmarks/*.py"),
    ]
    users = {
        str(source.relative_to(ROOT)): sorted(_imports(source) & old)
        for source in sources
        if source.name != "test_compat.py"
    }
    assert {k: v for k, v in users.items() if v} == {}


def test_import_rail_mj_is_light():
    """`import rail_mj` loads neither MuJoCo nor the plotting and recording libraries: the
    public names are imported on first use."""
    heavy = "('mujoco', 'rerun', 'matplotlib', 'numba', 'trimesh', 'scipy')"
    code = f"import sys, rail_mj; print(' '.join(m for m in {heavy} if m in sys.modules))"
    result = subprocess.run([PYTHON, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert result.stdout.strip() == ""


def test_dir_lists_the_public_names_and_each_resolves():
    names = dir(rail_mj)
    assert "__version__" in names
    assert not [n for n in names if n in {"Path", "hashlib", "importlib", "os"}]
    public = [n for n in names if not n.startswith("_")]
    assert {"load_layout", "Vehicle", "simulate", "Stability", "summary", "sweep", "write_recording"} <= set(public)
    for name in public:
        assert getattr(rail_mj, name) is not None, name


@pytest.mark.parametrize("module", ["rail_mj", "rail_mj.cli"])
def test_python_m_runs_the_command(module):
    result = subprocess.run([PYTHON, "-m", module, "--help"], cwd=ROOT, capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stderr
    assert "Usage:" in result.stdout and "run" in result.stdout


def test_the_version_has_one_source():
    """pyproject.toml reads the version from rail_mj.__version__; the CHANGELOG's newest
    release is that version."""
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert re.search(r'^dynamic = \["version"\]', pyproject, re.M)
    assert 'version = { attr = "rail_mj.__version__" }' in pyproject
    changelog = (ROOT / "CHANGELOG.md").read_text()
    newest = re.search(r"^## \[?(\d+\.\d+\.\d+)", changelog, re.M)
    assert newest and newest.group(1) == rail_mj.__version__


@pytest.mark.parametrize("folder", FLOW)
def test_each_folder_says_what_its_modules_do(folder):
    """A folder's __init__ docstring has a line for each of its modules: the map one level
    below the README's tree."""
    package = ROOT / "rail_mj" / folder
    doc = ast.get_docstring(ast.parse((package / "__init__.py").read_text())) or ""
    named = set(re.findall(r"^\s*(\w+)\.py\b", doc, re.M))
    modules = {p.stem for p in package.glob("*.py")} - {"__init__", "__main__"}
    assert modules <= named, sorted(modules - named)
