"""One range type for every `A:B:N[:log]` a user writes: N values from A to B.

A `Span` is read from its text (`Span.parse`) or made from numbers (`Span.of`, the Python
API) and checked against a rule set, which says what that kind of span may be:

SPEEDS      `sweep --speeds`, `map --speeds`: 0 < A <= B, B within railway speeds
LOCUS       `root-locus --speeds`: as SPEEDS, and at least two speeds, A < B
AMPLITUDES  `conicity --amplitudes`: 0 < A <= B mm, one amplitude only as A:A:1
GRID        `sweep --grid`, `map --x/--y`: any finite A != B, or A:B:N:log for A, B > 0
SWEEP       the speeds given to `rail_mj.studies.sweep.sweep` through the Python API
SEARCH      the range a critical speed is searched over: A < B with N >= 2 scan points
FREQUENCIES `response --frequencies`: 0.001 <= A < B <= 1000 Hz, N >= 2, geometric (`:log`) or even

The first rule a span breaks is its one-line error (`SpanError`), naming the option.
The messages are those each option gave before they shared this type: tests and users'
scripts match them.

Example:

    >>> Span.parse("10:30:3", SPEEDS, "--speeds").values()
    [10.0, 20.0, 30.0]
    >>> Span.parse("1e5:1e7:3:log", GRID, "--grid primary.yaw_stiffness").values()
    [100000.0, 1000000.0, 10000000.0]
    >>> Span.parse("30:10:3", SPEEDS, "--speeds")
    Traceback (most recent call last):
    ...
    rail_mj.studies.span.SpanError: --speeds A:B:N needs 0 < A <= B and 1 <= N <= 100000, got '30:10:3'
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

from rail_mj.practice import RANGES


class SpanError(ValueError):
    """A span that is not `A:B:N[:log]`, or breaks its rules; one line."""


@dataclasses.dataclass(frozen=True)
class Span:
    """N values from A to B, evenly or (`log`) geometrically spaced."""

    a: float
    b: float
    n: int
    log: bool = False
    # How the values between A and B are placed. The two ways differ in the last bit for
    # some A, B, N (5:150:60 in 12 of its speeds), and the outputs print the values in full:
    # each option keeps the one it had. "linspace": numpy.linspace (A + k * ((B - A) / (N - 1)),
    # B itself last), as sweeps and grids; "ratio": A + (B - A) * k / (N - 1), as root loci and
    # conicity amplitudes.
    spacing: str = "linspace"
    text: str = dataclasses.field(default="", compare=False)  # as written, for messages

    @classmethod
    def parse(cls, text: str, rules: Rules, option: str) -> Span:
        """`text` read as `A:B:N` (or `A:B:N:log` where the rules allow it), then checked."""
        parts = text.split(":")
        log = rules.log and len(parts) == 4 and parts[3] == "log"
        try:
            if len(parts) != (4 if log else 3):
                raise ValueError
            a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise SpanError(rules.syntax.format(option=option, text=text, unit=rules.unit)) from None
        return cls(a, b, n, log, text=text).check(rules, option)

    @classmethod
    def of(cls, a: float, b: float, n: int, rules: Rules, option: str) -> Span:
        """A span of numbers (the Python API), checked; its text is `A:B:N`."""
        return cls(a, b, n, text=f"{a}:{b}:{n}").check(rules, option)

    def check(self, rules: Rules, option: str) -> Span:
        """This span if it keeps `rules` (spaced as they say), else the first rule's error."""
        for rule in rules.rules:
            error = rule.error(self, option, rules.unit)
            if error is not None:
                raise SpanError(error)
        return dataclasses.replace(self, spacing=rules.spacing)

    def values(self) -> list[float]:
        if self.n == 1:
            return [float(self.a)]
        if self.spacing == "ratio":
            return [self.a + (self.b - self.a) * k / (self.n - 1) for k in range(self.n)]
        import numpy as np

        values = np.geomspace(self.a, self.b, self.n) if self.log else np.linspace(self.a, self.b, self.n)
        return [float(v) for v in values]

    def __str__(self) -> str:
        return self.text


