"""Periodic steady state through smooth nonlinear elements (analyses/pss_smooth.py): the
finite-difference shooting on the Newton stepper against the last period of long transients
of the same circuits, the fixed point it claims, and its clear failure."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from circuitnsds.analyses.operating_point import operating_point
from circuitnsds.analyses.pss import _plain_transient, _whole_grid
from circuitnsds.engine.stepper import StartState
from circuitnsds.errors import CircuitWarning, SimulationError
from tests.conftest import circuit_from

# an RC driven by a SIN into a Shockley-law current sink behind 50 Ω: conducting on the
# positive half-waves (14 mA peak), linear (τ = 100 Ω ∥ 1 kΩ · 20 µF = 1.82 ms) otherwise
DIODE_RC = ("vin in 0 sin(0 20 1k)\nr1 in x 100\nc1 x 0 20u\nr3 x d 50\n"
            "g1 d 0 cur={1e-12*(exp(v(d)/0.025)-1)}\nr2 x 0 1k\n.tran 10u 2m")


def _quiet(function, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (the Newton stepper's run note)
        return function(*args, **kwargs)


def test_the_diode_law_rc_settles_to_the_last_period_of_a_long_transient():
    # before: pss refused every circuit with a smooth relation ("pss cannot run through ...")
    result = _quiet(circuit_from(DIODE_RC).pss)
    assert result.relative_residual <= 1e-9
    assert result.state_names == ["v(x)"]
    assert result.iterations >= 1  # the operating point is not on the orbit: shooting worked
    # the same implicit-Euler steps on the same grid, 30 periods from the operating point
    # (e^-25 of the start left): the orbit is their last period to the shooting's tolerance
    circuit = circuit_from(DIODE_RC)
    mlcs = circuit.mlcs()
    start = operating_point(circuit, mlcs)
    run = _quiet(_plain_transient, mlcs, _whole_grid(mlcs, 10e-6, 30e-3),
                 StartState(start.y, start.charge, None, start.active, start.switches))
    for signal in ("v(x)", "v(d)"):
        column = mlcs.unknowns.index(signal)
        settled = np.interp(result.waveforms.time + 29e-3, run.time, run.y[:, column])
        error = np.abs(result.waveforms[signal] - settled).max() / np.abs(settled).max()
        assert error < 1e-7, (signal, error)
    # the transient of the command line (steps of its own length by truncation error): the
    # same to the implicit-Euler step's error (measured 6.2e-4)
    transient = _quiet(circuit_from(DIODE_RC).transient, stop=30e-3)
    settled = np.interp(result.waveforms.time + 29e-3, transient.time, transient["v(x)"])
    assert np.abs(result.waveforms["v(x)"] - settled).max() < 2e-3 * np.abs(settled).max()
    # the multiplier of a period: the linear RC's over its 100 implicit-Euler steps,
    # (1 + h/τ)^-100 = 0.578, shortened by the conducting half-waves
    largest = float(np.abs(result.multipliers).max())
    assert 0.1 < largest < 0.95 * (1.0 + 10e-6 / (1e5 / 1.1e3 * 20e-6)) ** -100
    # the orbit repeats: its first and last points are the same state
    assert result.waveforms["v(x)"][0] == pytest.approx(result.waveforms["v(x)"][-1], abs=1e-9)
    assert "finite-difference" in result.summary() and "periods run" in result.summary()


def test_a_shooting_that_does_not_settle_fails_clearly_instead_of_returning_its_best():
    with pytest.raises(SimulationError, match=r"periodic steady state was not found.*Newton stepper"):
        _quiet(circuit_from(DIODE_RC).pss, max_iterations=0)


def test_the_cli_runs_pss_through_a_smooth_element(tmp_path):
    from circuitnsds.cli.main import main

    netlist = tmp_path / "diode_rc.cir"
    netlist.write_text("diode law rc\n" + DIODE_RC + "\n.end\n")
    output = tmp_path / "out.csv"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        status = main(["pss", str(netlist), "-o", str(output)])
    assert status == 0
    header = output.read_text().splitlines()[0].lower()
    assert "v(x)" in header and "v(d)" in header


def test_ac_around_a_smooth_pss_is_refused_in_words_that_fit_it():
    # before this module, the refusal blamed .options method=exact, which the circuit never set
    from circuitnsds.errors import CircuitError

    with pytest.raises(CircuitError, match=r"through smooth nonlinear elements.*no step maps"):
        _quiet(circuit_from(DIODE_RC).ac, around="pss", input="vin", outputs="v(x)",
               frequencies=[1e3])


def test_the_npn_switch_with_a_collector_capacitor_recharges_as_the_rc_closed_form():
    # q1's junction charges make v(b) a state beside v(c); while q1 is off (vin = 0 from 12 µs)
    # cl recharges through rl: implicit Euler's v(c)_k = 5 − (5 − v(c)_0)(1 + h/τ)^-k, τ = 10 µs,
    # to q1's 1 pF collector capacitance (measured 1.0e-4 V)
    netlist = ("vcc vcc 0 5\nrl vcc c 1k\ncl c 0 10n\nvin in 0 pulse(0 5 0 1u 1u 10u 20u)\n"
               "rb in b 10k\nq1 c b 0 qn\n.model qn npn(is=1e-14 bf=100 cje=2p cjc=1p tf=1n)\n"
               ".tran 0.1u 40u")
    result = _quiet(circuit_from(netlist).pss, period=20e-6)
    assert result.state_names == ["v(c)", "v(b)"]
    time, v_c = result.waveforms.time, result.waveforms["v(c)"]
    first = int(np.searchsorted(time, 13e-6))
    steps = np.arange(time.size - first)
    closed_form = 5.0 - (5.0 - v_c[first]) * (1.0 + 0.1e-6 / 10e-6) ** -steps
    assert np.abs(v_c[first:] - closed_form).max() < 5e-4
    assert v_c[np.searchsorted(time, 8e-6)] < 0.2  # saturated while driven
    assert v_c[0] == pytest.approx(v_c[-1], abs=1e-9)


def test_an_unstable_orbit_is_warned_about_and_its_multiplier_is_the_closed_form():
    # g1 feeds 2 mS (and a cubic term, 1e-6 of it at 1 V) back into c1 against r1's 1 mS: a net
    # −1 mS on 1 µF grows by 1/(1 − h/τ) per implicit-Euler step, τ = 1 ms, h = 10 µs:
    # 0.99^-100 = 2.732 per period; Newton still finds the (small, unstable) periodic orbit
    netlist = ("vin in 0 sin(0 1 1k)\nr1 in x 1k\nc1 x 0 1u\n"
               "g1 0 x cur={2e-3*v(x)+1e-6*v(x)*v(x)*v(x)}\n.tran 10u 2m")
    with pytest.warns(CircuitWarning, match=r"not stable.*2\.73"):
        result = circuit_from(netlist).pss()
    assert float(np.abs(result.multipliers).max()) == pytest.approx(0.99**-100, rel=1e-4)
