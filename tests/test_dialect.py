"""Issue 32, the dialect people write: element values that step in time (exact for R, V, I;
clear refusals for what varies continuously and for C, L) and LTspice's parasitics."""

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.errors import NetlistError, NetlistWarning


def run(body, stop="3m", step="10u"):
    circuit = circuitnsds.read_netlist(f"t\n{body}\n.tran {step} {stop}\n.end\n")
    return circuit.transient()


def test_voltage_source_stepping_in_time_charges_an_rc_as_the_analytic_solution():
    result = run("V1 in 0 {time < 1m ? 0 : 5}\nR1 in out 1k\nC1 out 0 1u", step="1u")
    t, v = result["time"], result["v(out)"]
    after = t >= 1e-3
    assert np.all(v[~after] == 0)
    expected = 5 * (1 - np.exp(-(t[after] - 1e-3) / 1e-3))
    assert np.max(np.abs(v[after] - expected)) < 5 * 1e-3 / 2 * 1.0  # implicit Euler, h = 1 µs


def test_current_source_window_of_time():
    result = run("I1 0 out {(time > 0.5m && time < 1.5m) ? 1m : 0}\nR1 out 0 1k")
    t, v = result["time"], result["v(out)"]
    inside = (t > 0.5e-3) & (t <= 1.5e-3)
    assert np.allclose(v[inside], 1.0) and np.allclose(v[~inside], 0.0)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(0.1, 2.9), min_size=1, max_size=3, unique=True),
       st.lists(st.sampled_from([1.0, 2.0, 5.0, 10.0]), min_size=4, max_size=4))
def test_a_resistor_of_nested_conditions_on_time_has_its_value_between_every_corner(corners, values):
    corners = sorted(round(c, 2) for c in corners)
    corners = sorted(set(corners))
    expression = str(values[len(corners)])
    for corner, value in reversed(list(zip(corners, values))):
        expression = f"time < {corner}m ? {value} : ({expression})"
    result = run(f"V1 a 0 1\nR1 a 0 {{{expression}}}", step="10u")
    t, current = result["time"], result["i(r1)"]
    edges = [0.0] + [c * 1e-3 for c in corners] + [np.inf]
    for k, (low, high) in enumerate(zip(edges, edges[1:])):
        inside = (t > low * (1 + 1e-9)) & (t < high)  # (at a corner: the value before it)
        assert np.allclose(current[inside], 1 / values[k]), (expression, k)


@pytest.mark.parametrize(("line", "pattern"), [
    ("R1 a 0 {1+time*1k}", r"r1: resistance \{.*\} varies continuously with time: not supported"),
    ("R1 a 0 {time<1m ? 1k : 0}", r"r1: resistance .* takes the value 0; it must be positive"),
    ("C1 a 0 {time<1m ? 1u : 2u}", r"c1: a capacitance that depends on time .* is not supported"),
    ("R1 a 0 {time<1m ? 1k : 2k} tc1=1", r"r1: unexpected 'tc1=1' after the value"),
])
def test_what_is_not_a_step_in_time_is_refused_with_what_to_write(line, pattern):
    with pytest.raises(NetlistError, match=pattern) as error:
        run(f"V1 a 0 1\n{line}")
    assert error.value.hint


@pytest.mark.parametrize(("line", "pattern"), [
    ("V1 a 0 1 Rpar=1", r"v1: Rpar= is not a parasitic of a voltage source \(LTspice gives it Rser, Cpar\)"),
    ("I1 a 0 1 Rser=1", r"i1: Rser= is not a parasitic of a current source \(LTspice gives it none\)"),
])
def test_a_parasitic_ltspice_does_not_give_the_element_is_refused(line, pattern):
    with pytest.raises(NetlistError, match=pattern):
        run(f"{line}\nR1 a 0 1")


