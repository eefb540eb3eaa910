"""One range type for every `A:B:N[:log]`: its rule sets, its values and its one-line errors.

The messages are those the options gave before they shared `Span` (users' scripts match them);
the CLI's own tests (test_cli_robustness, test_conicity, test_stability, test_sweep) see them
through the commands.
"""

from __future__ import annotations

import numpy as np
import pytest

from rail_mj.practice import RANGES
from rail_mj.studies.span import AMPLITUDES, GRID, LOCUS, SEARCH, SPEEDS, SWEEP, Span, SpanError


def error(text: str, rules, option: str = "--speeds") -> str:
    with pytest.raises(SpanError) as e:
        Span.parse(text, rules, option)
    message = str(e.value)
    assert "\n" not in message
    return message


# --- reading --------------------------------------------------------------------------


def test_a_span_is_its_three_numbers_and_keeps_its_text():
    span = Span.parse("10:30:3", SPEEDS, "--speeds")
    assert (span.a, span.b, span.n, span.log) == (10.0, 30.0, 3, False)
    assert str(span) == "10:30:3"
    assert span == Span(10.0, 30.0, 3)  # the text is for messages only


@pytest.mark.parametrize("text", ["a:b:c", "1:2", "1:2:3:4", "5:10:2.5", "1:2:3:log", ""])
def test_what_is_not_a_b_n_names_the_option_the_form_and_the_unit(text):
    assert error(text, SPEEDS) == f"--speeds must be A:B:N (from A to B m/s in N steps), got {text!r}"


def test_amplitudes_name_their_unit():
    assert error("1:x:3", AMPLITUDES, "--amplitudes") == (
        "--amplitudes must be A:B:N (from A to B mm in N steps), got '1:x:3'"
    )


@pytest.mark.parametrize("text", ["1:2:3:lin", "1:2", "x", "1:2:3:log:log"])
def test_a_grid_may_end_in_log_and_in_nothing_else(text):
    assert error(text, GRID, "--grid k") == f"--grid k must be A:B:N or A:B:N:log, got {text!r}"


def test_a_log_grid_is_geometric():
    span = Span.parse("1e5:1e7:3:log", GRID, "--grid k")
    assert span.log and span.values() == [1e5, 1e6, 1e7]


# --- the rules of each set ---------------------------------------------------------------


@pytest.mark.parametrize("text", ["0:10:3", "10:5:3", "5:10:0", "5:10:200000", "nan:5:3", "5:inf:3", "-5:10:3"])
def test_speeds_are_positive_ordered_and_fewer_than_100000(text):
    assert error(text, SPEEDS) == f"--speeds A:B:N needs 0 < A <= B and 1 <= N <= 100000, got {text!r}"


def test_speeds_may_be_one_and_must_be_railway_speeds():
    assert Span.parse("30:30:1", SPEEDS, "--speeds").values() == [30.0]
    assert error("5:1000:3", SPEEDS) == f"--speeds: B {RANGES['speed'].check(1000.0)}"
    assert "320 m/s" in error("5:1000:3", SPEEDS)


@pytest.mark.parametrize("text", ["5:5:1", "5:5:3", "5:10:1"])
def test_a_root_locus_needs_two_speeds_at_least(text):
    assert error(text, LOCUS) == f"--speeds A:B:N needs A < B and N >= 2, got {text!r}"


def test_the_first_rule_broken_is_the_message():
    """10:5:1 breaks both of LOCUS's rules: the speeds' own comes first, as it did."""
    assert "needs 0 < A <= B" in error("10:5:1", LOCUS)
    assert "B must be between" in error("5:400:1", LOCUS)


@pytest.mark.parametrize("text", ["5:1:3", "0:1:3", "1:2:1", "nan:1:3", "1:2:20000"])
def test_amplitudes_are_positive_ordered_and_one_only_as_a_a_1(text):
    assert error(text, AMPLITUDES, "--amplitudes") == (
        f"--amplitudes A:B:N needs 0 < A <= B and 1 <= N <= 10000 (N = 1: A = B), got {text!r}"
    )
    assert Span.parse("3:3:1", AMPLITUDES, "--amplitudes").values() == [3.0]


@pytest.mark.parametrize("text", ["1:1:3", "1:2:0", "nan:1:2", "1:2:200000"])
def test_a_grid_is_finite_and_moves(text):
    assert error(text, GRID, "--grid k") == f"--grid k {text!r}: need finite A != B and 1 <= N <= 100000"


@pytest.mark.parametrize("text", ["0:1:3:log", "-1:2:3:log", "1:-2:3:log"])
def test_a_log_grid_is_positive(text):
    assert error(text, GRID, "--grid k") == f"--grid k {text!r}: a log range needs A > 0 and B > 0"
    assert Span.parse(text[: -len(":log")], GRID, "--grid k").values()  # the same, evenly, is fine


def test_a_grid_may_go_down_and_cross_zero():
    assert Span.parse("1:-1:3", GRID, "--grid k").values() == [1.0, 0.0, -1.0]


def test_speeds_from_the_python_api_read_as_numbers():
    assert Span.of(40.0, 80.0, 3, SWEEP, "speeds").check(GRID, "--speeds").values() == [40.0, 60.0, 80.0]
    with pytest.raises(SpanError, match=r"^speeds need 0 < A <= B and 1 <= N, got 80.0:40.0:3$"):
        Span.of(80.0, 40.0, 3, SWEEP, "speeds")
    with pytest.raises(SpanError, match=r"^a critical speed needs a speed range A < B with N >= 2 points, got 5:5:1$"):
        Span.of(5, 5, 1, SWEEP, "speeds").check(SEARCH, "speeds")


def test_span_error_is_a_value_error():
    assert issubclass(SpanError, ValueError)


# --- the values ----------------------------------------------------------------------------


@pytest.mark.parametrize("text", ["5:150:60", "1:9:7", "0.3:3.3:11", "0.05:0.3:6", "1:-1:5", "2:2:1"])
def test_grid_values_are_numpy_linspace_and_locus_values_the_ratio(text):
    """The two ways of spacing differ in the last bit for some spans (5:150:60 in 12 of its
    speeds): each option keeps the values it always had."""
    a, b, n = (float(x) for x in text.split(":"))
    n = int(n)
    assert Span.parse(text, GRID, "--grid k").values() == [float(v) for v in np.linspace(a, b, n)]
    if a < b:
        ratio = [a + (b - a) * k / (n - 1) for k in range(n)]
        assert Span.parse(text, LOCUS, "--speeds").values() == ratio
        assert Span.parse(text, AMPLITUDES, "--amplitudes").values() == ratio


def test_the_two_spacings_differ_where_the_options_said():
    span = Span.parse("5:150:60", SPEEDS, "--speeds")
    grid, locus = span.values(), Span.parse("5:150:60", LOCUS, "--speeds").values()
    assert grid == [float(v) for v in np.linspace(5, 150, 60)]
    assert sum(g != r for g, r in zip(grid, locus)) == 12
    assert grid[0] == locus[0] == 5.0 and grid[-1] == locus[-1] == 150.0


def test_log_values_are_numpy_geomspace():
    assert Span.parse("1e5:2e7:7:log", GRID, "--grid k").values() == [float(v) for v in np.geomspace(1e5, 2e7, 7)]
