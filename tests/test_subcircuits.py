"""Subcircuits: flattening, hierarchical names, local models, parameters; bundled netlists end to end."""

import math
import time

import numpy as np
import pytest

import circuitnsds
from circuitnsds.errors import NetlistError
from circuitnsds.netlist import flatten, load_netlist_text
from tests.conftest import NETLISTS


def flat(body: str, file: str = "s.cir") -> dict[str, tuple[str, ...]]:
    """Flat statements of a netlist body, by their first token (commands: first occurrence)."""
    netlist = load_netlist_text(f"title\n{body}\n.end\n", file=file)
    result: dict[str, tuple[str, ...]] = {}
    for statement in netlist.statements:
        result.setdefault(statement.keyword if not statement.is_command else
                          f"{statement.keyword} {statement.tokens[1]}", statement.tokens)
    return result


NESTED = """\
.subckt outer in out params: r=1k
D1 in mid dmod
R1 mid out {r}
Xin mid inner
.model dmod D(Vfwd=0.7)
.subckt inner a
Ra a b 1
Db b 0 dmod
Dg b 0 dglobal
.ends inner
.ends outer
X1 n1 n2 outer
X2 n2 gnd outer r=2k
.model dglobal D
"""


def test_nested_instances_get_hierarchical_names():
    statements = flat(NESTED)
    assert statements["x1.d1"] == ("x1.d1", "n1", "x1.mid", "x1.dmod")
    assert statements["x1.r1"] == ("x1.r1", "x1.mid", "n2", "1000.0")
    assert statements["x1.xin.ra"] == ("x1.xin.ra", "x1.mid", "x1.xin.b", "1")
    # the nested definition uses the model local to its enclosing instance; top-level models are global
    assert statements["x1.xin.db"] == ("x1.xin.db", "x1.xin.b", "0", "x1.dmod")
    assert statements["x1.xin.dg"] == ("x1.xin.dg", "x1.xin.b", "0", "dglobal")
    assert statements["x2.d1"] == ("x2.d1", "n2", "x2.mid", "x2.dmod")
    assert statements["x2.r1"] == ("x2.r1", "x2.mid", "gnd", "2000.0")
    assert statements[".model x1.dmod"] == (".model", "x1.dmod", "d", "(", "vfwd", "=", "0.7", ")")
    assert statements[".model x2.dmod"][1] == "x2.dmod"
    assert statements[".model dglobal"] == (".model", "dglobal", "d")
    assert not [k for k in statements if k.startswith((".subckt", ".ends", ".param")) or k in {"x1", "x2"}]


def test_locations_stay_in_the_definition_and_text_names_the_instance():
    netlist = load_netlist_text(f"title\n{NESTED}.end\n", file="s.cir")
    by_name = {s.keyword: s for s in netlist.statements}
    assert str(by_name["x1.d1"].location) == "s.cir:3"
    assert str(by_name["x2.xin.db"].location) == "s.cir:9"
    assert by_name["x1.d1"].text == "D1 in mid dmod   [in x1]"
    assert by_name["x2.xin.db"].text == "Db b 0 dmod   [in x2.xin]"


def test_a_flat_netlist_flattens_to_itself():
    once = load_netlist_text(f"title\n{NESTED}.end\n")
    twice = flatten(once)
    assert [s.tokens for s in twice.statements] == [s.tokens for s in once.statements]


def test_control_blocks_are_kept_out_of_expansion():
    """An ngspice script is neither substituted nor expanded (its X1 is no instance): the
    parser sets it aside once, with the commands it holds."""
    netlist = load_netlist_text("t\n.control\nlet x = {1+1}\nX1 a b\n.endc\nR1 a 0 {2}\n")
    assert [s.tokens for s in netlist.statements] == [("r1", "a", "0", "2.0")]
    assert [(b.location.line, b.commands) for b in netlist.control_blocks] == [(2, ["let", "x1"])]


