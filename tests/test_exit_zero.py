"""Exit 0 with a wrong number (issue 36): each case gave a wrong or misleading result with
no word; each test pins the right answer (closed form, or ngspice's) or the warning."""

from __future__ import annotations

import numpy as np
import pytest

import circuitnsds
from tests.conftest import circuit_from

# --- 1. θ = ½ after a circuit-controlled switch closes onto a capacitor -----------------------

GATE_RC_CLOSES_ONTO_C = """V1 in 0 12
Vg g0 0 PULSE(0 5 1u 0 0 5u 10u)
Rg g0 g 3
Cg g 0 5n
S1 in sw g 0 sw1
C1 sw 0 3n
R1 sw 0 10
.model sw1 SW(VT=2.6 RON=10m)
.tran 1n 3u"""


def test_theta_half_does_not_ring_after_a_switch_closes_onto_a_capacitor():
    # Ron·C1 = 30 ps against h = 1 ns: once closed, v(sw) = 12·10/10.01 V within a few
    # steps and i(s1) = 12/10.01 A (C1 charged). One implicit-Euler restart left the fast mode
    # ringing: i(s1) = +37, -31, +30, -24 A.
    waves = circuit_from(GATE_RC_CLOSES_ONTO_C).transient(theta=0.5)
    current = waves["i(s1)"]
    closed = int(np.argmax(np.abs(current) > 0.5))
    settled = 12 / 10.01
    np.testing.assert_allclose(current[closed + 4:], settled, rtol=2e-3)
    np.testing.assert_allclose(waves["v(sw)"][closed + 4:], 10 * settled, rtol=1e-4)


# --- 3. a consistent .ic ------------------------------------------------------------------------

IC_ON_A_DRIVEN_NODE = """V1 n 0 {v}
R1 n a 1k
C1 a 0 1u
.ic v(n)={ic}
.tran 10u 1m"""


def test_an_ic_that_repeats_the_source_is_accepted():
    # v(n) is held by V1; an .ic that says the same (0 against the solver's -0, or within
    # rounding) is consistent: the operating point (C1 open, no current in R1) has v(a) = v
    for v, ic in (("0", "0"), ("5", "5.0000000001"), ("-3.3", "-3.3")):
        waves = circuit_from(IC_ON_A_DRIVEN_NODE.format(v=v, ic=ic)).transient()
        np.testing.assert_allclose(waves["v(n)"], float(v), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(waves["v(a)"], float(v), rtol=1e-9, atol=1e-15)


def test_an_ic_that_contradicts_the_source_names_it_without_a_minus_zero():
    with pytest.raises(circuitnsds.SimulationError) as raised:
        circuit_from(IC_ON_A_DRIVEN_NODE.format(v="0", ic="0.1")).transient()
    assert ".ic v(n)=0.1 contradicts the sources, which hold n at 0 V" in str(raised.value)
