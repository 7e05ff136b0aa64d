"""Level-1 MOSFETs read as smooth devices (``smooth=1``) against ngspice 39 at DC (marker
``ngspice``): terminal currents at ngspice's terminal voltages over gate sweeps through
cut-off, saturation, the linear region and inverse mode, with the body effect."""

import warnings

import pytest

from tests.smooth_ngspice import ngspice_dc, relation_of, terminal_currents

pytestmark = pytest.mark.ngspice

CASES = {
    "nmos square law": ("nmos(vto=0.8 kp=60u lambda=0.03 smooth=1)", 1, "l=2u w=20u"),
    "nmos body effect, series resistances": (
        "nmos(vto=0.7 kp=110u gamma=0.45 phi=0.7 lambda=0.02 rd=15 rs=10 ld=0.1u is=1e-13 "
        "smooth=1)", 1, "l=1u w=50u m=2"),
    "pmos": ("pmos(vto=-0.9 kp=40u gamma=0.5 phi=0.65 lambda=0.05 smooth=1)", -1, "l=1u w=30u"),
}


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize(("vds", "vbs"), [(5.0, 0.0), (0.3, -1.5), (-0.3, -0.5), (-4.0, 0.0),
                                          (2.0, 0.3)])
def test_terminal_currents_match_ngspice_over_a_gate_sweep(case, vds, vbs):
    model, polarity, geometry = CASES[case]
    netlist = (f"vd d 0 {polarity * vds}\nvg g 0 0\nvb b 0 {polarity * vbs}\n"
               f"m1 d g 0 b mx {geometry}\n.model mx {model}")
    start, stop = (-1.0, 5.0) if polarity > 0 else (-5.0, 1.0)
    vectors = ["v(g)", "v(d)", "v(b)", "i(vd)", "i(vg)", "i(vb)"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        theirs = ngspice_dc(netlist, f"vg {start} {stop} 0.1", vectors)
        relation, unknowns = relation_of(netlist, "m1")
    for k, vg in enumerate(theirs["v(g)"]):
        fixed = {"v(d)": theirs["v(d)"][k], "v(g)": vg, "v(b)": theirs["v(b)"][k]}
        ours = terminal_currents(relation, unknowns, fixed)
        for node, source in (("v(d)", "i(vd)"), ("v(b)", "i(vb)")):
            assert ours[node] == pytest.approx(-theirs[source][k], rel=1e-6, abs=1e-14), (
                f"{case}, vds={vds}, vbs={vbs}, vg={vg:.2f}: {node}")
        assert ours["v(g)"] == 0.0 and abs(theirs["i(vg)"][k]) < 1e-14
