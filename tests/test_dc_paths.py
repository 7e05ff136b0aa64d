"""Issue 32: nodes without a DC path to ground get ngspice's GMIN, with a warning naming them and
the elements that isolate them; where GMIN would set the answer (a current source feeding them)
the run is refused, naming the source. Closed-form checks; the ngspice comparisons are in
``test_dialect_ngspice.py``."""

import warnings

import numpy as np
import pytest

import circuitnsds
from circuitnsds.circuit.elements.passive import GminLeak
from circuitnsds.errors import CircuitError, NetlistWarning

CAP_COUPLED = "V1 in 0 PULSE(0 1 1m 1u 1u 2m 4m)\nR1 in a 1k\nC1 a b 1u\nR2 b c 1k\nC2 c 0 1u\n"
FLOATING_SECONDARY = ("V1 p 0 SIN(0 10 1k)\nR1 p q 1\nL1 q 0 1m\nL2 s1 s2 1m\nK1 L1 L2 0.99\n"
                      "R2 s1 s2 100\n")


def read(body, tran=".tran 10u 5m"):
    return circuitnsds.read_netlist(f"t\n{body}{tran}\n.end\n")


def quiet(body, tran=".tran 10u 5m"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read(body, tran)


def leaks(circuit):
    return {e.nodes[0]: e.conductance for e in circuit.elements if isinstance(e, GminLeak)}


def test_nodes_held_only_by_capacitors_get_gmin_with_a_warning_naming_them_and_the_capacitors():
    with pytest.warns(NetlistWarning, match=r"<text>:4: node\(s\) b, c have no DC path to ground \(connected "
                      r"to the rest only through c1 \(<text>:4\), c2 \(<text>:6\)\): added gmin = 1e-12 S"):
        circuit = read(CAP_COUPLED)
    assert leaks(circuit) == {"b": 1e-12, "c": 1e-12}
    # before the pulse nothing moves: the operating point GMIN gives is 0 V on both
    result = circuit.transient()
    before = result["time"] < 1e-3
    assert np.all(np.abs(result["v(b)"][before]) < 1e-12)
    assert "i(gmin(b))" not in result.signals  # not the user's element: no signal of its own


def test_options_gmin_sets_the_conductance():
    assert leaks(quiet(".options gmin=1e-9\n" + CAP_COUPLED)) == {"b": 1e-9, "c": 1e-9}


def test_a_floating_secondary_swings_symmetrically_about_ground_as_gmin_on_both_nodes_makes_it():
    with pytest.warns(NetlistWarning, match=r"node\(s\) s1, s2 have no DC path to ground \(connected to the "
                      r"rest only through k1 \(<text>:6\)\)"):
        circuit = read(FLOATING_SECONDARY, ".tran 10u 3m")
    result = circuit.transient()
    swing = np.max(np.abs(result["v(s1)"]))
    assert swing > 1.0
    # equal leaks from s1 and s2 carry opposite currents only when v(s1) = -v(s2); the common
    # mode rests on 1e-12 S beside 1e-2 S (R2, h/L): round-off of 1e-16 · 1e10 relative to the swing
    # (a leak on one node only would put v(s2) at 0 and the sum at the whole swing)
    assert np.max(np.abs(result["v(s1)"] + result["v(s2)"])) < 1e-3 * swing


def test_under_uic_only_the_nodes_the_time_steps_leave_floating_get_gmin():
    assert leaks(quiet(CAP_COUPLED, ".tran 10u 5m uic")) == {}
    assert set(leaks(quiet(FLOATING_SECONDARY, ".tran 10u 3m uic"))) == {"s1", "s2"}


def test_a_node_held_by_ic_has_its_dc_path_and_charges_as_the_current_source_says():
    # ngspice's integrate1.cir: 1 A into R1 + C1 (1 F), v(2) held at 0 by .ic at the operating point
    circuit = read("I1 0 1 1\nR1 1 2 1\nC1 2 3 1\nVm1 3 0 0\n.ic v(2)=0\n", ".tran 0.01 1")
    assert leaks(circuit) == {}
    result = circuit.transient()
    assert result["v(2)"] == pytest.approx(result["time"], abs=1e-9)  # q = I t, C = 1 F
    assert result["v(1)"][1:] == pytest.approx(result["time"][1:] + 1.0, abs=1e-9)


def test_a_current_source_feeding_a_node_without_dc_path_is_refused_naming_the_source():
    circuit = quiet("I1 0 1 1m\nC1 1 0 1u\n", ".tran 10u 1m")
    assert leaks(circuit) == {}
    with pytest.raises(CircuitError, match=r"node\(s\) 1 have no DC path to ground and i1 \(<text>:2\) "
                       r"drive\(s\) a current into them .*no DC operating point exists") as error:
        circuit.transient()
    assert "UIC" in error.value.hint


def test_a_current_source_that_is_zero_at_the_start_lets_gmin_hold_the_node_and_charges_it_linearly():
    circuit = quiet("I1 0 1 PULSE(0 1m 0.1m 1n 1n 1 2)\nC1 1 0 1u\n", ".tran 1u 1m")
    assert leaks(circuit) == {"1": 1e-12}
    result = circuit.transient()
    t = result["time"]
    expected = np.where(t > 0.1e-3, 1e-3 * (t - 0.1e-3) / 1e-6, 0.0)
    assert result["v(1)"] == pytest.approx(expected, abs=2e-3)  # the 1 ns edge inside a 1 µs step


def test_an_xspice_integrator_holds_its_out_ic_at_the_operating_point_as_ngspice_int_does():
    circuit = read("V4 in 0 PWL(0 0 1 1)\nR4 in 0 1k\naint in out int_in\nR5 out 0 1k\n"
                   ".model int_in int(gain=1.0 out_ic=0.25)\n", ".tran 0.01 1")
    result = circuit.transient()
    assert result["v(out)"][0] == pytest.approx(0.25)
    # out = out_ic + t²/2, implicit Euler's error h·t/2 at most
    assert result["v(out)"] == pytest.approx(0.25 + result["time"] ** 2 / 2, abs=0.01)


def test_an_island_no_element_joins_to_the_circuit_is_still_refused():
    # ngspice 39 runs "V1 a b 1, R1 a b 1" on its own at v(a) = 2 V, v(b) = 1 V: its operating-point
    # search decides, not the circuit
    circuit = quiet("V0 c 0 1\nR3 c 0 1\nV1 a b 1\nR1 a b 1\n", ".tran 1u 10u")
    assert leaks(circuit) == {}
    with pytest.raises(CircuitError, match=r"node\(s\) a, b have no path to ground"):
        circuit.transient()
