"""Track files, read and checked into a `Track`: sections in TOML, or design geometry in CSV.

TOML, SI units: `[[section]]` tables in order, each with `kind` and `length` (m).

    [[section]]
    kind = "straight"          # "straight", "transition" or "curve"
    length = 200.0             # m
    [[section]]
    kind = "transition"        # curvature and cant linear in distance (a clothoid)
    length = 100.0
    [[section]]
    kind = "curve"
    length = 300.0
    radius = 600.0             # m; positive turns left, negative right
    cant = 0.15                # m, outer rail over inner over 1.5 m (optional, default 0)

A transition runs from the curvature and cant of the section before it to those of the section
after it; a track that starts or ends with one runs it from or to a level straight. A curve's
`cant` raises its outer rail: the Track's cant is signed as the curvature (rail_mj.track.geometry).

CSV: a header naming the columns `x_m, curvature_1_per_m, cant_m` (any order), then one row per
point, x strictly increasing from 0, curvature and cant signed as the Track's (cant_m positive
raises the right rail, the outer rail of a left curve). Between rows both are linear; each
stretch between two rows is a section (straight or curve where nothing changes, rows of the same
curvature and cant joined into one; transition where something does). Lines starting with '#'
are comments.

Every problem raises `TrackError`, one line naming the file and the section (or CSV line) and
what is wrong; legal values far from practice and steps with no transition between sections are
warned about in `Track.warnings` (rail_mj.practice holds the ranges and their sources).

Example:

    >>> track = load_track("models/tracks/curve-600.toml")
    >>> track.length, track.curves[0].radius, track.curves[0].cant
    (900.0, 600.0, 0.15)
    >>> float(track.curvature(250.0)) * 600.0  # halfway along the first transition
    0.5
    >>> try:
    ...     track_from_dict({"section": [{"kind": "curve", "length": 100.0}]}, "track.toml")
    ... except TrackError as e:
    ...     print(e)
    track.toml: section 1 (curve): radius missing: a curve needs its radius (m; positive turns left, negative right)
"""

from __future__ import annotations

import csv
import math
import tomllib
from pathlib import Path
from typing import Any

from rail_mj.files import read_input
from rail_mj.practice import CANT_STEP, CURVATURE_STEP, RANGES
from rail_mj.track.geometry import KINDS, Section, Track, TrackError
from rail_mj.track.irregularities import irregularities_from_dict

# Longer than any railway line (the Trans-Siberian is 9289 km), and than any run; a length past
# it is a unit or a typing mistake.
MAX_LENGTH = 1e7  # m
CSV_COLUMNS = ("x_m", "curvature_1_per_m", "cant_m")
# The keys each kind of section takes; what is not here is a typo or belongs to another kind.
KEYS = {"straight": ("kind", "length"), "transition": ("kind", "length"), "curve": ("kind", "length", "radius", "cant")}
NOT_HERE = {
    "straight": "a straight is level and has no radius (only a curve has radius and cant)",
    "transition": "a transition takes its curvature and cant from the sections either side",
}


