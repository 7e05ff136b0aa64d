"""ngspice's level-1 diode as a smooth device (``smooth=1`` on its model) against ngspice 39
at DC (marker ``ngspice``): the current over sweeps through reverse bias, ngspice's cubic
tail, breakdown (its IBV-matched voltage), forward conduction and the knees."""

import pytest

from tests.smooth_ngspice import ngspice_dc, relation_of, terminal_currents

pytestmark = pytest.mark.ngspice

CASES = {
    # name: (model, sweep, ngspice options: its default RELTOL sets BV's matching iteration)
    "plain": ("d(is=1e-14 smooth=1)", "-3 0.85 0.01", "itl2=500"),
    "emission, knees": ("d(is=2e-12 n=1.8 ikf=50m ikr=1m smooth=1)", "-3 1.6 0.01", "itl2=500"),
    "zener breakdown": ("d(is=1e-14 bv=5.1 ibv=5m nbv=1.3 smooth=1)", "-5.4 0.8 0.005",
                        "itl2=500"),
    "breakdown, low ibv": ("d(is=1e-9 bv=12 ibv=1n smooth=1)", "-12.5 0.6 0.01", "itl2=500"),
    "series resistance": ("d(is=3e-15 n=1.05 rs=0.5 smooth=1)", "-2 1.2 0.01", None),
}


@pytest.mark.parametrize("case", CASES)
def test_current_matches_ngspice_over_a_sweep(case):
    model, sweep, options = CASES[case]
    netlist = f"va a 0 0\nd1 a 0 dx\n.model dx {model}"
    kwargs = {} if options is None else {"options": options}
    theirs = ngspice_dc(netlist, f"va {sweep}", ["v(a)", "i(va)"], **kwargs)
    relation, unknowns = relation_of(netlist, "d1")
    for k, va in enumerate(theirs["v(a)"]):
        ours = terminal_currents(relation, unknowns, {"v(a)": va})
        assert ours["v(a)"] == pytest.approx(-theirs["i(va)"][k], rel=1e-6, abs=1e-14), (
            f"{case}: va={va:.3f}")
