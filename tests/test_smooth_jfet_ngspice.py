"""Level-1 JFETs against ngspice 39 at DC (marker ``ngspice``): terminal currents of our
equations at the terminal voltages ngspice solved for, over gate sweeps crossing cut-off,
the linear and saturated regions, inverse mode and forward-biased gates."""

import warnings

import pytest

from tests.smooth_ngspice import ngspice_dc, relation_of, terminal_currents

pytestmark = pytest.mark.ngspice

VENDOR_2N3819 = ("njf(beta=1.304m betatce=-.5 rd=1 rs=1 lambda=2.25m vto=-3 vtotc=-2.5m "
                 "is=33.57f isr=322.4f n=1 nr=2 xti=3 alpha=311.7u vk=243.6 cgd=1.6p m=.3622 "
                 "pb=1 fc=.5 cgs=2.414p kf=9.882e-18 af=1)")
"""A PSpice-style vendor card: ngspice 39 ignores ISR, N, NR, ALPHA, VK, M (and so do we)."""
CASES = {
    "njf defaults": ("njf", 1),
    "njf lambda, is": ("njf(vto=-1.5 beta=2m lambda=0.02 is=1e-12)", 1),
    "njf doping profile b": ("njf(vto=-2.5 beta=1m b=0.6 pb=0.8 lambda=0.01)", 1),
    "pjf series resistances": ("pjf(vto=-2 beta=3m lambda=0.01 rd=20 rs=5 b=1.3)", -1),
    "2n3819 (vendor)": (VENDOR_2N3819, 1),
}


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("vds", [6.0, 0.4, -0.4, -6.0])
def test_terminal_currents_match_ngspice_over_a_gate_sweep(case, vds):
    model, polarity = CASES[case]
    netlist = f"vd d 0 {polarity * vds}\nvg g 0 0\nj1 d g 0 jx\n.model jx {model}"
    start, stop = (-5.0, 0.7) if polarity > 0 else (-0.7, 5.0)
    theirs = ngspice_dc(netlist, f"vg {start} {stop} 0.05", ["v(g)", "v(d)", "i(vd)", "i(vg)"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the vendor card's parameters ngspice ignores
        relation, unknowns = relation_of(netlist, "j1")
    for k, vg in enumerate(theirs["v(g)"]):
        ours = terminal_currents(relation, unknowns, {"v(d)": theirs["v(d)"][k], "v(g)": vg})
        for node, source in (("v(d)", "i(vd)"), ("v(g)", "i(vg)")):
            assert ours[node] == pytest.approx(-theirs[source][k], rel=1e-6, abs=1e-14), (
                f"{case}, vds={vds}, vg={vg:.3f}: {node}")
