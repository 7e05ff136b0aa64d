"""Ideal ``S``/``W`` switches: closed ``v = RON·i``, open ``i = v/ROFF``, ngspice hysteresis.

The switch closes when its control exceeds ``VT + VH`` and opens when it falls below
``VT - VH``; in between it keeps its state (initially its ``ON``/``OFF`` flag). A switch
whose control is a source's time function (a voltage source across its control nodes)
switches exactly at the threshold crossing, which is a grid point; a switch controlled by
anything else switches at the crossing located inside the step (tests/test_events.py).
"""


import numpy as np
import pytest

import circuitnsds
import circuitnsds.engine.integrate
from tests.conftest import NETLISTS, circuit_from

VIN, RSERIES = 10.0, 1e3


def divider(control: str, model: str, flag: str = "", extra: str = "") -> str:
    """V1 (10 V) -> R1 (1 kohm) -> node a -> S1 -> ground, S1 controlled by v(c)."""
    return (f"V1 in 0 {VIN}\nR1 in a {RSERIES}\nS1 a 0 c 0 sw {flag}\n{control}\n"
            f".model sw SW({model})\n{extra}")


def closed_values(ron: float) -> tuple[float, float]:
    return VIN * ron / (RSERIES + ron), VIN / (RSERIES + ron)


def open_values(roff: float) -> tuple[float, float]:
    return VIN * roff / (RSERIES + roff), VIN / (RSERIES + roff)


# --- static behaviour ---------------------------------------------------------------------------


