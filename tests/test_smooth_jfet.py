"""Level-1 JFETs as smooth relations: Jacobians against finite differences (Hypothesis), the
square law and the symmetry of drain and source in closed form, limiting, the card reader."""

import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from circuitnsds.circuit.elements.smooth.jfet import JfetModel, drain_current
from circuitnsds.errors import NetlistError, NetlistWarning
from tests.conftest import circuit_from
from tests.smooth_ngspice import relation_of
from tests.test_smooth_bjt import central_difference

MODELS = {
    "njf, everything": "njf(vto=-2.5 beta=1m b=0.6 pb=0.8 lambda=0.02 rd=10 rs=3 cgs=3p cgd=1p "
                       "is=1e-13 fc=0.5)",
    "pjf, square law": "pjf(vto=-1.5 beta=2m lambda=0.01 cgs=2p cgd=2p rs=1)",
}


def relation(model: str):
    return relation_of(f"vd d 0 1\nvg g 0 0\nj1 d g s jx\nrs s 0 1\n.model jx {model}", "j1")


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(sorted(MODELS)), st.floats(-6, 0.9), st.floats(-8, 8), st.floats(-2, 2),
       st.lists(st.floats(-0.05, 0.05), min_size=2, max_size=2))
def test_jacobians_of_currents_and_charges_are_their_finite_differences(name, vgs, vds, vs, offsets):
    sign = -1.0 if name.startswith("pjf") else 1.0
    model = JfetModel("j", vto=-2.5 if sign > 0 else -1.5)
    vgd = vgs - vds
    # the regions meet with a kink of the second derivative only; keep off the corners
    for corner in (vgs - model.vto, vgd - model.vto, vds, vgs - model.vto - vds,
                   vgd - model.vto + vds):
        assume(abs(corner) > 1e-3)
    rel, unknowns = relation(MODELS[name])
    gate = vs + sign * vgs
    values = {"v(d)": gate - sign * vgd + offsets[0], "v(g)": gate, "v(s)": vs + offsets[1],
              "v(j1#drain)": gate - sign * vgd, "v(j1#source)": vs}
    x = np.array([values[unknowns[k]] for k in rel.inputs])
    _, jacobian, _, q_jacobian = rel.evaluate(x, 0.0)
    for derivative, index in ((jacobian, 0), (q_jacobian, 2)):
        numeric = central_difference(lambda y, index=index: rel.evaluate(y, 0.0)[index], x)
        scale = np.max(np.abs(derivative)) + 1e-300
        np.testing.assert_allclose(derivative, numeric, rtol=2e-5, atol=1e-6 * scale)


def test_square_law_with_b_one():
    model = JfetModel("j", vto=-2.0, beta=1e-3, lam=0.05)
    # saturation: beta (1 + lambda vds) (vgs - vto)^2
    assert drain_current(model, -1.0, -6.0)[0] == pytest.approx(1e-3 * 1.25 * 1.0)
    # linear: beta (1 + lambda vds) vds (2 (vgs - vto) - vds)
    assert drain_current(model, -0.5, -0.8)[0] == pytest.approx(1e-3 * 1.015 * 0.3 * 2.7)
    assert drain_current(model, -2.5, -7.0)[0] == 0.0


@settings(max_examples=100, deadline=None)
@given(st.floats(-4, 0.5), st.floats(-4, 0.5), st.floats(0.2, 1.8), st.floats(0, 0.1))
def test_drain_and_source_exchange_reverses_the_current(vgs, vgd, b, lam):
    model = JfetModel("j", vto=-2.0, beta=1e-3, lam=lam, b=b)
    forward, _, _ = drain_current(model, vgs, vgd)
    backward, _, _ = drain_current(model, vgd, vgs)
    assert forward == pytest.approx(-backward, rel=1e-12, abs=1e-18)


def test_limiting_moves_a_huge_gate_step_onto_the_threshold_scale():
    rel, unknowns = relation("njf(vto=-2)")
    names = [unknowns[k] for k in rel.inputs]
    old = np.array([{"v(d)": 1.0, "v(g)": -3.0, "v(s)": 0.0}[n] for n in names])
    new = np.array([{"v(d)": 1.0, "v(g)": 40.0, "v(s)": 0.0}[n] for n in names])
    limited = dict(zip(names, rel.limit(new, old)))
    # fetlim from cut-off: a step to above vto + 0.5 stops at vto + 0.5
    assert limited["v(g)"] - limited["v(s)"] == pytest.approx(-1.5)


def test_vendor_parameters_ngspice_does_not_know_are_ignored_with_a_warning():
    with pytest.warns(NetlistWarning, match="isr, alpha ignored"):
        circuit = circuit_from("vd d 0 5\nj1 d 0 0 jx\n.model jx njf(vto=-3 isr=1p alpha=1u)")
    assert circuit.element("j1").model.vto == -3.0


@pytest.mark.parametrize(("text", "words"), [
    ("j1 d 0 0 jx\n.model jx njf(pb=0)", "PB must be positive"),
    ("j1 d 0 0 jx\n.model jx njf(tnom=30)", "TNOM=30"),
    ("j1 d 0 0 jy\n.model jx njf", "model 'jy' is not defined"),
    ("j1 d 0 jx\n.model jx njf", "expected drain, gate, source"),
    ("j1 d 0 0 jx 3\n.model jx njf", "area 3 is not supported"),
])
def test_errors_name_the_parameter_or_line(text, words):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(NetlistError, match=words):
            circuit_from(f"vd d 0 5\n{text}")
