"""ngspice's VDMOS as a smooth device (``smooth=1`` on its model) against ngspice 39 at DC
(marker ``ngspice``): terminal currents over gate sweeps through weak inversion, saturation,
the linear region, inverse mode and the conducting body diode."""

import warnings

import pytest

from tests.smooth_ngspice import ngspice_dc, relation_of, terminal_currents

pytestmark = pytest.mark.ngspice

CASES = {
    "irf530 (vendor)": ("vdmos(rg=3 vto=4 rd=50m rs=12m rb=60m kp=5 lambda=.01 cgdmax=1n "
                        "cgdmin=.26n cgs=.2n cjo=.4n is=52p ksubthres=.1 ron=160m qg=26n "
                        "smooth=1)", 1),
    "theta, mtriode, subshift, rds, breakdown": (
        "vdmos(vto=2.5 kp=8 theta=0.05 mtriode=1.6 subshift=0.1 ksubthres=0.15 lambda=0.02 "
        "rd=20m rs=5m rds=10k rb=10m is=1e-12 n=1.2 bv=40 ibv=1m smooth=1)", 1),
    "irf7404 (vendor, pchan)": ("vdmos(pchan rg=3 rd=16m rs=12m vto=-1 kp=30 cgdmax=1.6n "
                                "cgdmin=.2n cgs=2.7n cjo=.8n is=80p rb=20m ksubthres=.1 "
                                "smooth=1)", -1),
    "no vto given": ("vdmos(kp=2 smooth=1)", 1),
}


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("vds", [10.0, 0.2, -0.2, -1.0])
def test_terminal_currents_match_ngspice_over_a_gate_sweep(case, vds):
    model, polarity = CASES[case]
    netlist = f"vd d 0 {polarity * vds}\nvg g 0 0\nm1 d g 0 mx\n.model mx {model}"
    start, stop = (-2.0, 8.0) if polarity > 0 else (-8.0, 2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        theirs = ngspice_dc(netlist, f"vg {start} {stop} 0.05", ["v(g)", "v(d)", "i(vd)", "i(vg)"])
        relation, unknowns = relation_of(netlist, "m1")
    for k, vg in enumerate(theirs["v(g)"]):
        ours = terminal_currents(relation, unknowns, {"v(d)": theirs["v(d)"][k], "v(g)": vg})
        # abs: one ulp of a 10 V node across RD = 16 mOhm is 1.1e-13 A, in both simulators
        assert ours["v(d)"] == pytest.approx(-theirs["i(vd)"][k], rel=1e-6, abs=5e-13), (
            f"{case}, vds={vds}, vg={vg:.2f}")
