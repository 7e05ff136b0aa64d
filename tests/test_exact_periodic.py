"""The periodic orbit of the exact period map (issue 31): Newton with the exact monodromy,
saltation at every located event (a DCM diode's turn-off included)."""

from __future__ import annotations

import numpy as np

import circuitnsds
from circuitnsds.analyses.operating_point import operating_point, uic_state
from circuitnsds.engine.exact.periodic import period_map, periodic_orbit
from circuitnsds.engine.exact.run import ExactSystem
from tests.conftest import NETLISTS

BENCHMARKS = NETLISTS.parent / "benchmarks" / "netlists"


def _finite_difference_monodromy(mlcs, orbit, period: float = 10e-6) -> np.ndarray:
    """The period map's derivative at the orbit by forward differences (1e-6 of each state)."""
    system = ExactSystem(mlcs)
    base = period_map(system, 0.0, period, orbit.x, orbit.active, orbit.closed)[0]
    differences = np.zeros_like(orbit.monodromy)
    for j in range(orbit.x.size):
        step = np.zeros(orbit.x.size)
        step[j] = 1e-6 * max(1.0, abs(orbit.x[j]))
        moved = period_map(system, 0.0, period, orbit.x + step, orbit.active, orbit.closed)[0]
        differences[:, j] = (moved - base) / step[j]
    return differences


def _orbit(path):
    circuit = circuitnsds.read_netlist(path)
    mlcs = circuit.mlcs()
    start = operating_point(circuit, mlcs)
    active = np.zeros(mlcs.m, bool) if start.active is None else np.asarray(start.active, bool)
    return mlcs, periodic_orbit(mlcs, 0.0, 10e-6, start.y, active, tuple(start.switches))


def test_the_boosts_exact_orbit_has_the_mean_output_of_the_issue():
    # issue 31: the exact orbit's mean v(out) is 23.839697 V (a peer: 5e-7 V off; implicit
    # Euler's pss: 2.1e-3 V off); Newton from the operating point takes two steps
    mlcs, orbit = _orbit(NETLISTS / "boost_converter.cir")
    assert abs(orbit.means[mlcs.unknowns.index("v(out)")] - 23.839697) < 1e-6
    assert len(orbit.residuals) <= 3 and orbit.residuals[-1] < 1e-12


def test_the_monodromy_is_the_derivative_of_the_period_map_with_saltation():
    # Peak-current mode (the bundled netlist, no slope compensation): S1 opens when i(L1)
    # reaches 2.2 A, an instant that moves with the state, where the state's derivative
    # jumps: the saltation there is what makes Φ the derivative of the period map (without
    # it Newton stalls at a residual of 1.19). Checked against finite differences of the map.
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_peak_current.cir")
    mlcs = circuit.mlcs()
    start = uic_state(circuit, mlcs)
    orbit = periodic_orbit(mlcs, 0.0, 10e-6, start.y, np.zeros(mlcs.m, bool), tuple(start.switches),
                           warm_periods=20)
    assert orbit.residuals[-1] < 1e-12
    differences = _finite_difference_monodromy(mlcs, orbit)
    assert np.max(np.abs(differences - orbit.monodromy)) < 1e-4 * np.max(np.abs(orbit.monodromy))
    # above 50 % duty without slope compensation the period-1 orbit is unstable (the
    # subharmonic instability of peak-current control): a multiplier outside the unit circle
    assert np.max(np.abs(np.linalg.eigvals(orbit.monodromy))) > 1.5


def test_a_dcm_boosts_orbit_converges_quadratically_with_its_inductor_reset():
    # in DCM the inductor's current is 0 at the end of each period whatever the start: a
    # Floquet multiplier 0
    mlcs, orbit = _orbit(BENCHMARKS / "boost_dcm.cir")
    multipliers = np.sort(np.abs(np.linalg.eigvals(orbit.monodromy)))
    assert multipliers[0] < 1e-9 and 0.9 < multipliers[1] < 1
    assert orbit.residuals[-1] < 1e-11 and orbit.residuals[-2] < 1e-5


def test_pss_with_method_exact_is_the_exact_orbit_and_ac_runs_around_it():
    text = (NETLISTS / "boost_converter.cir").read_text().replace(".end", ".options method=exact\n.end")
    circuit = circuitnsds.read_netlist(text)
    result = circuit.pss()
    assert "on the exact period map" in result.summary()
    assert abs(result.means["v(out)"] - 23.839697) < 1e-6
    assert result.state_names == ["v(out)", "i(l1)"] and result.relative_residual < 1e-12
    # the rows of the period are the exact stepper's from the orbit: periodic to round-off
    v = np.asarray(result.waveforms["v(out)"])
    assert abs(v[-1] - v[0]) < 1e-12 and 23.7 < v.min() < v.max() < 24.0
    # the implicit-Euler shooting's multipliers at the netlist's step are close to the exact ones
    theta = circuitnsds.read_netlist(NETLISTS / "boost_converter.cir").pss()
    assert np.max(np.abs(np.abs(theta.multipliers) - np.abs(result.multipliers))) < 1e-3
    # ac around it runs on the orbit's segments (tests/test_exact_ac.py): near the θ-based ac
    # at a frequency far below the switching (where implicit Euler's warping is small)
    exact_ac = circuit.ac(input="vin", outputs="v(out)", frequencies=[1e3], pss=result)
    theta_ac = circuitnsds.read_netlist(NETLISTS / "boost_converter.cir").ac(
        input="vin", outputs="v(out)", frequencies=[1e3], pss=theta)
    assert exact_ac.around == "pss"
    ratio = exact_ac.transfer["v(out)"][0] / theta_ac.transfer["v(out)"][0]
    assert abs(20 * np.log10(abs(ratio))) < 0.1 and abs(np.degrees(np.angle(ratio))) < 1.0
    # (method=auto shoots on this map too: tests/test_pss.py)


def test_a_ramp_comparators_saltation_counts_the_ramps_own_slope():
    # Voltage-mode loop (tests/test_ac_pwm.py's closed-loop buck): S1 opens where the control
    # 0.2·(3 V − v(out)) meets a 0..1 V ramp. The event function moves with the state and with
    # time by itself (the ramp), so the saltation's rate is ∇g·f⁻ + ∂g/∂t; with ∇g·f⁻ alone
    # the monodromy was wrong and Newton stalled at a residual of 1.25 after 30 steps.
    from tests.test_ac_pwm import buck, read

    circuit = read(buck(loop=True))
    mlcs = circuit.mlcs()
    start = uic_state(circuit, mlcs)
    orbit = periodic_orbit(mlcs, 0.0, 10e-6, start.y, np.zeros(mlcs.m, bool), tuple(start.switches),
                           warm_periods=5)
    assert orbit.residuals[-1] < 1e-12 and len(orbit.residuals) <= 6
    differences = _finite_difference_monodromy(mlcs, orbit)
    assert np.max(np.abs(differences - orbit.monodromy)) < 1e-6 * np.max(np.abs(orbit.monodromy))
