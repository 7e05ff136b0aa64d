"""ngspice's VDMOS as a smooth relation (``smooth=1``): Jacobians against finite differences
(Hypothesis), the gate-drain charge's capacitance, the card reader's refusals."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from circuitnsds.circuit.elements.smooth.junctions import thermal_voltage
from circuitnsds.circuit.elements.smooth.vdmos import Vdmos, VdmosModel, gate_drain_charge
from circuitnsds.errors import NetlistError
from tests.conftest import circuit_from
from tests.smooth_ngspice import relation_of
from tests.test_smooth_bjt import central_difference

VT = thermal_voltage()
FULL = ("vdmos(rg=3 vto=4 rd=50m rs=12m rb=60m kp=5 lambda=.01 theta=0.03 mtriode=1.3 "
        "cgdmax=1n cgdmin=.26n cgs=.2n cjo=.4n is=52p tt=20n ksubthres=.1 rds=1meg smooth=1)")


@settings(max_examples=150, deadline=None)
@given(st.booleans(), st.floats(-3, 12), st.floats(-1.0, 30), st.floats(-2, 2),
       st.lists(st.floats(-0.05, 0.05), min_size=4, max_size=4))
def test_jacobians_of_currents_and_charges_are_their_finite_differences(pchan, vgs, vds, vs,
                                                                        offsets):
    sign = -1.0 if pchan else 1.0
    control = vgs if vds >= 0 else vgs - vds
    overdrive = 0.1 * math.log1p(math.exp(min(50.0, (control - 4.0) / 0.1)))
    for corner in (vds, overdrive - 1.3 * abs(vds), -vds + 3 * VT, vgs - vds):
        assume(abs(corner) > 2e-3)  # the regions' corners, the diode's tail, vgd = 0
    model = FULL.replace("vdmos(", "vdmos(pchan vto=-4 ").replace(" vto=4", "") if pchan else FULL
    rel, unknowns = relation_of(f"vd d 0 1\nvg g 0 1\nm1 d g s mx\nrs s 0 1\n.model mx {model}",
                                "m1")
    values = {"v(s)": vs + offsets[0], "v(g)": vs + sign * vgs + offsets[1],
              "v(d)": vs + sign * vds + offsets[2], "v(m1#drain)": vs + sign * vds,
              "v(m1#gate)": vs + sign * vgs, "v(m1#source)": vs,
              "v(m1#body diode)": vs + offsets[3]}
    x = np.array([values[unknowns[k]] for k in rel.inputs])
    _, jacobian, _, q_jacobian = rel.evaluate(x, 0.0)
    for derivative, index in ((jacobian, 0), (q_jacobian, 2)):
        numeric = central_difference(lambda y, index=index: rel.evaluate(y, 0.0)[index], x)
        scale = np.max(np.abs(derivative)) + 1e-300
        np.testing.assert_allclose(derivative, numeric, rtol=2e-5, atol=1e-6 * scale)


def test_gate_drain_capacitance_spans_cgdmin_to_cgdmax():
    model = VdmosModel("m", cgdmin=0.26e-9, cgdmax=1e-9, a=1.0)
    assert gate_drain_charge(model, 50.0)[1] == pytest.approx(1e-9, rel=1e-9)  # channel on
    low = gate_drain_charge(model, -1e6)[1]  # atan -> -pi/2: CGDMIN
    assert low == pytest.approx(0.26e-9, rel=1e-5)
    assert gate_drain_charge(model, 0.0) == (0.0, pytest.approx(1e-9 - 0.74e-9 / (1 + math.pi / 2)))


def test_smooth_flag_makes_a_vdmos_the_smooth_device():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuit_from(f"vd d 0 1\nvg g 0 1\nm1 d g 0 mx\n.model mx {FULL}")
    assert isinstance(circuit.element("m1"), Vdmos)
    assert circuit.element("m1").model.diode.rs == 0.06  # RB: the body diode's resistance


@pytest.mark.parametrize(("line", "model", "words"), [
    ("m1 d g 0 mx", "vdmos(rq=1 smooth=1)", "RQ \\(quasi-saturation\\)"),
    ("m1 d g 0 t mx", "vdmos(smooth=1)", "three terminals"),
    ("m1 d g 0 mx m=2", "vdmos(smooth=1)", "m=2 is not supported"),
])
def test_what_the_smooth_vdmos_does_not_take_is_refused(line, model, words):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(NetlistError, match=words):
            circuit_from(f"vd d 0 1\nvg g 0 1\n{line}\n.model mx {model}")