def load_track(path: str | Path) -> Track:
    """Read and check a track file: TOML sections (.toml) or CSV design geometry (.csv)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".csv"):
        raise TrackError(
            f"{path}: a track file is .toml (sections) or .csv ({', '.join(CSV_COLUMNS)}), got {suffix or 'no suffix'}"
        )
    try:
        text = read_input(path).decode("utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise TrackError(f"{path}: cannot read: {getattr(e, 'strerror', None) or e}") from None
    if suffix == ".csv":
        return track_from_csv(text, source=str(path))
    try:
        data = tomllib.loads(text)
    except ValueError as e:  # TOMLDecodeError, and integers too long to convert
        raise TrackError(f"{path}: not valid TOML: {e}") from None
    except RecursionError:  # arrays or tables nested hundreds deep: no track is
        raise TrackError(f"{path}: not a track: its arrays or tables are nested too deeply to read") from None
    return track_from_dict(data, source=str(path))


# --- TOML ----------------------------------------------------------------------------------------


def track_from_dict(data: Any, source: str = "<track>") -> Track:
    """A track from TOML already parsed: {"section": [{"kind": ..., "length": ...}, ...]}."""
    if not isinstance(data, dict):
        raise TrackError(f"{source}: must be a table of [[section]] tables, got {_kind(data)}")
    for key in data:
        if key not in ("section", "irregularities"):
            raise TrackError(f"{source}: {key}: unknown key (a track file is [[section]] tables, in order)")
    if "section" not in data:
        raise TrackError(f"{source}: section: missing: a track is [[section]] tables, in order, at least one")
    tables = data["section"]
    if isinstance(tables, dict):
        raise TrackError(
            f"{source}: section: is one [section] table: give each as an array entry, [[section]], in order"
        )
    if not isinstance(tables, list):
        raise TrackError(f"{source}: section: must be [[section]] tables, got {_kind(tables)}")
    if not tables:
        raise TrackError(f"{source}: section: empty: a track needs at least one [[section]]")

    warnings: list[str] = []
    # Each section's kind, length and, for straights and curves, its constant curvature and cant.
    raw: list[tuple[str, float, tuple[float, float] | None, float | None]] = []
    for k, table in enumerate(tables, start=1):
        raw.append(_section(source, k, table, warnings))

    level = (0.0, 0.0)  # a straight's curvature and cant: what a track starts from and ends with
    sections: list[Section] = []
    start = 0.0
    for k, (kind, length, constant, radius) in enumerate(raw, start=1):
        if constant is not None:
            begin = end = constant
        else:
            before = raw[k - 2][2] if k > 1 else level
            if before is None:
                raise TrackError(
                    f"{source}: section {k} (transition): follows a transition: a transition runs between "
                    f"two sections of constant curvature and cant (straights or curves)"
                )
            after = raw[k][2] if k < len(raw) else level
            begin, end = before, after or level  # a transition after it is refused on the next turn
        sections.append(Section(k, kind, start, length, begin[0], end[0], begin[1], end[1], radius))
        start = sections[-1].end
    if start > MAX_LENGTH:
        raise TrackError(f"{source}: the track is {start:g} m long, more than {MAX_LENGTH:g} m: check the units (m)")
    warnings += _steps(source, sections)
    irregular = None
    if "irregularities" in data:
        base = Path(source).parent

        def read(name: str) -> str:
            try:
                return read_input(base / name).decode("utf-8")
            except (OSError, UnicodeDecodeError) as e:
                why = getattr(e, "strerror", None) or e
                raise TrackError(f"{source}: irregularities.file: {name}: cannot read: {why}") from None

        irregular = irregularities_from_dict(data["irregularities"], source, read)
    return Track(tuple(sections), source, tuple(warnings), irregular)


def _section(
    source: str, k: int, table: Any, warnings: list[str]
) -> tuple[str, float, tuple[float, float] | None, float | None]:
    """One [[section]], checked: its kind, length and (straights and curves) its constant
    curvature and signed cant, and a curve's radius."""
    if not isinstance(table, dict):
        raise TrackError(f"{source}: section {k}: must be a table, got {_kind(table)}")
    kind = table.get("kind")
    if kind is None:
        raise TrackError(f"{source}: section {k}: kind missing: one of {', '.join(map(repr, KINDS))}")
    if not isinstance(kind, str) or kind not in KINDS:
        raise TrackError(f"{source}: section {k}: kind: must be one of {', '.join(map(repr, KINDS))}, got {kind!r}")
    where = f"{source}: section {k} ({kind})"
    for key in table:
        if key not in KEYS[kind]:
            if key in KEYS["curve"]:
                raise TrackError(f"{where}: {key}: not used: {NOT_HERE[kind]}")
            raise TrackError(f"{where}: {key}: unknown key (a {kind} has {', '.join(KEYS[kind])})")
    if "length" not in table:
        raise TrackError(f"{where}: length missing: every section has its length (m)")
    length = _number(where, "length", table["length"])
    if length <= 0.0:
        raise TrackError(f"{where}: length: must be > 0 m, got {length:g}")
    if kind == "transition":
        return kind, length, None, None
    if kind == "straight":
        return kind, length, (0.0, 0.0), None
    if "radius" not in table:
        raise TrackError(f"{where}: radius missing: a curve needs its radius (m; positive turns left, negative right)")
    radius = _number(where, "radius", table["radius"])
    label = "radius" if radius >= 0 else "radius (its size; negative turns right)"
    _practice(where, label, "track.radius", abs(radius), warnings)
    cant = _number(where, "cant", table.get("cant", 0.0))
    _practice(where, "cant", "track.cant", cant, warnings)
    side = 1.0 if radius > 0 else -1.0  # the outer rail: the right one in a left curve
    return kind, length, (1.0 / radius, side * cant + 0.0), radius  # + 0.0: no -0.0 for a level curve