@dataclasses.dataclass(frozen=True)
class Rule:
    """A condition on a span and the error when it fails: a format string of `option`, `text`
    (the span as written) and `unit`."""

    holds: Callable[[Span], bool]
    message: str

    def error(self, span: Span, option: str, unit: str) -> str | None:
        return None if self.holds(span) else self.message.format(option=option, text=span.text, unit=unit)


@dataclasses.dataclass(frozen=True)
class Within:
    """B within the refusal interval of a range of practice (rail_mj.layout.practice)."""

    key: str

    def error(self, span: Span, option: str, unit: str) -> str | None:
        error = RANGES[self.key].check(span.b)
        return None if error is None else f"{option}: B {error}"


@dataclasses.dataclass(frozen=True)
class Rules:
    """What a kind of span may be: its unit, the message for text that is no span, its rules
    in order, whether `:log` is allowed, and how its values are spaced (Span.spacing)."""

    unit: str
    syntax: str
    rules: tuple[Rule | Within, ...]
    log: bool = False
    spacing: str = "linspace"

    def but(self, *rules: Rule | Within, spacing: str | None = None) -> Rules:
        """These rules, then more."""
        return dataclasses.replace(self, rules=self.rules + rules, spacing=spacing or self.spacing)


def _finite(s: Span) -> bool:
    return math.isfinite(s.a) and math.isfinite(s.b)


MAX_POINTS = 100_000  # values in a span: far more than any study runs, far fewer than fill the memory
MAX_AMPLITUDES = 10_000  # each an integration of the Klingel motion

_OPTION = "{option} must be A:B:N (from A to B {unit} in N steps), got {text!r}"
_POSITIVE = Rule(
    lambda s: _finite(s) and 0 < s.a <= s.b and 1 <= s.n <= MAX_POINTS,
    "{option} A:B:N needs 0 < A <= B and 1 <= N <= 100000, got {text!r}",
)

SPEEDS = Rules("m/s", _OPTION, (_POSITIVE, Within("speed")))
LOCUS = SPEEDS.but(
    Rule(lambda s: s.a < s.b and s.n >= 2, "{option} A:B:N needs A < B and N >= 2, got {text!r}"), spacing="ratio"
)
AMPLITUDES = Rules(
    "mm",
    _OPTION,
    (
        Rule(
            lambda s: _finite(s) and 0 < s.a <= s.b and 1 <= s.n <= MAX_AMPLITUDES and (s.n > 1 or s.a == s.b),
            "{option} A:B:N needs 0 < A <= B and 1 <= N <= 10000 (N = 1: A = B), got {text!r}",
        ),
    ),
    spacing="ratio",
)
GRID = Rules(
    "",
    "{option} must be A:B:N or A:B:N:log, got {text!r}",
    (
        Rule(
            lambda s: _finite(s) and 1 <= s.n <= MAX_POINTS and not (s.n > 1 and s.a == s.b),
            "{option} {text!r}: need finite A != B and 1 <= N <= 100000",
        ),
        Rule(lambda s: not s.log or (s.a > 0 and s.b > 0), "{option} {text!r}: a log range needs A > 0 and B > 0"),
    ),
    log=True,
)
SWEEP = Rules(
    "m/s",
    _OPTION,
    (
        Rule(
            lambda s: _finite(s) and 0 < s.a <= s.b and 1 <= s.n <= MAX_POINTS,
            "{option} need 0 < A <= B and 1 <= N, got {text}",
        ),
    ),
)
SEARCH = Rules(
    "m/s",
    _OPTION,
    (
        Rule(
            lambda s: s.a < s.b and s.n >= 2,
            "a critical speed needs a speed range A < B with N >= 2 points, got {text}",
        ),
    ),
)
FREQUENCIES = Rules(
    "Hz",
    "{option} must be A:B:N or A:B:N:log (from A to B Hz in N steps), got {text!r}",
    (
        Rule(
            lambda s: _finite(s) and 1e-3 <= s.a < s.b <= 1e3 and 2 <= s.n <= MAX_POINTS,
            "{option} A:B:N needs 0.001 <= A < B <= 1000 Hz and 2 <= N <= 100000, got {text!r}",
        ),
    ),
    log=True,
)
