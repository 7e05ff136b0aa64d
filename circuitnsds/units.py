"""Numbers for people: engineering notation with SI prefixes (``12.5 mA``, ``20 µs``)."""

from __future__ import annotations

import math

PREFIXES = {-15: "f", -12: "p", -9: "n", -6: "µ", -3: "m", 0: "", 3: "k", 6: "M", 9: "G", 12: "T"}


def engineering_scale(value: float) -> tuple[float, str]:
    """``(factor, prefix)`` such that ``value * factor`` lies in [1, 1000) (0 and non-finite: 1, "")."""
    if value == 0 or not math.isfinite(value):
        return 1.0, ""
    exponent = 3 * math.floor(math.log10(abs(value)) / 3)
    exponent = min(max(exponent, min(PREFIXES)), max(PREFIXES))
    return 10.0 ** -exponent, PREFIXES[exponent]


def format_si(value: float, unit: str = "", digits: int = 4) -> str:
    """``value`` with an SI prefix and ``digits`` significant digits: ``format_si(0.0125, "A")``
    is ``"12.5 mA"``. NaN and infinities are written as such."""
    if not math.isfinite(value):
        return f"{value} {unit}".rstrip()
    factor, prefix = engineering_scale(float(f"{value:.{digits - 1}e}"))  # 999.96 -> 1 k
    text = f"{value * factor:.{digits}g}"
    return f"{text} {prefix}{unit}".rstrip()


def time_unit(span: float) -> tuple[float, str]:
    """``(factor, unit)`` to show times up to ``span`` seconds in s, ms, µs, ns or ps."""
    if span <= 0 or not math.isfinite(span):
        return 1.0, "s"
    factor, prefix = engineering_scale(span)
    if factor < 1.0:  # kiloseconds and more: stay in seconds
        return 1.0, "s"
    if factor > 1e12:
        factor, prefix = 1e12, "p"
    return factor, f"{prefix}s"