def _number(where: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TrackError(f"{where}: {key}: must be a number, got {_kind(value)}")
    try:
        number = float(value)
    except OverflowError:  # a TOML integer beyond float range
        number = math.inf
    if not math.isfinite(number):
        raise TrackError(f"{where}: {key}: must be finite, got {number:g}")
    return number


def _practice(where: str, label: str, key: str, value: float, warnings: list[str]) -> None:
    """Refuse a value that no track has (rail_mj.practice.RANGES[key]); note one far from practice."""
    limits = RANGES[key]
    error = limits.check(value)
    if error:
        raise TrackError(f"{where}: {label}: {error}")
    note = limits.warning(value)
    if note:
        warnings.append(f"{where}: {label}: {note}")


def _steps(source: str, sections: list[Section]) -> list[str]:
    """A warning for each change of curvature or cant between two sections with no transition
    between them, beyond rounding (rail_mj.practice.CURVATURE_STEP, CANT_STEP)."""
    notes = []
    for a, b in zip(sections, sections[1:]):
        steps = []
        dk, dd = b.curvature_start - a.curvature_end, b.cant_start - a.cant_end
        if abs(dk) > CURVATURE_STEP:
            steps.append(
                f"curvature steps by {dk:.6g} 1/m (the lateral acceleration by V^2 times it, "
                f"{abs(dk) * (100.0 / 3.6) ** 2:.3g} m/s^2 at 100 km/h)"
            )
        if abs(dd) > CANT_STEP:
            steps.append(f"cant steps by {dd * 1e3:.4g} mm (the track twists in no length)")
        if steps:
            notes.append(
                f"{source}: {a.label} to {b.label}: {' and '.join(steps)} with no transition between: "
                f"the vehicle is kicked; EN 13803 runs curvature and cant up along a transition"
            )
    return notes


# --- CSV -----------------------------------------------------------------------------------------


def track_from_csv(text: str, source: str = "<track>") -> Track:
    """A track from the text of a CSV of design geometry: x_m, curvature_1_per_m, cant_m."""
    lines = [
        (n, line)
        for n, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not lines:
        raise TrackError(f"{source}: empty: a track CSV has a header ({', '.join(CSV_COLUMNS)}) and rows")
    (header_line, header_text), body = lines[0], lines[1:]
    header = [name.strip() for name in next(csv.reader([header_text]))]
    for name in header:
        if name not in CSV_COLUMNS:
            raise TrackError(
                f"{source}: line {header_line}: unknown column {name!r}: a track CSV has the columns "
                f"{', '.join(CSV_COLUMNS)}"
            )
        if header.count(name) > 1:
            raise TrackError(f"{source}: line {header_line}: column {name} given twice")
    for name in CSV_COLUMNS:
        if name not in header:
            raise TrackError(
                f"{source}: line {header_line}: column {name} missing: a track CSV has the columns "
                f"{', '.join(CSV_COLUMNS)} (is the first line the header?)"
            )
    rows: list[tuple[int, float, float, float]] = []
    for n, line in body:
        values = next(csv.reader([line]))
        if len(values) != len(header):
            raise TrackError(f"{source}: line {n}: {len(values)} values for the {len(header)} columns of the header")
        row = dict(zip(header, (v.strip() for v in values)))
        numbers = []
        for name in CSV_COLUMNS:
            try:
                number = float(row[name])
            except ValueError:
                raise TrackError(f"{source}: line {n}: {name}: not a number: {row[name]!r}") from None
            if not math.isfinite(number):
                raise TrackError(f"{source}: line {n}: {name}: must be finite, got {row[name]!r}")
            numbers.append(number)
        x, curvature, cant = numbers
        if not rows and x != 0.0:
            raise TrackError(f"{source}: line {n}: x_m must start at 0 (the track's start), got {x:g}")
        if rows and not x > rows[-1][1]:
            raise TrackError(f"{source}: line {n}: x_m must increase from row to row: {x:g} after {rows[-1][1]:g}")
        if x > MAX_LENGTH:
            raise TrackError(f"{source}: line {n}: x_m: {x:g} m is more than {MAX_LENGTH:g} m: check the units (m)")
        rows.append((n, x, curvature, cant))
    if len(rows) < 2:
        raise TrackError(
            f"{source}: {len(rows)} row{'s' if len(rows) != 1 else ''}: a track CSV needs two or more, "
            f"x_m from 0 to its end"
        )
    warnings = _csv_practice(source, rows)

    sections: list[Section] = []
    for (_, x0, k0, d0), (_, x1, k1, d1) in zip(rows, rows[1:]):
        constant = k0 == k1 and d0 == d1
        last = sections[-1] if sections else None
        if (
            constant
            and last is not None
            and last.kind != "transition"
            and (last.curvature_end, last.cant_end) == (k0, d0)
        ):
            sections[-1] = Section(last.number, last.kind, last.start, x1 - last.start, k0, k0, d0, d0, last.radius)
            continue
        if constant:
            kind, radius = ("straight", None) if k0 == 0.0 else ("curve", 1.0 / k0)
        else:
            kind, radius = "transition", None
        sections.append(Section(len(sections) + 1, kind, x0, x1 - x0, k0, k1, d0, d1, radius))
    return Track(tuple(sections), source, tuple(warnings))


def _csv_practice(source: str, rows: list[tuple[int, float, float, float]]) -> list[str]:
    """Refuse a row no track has; warn (once each) about the tightest radius and the steepest
    or adverse cant outside practice."""
    warnings: list[str] = []
    for n, _, curvature, cant in rows:
        where = f"{source}: line {n}"
        if curvature != 0.0:
            error = RANGES["track.radius"].check(1.0 / abs(curvature))
            if error:
                raise TrackError(
                    f"{where}: curvature_1_per_m {curvature:g} is a radius of {1 / abs(curvature):g} m: {error}"
                )
        error = RANGES["track.cant"].check(cant)
        if error:
            raise TrackError(f"{where}: cant_m: {error}")
    n, _, curvature, _ = max(rows, key=lambda row: abs(row[2]))
    note = RANGES["track.radius"].warning(1.0 / abs(curvature)) if curvature else None
    if note:
        warnings.append(f"{source}: line {n}: curvature_1_per_m {curvature:g}, a radius of {note}")
    n, _, _, cant = max(rows, key=lambda row: abs(row[3]))
    note = RANGES["track.cant"].warning(abs(cant))
    if note:
        warnings.append(f"{source}: line {n}: cant_m: {note}")
    adverse = [(n, k, d) for n, _, k, d in rows if k * d < 0.0]
    if adverse:
        n, curvature, cant = max(adverse, key=lambda row: abs(row[2]))
        warnings.append(
            f"{source}: line {n}: cant_m {cant:g} raises the inner rail of a curve of curvature {curvature:g} 1/m "
            f"(negative cant, found only on turnouts off canted curves): cant_m is signed as curvature_1_per_m, "
            f"positive raising the right rail, the outer rail of a left curve"
        )
    return warnings


def _kind(value: Any) -> str:
    return {dict: "a table", list: "a list", str: "a string", bool: "a boolean"}.get(type(value), repr(value))
