"""SPICE numbers: ``10uF``, ``1kHz``, ``2.2meg``, ``1e-3``, ``5mil``.

A number may carry a scale suffix (case-insensitive) followed by any letters,
which are ignored as units, exactly as SPICE does (so ``1F`` is one femto, not
one farad, and ``1mF`` is one milli).
"""

from __future__ import annotations

import math
import re
from decimal import Decimal

_SCALES = {
    "t": "1e12", "g": "1e9", "meg": "1e6", "k": "1e3", "mil": "25.4e-6",
    "m": "1e-3", "u": "1e-6", "n": "1e-9", "p": "1e-12", "f": "1e-15",
    "\u00b5": "1e-6",  # µ, which LTspice writes and ngspice reads as u (inpcom.c utf8_check)
    "\u03bc": "1e-6",  # Greek mu, the same sign (and what µ becomes in lower case)
}
SCALE_FACTORS: dict[str, float] = {key: float(text) for key, text in _SCALES.items()}
"""Scale suffix (lower case) -> factor."""

_NUMBER = re.compile(
    r"""^(?P<mantissa>[+-]?(?:\d+\.?\d*|\.\d+)(?:e[+-]?\d+)?)
         (?P<scale>meg|mil|[tgkmunpf\u00b5\u03bc])?
         (?P<unit>[a-z%]*)$""",
    re.IGNORECASE | re.VERBOSE,
)


def parse_value(token: str) -> float:
    """Return the value of a SPICE number token in SI units.

    Raises:
        ValueError: if ``token`` is not a number (the caller adds file:line).
    """
    match = _NUMBER.match(token.strip())
    if match is None:
        raise ValueError(f"{token!r} is not a number")
    scale = match["scale"]
    if not scale:
        value = float(match["mantissa"])
    else:
        # decimal arithmetic so that 10u is exactly the double nearest 1e-5
        value = float(Decimal(match["mantissa"]) * Decimal(_SCALES[scale.lower()]))
    if not math.isfinite(value):
        raise ValueError(f"{token!r} is too large for a double")
    if value == 0.0 and Decimal(match["mantissa"]) != 0:
        raise ValueError(f"{token!r} is too small for a double (it would be 0; the smallest "
                         "positive one is about 5e-324, ordinary ones start at 2.2e-308)")
    return value


def is_value(token: str) -> bool:
    """True when ``token`` reads as a finite SPICE number."""
    try:
        parse_value(token)
    except ValueError:
        return False
    return True