def test_flattened_netlist_elaborates_and_simulates_like_the_hand_flattened_one():
    hierarchical = """half-wave rectifier in a subcircuit
.subckt rect in out params: rl=1k
D1 in out dideal
R1 out 0 {rl}
.model dideal D
.ends
V1 a 0 SIN(0 10 50)
X1 a b rect rl=2k
.tran 100u 40m
.end
"""
    by_hand = """half-wave rectifier, flat
V1 a 0 SIN(0 10 50)
x1.d1 a b x1.dideal
x1.r1 b 0 2k
.model x1.dideal D
.tran 100u 40m
.end
"""
    waves = circuitnsds.read_netlist(hierarchical).transient()
    reference = circuitnsds.read_netlist(by_hand).transient()
    assert "i(x1.d1)" in waves.names and "i(x1.r1)" in waves.names
    np.testing.assert_array_equal(waves["v(b)"], reference["v(b)"])
    np.testing.assert_array_equal(waves["i(x1.d1)"], reference["i(x1.d1)"])
    assert waves["v(b)"].max() == pytest.approx(10.0, abs=1e-9)


def test_instance_parameters_use_the_callers_scope_and_defaults_use_each_other():
    statements = flat("""\
.param rload=50
.subckt inner a b params: r=1 twice={2*r}
R1 a b {twice}
.ends
.subckt outer a b PARAMS: scale=3
.param local={scale*10}
X9 a b inner r={local+scale}
.ends
X1 p q outer scale=2
X2 p q outer
X3 p q inner params: r='rload'
X4 p q inner twice=7 r = rload / 5
""")
    assert statements["x1.x9.r1"][3] == "44.0"   # 2 * (2*10 + 2)
    assert statements["x2.x9.r1"][3] == "66.0"   # default scale = 3
    assert statements["x3.r1"][3] == "100.0"
    assert statements["x4.r1"][3] == "7.0"


def test_ground_global_nodes_and_ports():
    statements = flat("""\
.global vdd vss
.subckt s a
R1 a vdd 1
R2 gnd vss 1
R3 0 inner 1
.ends
X1 top s
""")
    assert statements["x1.r1"] == ("x1.r1", "top", "vdd", "1")
    assert statements["x1.r2"] == ("x1.r2", "gnd", "vss", "1")
    assert statements["x1.r3"] == ("x1.r3", "0", "x1.inner", "1")


def test_controlling_sources_inductors_and_model_names_are_renamed():
    statements = flat("""\
.subckt s a b
Vsense a m 0
F1 b 0 vsense 2
H1 b 0 vsense 10
Htop b 0 vtop 10
L1 m 0 1m
L2 b 0 1m
K1 L1 L2 0.5
E1 c 0 a b 1
G1 c 0 a b 1m
S1 b 0 a 0 swmod
W1 b 0 vsense swmod
RS a 3 RMOD 2.5
.model swmod SW(Ron=1 Roff=1meg Vt=0.5)
.model rmod RES(TC1=1e-3)
.ends
X1 in out s
""")
    assert statements["x1.f1"] == ("x1.f1", "out", "0", "x1.vsense", "2")
    assert statements["x1.h1"] == ("x1.h1", "out", "0", "x1.vsense", "10")
    assert statements["x1.htop"] == ("x1.htop", "out", "0", "vtop", "10")  # not defined inside: top level
    assert statements["x1.k1"] == ("x1.k1", "x1.l1", "x1.l2", "0.5")
    assert statements["x1.e1"] == ("x1.e1", "x1.c", "0", "in", "out", "1")
    assert statements["x1.g1"] == ("x1.g1", "x1.c", "0", "in", "out", "1m")
    assert statements["x1.s1"] == ("x1.s1", "out", "0", "in", "0", "x1.swmod")
    assert statements["x1.w1"] == ("x1.w1", "out", "0", "x1.vsense", "x1.swmod")
    assert statements["x1.rs"] == ("x1.rs", "in", "x1.3", "x1.rmod", "2.5")


def test_a_local_model_hides_a_global_one_of_the_same_name():
    statements = flat("""\
.subckt s a
D1 a 0 dm
.model dm D(Vfwd=1)
.ends
.subckt t a
D1 a 0 dm
.ends
X1 p s
X2 p t
.model dm D
""")
    assert statements["x1.d1"][3] == "x1.dm"
    assert statements["x2.d1"][3] == "dm"


def test_definitions_may_follow_their_use_and_ic_nodes_are_renamed():
    statements = flat("""\
X1 p later
.subckt later a
C1 a n 1u
.ic v(n)=1 v(a)=2
.ends
""")
    assert statements["x1.c1"] == ("x1.c1", "p", "x1.n", "1u")
    assert statements[".ic v"] == (".ic", "v", "(", "x1.n", ")", "=", "1", "v", "(", "p", ")", "=", "2")


