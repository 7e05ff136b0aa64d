"""SPICE number parsing."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from circuitnsds.values import SCALE_FACTORS, is_value, parse_value


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("10", 10.0), ("4.7k", 4.7e3), ("10uF", 10e-6), ("1kHz", 1e3), ("2.2meg", 2.2e6),
        ("2.2MEGohm", 2.2e6), ("1e-3", 1e-3), ("1.5e3k", 1.5e6), ("5mil", 5 * 25.4e-6),
        ("3m", 3e-3), ("3ms", 3e-3), ("-2.5V", -2.5), (".5n", 0.5e-9), ("1p", 1e-12),
        ("1f", 1e-15), ("1F", 1e-15), ("2g", 2e9), ("1t", 1e12), ("+3", 3.0), ("100nH", 100e-9),
    ],
)
def test_known_values(text, expected):
    assert math.isclose(parse_value(text), expected, rel_tol=1e-12)


@pytest.mark.parametrize("text", ["abc", "", "k10", "1..2", "--1", "1e", "e5", "=", "("])
def test_rejects_non_numbers(text):
    if text == "1e":  # '1' followed by the unit letter 'e' is a number in SPICE
        assert parse_value(text) == 1.0
        return
    assert not is_value(text)
    with pytest.raises(ValueError):
        parse_value(text)


@given(
    mantissa=st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False),
    scale=st.sampled_from(sorted(SCALE_FACTORS)),
    unit=st.sampled_from(["", "V", "A", "Hz", "ohm", "s"]),
    upper=st.booleans(),
)
def test_round_trip_with_scale_and_unit(mantissa, scale, unit, upper):
    if unit and scale in {"m", "meg"} and unit.lower().startswith("e"):
        return
    suffix = (scale.upper() if upper else scale) + unit
    text = repr(mantissa) + suffix
    if mantissa != 0 and mantissa * SCALE_FACTORS[scale] == 0:  # underflows: said, never a silent 0
        with pytest.raises(ValueError, match="too small"):
            parse_value(text)
        return
    assert math.isclose(parse_value(text), mantissa * SCALE_FACTORS[scale], rel_tol=1e-12,
                        abs_tol=1e-300)