@pytest.mark.parametrize("ron", [10.0, 0.5, 0.0])
def test_closed_switch_is_v_equals_ron_i(ron):
    waves = circuit_from(divider("Vc c 0 5", f"VT=2.5 VH=0.5 RON={ron} ROFF=1meg")).transient(1e-6, 5e-6)
    v, i = closed_values(ron)
    np.testing.assert_allclose(waves["v(a)"][1:], v, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(waves["i(s1)"][1:], i, rtol=1e-12)
    np.testing.assert_allclose(waves["v(a)"][1:], ron * waves["i(s1)"][1:], rtol=1e-12, atol=1e-13)
    if ron == 0:  # a perfect short: not merely small
        assert np.all(np.abs(waves["v(a)"][1:]) <= 1e-12)


@pytest.mark.parametrize("roff", [1e6, 1e12])
def test_open_switch_is_i_equals_v_over_roff(roff):
    model = f"VT=2.5 VH=0.5 RON=1 ROFF={roff}"
    waves = circuit_from(divider("Vc c 0 0", model)).transient(1e-6, 5e-6)
    v, i = open_values(roff)
    np.testing.assert_allclose(waves["v(a)"], v, rtol=1e-12)
    np.testing.assert_allclose(waves["i(s1)"], i, rtol=1e-9)
    op = circuit_from(divider("Vc c 0 0", model)).operating_point()
    assert op["i(s1)"] == pytest.approx(i, rel=1e-9)


def test_default_roff_is_one_over_gmin_and_gmin_option_changes_it():
    waves = circuit_from(divider("Vc c 0 0", "VT=1")).transient(1e-6, 3e-6)
    np.testing.assert_allclose(waves["i(s1)"], open_values(1e12)[1], rtol=1e-6)
    waves = circuit_from(divider("Vc c 0 0", "VT=1", extra=".options gmin=1e-6")).transient(1e-6, 3e-6)
    np.testing.assert_allclose(waves["i(s1)"], open_values(1e6)[1], rtol=1e-9)


def test_default_ron_is_one_ohm():
    waves = circuit_from(divider("Vc c 0 5", "VT=1")).transient(1e-6, 3e-6)
    np.testing.assert_allclose(waves["i(s1)"][1:], closed_values(1.0)[1], rtol=1e-12)


def test_operating_point_of_a_closed_switch():
    # The DC operating point must use the state the control imposes (ngspice iterates the
    # switch state with the DC solution): 5 V > VT + VH closes the switch.
    circuit = circuit_from(divider("Vc c 0 5", "VT=2.5 VH=0.5 RON=10 ROFF=1meg"))
    v, i = closed_values(10.0)
    op = circuit.operating_point()
    assert op["i(s1)"] == pytest.approx(i, rel=1e-9)
    assert op["v(a)"] == pytest.approx(v, rel=1e-9)
    waves = circuit.transient(1e-6, 3e-6)
    assert waves["i(s1)"][0] == pytest.approx(i, rel=1e-9)  # the t = 0 row is the operating point


def test_operating_point_keeps_the_on_flag_inside_the_band():
    # ON with the control between VT - VH and VT + VH: closed at the operating point too
    # (ngspice: MODEINITJCT puts it in HYST_ON, the DC iterations keep it there).
    op = circuit_from(divider("Vc c 0 2.5", "VT=2.5 VH=0.5 RON=10 ROFF=1meg", "ON")).operating_point()
    assert op["i(s1)"] == pytest.approx(closed_values(10.0)[1], rel=1e-9)


# --- hysteresis with a source-driven control: exact instants ------------------------------------


def closed_steps(waves, threshold: float = 1e-3) -> np.ndarray:
    """Whether the step ending at each grid point had the switch closed (from its current)."""
    return waves["i(s1)"] > threshold


def test_hysteresis_on_a_triangle_switches_exactly_at_vt_plus_vh_and_vt_minus_vh():
    # triangle 0 -> 5 V in 1 ms, back to 0 at 2 ms, twice; VT = 2.3, VH = 0.4:
    # closes at 2.7 V (t = 0.54 ms, 2.54 ms), opens at 1.9 V (t = 1.62 ms, 3.62 ms).
    # The step (70 us) puts none of these on the regular grid: they must be added.
    h = 70e-6
    body = divider("Vc c 0 PWL(0 0 1m 5 2m 0 3m 5 4m 0)", "VT=2.3 VH=0.4 RON=10 ROFF=1meg",
                   extra=f".tran {h} 4m")
    # (θ's grid: each crossing a point, the switch changing in the step after it; the exact
    # integrator locates the instant, to 1e-12 of it, on either side of the point: pinned)
    waves = circuit_from(body).transient(method="theta")
    t = waves.time
    crossings = [(0.54e-3, 1.62e-3), (2.54e-3, 3.62e-3)]
    for instant in np.ravel(crossings):
        assert np.min(np.abs(t - instant)) <= 1e-15, f"{instant} is not a grid point"
    expected = np.zeros(t.size, dtype=bool)
    for on, off in crossings:
        expected |= (t > on + 1e-15) & (t <= off + 1e-15)
    np.testing.assert_array_equal(closed_steps(waves), expected)
    # and the waveform values in each state
    v_closed, _ = closed_values(10.0)
    v_open, _ = open_values(1e6)
    np.testing.assert_allclose(waves["v(a)"], np.where(expected, v_closed, v_open), rtol=1e-12)
    # without hysteresis (VH = 0) both transitions happen at 2.3 V: 0.46 ms and 1.54 ms
    plain = circuit_from(body.replace("VH=0.4", "VH=0")).transient(method="theta")
    tp = plain.time
    first = tp[np.argmax(closed_steps(plain))]
    assert tp[np.searchsorted(tp, 0.46e-3 - 1e-15)] == pytest.approx(0.46e-3, abs=1e-15)
    assert tp[np.searchsorted(tp, first) - 1] == pytest.approx(0.46e-3, abs=1e-15)


def test_reversed_control_nodes_use_minus_the_source():
    # S1 a 0 0 c: the control is v(0) - v(c) = -v(c); v(c) falls 0 -> -5 V over 1 ms, so the
    # control rises through VT + VH = 2.7 V at 0.54 ms (exactly, as it is a source's function)
    body = (f"V1 in 0 {VIN}\nR1 in a {RSERIES}\nS1 a 0 0 c sw\nVc c 0 PWL(0 0 1m -5)\n"
            ".model sw SW(VT=2.3 VH=0.4 RON=10 ROFF=1meg)\n.tran 70u 1m")
    waves = circuit_from(body).transient()
    t = waves.time
    np.testing.assert_array_equal(closed_steps(waves), t > 0.54e-3 + 1e-15)
    assert np.min(np.abs(t - 0.54e-3)) <= 1e-15


@pytest.mark.parametrize(("flag", "closed"), [("ON", True), ("OFF", False), ("", False)])
def test_initial_flag_is_kept_while_the_control_stays_in_the_band(flag, closed):
    # v(c) = 2.5 V, band [2, 3]: the switch never leaves its initial state
    waves = circuit_from(divider("Vc c 0 2.5", "VT=2.5 VH=0.5 RON=10 ROFF=1meg", flag)
                         ).transient(1e-5, 1e-4)
    assert np.all(closed_steps(waves)[1:] == closed)


def test_on_flag_then_control_leaves_the_band_downwards():
    # ON, control inside the band until it falls through VT - VH = 2 V at t = 0.5 ms
    body = divider("Vc c 0 PWL(0 2.5 1m 1.5)", "VT=2.5 VH=0.5 RON=10 ROFF=1meg", "ON",
                   extra=".tran 30u 1m")
    waves = circuit_from(body).transient()
    t = waves.time
    np.testing.assert_array_equal(closed_steps(waves)[1:], (t <= 0.5e-3 + 1e-15)[1:])


def test_sine_driven_switch_changes_within_half_a_step_of_the_crossing():
    # A SIN control is the source's function too, but its crossings are not grid points:
    # each step takes the state of the control at its middle. 5 sin(2 pi 1k t) crosses
    # VT = 2.5 V upwards at 1/12 ms and downwards at 5/12 ms (then every 1 ms).
    h = 30e-6
    body = divider("Vc c 0 SIN(0 5 1k)", "VT=2.5 RON=10 ROFF=1meg", extra=f".tran {h} 2m")
    waves = circuit_from(body).transient(method="theta")  # (θ's rule: the step's middle, pinned)
    t = waves.time
    middle = 0.5 * (t[1:] + t[:-1])
    np.testing.assert_array_equal(closed_steps(waves)[1:], 5 * np.sin(2 * np.pi * 1e3 * middle) > 2.5)
    changes = t[np.flatnonzero(np.diff(closed_steps(waves).astype(int)))]  # starts of new states
    crossings = np.sort(np.concatenate([np.arange(2) * 1e-3 + 1e-3 / 12, np.arange(2) * 1e-3 + 5e-3 / 12]))
    assert changes.size == crossings.size
    assert np.all(np.abs(changes - crossings) <= h / 2 + 1e-15)


# --- state-controlled switches: at the located crossing -----------------------------------------


def replay_hysteresis(control: np.ndarray, on: float, off: float, initial: bool) -> np.ndarray:
    """The state at each grid point from the control there (independent of the code)."""
    states = np.zeros(control.size, dtype=bool)
    state = initial
    for k in range(control.size):
        if control[k] > on:
            state = True
        elif control[k] < off:
            state = False
        states[k] = state
    return states


def test_w_switch_controlled_by_the_current_of_a_zero_volt_source():
    # i(vsense) = v(in)/1k: triangle 0 -> 10 mA -> 0 over 2 ms. CSW IT = 5 mA, IH = 1 mA:
    # closes when i > 6 mA (analytic t = 0.6 ms), opens when i < 4 mA (t = 1.6 ms).
    h = 70e-6
    body = f"""V1 in 0 PWL(0 0 1m 10 2m 0)
Rsense in x 1k
Vsense x 0 0
V2 p 0 5
R2 p a 100
W1 a 0 Vsense wmod
.model wmod CSW(IT=5m IH=1m RON=1 ROFF=1meg)
.tran {h} 2m
"""
    waves = circuit_from(body).transient()
    np.testing.assert_allclose(waves["i(vsense)"], waves["v(in)"] / 1e3, rtol=1e-12, atol=1e-15)
    closed = waves["i(w1)"] > 1e-3
    np.testing.assert_array_equal(closed, replay_hysteresis(waves["i(vsense)"], 6e-3, 4e-3, False))
    # the control is linear in time: the located instants are the analytic ones
    assert waves.events == [(pytest.approx(0.6e-3, rel=1e-9), "w1", True),
                            (pytest.approx(1.6e-3, rel=1e-9), "w1", False)]
    np.testing.assert_allclose(waves["i(w1)"][closed], 5 / 101, rtol=1e-12)


def test_switch_controlled_by_a_circuit_node_switches_at_the_crossing():
    # v(c) charges through RC = 1 ms towards 10 V (UIC from 0): crosses VT = 3 V at
    # t* = RC·ln(10/7) = 0.3567 ms. The switch sits in another loop (it does not load c).
    h, rc = 10e-6, 1e-3
    body = f"""V1 in 0 10
R1 in c 1k
C1 c 0 1u
V2 p 0 5
R2 p a 100
S1 a 0 c 0 sw
.model sw SW(VT=3 RON=1 ROFF=1meg)
.tran {h} 1m uic
"""
    # (the crossing of θ's trajectory, interpolated in its step: pinned to θ; the exact
    # integrator's is rc·ln(10/7) itself)
    waves = circuit_from(body).transient(method="theta")
    t = waves.time
    closed = waves["i(s1)"] > 1e-3
    np.testing.assert_array_equal(closed, replay_hysteresis(waves["v(c)"], 3.0, 3.0, False))
    # the switching lies inside the step in which the simulated v(c) crosses 3 V ...
    k_cross = int(np.argmax(waves["v(c)"] > 3.0))
    (event,) = waves.switchings("s1", True)
    assert t[k_cross - 1] < event <= t[k_cross]
    # ... where the implicit Euler partial step from t[k-1] reaches 3 V exactly:
    # v(t_k-1 + τ) = (v_k-1 + τ/RC·10)/(1 + τ/RC)
    v_before = waves["v(c)"][k_cross - 1]
    tau = rc * (3.0 - v_before) / (10.0 - 3.0)
    assert event == pytest.approx(t[k_cross - 1] + tau, rel=1e-9)
    # and implicit Euler's crossing is within a step of the analytic one
    assert abs(event - rc * np.log(10 / 7)) <= h


def test_relaxation_oscillator_with_hysteresis():
    # C charged from 10 V through 10 kohm; S1 discharges it through 100 ohm while closed.
    # Closes above 6 V (VT = 4, VH = 2), opens below 2 V. Charging 2 -> 6 V takes
    # RC ln((10-2)/(10-6)); discharging towards 10·100/10100 V takes Rth·C ln((6-v∞)/(2-v∞)).
    h = 1e-6
    r, rd, c = 10e3, 100.0, 1e-7
    body = f"""V1 in 0 10
R1 in x {r}
C1 x 0 {c}
S1 x 0 x 0 sw
.model sw SW(VT=4 VH=2 RON={rd} ROFF=1e12)
.tran {h} 10m uic
"""
    waves = circuit_from(body).transient()
    t = waves.time
    closed = waves["i(s1)"] > 1e-3
    starts = t[np.flatnonzero(np.diff(closed.astype(int)) == 1)]
    stops = t[np.flatnonzero(np.diff(closed.astype(int)) == -1)]
    charge = r * c * np.log(8 / 4)
    rth = r * rd / (r + rd)
    v_inf = 10 * rd / (r + rd)
    discharge = rth * c * np.log((6 - v_inf) / (2 - v_inf))
    period = np.diff(starts)[2:]
    assert period.size >= 5  # it oscillates (about 14 periods in 10 ms)
    # each phase is detected within one step (plus implicit Euler's O(h) drift of the ramp)
    assert np.all(np.abs(period - (charge + discharge)) <= 3 * h + 0.01 * (charge + discharge))
    on_time = (stops[2:2 + period.size] - starts[2:2 + period.size])
    assert np.all(np.abs(on_time - discharge) <= 3 * h + 0.05 * discharge)
    assert waves["v(x)"][t > 2e-3].max() <= 6 + 10 * h / (r * c) * 10
    assert waves["v(x)"][t > 2e-3].min() >= 2 - 10 * h / (rth * c) * 6


# --- the three stepping paths agree ------------------------------------------------------------


def _run_paths(circuit, monkeypatch, stop, theta=1.0):
    # (the θ-method's stepping paths: pinned to θ)
    results = {path: circuit.transient(stop=stop, theta=theta, stepping=path, method="theta")
               for path in ("compiled", "numpy", "mlcp")}
    with monkeypatch.context() as patch:  # no dense step maps
        patch.setattr(circuitnsds.engine.integrate, "DENSE_MAP_LIMIT", 0)
        results["no dense map"] = circuit.transient(stop=stop, theta=theta, method="theta")
    return results


@pytest.mark.parametrize(("netlist", "stop", "theta"), [("buck_converter.cir", 0.3e-3, 1.0),
                                                         ("buck_converter.cir", 0.3e-3, 0.5),
                                                         ("bridge_rectifier.cir", 30e-3, 1.0),
                                                         ("cockcroft_walton.cir", 0.1, 1.0)])
def test_compiled_numpy_and_mlcp_paths_agree(monkeypatch, netlist, stop, theta):
    """The mode table (compiled and numpy), the sparse maps and one MLCP per step are one
    scheme: the same steps, restarts and modes, so the same numbers to rounding."""
    circuit = circuitnsds.read_netlist(NETLISTS / netlist)
    results = _run_paths(circuit, monkeypatch, stop, theta)
    assert results["compiled"].stats["mapped_steps"] > 0.2 * results["compiled"].stats["steps"]
    if netlist == "cockcroft_walton.cir":  # diodes at zero current: within the sign tolerance
        assert results["compiled"].stats["mapped_steps"] > 0.9 * results["compiled"].stats["steps"]
    assert results["numpy"].stats["mapped_steps"] == results["compiled"].stats["mapped_steps"]
    assert results["mlcp"].stats["mapped_steps"] == 0
    assert results["mlcp"].stats["mlcp_steps"] == results["mlcp"].stats["steps"]
    reference = results["compiled"]
    # where diodes sit at zero current on both sides, each path may settle such a pair on
    # either side within the sign tolerance (1e-7 of the terms that make up a value; for a
    # diode current the terms are C/h·v, 1000x the current): 3e-10 A of 4e-4 A, not 1e-9
    relative = 1e-6 if netlist == "cockcroft_walton.cir" else 1e-9
    for path in ("numpy", "no dense map", "mlcp"):
        other = results[path]
        np.testing.assert_array_equal(other.time, reference.time)
        for name in reference.names:
            scale = max(np.abs(reference[name]).max(), 1e-30)
            np.testing.assert_allclose(other[name], reference[name], rtol=0, atol=relative * scale,
                                       err_msg=f"{netlist}: {name} ({path} path)")


# --- errors ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("lines", "line", "words"),
    [
        ("S1 a 0 c 0 nomodel", 4, ["nomodel", "not defined"]),
        ("S1 a 0 c 0 wm\n.model wm CSW(IT=1m)", 4, ["wm", "sw model"]),
        ("W1 a 0 Vc sm\n.model sm SW(VT=1)", 4, ["sm", "csw model"]),
        ("S1 a 0 c 0 dm\n.model dm D", 4, ["dm", "diode"]),
        ("S1 a 0 c 0 sm\n.model sm SW(VT=1 VON=2)", 5, ["von", "unknown parameter"]),
        ("S1 a 0 c 0 sm\n.model sm SW(VT=1 IT=2)", 5, ["it", "unknown parameter"]),
        ("W1 a 0 Vc cm\n.model cm CSW(IT=1 VT=2)", 5, ["vt", "unknown parameter"]),
        ("S1 a 0 c 0 sm\n.model sm SW(VT=1 RON=-1)", 5, ["ron", "negative"]),
        ("S1 a 0 c 0 sm\n.model sm SW(VT=1 ROFF=0)", 5, ["roff", "positive"]),
        ("W1 a 0 Vx cm\n.model cm CSW(IT=1)", 4, ["vx", "not a voltage source"]),
        ("W1 a 0 R1 cm\n.model cm CSW(IT=1)", 4, ["r1", "not a voltage source"]),
        ("S1 a 0 c sm\n.model sm SW(VT=1)", 4, ["missing"]),
        ("S1 a 0 c 0 sm MAYBE\n.model sm SW(VT=1)", 4, ["maybe"]),
    ],
)
def test_switch_errors_name_the_line(lines, line, words):
    body = f"V1 in 0 1\nR1 in a 1k\n{lines}\nVc c 0 1"
    with pytest.raises(circuitnsds.NetlistError) as info:
        circuit_from(body)
    message = str(info.value).lower()
    assert f"<text>:{line}:" in message
    for word in words:
        assert word in message


