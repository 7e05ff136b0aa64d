"""Level-1 MOSFETs as smooth relations: the ``smooth=1`` rule on the model or the line,
Jacobians against finite differences (Hypothesis), the square law in closed form, limiting,
the card reader's refusals."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from circuitnsds.circuit.elements.mosfet import Mosfet
from circuitnsds.circuit.elements.smooth.junctions import thermal_voltage
from circuitnsds.circuit.elements.smooth.mos1 import Mos1, Mos1Model, drain_current, drain_threshold
from circuitnsds.errors import NetlistError, NetlistWarning
from tests.conftest import circuit_from
from tests.smooth_ngspice import relation_of
from tests.test_smooth_bjt import central_difference

VT = thermal_voltage()
FULL = ("nmos(vto=0.7 kp=110u gamma=0.45 phi=0.7 lambda=0.02 rd=15 rs=10 ld=0.1u is=1e-13 "
        "cbd=20f cbs=25f mj=0.4 pb=0.9 cgso=1n cgdo=1n cgbo=0.5n smooth=1)")


def mosfet_circuit(line: str, model: str):
    return circuit_from(f"vd d 0 5\nvg g 0 2\n{line}\n.model mx {model}")


@pytest.mark.parametrize(("line", "model", "smooth"), [
    ("m1 d g 0 0 mx", "nmos(vto=1 kp=50u smooth=1)", True),
    ("m1 d g 0 0 mx smooth=1", "nmos(vto=1 kp=50u)", True),
    ("m1 d g 0 0 mx smooth=0 w=10u", "nmos(vto=1 kp=50u smooth=1)", False),
    ("m1 d g 0 0 mx", "nmos(vto=1 kp=50u)", False),
])
def test_smooth_flag_on_the_model_or_the_line_chooses_the_device(line, model, smooth):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        element = mosfet_circuit(line, model).element("m1")
    assert isinstance(element, Mos1 if smooth else Mosfet)


@pytest.mark.parametrize(("line", "model"), [
    ("m1 d g 0 0 mx smooth=2", "nmos(vto=1 kp=50u)"),
    ("m1 d g 0 0 mx", "nmos(vto=1 kp=50u smooth=0.5)"),
    ("m1 d g 0 0 mx smooth=-1", "nmos(vto=1 kp=50u smooth=1)"),
])
def test_a_smooth_flag_other_than_0_or_1_is_refused_at_its_line(line, model):
    # smooth=2 or 0.5 read as 1 without a word (and any nonzero diode model's smooth= too)
    with pytest.raises(NetlistError, match=r"smooth=(2|0.5|-1) must be 0 or 1"):
        mosfet_circuit(line, model)


def test_a_diode_model_with_a_smooth_flag_other_than_0_or_1_is_refused():
    with pytest.raises(NetlistError, match=r"smooth=3 must be 0 or 1"):
        circuit_from("V1 a 0 1\nD1 a 0 dx\n.model dx d(is=1e-14 smooth=3)\n.tran 1u 10u")


@settings(max_examples=150, deadline=None)
@given(st.booleans(), st.floats(-2, 6), st.floats(-6, 6), st.floats(-3, 0.6), st.floats(-2, 2),
       st.lists(st.floats(-0.05, 0.05), min_size=2, max_size=2))
def test_jacobians_of_currents_and_charges_are_their_finite_differences(
        pmos, vgs, vds, vbs, vs, offsets):
    model = Mos1Model("m", vto=0.7, gamma=0.45, phi=0.7)
    # keep off the corners of the regions, ngspice's bulk-junction step at -3 Vt and the
    # threshold's clamp where the body voltage reaches 2 PHI
    body = vbs if vds >= 0 else vbs - vds
    control = vgs if vds >= 0 else vgs - vds
    von = drain_threshold(model, body)
    for corner in (control - von, vds, control - von - abs(vds), vbs + 3 * VT, vbs - vds + 3 * VT,
                   body - 2 * 0.7):
        assume(abs(corner) > 2e-3)
    sign = -1.0 if pmos else 1.0
    rel, unknowns = relation_of(f"vd d 0 1\nvg g 0 1\nvb b 0 0\nm1 d g s b mx l=1u w=50u\n"
                                f"rs s 0 1\n.model mx {FULL.replace('nmos', 'pmos') if pmos else FULL}",
                                "m1")
    values = {"v(g)": vs + sign * vgs, "v(b)": vs + sign * vbs, "v(s)": vs + offsets[1],
              "v(d)": vs + sign * vds + offsets[0], "v(m1#drain)": vs + sign * vds,
              "v(m1#source)": vs}
    x = np.array([values[unknowns[k]] for k in rel.inputs])
    _, jacobian, _, q_jacobian = rel.evaluate(x, 0.0)
    for derivative, index in ((jacobian, 0), (q_jacobian, 2)):
        numeric = central_difference(lambda y, index=index: rel.evaluate(y, 0.0)[index], x)
        scale = np.max(np.abs(derivative)) + 1e-300
        np.testing.assert_allclose(derivative, numeric, rtol=2e-5, atol=1e-6 * scale)


def test_square_law_in_saturation_and_the_linear_region():
    model = Mos1Model("m", vto=1.0, beta=1e-3, lam=0.1)
    assert drain_current(model, 3.0, 5.0, 0.0)[0] == pytest.approx(0.5e-3 * 1.5 * 4.0)
    assert drain_current(model, 3.0, 1.0, 0.0)[0] == pytest.approx(1e-3 * 1.1 * 1.0 * 1.5)
    # inverse mode: the same device seen from the other end
    assert drain_current(model, 2.0, -1.0, 0.0)[0] == pytest.approx(
        -drain_current(model, 3.0, 1.0, 1.0)[0])


def test_limiting_holds_a_gate_step_near_the_threshold():
    rel, unknowns = relation_of("vd d 0 1\nvg g 0 1\nm1 d g 0 0 mx\n.model mx nmos(vto=1 "
                                "kp=50u smooth=1)", "m1")
    names = [unknowns[k] for k in rel.inputs]
    old = np.array([{"v(d)": 1.0, "v(g)": 0.0}[n] for n in names])
    new = np.array([{"v(d)": 1.0, "v(g)": 50.0}[n] for n in names])
    assert dict(zip(names, rel.limit(new, old)))["v(g)"] == pytest.approx(1.5)  # vto + 0.5


def test_meyer_capacitances_left_out_are_said():
    with pytest.warns(NetlistWarning, match="Meyer gate capacitances are left out"):
        mosfet_circuit("m1 d g 0 0 mx", "nmos(vto=1 kp=50u tox=20n smooth=1)")


@pytest.mark.parametrize(("line", "model", "words"), [
    ("m1 d g 0 0 mx", "nmos(level=3 smooth=1)", "level 3 MOSFET as a smooth device"),
    ("m1 d g 0 0 mx", "nmos(cj=1m smooth=1)", "CJ"),
    ("m1 d g 0 0 mx", "nmos(nsub=1e16 tox=20n smooth=1)", "GAMMA and PHI derived from NSUB"),
    ("m1 d g 0 0 mx ad=1p", "nmos(smooth=1)", "instance parameter 'ad'"),
])
def test_what_the_smooth_device_does_not_take_is_refused_by_name(line, model, words):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(NetlistError, match=words):
            mosfet_circuit(line, model)


def test_a_level1_card_without_junction_current_runs_to_the_square_law_closed_form():
    # IS=0 (a card that leaves out the bulk junctions): the junction limiting's critical
    # voltage Vt·ln(Vt/(√2·IS)) divided by zero (a ZeroDivisionError traceback); now none is
    # limited. beta = KP·W/L = 1 A/V², Vgs − Vto = 3.5 V, triode through 10 Ω from 12 V:
    # 12 − Vds = 10·(3.5·Vds − Vds²/2), Vds = (36 − √1056)/10
    circuit = circuit_from(".model nl nmos(level=1 vto=1.5 kp=2e-5 is=0 smooth=1)\nvdd vdd 0 12\n"
                           "rl vdd d 10\nvg g 0 5\nm1 d g 0 0 nl w=0.1 l=2u\n.tran 10n 1u")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuit.transient()
    assert float(waves["v(d)"][-1]) == pytest.approx((36 - math.sqrt(1056)) / 10, rel=1e-4)
