"""Gummel–Poon BJTs against ngspice 39 at DC (marker ``ngspice``): the terminal currents of
our equations at the terminal voltages ngspice solved for, over sweeps that cross cut-off,
forward and reverse activity, saturation and ngspice's cubic reverse tail."""

import pytest

from tests.smooth_ngspice import ngspice_dc, relation_of, terminal_currents

pytestmark = pytest.mark.ngspice

FULL_NPN = ("npn(is=2e-14 bf=120 br=3 nf=1.02 nr=1.05 vaf=60 var=12 ikf=0.2 ikr=0.05 "
            "ise=3e-13 ne=1.6 isc=5e-12 nc=1.8)")
SPICE2_LEAKAGE = "npn(is=1e-15 bf=50 ise=200 ne=2 isc=100 nc=2 vaf=80)"
"""``ISE``, ``ISC`` above 1e-4: multiples of ``IS``, as ngspice still reads them."""
SERIES = ("npn(is=1e-14 bf=150 vaf=70 ikf=0.3 rb=50 rbm=5 rc=1.5 re=0.4 ise=1e-14 ne=1.5)")
IRB = "npn(is=1e-14 bf=150 rb=100 rbm=10 irb=1m re=0.2 rc=1)"
VENDOR_2N2222 = ("npn(is=14.34f xti=3 eg=1.11 vaf=74.03 bf=255.9 ne=1.307 ise=14.34f ikf=.2847 "
                 "xtb=1.5 br=6.092 nc=2 isc=0 ikr=0 rc=1 cjc=7.306p mjc=.3416 vjc=.75 fc=.5 "
                 "cje=22.01p mje=.377 vje=.75 tr=46.91n tf=411.1p itf=.6 vtf=1.7 xtf=3 rb=10)")
VENDOR_2N2907 = ("pnp(is=650.6e-18 xti=3 eg=1.11 vaf=115.7 bf=231.7 ne=1.829 ise=54.81f "
                 "ikf=1.079 xtb=1.5 br=3.563 nc=2 isc=0 ikr=0 rc=.715 cjc=14.76p mjc=.5383 "
                 "vjc=.75 fc=.5 cje=19.82p mje=.3357 vje=.75 tr=111.3n tf=603.7p itf=.65 vtf=5 "
                 "xtf=1.7 rb=10)")

CASES = {
    "npn all dc parameters": (FULL_NPN, 1),
    "pnp all dc parameters": (FULL_NPN.replace("npn", "pnp"), -1),
    "spice2 leakage multiples": (SPICE2_LEAKAGE, 1),
    "series resistances, rbm": (SERIES, 1),
    "base resistance with irb": (IRB, 1),
    "2n2222 (vendor)": (VENDOR_2N2222, 1),
    "2n2907 (vendor, pnp)": (VENDOR_2N2907, -1),
}


def sweep_netlist(model: str, vce: float) -> str:
    return f"vc c 0 {vce}\nvb b 0 0\nq1 c b 0 qx\n.model qx {model}"


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("vce", [5.0, 0.2, -2.0])
def test_terminal_currents_match_ngspice_over_a_base_sweep(case, vce):
    model, polarity = CASES[case]
    netlist = sweep_netlist(model, polarity * vce)
    start, stop = (-3.0, 0.95) if polarity > 0 else (-0.95, 3.0)
    theirs = ngspice_dc(netlist, f"vb {start} {stop} 0.05", ["v(b)", "v(c)", "i(vc)", "i(vb)"])
    relation, unknowns = relation_of(netlist, "q1")
    for k, vb in enumerate(theirs["v(b)"]):
        ours = terminal_currents(relation, unknowns, {"v(c)": theirs["v(c)"][k], "v(b)": vb})
        # a source's current flows into its + node: the device draws -i(v) from the node
        for node, source in (("v(c)", "i(vc)"), ("v(b)", "i(vb)")):
            expected = -theirs[source][k]
            assert ours[node] == pytest.approx(expected, rel=1e-6, abs=1e-14), (
                f"{case}, vce={vce}, vb={vb:.3f}: {node}")
