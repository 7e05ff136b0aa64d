"""Issue 34: diodes fitted to SPICE models are fitted where the circuit works in every
analysis: the periodic steady state and the small-signal analysis around an operating point
refit them as the transient does (before, pss and ac kept the fit made when the netlist
was read, and `pss` ignored pwlfit=auto)."""

import math
import warnings

import pytest

import circuitnsds
from circuitnsds.errors import RunNote

VT = 1.380649e-23 * 300.15 / 1.602176634e-19

ZENER_CLIPPER_5A = """Zener clipper at 5 A
V1 in 0 SIN(0 20 1k)
R1 in out 3
DZ1 0 out zspice
.model zspice D(IS=1e-14 N=0.05 BV=5.1 IBV=1m)
.tran 10u 2m
.end
"""


def test_pss_refits_to_the_currents_of_its_periodic_steady_state():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = circuitnsds.read_netlist(ZENER_CLIPPER_5A).pss()
    assert any(issubclass(w.category, RunNote) and "refitted" in str(w.message) for w in caught)
    waves = result.waveforms
    reverse = -float(waves["i(dz1)"].min())
    assert reverse > 4  # 20 V through 3 ohm, less the Zener's 5.1 V
    # the model's breakdown curve (NBV defaults to N in ngspice), written out here
    model = 5.1 + 0.05 * VT * math.log(reverse / 1e-3)
    assert float(waves["v(out)"].max()) == pytest.approx(model, abs=2e-3)  # fit within 1 mV


def test_ac_around_an_operating_point_refits_to_its_currents():
    """A diode biased at 47 nA (1 V through 10 Mohm): its small-signal resistance N·Vt/I is
    554 kohm, so the gain to v(a) is 0.0525. The branches fitted 5 decades below 1 A gave
    5.7e-9 (their first branch's slope); refitted at the operating point, the chord of the
    branch that carries it is within a factor of 2 of the tangent."""
    text = """diode biased at 50 nA
V1 in 0 DC 1 AC 1
R1 in a 10meg
D1 a 0 dd
.model dd D(IS=1e-14 N=1)
.end
"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = circuitnsds.read_netlist(text).ac("v1", ["v(a)"], [1.0], around="op")
    low, high = 0.0, 1.0  # the operating point: (1 - v)/10M = IS (exp(v/Vt) - 1)
    for _ in range(100):
        v = (low + high) / 2
        low, high = (v, high) if (1 - v) / 10e6 > 1e-14 * math.expm1(v / VT) else (low, v)
    current = (1 - v) / 10e6
    resistance = VT / current
    gain = resistance / (10e6 + resistance)
    assert 0.5 < abs(complex(result.transfer["v(a)"][0])) / gain < 2