def test_negative_hysteresis_is_taken_as_its_magnitude_with_a_warning():
    body = divider("Vc c 0 PWL(0 0 1m 5)", "VT=2.3 VH=-0.4 RON=10 ROFF=1meg", extra=".tran 70u 1m")
    with pytest.warns(circuitnsds.NetlistWarning, match="(?i)vh"):
        circuit = circuit_from(body)
    waves = circuit.transient()
    np.testing.assert_array_equal(closed_steps(waves), waves.time > 0.54e-3 + 1e-15)


def _buck_error(step: float, theta: float, reference) -> float:
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    waves = circuit.transient(step=step, stop=0.4e-3, theta=theta, method="theta")  # θ's order
    t_ref, v_ref = reference
    return float(np.max(np.abs(np.interp(t_ref, waves.time, waves["v(out)"]) - v_ref)))


@pytest.mark.parametrize(("theta", "order"), [(1.0, 1), (0.5, 2)])
def test_converter_convergence_order(theta, order):
    """Every switching instant of the buck converter is a grid point, so the θ-method keeps
    its order across them: halving the step divides the error by 2 (implicit Euler) or by
    4 (θ = 0.5, whose step after each switching is an implicit Euler restart, an O(h²) local
    error at a fixed number of instants)."""
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    fine = circuit.transient(step=0.1e-6 / 16, stop=0.4e-3, theta=theta, method="theta")
    reference = (fine.time, fine["v(out)"])
    errors = [_buck_error(h, theta, reference) for h in (0.2e-6, 0.1e-6)]
    ratio = errors[0] / errors[1]
    assert 0.8 * 2**order < ratio < 1.25 * 2**order, (errors, ratio)


