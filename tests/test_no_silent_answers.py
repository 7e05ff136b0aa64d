"""Circuits whose ideal answer does not exist or is not unique must not get one silently
(issue 20: items 2, 3 and 9)."""

import warnings

import numpy as np
import pytest

from circuitnsds.cli.main import main
from circuitnsds.errors import CircuitError, CircuitWarning
from tests.conftest import circuit_from

# --- item 2: a current source forced against a blocking diode ---------------------------------

def test_current_source_against_a_diode_is_refused_before_simulating(tmp_path, capsys):
    netlist = tmp_path / "forced.cir"
    netlist.write_text("forced\nI1 a 0 DC 1m\nD1 a 0 dx\n.model dx D\n.tran 1u 10u\n.end\n")
    assert main(["run", str(netlist), "-o", str(tmp_path / "out.csv"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "forced.cir:2" in err and "i1" in err and "d1" in err and "node(s) a" in err
    assert not (tmp_path / "out.csv").exists()          # no -1 GV waveform


def test_current_source_along_a_diode_runs():
    # the same source with the diode turned round: it conducts the 1 mA, v(a) = 0 (ideal)
    waves = circuit_from("I1 a 0 DC 1m\nD1 0 a dx\n.model dx D\n.tran 1u 10u").transient()
    np.testing.assert_allclose(waves["i(d1)"][1:], 1e-3, rtol=1e-9)
    np.testing.assert_allclose(waves["v(a)"][1:], 0.0, atol=1e-9)


def test_alternating_current_source_is_refused_at_its_first_wrong_half_cycle():
    circuit = circuit_from("I1 0 a SIN(0 1m 50)\nD1 a 0 dx\n.model dx D\n.tran 100u 40m")
    with pytest.raises(CircuitError, match=r"i1 drives \S+ A out of node\(s\) a at t = 0\.010"):
        circuit.transient()


def test_an_explicit_roff_makes_the_leakage_the_answer_with_a_warning():
    circuit = circuit_from("I1 a 0 DC 1m\nD1 a 0 dx\n.model dx D(Roff=1k)\n.tran 1u 10u")
    with pytest.warns(CircuitWarning, match="Roff = 1e\\+03"):
        waves = circuit.transient()
    np.testing.assert_allclose(waves["v(a)"][1:], -1.0, rtol=1e-9)  # -1 mA · 1 kΩ


# --- item 3: a singular step system is an error, not an arbitrary point --------------------

SINGULAR = "V1 in 0 1\nE1 a 0 a 0 1\nR1 a in 1k\n.tran 1u 10u"   # v(a) = 1·v(a): anything


@pytest.mark.parametrize("uic", [False, True])
def test_undetermined_node_voltage_is_an_error(uic):
    from circuitnsds.errors import SimulationError
    with pytest.raises(SimulationError, match=r"v\(a\)") as caught:
        circuit_from(SINGULAR).transient(uic=uic)
    assert "v(in)" not in str(caught.value).split("hint")[0]   # v(in) = 1 V is determined
    partial = caught.value.partial
    assert partial is None or partial.time.size <= 1              # nothing after t = 0


def test_enumeration_refuses_a_face_along_which_free_unknowns_vary():
    from circuitnsds.solvers import LCPSolverFailure
    from circuitnsds.solvers.enumeration import enumerate_mlcp
    # u0 + u1 = 1, no pairs: a line of solutions
    K = np.array([[1.0, 1.0], [1.0, 1.0]])
    with pytest.raises(LCPSolverFailure) as caught:
        enumerate_mlcp(K, 2, np.array([-1.0, -1.0]))
    assert caught.value.reason == "undetermined"
    assert list(caught.value.undetermined) == [0, 1]


def test_enumeration_still_accepts_pairs_that_split_a_current():
    from circuitnsds.solvers.enumeration import enumerate_mlcp
    # node u fed 1 A, two ideal diodes from u to ground: u = 0, z1 + z2 = 1, split arbitrary
    K = np.array([[0.0, 1.0, 1.0], [-1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    x, active, _, _ = enumerate_mlcp(K, 1, np.array([-1.0, 0.0, 0.0]))
    assert x[0] == pytest.approx(0.0, abs=1e-9) and x[1] + x[2] == pytest.approx(1.0)
    assert x[1] >= -1e-12 and x[2] >= -1e-12


# --- item 9: what the ideal model leaves open is said ----------------------------------------

def test_ideal_diodes_in_parallel_are_warned_about_at_run():
    body = "V1 a 0 SIN(0 5 50)\nR1 a b 1k\nD1 b 0 dd\nD2 b 0 dd\n.model dd D\n.tran 100u 20m"
    with pytest.warns(CircuitWarning, match="d1, d2 are ideal .* in parallel from b to 0"):
        waves = circuit_from(body).transient()
    total = waves["i(d1)"] + waves["i(d2)"]                      # the sum is determined
    np.testing.assert_allclose(total, np.maximum(waves["v(a)"], 0) / 1e3, atol=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                           # with Ron they share: no warning
        circuit_from(body.replace(".model dd D", ".model dd D(Ron=1)")).transient()


CUT = """V1 in 0 1
R1 in a 1
L1 a b 1m
Vg g 0 PULSE(5 0 1m 1u 1u 10 20)
S1 b 0 g 0 sw
.model sw SW(VT=2.5 RON=0.01 ROFF=1e9)
.tran 1u 2m"""


def test_an_inductor_current_cut_in_one_step_is_warned_with_its_dirac_weight():
    # 1 V / 1.01 ohm = 0.990 A through 1 mH, cut when S1 opens at 1 ms: flux L·I = 0.99 mV·s
    with pytest.warns(CircuitWarning, match=r"current of l1 \(0\.99 A\) is cut in one step at "
                                            r"t = 0\.001\d* s.*L·ΔI = 0\.00099 V·s"):
        waves = circuit_from(CUT).transient()
    assert np.abs(waves["i(l1)"][-1]) < 1e-6                     # it was cut
    flux = waves.flux_impulse("L1")
    assert np.count_nonzero(flux) == 1 and flux.sum() == pytest.approx(-1e-3 / 1.01, rel=1e-3)
    assert waves.time[np.flatnonzero(flux)[0]] == pytest.approx(1e-3, abs=2e-6)
    with warnings.catch_warnings():                               # a freewheeling diode: no cut
        warnings.simplefilter("error", CircuitWarning)
        free = circuit_from(CUT + "\nD1 b a dd\n.model dd D").transient()
    assert free["i(l1)"][-1] > 0.1                                # still decaying through D1
    assert not free.flux_impulses and not free.flux_impulse("l1").any()


BURST = """V1 in 0 DC 10
Vctl ctl 0 PULSE(0 1 30u 1n 1n 20u 1)
S1 in a ctl 0 sw
R1 a b 0.1
L1 b c 1u
C1 c 0 1u
D1 0 b dfw
Rc c 0 1k
.model sw SW(VT=0.5 VH=0 RON=10m ROFF=1e6)
.model dfw D(Ron=1m)
.tran {step} 1m"""


def test_a_current_that_falls_smoothly_between_exact_rows_is_not_a_cut():
    # An LC tank rings while S1 is closed (30 to 50 us). When S1 opens at 50 us, L1 carries
    # 2.98 A; D1 takes it and the tank rings it down to zero in a quarter period
    # (pi/2 sqrt(LC) = 1.6 us), long before the next 100 us row.
    # The exact rows are the closed form at their instants (the same values as rows 20 ns
    # apart), so the step from 2.98 A to 0 is no cut: its mean voltage L·ΔI/Δt is 0.06 V in a
    # 10 V circuit (the cut above needs 990 V of a 1 V one). It was warned as a Dirac voltage.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fine = circuit_from(BURST.format(step="20n")).transient()
    released = np.flatnonzero(fine.time >= 50.002e-6)[0]
    assert fine["i(l1)"][released] > 2.9
    assert np.all(np.abs(fine["i(l1)"][fine.time > 52e-6]) < 1e-4)  # rung down through D1, no cut
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        coarse = circuit_from(BURST.format(step="100u")).transient()
    assert not [w for w in said if "is cut in one step" in str(w.message)]
    assert not coarse.flux_impulses
    common = np.isin(fine.time, coarse.time)
    assert np.count_nonzero(common) >= 10
    np.testing.assert_allclose(coarse["i(l1)"][np.isin(coarse.time, fine.time)], fine["i(l1)"][common],
                               rtol=1e-9, atol=1e-12)


def test_the_dirac_weight_survives_a_reported_grid_coarser_than_the_steps():
    # TSTEP 20 us cannot resolve the 10 kHz ripple: integrated finer, reported every 20 us;
    # the cut's flux is summed onto the reported point at or after it, not lost
    text = CUT.replace("V1 in 0 1", "V1 in 0 SIN(1 1m 10k)").replace(".tran 1u 2m", ".tran 20u 2m")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuit_from(text).transient()
    assert np.diff(waves.time).max() == pytest.approx(20e-6)
    flux = waves.flux_impulse("l1")
    assert np.count_nonzero(flux) == 1 and flux.sum() == pytest.approx(-1e-3 / 1.01, rel=2e-3)


def test_a_reported_grid_coarser_than_the_steps_samples_capacitor_currents():
    # TSTEP 50 us cannot resolve the 10 kHz source: integrated every 5 us, reported every
    # 50 us. Every reported signal is its value at the reported instant, so Kirchhoff's
    # current law holds at node b on each reported row (i(r1) = i(c1) + i(d1)) and i(c1) is
    # the current of the run at 5 us sampled there; it was ΔQ/Δt over the 50 us between
    # reported rows (half a period: the wrong sign, KCL off by 0.5 mA).
    text = """V1 a 0 SIN(0 1 10k)
R1 a b 1k
C1 b 0 10n
D1 b c dx
R2 c 0 1k
.model dx D(Vfwd=0.3 Ron=10)
.tran 50u 1m"""
    with pytest.warns(Warning, match="reported every TSTEP"):
        coarse = circuit_from(text).transient()
    fine = circuit_from(text).transient(step=5e-6)
    assert np.diff(coarse.time).max() == pytest.approx(50e-6)
    kcl = coarse["i(r1)"] - coarse["i(c1)"] - coarse["i(d1)"]
    assert np.abs(kcl).max() < 1e-12
    rows = np.searchsorted(fine.time, coarse.time)
    np.testing.assert_array_equal(fine.time[rows], coarse.time)
    np.testing.assert_allclose(coarse["i(c1)"], fine["i(c1)"][rows], rtol=0, atol=1e-15)


def test_capacitor_current_obeys_kcl_on_the_rows_of_split_steps():
    # a relaxation oscillator: S1 discharges C1 whenever v(b) exceeds 2.25 V, down to 1.75 V
    # (10 ohm x 1 uF: within a 10 us step). Each step with a located switching is split and
    # its grid point holds the state of the last part; i(c1) there was ΔQ/Δt over the whole
    # step while i(r1) and i(s1) were those at the point: KCL at b off by 0.21 A.
    waves = circuit_from("V1 a 0 SIN(0 5 1k)\nR1 a b 100\nC1 b 0 1u\nS1 b 0 b 0 sw\n"
                         ".model sw SW(Vt=2 Vh=0.5 Ron=10 Roff=1e6)\n.tran 10u 2m").transient()
    assert waves.stats["events"] >= 10
    kcl = waves["i(r1)"] - waves["i(c1)"] - waves["i(s1)"]
    assert np.abs(kcl).max() < 1e-9