def test_source_series_resistance_divides_as_the_resistors_it_stands_for():
    # V1 = 1 V with Rser = 1 Ω into 3 Ω: 0.75 V; Cpar=0 and Rser=0 mean none, as in LTspice
    result = run("V1 a 0 1 Rser=1 Cpar=0\nR1 a 0 3\nV2 b 0 2 Rser=0\nR2 b 0 1", stop="10u", step="1u")
    assert np.allclose(result["v(a)"], 0.75) and np.allclose(result["i(v1)"], -0.25)
    assert np.allclose(result["v(b)"], 2.0)


def test_unquoted_library_path_with_spaces_is_read_with_a_warning(tmp_path):
    (tmp_path / "my models").mkdir()
    (tmp_path / "my models" / "d lib.lib").write_text(".lib fast\n.model dx D(Ron=1 Vfwd=0.5)\n.endl\n")
    netlist = tmp_path / "t.cir"
    netlist.write_text("t\n.lib my models/d lib.lib fast\nV1 a 0 1\nD1 a 0 dx\n.tran 1u 10u\n.end\n")
    with pytest.warns(NetlistWarning, match=r"t.cir:2: \.lib: the unquoted path 'my models/d lib.lib' "
                      r".* quotes"):
        result = circuitnsds.read_netlist(netlist).transient()
    assert np.allclose(result["i(d1)"], 0.5)  # (1 V - 0.5 V) / 1 Ω
    netlist.write_text("t\n.lib my models/other lib.lib fast\n.end\n")
    with pytest.raises(NetlistError, match=r"\.lib takes a file and a section name, got 4 words"):
        circuitnsds.read_netlist(netlist)


@pytest.mark.parametrize(("options", "pattern"), [
    ("r=0.5m", r"PWL r=0.0005 must be one of its times before the last \(0, 0.001\)"),
    ("r=2m", r"PWL r=0.002 must be one of its times before the last"),
    ("td=-1m", r"PWL td=-0.001 must not be negative"),
])
def test_pwl_repeat_and_delay_are_checked(options, pattern):
    with pytest.raises(NetlistError, match=pattern):
        run(f"V1 a 0 PWL(0 0 1m 1 2m 0) {options}\nR1 a 0 1")


def test_pwl_repeat_writes_the_repetitions_out_to_the_stop_time():
    result = run("V1 a 0 PWL(0 0 1m 1 2m 0) r=0 td=0.5m\nR1 a 0 1", stop="7m", step="50u")
    t, v = result["time"], result["v(a)"]
    expected = np.interp((t - 0.5e-3) % 2e-3, [0, 1e-3, 2e-3], [0, 1, 0]) * (t >= 0.5e-3)
    assert np.allclose(v, expected, atol=1e-12)


def test_a_parameter_in_braces_inside_a_behavioural_expression_is_its_value():
    # KiCad power-electronics libraries write V=i(vs1)*{N} in a subcircuit (ngspice reads it)
    body = (".subckt amp a b n=1\nB1 b 0 V=v(a)*{N}\n.ends\nV1 in 0 2\nX1 in out amp n=3\n"
            "R1 out 0 1")
    assert np.allclose(run(body, stop="10u", step="1u")["v(out)"], 6.0)


def test_a_parameter_in_braces_inside_an_xspice_vector_is_its_value():
    body = (".subckt s a b out kp=1\nA1 [a b] out sum1\n.model sum1 summer(in_gain=[{kp} 1.0])\n.ends\n"
            "V1 a 0 2\nV2 b 0 1\nX1 a b out s kp=3\nR1 out 0 1")
    assert np.allclose(run(body, stop="10u", step="1u")["v(out)"], 7.0)


def test_a_capacitance_of_node_voltages_is_refused_as_a_smooth_nonlinear_element():
    with pytest.raises(NetlistError, match=r"c1: a capacitance that depends on v\(a\) is a smooth "
                       r"nonlinear element: not supported .*issue 33"):
        run("V1 a 0 1\nR1 a b 1\nC1 b 0 c = 'v(a) < 5 ? 1u : 2u'")