@pytest.mark.parametrize("body, message", [
    (".subckt a p\nXself p a\n.ends", r"s.cir:3: xself: subcircuit 'a' instantiates itself "
     r"\(x1 \(a\) -> x1.xself \(a\)\)"),
    (".subckt a p\nXb p b\n.ends\n.subckt b p\nXa p a\n.ends",
     r"s.cir:6: xa: subcircuit 'a' instantiates itself \(x1 \(a\) -> x1.xb \(b\) -> x1.xb.xa \(a\)\)"),
    (".subckt a p\n.ends\nX2 p nowhere", r"(?s)s.cir:4: x2: subcircuit 'nowhere' is not defined.*"
     r"hint: defined here: a;"),
    (".subckt a p q\n.ends\nX2 p a", r"s.cir:4: x2: subcircuit a has 2 ports \(p q\), the instance gives "
     r"1 nodes \(p\)\n  hint: .subckt a is at s.cir:2"),
    ("X2", r"s.cir:2: x2: missing subcircuit name"),
    (".subckt a p r=1\n.ends\nX2 p a c=2", r"s.cir:4: x2: subcircuit a has no parameter 'c' "
     r"\(its parameters: r\)"),
    (".subckt a p r=1\n.ends\nX2 p a r=2 r=3", r"s.cir:4: x2: parameter 'r' is given twice"),
    (".subckt a p r=1\n.ends\nX2 p a r={q}", r"s.cir:4: x2: parameter r: undefined parameter 'q' in 'q'"),
    (".subckt a p\nR1 p 0 1", r"s.cir:2: .subckt a has no .ends"),
    (".ends", r"s.cir:2: .ends without a .subckt"),
    (".subckt a p\n.ends b", r"s.cir:3: .ends b closes .subckt a \(s.cir:2\)"),
    (".subckt a p\n.ends\n.subckt A q\n.ends",
     r"s.cir:4: subcircuit 'a' is defined twice \(first at s.cir:2\)"),
    (".subckt a p (\n.ends", r"s.cir:2: .subckt a: '\(' cannot be a port"),
    (".subckt a p p\n.ends", r"s.cir:2: .subckt a: port 'p' is listed twice"),
    (".subckt", r"s.cir:2: .subckt has no name"),
    (".subckt a p r=1 r=2\n.ends", r"s.cir:2: .subckt a: parameter 'r' is given twice"),
    (".subckt a p x=\n.ends", r"s.cir:2: .subckt a: x= has no value"),
    (".subckt a p\n.subckt b q\n.ends b\n.ends a\nX1 n b", r"s.cir:6: x1: subcircuit 'b' is not defined"),
])
def test_subcircuit_errors(body, message):
    text = f"title\n{body}\n" + ("X1 n a\n" if "X1" not in body and "X2" not in body else "") + ".end\n"
    with pytest.raises(NetlistError, match=message):
        load_netlist_text(text, file="s.cir")


def test_parameter_errors_inside_an_instance_point_into_the_definition():
    body = ".subckt s a params: p={q} q={p}\n.ends\nX1 n s"
    with pytest.raises(NetlistError, match=r"s.cir:2: parameters refer to each other in a cycle: "
                       r"p -> q -> p"):
        load_netlist_text(f"title\n{body}\n.end\n", file="s.cir")
    body = ".subckt s a\n.param k=2\nR1 a 0 {k*missing}\n.ends\nX7 n s"
    with pytest.raises(NetlistError, match=r"s.cir:4: r1: undefined parameter 'missing' in 'k\*missing' "
                       r"\(in instance x7\)"):
        load_netlist_text(f"title\n{body}\n.end\n", file="s.cir")
    body = ".subckt s a params: k=1\n.param k=2\n.ends\nX7 n s"
    with pytest.raises(NetlistError, match=r"s.cir:3: parameter 'k' is defined twice in instance x7"):
        load_netlist_text(f"title\n{body}\n.end\n", file="s.cir")


def test_elaboration_errors_of_flat_elements_name_the_instance_and_the_definition_line():
    text = "title\n.subckt s a\nR1 a 0 {-1}\n.ends\nX1 n s\nV1 n 0 1\n.tran 1m 2m\n.end\n"
    with pytest.raises(NetlistError) as info:
        circuitnsds.read_netlist(text)
    assert str(info.value.where) == "<text>:3"
    assert "x1.r1" in str(info.value)


# ---------------------------------------------------------------- bundled netlists end to end


