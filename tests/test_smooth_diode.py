"""ngspice's Shockley diode as a smooth relation (``smooth=1`` on the model): the rule, the
breakdown matched to ``IBV``, Jacobians against finite differences (Hypothesis), limiting in
and out of breakdown, the card reader's refusals."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from circuitnsds.circuit.elements import Diode
from circuitnsds.circuit.elements.smooth.diode import (
    ShockleyDiode,
    ShockleyDiodeModel,
    breakdown_voltage,
    diode_current,
)
from circuitnsds.circuit.elements.smooth.junctions import thermal_voltage
from circuitnsds.errors import NetlistError
from tests.conftest import circuit_from
from tests.smooth_ngspice import relation_of
from tests.test_smooth_bjt import central_difference

VT = thermal_voltage()
FULL = "d(is=2e-12 n=1.4 rs=0.3 bv=8 ibv=2m nbv=1.2 ikf=0.1 ikr=5m cjo=10p vj=0.7 m=0.4 tt=5n smooth=1)"


def test_smooth_flag_on_the_model_chooses_the_device():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuit_from("va a 0 1\nd1 a 0 ds\nd2 a 0 dp\n.model ds d(is=1e-14 smooth=1)\n"
                               ".model dp d(is=1e-14)")
    assert isinstance(circuit.element("d1"), ShockleyDiode)
    assert isinstance(circuit.element("d2"), Diode)


def test_breakdown_voltage_passes_ibv_at_bv():
    model = ShockleyDiodeModel("d", is_=1e-14, bv=5.1, ibv=5e-3, nbv=1.3)
    knee = breakdown_voltage(model, VT)
    assert 5.1 - 1.3 * VT * math.log(5e-3 / 1e-14) < knee < 5.1
    current, _ = diode_current(model, -5.1, VT, knee, gmin=0.0)
    assert current == pytest.approx(-5e-3, rel=2e-3)  # ngspice matches it to RELTOL = 1e-3


@settings(max_examples=200, deadline=None)
@given(st.floats(-12, 1.2), st.floats(-3, 3), st.floats(-0.05, 0.05))
def test_jacobians_of_current_and_charge_are_their_finite_differences(vd, vk, offset):
    model = ShockleyDiodeModel("d", is_=2e-12, n=1.4, bv=8, ibv=2e-3, nbv=1.2)
    knee = breakdown_voltage(model, VT)
    # ngspice's regions meet with a jump of the slope (-3 N Vt, -BV'), FC·VJ is smooth enough
    for corner in (vd + 3 * 1.4 * VT, vd + knee, vd):
        assume(abs(corner) > 1e-3)
    rel, unknowns = relation_of(f"va a 0 1\nd1 a k dx\nrk k 0 1\n.model dx {FULL}", "d1")
    values = {"v(a)": vk + vd + offset, "v(k)": vk, "v(d1#internal)": vk + vd}
    x = np.array([values[unknowns[k]] for k in rel.inputs])
    _, jacobian, _, q_jacobian = rel.evaluate(x, 0.0)
    for derivative, index in ((jacobian, 0), (q_jacobian, 2)):
        numeric = central_difference(lambda y, index=index: rel.evaluate(y, 0.0)[index], x)
        scale = np.max(np.abs(derivative)) + 1e-300
        np.testing.assert_allclose(derivative, numeric, rtol=2e-5, atol=1e-6 * scale)


@pytest.mark.parametrize(("old", "new", "low", "high"), [
    (0.0, 30.0, 0.0, 1.4 * VT * math.log(30 / (1.4 * VT)) + 1e-12),  # forward: logarithmic
    (-7.5, -40.0, -8.0, -7.5),  # into breakdown: limited in the breakdown's own frame
])
def test_limiting_keeps_the_step_on_the_exponential_scale(old, new, low, high):
    rel, unknowns = relation_of("va a 0 1\nd1 a 0 dx\n.model dx d(is=2e-12 n=1.4 bv=8 smooth=1)",
                                "d1")
    limited = rel.limit(np.array([new]), np.array([old]))[0]
    assert low <= limited <= high


@pytest.mark.parametrize(("text", "words"), [
    ("d1 a 0 dx\n.model dx d(isr=1n smooth=1)", "ISR=1e-09 \\(recombination current\\)"),
    ("d1 a 0 dx 2\n.model dx d(smooth=1)", "area 2 is not supported"),
    ("d1 a 0 dx m=3\n.model dx d(smooth=1)", "m=3 is not supported"),
    ("d1 a 0 dx\n.model dx d(n=0 smooth=1)", "N must be positive"),
])
def test_errors_name_the_parameter(text, words):
    with pytest.raises(NetlistError, match=words):
        circuit_from(f"va a 0 1\n{text}")
