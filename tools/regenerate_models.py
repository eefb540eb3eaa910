"""Regenerate the shipped models: models/<name>/<name>.toml -> <name>.xml, scene.xml, assets/.

    python tools/regenerate_models.py          # rewrite models/
    python tools/regenerate_models.py --check  # exit 1 if models/ is out of date

tests/vehicle/test_models.py runs the same comparison, so a stale models/ fails CI.

Profile files in assets/ (.csv, .prw, .prr: a layout's [profiles] wheel or rail, such as
models/manchester-coach-worn/assets/s1002_worn.csv from tools/worn_profile.py) are inputs, not
generated: they are kept, and not reported as out of date.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rail_mj.layout import load_layout
from rail_mj.vehicle.mjcf import generate, generated_files

MODELS = Path(__file__).resolve().parent.parent / "models"
PROFILE_SUFFIXES = (".csv", ".prw", ".prr")  # profile files: inputs a layout reads, kept


def is_input(path: Path) -> bool:
    """A file in assets/ that generation does not write: a profile the layout may read."""
    return path.suffix.lower() in PROFILE_SUFFIXES


def shipped_layouts() -> list[Path]:
    """Every models/<name>/<name>.toml."""
    return sorted(p for p in MODELS.glob("*/*.toml") if p.stem == p.parent.name)


def stale_files(layout_path: Path) -> list[str]:
    """Files under the layout's folder that differ from what generation would write now."""
    layout = load_layout(layout_path)
    folder = layout_path.parent
    expected = generated_files(layout)
    stale = [
        rel for rel, data in expected.items() if not (folder / rel).is_file() or (folder / rel).read_bytes() != data
    ]
    assets = folder / "assets"
    if assets.is_dir():
        stale += [
            f"assets/{p.name} (not generated)"
            for p in sorted(assets.iterdir())
            if f"assets/{p.name}" not in expected and not is_input(p)
        ]
    return stale


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only report, exit 1 if out of date")
    args = parser.parse_args()
    out_of_date = False
    for path in shipped_layouts():
        stale = stale_files(path)
        if args.check:
            for rel in stale:
                print(f"{path.parent.name}/{rel} is out of date")
            out_of_date |= bool(stale)
        else:
            assets = path.parent / "assets"
            for old in assets.glob("*") if assets.is_dir() else []:
                if not is_input(old):
                    old.unlink()  # a changed radius or conicity renames the mesh
            for written in generate(load_layout(path), path.parent):
                print(written.relative_to(MODELS.parent))
    return 1 if out_of_date else 0


if __name__ == "__main__":
    sys.exit(main())