def test_state_controlled_switch_paths_agree_at_theta_half(monkeypatch):
    """A switch controlled by a circuit voltage changes state at run time: with θ < 1 the
    step after it is an implicit Euler restart chosen in the loop, not from the schedule.
    The mode table, the numpy loop, the sparse maps and one MLCP per step must agree."""
    circuit = circuit_from("""V1 in 0 10
R1 in x 10k
C1 x 0 0.1u
S1 x 0 x 0 sw
D1 x y dd
R2 y 0 100k
C2 y 0 10n
.model sw SW(VT=4 VH=2 RON=100 ROFF=1e12)
.model dd D(Ron=10)
.tran 1u 5m uic""")
    results = _run_paths(circuit, monkeypatch, 5e-3, theta=0.5)
    reference = results["compiled"]
    closed = reference["i(s1)"] > 1e-3
    assert np.count_nonzero(np.diff(closed.astype(int)) == 1) >= 3  # it oscillates
    assert reference.stats["mapped_steps"] > 0.5 * reference.stats["steps"]
    # an MLCP step is accepted at a scaled residual of 1e-9 of the step matrix's row scale
    # (C/h·V, about 1 A here): the 90 µA diode current agrees to ~1e-12 A, 1e-8 of itself
    for path in ("numpy", "no dense map", "mlcp"):
        for name in reference.names:
            scale = max(np.abs(reference[name]).max(), 1e-30)
            np.testing.assert_allclose(results[path][name], reference[name], rtol=0, atol=1e-7 * scale,
                                       err_msg=f"{name} ({path} path)")


