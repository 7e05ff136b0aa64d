"""Dirac currents (state jumps) and the order of the θ-method."""

import math

import numpy as np
import pytest

from tests.conftest import circuit_from

STEP_CHARGE = """V1 in 0 PULSE(0 5 1m 0 0 1 2)
D1 in out ideal
C1 out 0 1u
R1 out 0 1meg
.model ideal D
.tran {h} 2m"""


@pytest.mark.parametrize("h", [1e-5, 1e-6])
def test_capacitor_charged_through_ideal_diode_jumps_in_one_step(h):
    waves = circuit_from(STEP_CHARGE.format(h=h)).transient()
    t, v = waves.time, waves["v(out)"]
    edge = np.flatnonzero(t > 1e-3)[0]  # first step after the source edge
    assert v[edge - 1] == pytest.approx(0.0, abs=1e-9)
    assert v[edge] == pytest.approx(5.0, rel=1e-5)  # the whole jump in one step
    impulse = waves.impulse("d1")
    # the Dirac's weight is the charge C*dV, whatever the step (leakage over one step aside)
    assert impulse[edge] == pytest.approx(1e-6 * 5.0, rel=1e-4)
    assert waves["i(d1)"][edge] == pytest.approx(impulse[edge] / h, rel=1e-6)
    # charge conservation over the whole run: diode charge = capacitor charge + leaked charge
    leaked = np.sum(v[1:] / 1e6 * np.diff(t))
    assert impulse.sum() == pytest.approx(1e-6 * v[-1] + leaked, rel=1e-6)


def rc_sine_error(h: float, theta: float) -> float:
    R, C, f = 1e3, 1e-6, 200.0
    tau, w = R * C, 2 * math.pi * f
    waves = circuit_from(f"V1 in 0 SIN(0 1 {f})\nR1 in out {R}\nC1 out 0 {C}\n"
                         f".tran {h} 5m uic").transient(theta=theta, method="theta")  # θ's order, pinned
    t = waves.time
    wt = w * tau
    exact = (np.sin(w * t) - wt * np.cos(w * t) + wt * np.exp(-t / tau)) / (1 + wt**2)
    return float(np.max(np.abs(waves["v(out)"] - exact)))


@pytest.mark.parametrize(("theta", "order"), [(1.0, 1.0), (0.5, 2.0)])
def test_convergence_order_on_a_smooth_circuit(theta, order):
    errors = [rc_sine_error(h, theta) for h in (4e-5, 2e-5, 1e-5)]
    rates = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    for rate in rates:
        assert rate == pytest.approx(order, abs=0.15), (errors, rates)


@pytest.mark.parametrize("theta", [1.0, 0.5])
def test_no_ringing_after_a_source_corner(theta):
    # C1 across an ideal source that ramps up in 10 us and falls in 1 us: the source current
    # is C·dV/dt + V/R (KCL at a: -i(v1) = i(c1) + i(r1) at every row). With θ = 0.5 and no
    # restart at the source's corners, the trapezoidal rule carried the slope before each
    # corner into the next step: -i(v1) alternated 0.0004 / 0.2005 A during the ramp (true
    # 0.1005) and ±2 A for ever after the fall (true 0). ngspice (method=trap) restarts with
    # backward Euler after a breakpoint and shows no ringing here.
    waves = circuit_from("V1 a 0 PULSE(0 1 100u 10u 1u 100u 1)\nC1 a 0 1u\nR1 a 0 1k\n"
                         ".tran 1u 400u").transient(theta=theta)
    source = -waves["i(v1)"]
    np.testing.assert_allclose(source, waves["i(c1)"] + waves["i(r1)"], rtol=0, atol=1e-9)
    during = (waves.time > 100.5e-6) & (waves.time < 109.5e-6)
    np.testing.assert_allclose(source[during], 0.1 + waves["v(a)"][during] / 1e3, rtol=1e-9)
    after = waves.time > 212e-6  # (the fall ends at 211 us)
    np.testing.assert_allclose(source[after], waves["v(a)"][after] / 1e3, rtol=0, atol=1e-12)