def test_a_model_defined_twice_the_same_way_is_a_warning_and_differently_an_error():
    with pytest.warns(NetlistWarning, match=r"\.model d1 is defined again with the same parameters"):
        run("V1 a 0 1\nD1 a 0 d1 \n.model d1 D(Ron=1)\n.model d1 D(Ron=1)", stop="10u", step="1u")
    with pytest.raises(NetlistError, match=r"\.model d1 is defined twice, with different parameters"):
        run("V1 a 0 1\nD1 a 0 d1 \n.model d1 D(Ron=1)\n.model d1 D(Ron=2)", stop="10u", step="1u")


EXTERNAL = Path(__file__).resolve().parent.parent / "netlists" / "external"


@pytest.mark.parametrize(("name", "refusal"), [
    ("kicad_pe/buck/buck.net", None),
    ("kicad_pe/BuckBoo/BuckBoo.net", None),
    ("kicad_pe/rectifier/rectifier.net", None),
    ("kicad_pe/Rectifier_3P/Rectifier_3P.net", None),
    ("kicad_pe/HWB/HWB.net", r"xbdge1.cper: a capacitance that depends on .* issue 33"),
    ("kicad_pe/PushPull_Conv/PushPull_Conv.net", r"xfmpush1.cper: a capacitance that depends on .* issue 33"),
    ("kicad_pe/FlyBavk/FlyBavk.net", r"xfmer1.cper: a capacitance that depends on .* issue 33"),
    ("kicad_pe/buckclose/buckclose.net", None),
    ("ng_cutout1.cir", None),
    ("ng_resume-1.cir", None),
    ("ng_xspice_c2.cir", None),
    ("ng_ddt-test3.cir", None),
    ("ng_integrate1.cir", None),
    ("ng_simple-meas-tran.sp", None),
    ("ng_memristor.sp", r"xmem.rmem: a resistance that depends on v\(xmem.x\) is a smooth .* issue 33"),
    ("ng_transformers1.cir", None),
    ("xy_bug45_diode_bridge.cir", None),
    ("xy_cmc_diode_clipper.cir", None),
    ("xy_diode_clipper_2par.net", None),
    ("xy_bug767a.cir", None),
    ("xy_bug1017.cir", None),
    ("xy_bug775son_core.cir", r"'xbr1.tmod' after the coupling coefficient is a core model"),
    # the further batch (--batch32b)
    ("ng_vdmos_dcdc.sp", None),
    ("ng_ddt-test1.cir", None),
    ("ng_ddt-test2.cir", r"b3: cannot represent the term \(ddt\(v\(1\)\)>0.0\).*issue 33"),
    ("ng_meas_expression.cir", None),
    ("ng_pwm-sin.cir", None),
    ("ng_v-i-sources-am-ffm.cir", None),
    ("ng_schmitt.cir", None),
    ("ng_inv_vdmos.sp", None),
    ("xy_gswitch.cir", r"sw1: Xyce's generic switch"),
    ("xy_iswitch_hyst1.cir", r"s1: Xyce's generic switch"),
    ("xy_vswitch_hyst1.cir", r"\.model sw VSWITCH: VHON, VHOFF \(Xyce's hysteresis"),
    ("xy_vswitch_a1.cir", None),
    ("xy_ind_path_to_ground.cir", None),
    ("xy_path_to_ground_core.cir", r"kc: 'nlcore' after the coupling coefficient is a core model"),
    ("xy_power_b_trap.cir", None),
    ("xy_vdmos_irf130.cir", r"MOSFET level 18 is not supported"),
    ("xy_4049osc.cir", None),
])
def test_the_issue_32_batch_reads_as_written_or_names_what_it_lacks(name, refusal):
    """The public netlists of docs/compare.md's issue-32 tables, read as written (their
    agreement with ngspice: benchmarks/external_netlists.py --batch32, --batch32b)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if refusal is None:
            assert circuitnsds.read_netlist(EXTERNAL / name).analyses["tran"]
        else:
            with pytest.raises(NetlistError, match=refusal):
                circuitnsds.read_netlist(EXTERNAL / name)