def test_mode_table_grows_and_starts_afresh_when_full():
    from circuitnsds.engine.dense_loop import ModeMap, ModeTable

    table = ModeTable(n=2, m=1, kstim=1, most=3)
    def mode(value):
        return ModeMap(P=np.full((3, 2), value), Q1=np.zeros((3, 1)), Q0=np.zeros((3, 1)),
                       c=np.zeros(3), W=np.zeros((1, 3)), e_w=np.zeros(1), resistance=np.ones(1),
                       active=np.array([0]))
    keys = [(0, 0, 0, bytes([k])) for k in range(4)]
    indices = [table.add(keys[k], mode(float(k))) for k in range(3)]
    assert indices == [0, 1, 2] and table.count == 3
    assert all(table.P[i, 0, 0] == float(i) for i in range(3))  # kept across the growth
    assert table.find(keys[1]) == 1
    assert table.add(keys[3], mode(3.0)) == 0  # full: starts afresh
    assert table.count == 1 and table.find(keys[1]) is None and table.P[0, 0, 0] == 3.0


@pytest.mark.parametrize("theta", [1.0, 0.5])
def test_converter_stays_in_the_mode_loop(theta):
    """Once both phases' modes are known the buck converter's periods run in the mode table:
    only the first periods (and the start-up transient) solve MLCPs. A regression here (an
    MLCP at every switching) once made the benchmark 6x slower with the same waveforms."""
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    stats = circuit.transient(theta=theta, method="theta").stats  # (θ's mode loop, pinned)
    assert stats["mlcp_steps"] < 0.005 * stats["steps"], stats
