"""IGBTs and thyristors (``Z`` lines with ``IGBT``/``SCR`` models): a controlled switch in series
with the on-state diode ``V0 + r·i`` (see circuitnsds/circuit/elements/power.py).

Expected values are closed forms of the circuits: the resistive chopper's on-state current
``(Vin - VCESAT)/(R + RON)``, the half-wave controlled rectifier's mean load voltage
``Vm·(1 + cos α)/(2π)`` (ideal device) and its conduction interval ``[α, π]``, and with
an R-L load the current's closed form up to its extinction angle β past π. ngspice has no
IGBT or thyristor primitive (its libraries model both as subcircuits of its own devices,
whose answers depend on those devices' Shockley curves), so no test here compares with it.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.cli.info import circuit_report
from circuitnsds.errors import NetlistError
from tests.conftest import NETLISTS, circuit_from

VIN, LOAD, VCESAT, RON = 100.0, 10.0, 1.5, 0.05


def chopper(model: str = f"VT=5 VCESAT={VCESAT} RON={RON}", source: str = f"DC {VIN}") -> str:
    """A low-side IGBT switching a resistive load (gate 15 V for 5 µs of each 10 µs)."""
    return (f"V1 in 0 {source}\nVG g 0 PULSE(0 15 0 1n 1n 5u 10u)\nRL in c {LOAD}\n"
            f"Z1 c g 0 igbt\n.model igbt IGBT({model})")


def test_igbt_chopper_on_state_is_vcesat_plus_ron_i():
    waves = circuit_from(chopper()).transient(10e-9, 40e-6)
    time, current, vce = waves["time"], waves["i(z1)"], waves["v(c)"]
    on = (time % 10e-6 > 0.5e-6) & (time % 10e-6 < 4.5e-6)
    off = (time % 10e-6 > 5.5e-6) & (time % 10e-6 < 9.5e-6)
    expected = (VIN - VCESAT) / (LOAD + RON)
    np.testing.assert_allclose(current[on], expected, rtol=1e-9)
    np.testing.assert_allclose(vce[on], VCESAT + RON * expected, rtol=1e-9)
    np.testing.assert_allclose(vce[off], VIN, rtol=1e-9)
    assert np.all(np.abs(current[off]) < 1e-9)


def test_igbt_current_cannot_reverse_without_its_antiparallel_diode():
    # the load's supply reverses (a 10 V, 50 kHz sine) while the gate holds the IGBT on
    body = chopper(source="SIN(0 10 50k)").replace("PULSE(0 15 0 1n 1n 5u 10u)", "DC 15")
    waves = circuit_from(body).transient(10e-9, 40e-6)
    current, supply = waves["i(z1)"], waves["v(in)"]
    assert current.min() > -1e-9  # reverse bias: only the 1e-12 S leakage
    forward = supply > VCESAT + 0.1
    np.testing.assert_allclose(current[forward], (supply[forward] - VCESAT) / (LOAD + RON), rtol=1e-9)
    # with a co-pack diode VFD=0.8, RFD=20m the reverse current flows through it
    copack = circuit_from(body.replace("RON=0.05", "RON=0.05 VFD=0.8 RFD=20m")).transient(10e-9, 40e-6)
    reverse = copack["v(in)"] < -0.9
    expected = (copack["v(in)"][reverse] + 0.8) / (LOAD + 0.02)
    np.testing.assert_allclose(copack["i(z1.dfree)"][reverse], -expected, rtol=1e-9)
    assert copack["i(z1)"][reverse].min() > -1e-9


def scr_rectifier(alpha: float, period: str = "20m", model: str = "IGT=10m") -> str:
    """A 100 V, 50 Hz half-wave controlled rectifier into 10 Ω, fired at ``alpha`` [rad]
    by a 5 V, 100 µs gate pulse through 100 Ω (43 mA) every ``period``."""
    fire = alpha / (2 * math.pi * 50)
    return (f"V1 in 0 SIN(0 100 50)\nRL in a 10\nZ1 a g 0 scr\nVG gd 0 PULSE(0 5 {fire!r} 1n 1n 100u "
            f"{period})\nRG gd g 100\n.model scr SCR({model})")


@pytest.mark.parametrize("degrees", [30, 60, 90, 135])
def test_thyristor_half_wave_mean_is_vm_1_plus_cos_alpha_over_2pi(degrees):
    alpha = math.radians(degrees)
    waves = circuit_from(scr_rectifier(alpha)).transient(1e-6, 40e-3)
    time, load = waves["time"], waves["v(in)"] - waves["v(a)"]
    second = time >= 20e-3
    mean = np.trapezoid(load[second], time[second]) / 20e-3
    # the firing instant is a grid point of the gate pulse; the step is 1 µs of 20 ms
    assert mean == pytest.approx(100 * (1 + math.cos(alpha)) / (2 * math.pi), rel=2e-4)


def test_thyristor_latches_after_its_gate_pulse_and_turns_off_at_current_zero():
    alpha = math.radians(60)
    # one gate pulse only (period 1 s): the second positive half-cycle must stay blocked
    waves = circuit_from(scr_rectifier(alpha, period="1")).transient(1e-6, 40e-3)
    time, current = waves["time"], waves["i(z1)"]
    phase = (2 * math.pi * 50 * time)
    first = (phase > alpha + 0.01) & (phase < math.pi - 0.01)
    np.testing.assert_allclose(current[first], 10 * np.sin(phase[first]), rtol=1e-9)
    assert np.all(waves["i(z1.gate)"][first & (time > 3.4833e-3 + 2e-6)] == 0)  # latched, no gate
    after = (time > 10.01e-3) & (time < 40e-3)
    assert np.all(np.abs(current[after]) < 1e-9)  # off at the current zero and never re-fired
    # off at the zero crossing: the last conducting step is within one step of t = 10 ms
    conducting = time[current > 1e-6]
    assert conducting.max() == pytest.approx(10e-3, abs=1.01e-6)


def test_thyristor_on_state_drop_and_holding_current():
    # VON + RON·i while conducting; IH = 5 mA turns it off when the anode current falls to 5 mA
    waves = circuit_from(scr_rectifier(math.radians(30), model="IGT=10m IH=5m VON=1 RON=0.1")
                         ).transient(1e-6, 20e-3)
    time, current, vak = waves["time"], waves["i(z1)"], waves["v(a)"]
    conducting = current > 1e-6
    np.testing.assert_allclose(vak[conducting], 1 + 0.1 * current[conducting], rtol=1e-9)
    phase_off = math.pi - math.asin((1 + 5e-3 * 10.1) / 100)  # 100 sin θ = 1 + 5 mA·(10 + 0.1)
    assert time[conducting].max() == pytest.approx(phase_off / (2 * math.pi * 50), abs=1.01e-6)


def test_info_names_igbts_and_thyristors():
    text, ok = circuit_report(circuit_from(chopper("VT=5 VCESAT=1.5 VFD=0.8") + "\n.tran 1u 2u"))
    assert ok
    assert "IGBTs (1): z1" in text
    assert "IGBT (collector c, gate g, emitter 0)" in text
    assert "antiparallel diode z1.dfree" in text and "tail current is not modelled" in text
    text, ok = circuit_report(circuit_from(scr_rectifier(1.0) + "\n.tran 1u 2u"))
    assert ok
    assert "thyristors (SCR) (1): z1" in text
    assert "thyristor (anode a, gate g, cathode 0)" in text
    assert "closes above 0.01 A, opens below 1e-09 A" in text


@pytest.mark.parametrize(
    ("body", "pattern"),
    [
        ("Z1 c g 0 m\n.model m IGBT(VCESAT=1)", r"VT is required"),
        ("Z1 c g 0 m\n.model m IGBT(RON=1)", r"VT and VCESAT are required"),
        ("Z1 a g 0 m\n.model m SCR(VON=1)", r"IGT is required"),
        ("Z1 a g 0 m\n.model m SCR(IGT=1m IH=5m)", r"above the holding current"),
        ("Z1 c g 0 m\n.model m IGBT(VT=5 VCESAT=1 BOGUS=2)", r"unknown parameter 'bogus'"),
        ("Z1 c g 0 m\n.model m IGBT(VT=5 VCESAT=-1)", r"VCESAT=-1 must be non-negative"),
        ("Z1 c g 0 nomodel", r"z1: IGBT or SCR model 'nomodel' is not defined"),
        ("Z1 d g s m\n.model m NMF(VTO=-2)", r"not an IGBT or SCR model.*MESFETs"),
        ("Z1 c g 0 m extra\n.model m IGBT(VT=5 VCESAT=1)", r"unexpected 'extra'"),
    ],
)
def test_power_device_errors_name_the_line(body, pattern):
    with pytest.raises(NetlistError, match=pattern) as caught:
        circuit_from(body)
    assert ":2:" in str(caught.value) or ":3:" in str(caught.value)


def test_shipped_netlists_run_to_their_closed_forms():

    chopper_waves = circuitnsds.read_netlist(NETLISTS / "power" / "igbt_chopper.cir").transient()
    assert chopper_waves["i(z1)"].max() == pytest.approx((48 - 1.7) / (4 + 0.02), rel=1e-9)
    rectifier = circuitnsds.read_netlist(NETLISTS / "power" / "thyristor_rectifier.cir").transient()
    time, load = rectifier["time"], rectifier["v(out)"]
    last = time >= time[-1] - 20e-3
    mean = np.trapezoid(load[last], time[last]) / 20e-3
    assert mean == pytest.approx(325 * (1 + math.cos(math.radians(45))) / (2 * math.pi), rel=5e-4)


def test_compare_refuses_a_z_line_that_ngspice_would_read_as_a_mesfet():
    from circuitnsds.compare.translate import translate_netlist

    with pytest.raises(NetlistError, match=r"z1: ngspice 39 has no IGBT or thyristor device"):
        translate_netlist(f"t\n{chopper()}\n.tran 1u 2u\n.end\n")


def test_igbt_loss_row_is_its_on_state_line_and_thermal_reaches_its_switch(tmp_path):
    from circuitnsds.output.measure import losses, mean
    from tests.test_thermal_losses import SWITCH_XML

    waves = circuit_from(chopper()).transient(10e-9, 40e-6)
    table = losses(waves, circuit_from(chopper()), outputs=("rl",))
    rows = {row.element: row for row in table.rows}
    assert "z1.on" not in rows  # its power is in z1's row
    current = waves["i(z1)"]
    expected = mean(waves.time, VCESAT * current + RON * current**2, 0, 40e-6)
    assert rows["z1"].power == pytest.approx(expected, rel=1e-6)
    (tmp_path / "igbt.xml").write_text(SWITCH_XML)
    (tmp_path / "c.cir").write_text(f"t\n{chopper()[:-1]} thermal=\"igbt.xml\")\n.tran 10n 40u\n.end\n")
    circuit = circuitnsds.read_netlist(tmp_path / "c.cir")
    assert circuit.element("z1").model.thermal == str(tmp_path / "igbt.xml")


@settings(max_examples=25, deadline=None)
@given(vcesat=st.floats(0.0, 3.0), ron=st.floats(0.0, 1.0), supply=st.floats(-500.0, 500.0),
       load=st.floats(1.0, 100.0))
def test_igbt_conducts_its_on_state_line_forward_and_nothing_reverse(vcesat, ron, supply, load):
    body = (f"V1 in 0 {supply!r}\nVG g 0 15\nRL in c {load!r}\nZ1 c g 0 igbt\n"
            f".model igbt IGBT(VT=5 VCESAT={vcesat!r} RON={ron!r})")
    current = circuit_from(body).transient(1e-6, 2e-6)["i(z1)"][-1]
    if supply > vcesat:
        assert current == pytest.approx((supply - vcesat) / (load + ron), rel=1e-9, abs=1e-9)
    else:  # blocked: at most the leakage of the two 1e-12 S off-resistances
        assert abs(current) <= abs(supply) * 1e-12 + 1e-12


def test_thyristor_with_an_inductive_load_conducts_past_the_voltage_zero_until_its_current_zero():
    # i(θ) = Vm/Z·(sin(θ − φ) − sin(α − φ)·e^(−(θ − α)/tan φ)) from the firing angle α to the
    # extinction angle β where it is zero again (past π: the inductor drives it on)
    from scipy.optimize import brentq

    vm, resistance, inductance, omega = 100.0, 10.0, 20e-3, 2 * math.pi * 50
    impedance, phi = math.hypot(resistance, omega * inductance), math.atan2(omega * inductance, resistance)
    alpha = math.radians(60)

    def current(theta):
        return vm / impedance * (math.sin(theta - phi)
                                 - math.sin(alpha - phi) * math.exp(-(theta - alpha) / math.tan(phi)))

    beta = brentq(current, math.pi, 2 * math.pi - 1e-9)  # 211.7°
    body = scr_rectifier(alpha).replace("RL in a 10", f"RL in m {resistance}\nLL m a {inductance}")
    waves = circuit_from(body).transient(1e-6, 40e-3)
    time, anode = waves["time"], waves["i(z1)"]
    second = time >= 20e-3
    assert time[(anode > 1e-6) & second].max() == pytest.approx(20e-3 + beta / omega, abs=1.01e-6)
    load = waves["v(in)"] - waves["v(a)"]
    mean = np.trapezoid(load[second], time[second]) / 20e-3
    assert mean == pytest.approx(vm * (math.cos(alpha) - math.cos(beta)) / (2 * math.pi), rel=2e-4)
    theta = omega * time[second] % (2 * math.pi)
    inside = (theta > alpha + 0.01) & (theta < beta - 0.01)
    expected = np.array([current(x) for x in theta[inside]])
    np.testing.assert_allclose(anode[second][inside], expected, atol=5e-4 * vm / impedance)