def test_cockcroft_walton_multiplier_tends_to_2_n_vpeak():
    start = time.perf_counter()
    circuit = circuitnsds.read_netlist(NETLISTS / "cockcroft_walton.cir")
    waves = circuit.transient()
    elapsed = time.perf_counter() - start
    stages, vpeak = 3, 10.0
    assert {e.name for e in circuit.elements if e.name.endswith(".d1")} == {"x1.d1", "x2.d1", "x3.d1"}
    out = waves["v(d3)"]
    assert out[-1] == pytest.approx(2 * stages * vpeak, abs=0.1)       # 59.94 V after 100 cycles
    assert out.max() <= 2 * stages * vpeak + 1e-6                     # ideal diodes never overshoot
    for stage in (1, 2):                                               # each DC node steps up by 2 Vpeak
        assert waves[f"v(d{stage})"][-1] == pytest.approx(2 * stage * vpeak, abs=0.1)
    # still converging monotonically: each cycle's peak output is higher than the previous one
    period = round(0.02 / (waves.time[1] - waves.time[0]))
    peaks = out[1:].reshape(-1, period).max(axis=1)
    assert np.all(np.diff(peaks) > 0)
    assert elapsed < 30  # about 1-3 s (20000 steps)


def test_param_rc_rectifier_matches_the_analytic_solution():
    circuit = circuitnsds.read_netlist(NETLISTS / "param_rc_rectifier.cir")
    vp, freq, r = 10.0, 50.0, 1e3
    omega = 2 * math.pi * freq
    capacitance = 1 / (2 * math.pi * freq * r)
    assert circuit.element("c1").capacitance == capacitance
    assert circuit.element("r1").resistance == r
    waves = circuit.transient()
    t, v = waves.time, waves["v(out)"]
    assert t[1] - t[0] == pytest.approx(1 / (freq * 1000))
    # while D1 conducts (from t = 0 to the first maximum of the capacitor voltage, where
    # i = C dv/dt = 0): v = vp/sqrt(2) sin(wt - pi/4) + vp/2 exp(-wt); then v holds
    charging = vp / math.sqrt(2) * np.sin(omega * t - math.pi / 4) + vp / 2 * np.exp(-omega * t)

    def slope(s: float) -> float:  # dv/dt of the charging solution [V/s]
        return vp * omega * (math.cos(omega * s - math.pi / 4) / math.sqrt(2) - math.exp(-omega * s) / 2)

    low, high = 1e-3, 10e-3                         # bisection for the end of conduction
    for _ in range(60):
        low, high = (low, (low + high) / 2) if slope((low + high) / 2) < 0 else ((low + high) / 2, high)
    t_max = low
    v_max = vp / math.sqrt(2) * math.sin(omega * t_max - math.pi / 4) + vp / 2 * math.exp(-omega * t_max)
    assert v_max == pytest.approx(7.562, abs=1e-3)
    conducting = t <= t_max
    np.testing.assert_allclose(v[conducting], charging[conducting], atol=0.02)
    holding = (t > t_max + 1e-4) & (t < 1 / freq)
    np.testing.assert_allclose(v[holding], v_max, atol=0.02)


def test_vendor_zener_regulator_holds_the_zener_voltage():
    circuit = circuitnsds.read_netlist(NETLISTS / "vendor_zener_regulator.cir")
    names = {e.name for e in circuit.elements}
    assert {"xz1.df", "xz1.dr", "xz1.rs", "xz1.e1", "xz1.iref", "xz1.rref"} <= names
    waves = circuit.transient()
    vin, vout = waves["v(in)"], waves["v(out)"]
    vz, rz, rser, rl = 5.1, 2.5, 220.0, 1000.0
    assert waves["v(xz1.10)"][-1] == pytest.approx(vz, abs=1e-9)  # the reference: 1 mA * 5.1k
    # below the knee: the divider; above: the Zener, vout = vz + rz * iz with iz = (vin-vout)/rser - vout/rl
    knee = vz * (rser + rl) / rl
    below = vin < knee - 0.05
    np.testing.assert_allclose(vout[below], vin[below] * rl / (rser + rl), atol=1e-6)
    above = vin > knee + 0.05
    expected = (vz + rz * vin[above] / rser) / (1 + rz / rser + rz / rl)
    np.testing.assert_allclose(vout[above], expected, atol=1e-6)
    assert vout[-1] == pytest.approx(5.1648, abs=1e-4)
    assert waves["i(xz1.dr)"][-1] == pytest.approx((vout[-1] - vz) / rz, rel=1e-6)
