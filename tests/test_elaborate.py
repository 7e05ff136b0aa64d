"""Meaning of netlist statements, and the errors and warnings for what is not supported."""

import math
import warnings

import numpy as np
import pytest

import circuitnsds
from circuitnsds.circuit.elements import Capacitor, Diode, Inductor, Resistor, VoltageSource
from circuitnsds.errors import NetlistError, NetlistWarning
from circuitnsds.system.stimuli import Dc, Exp, Pulse, Pwl, Sin


def read(body: str, title: str = "test"):
    return circuitnsds.read_netlist(f"{title}\n{body}\n.end\n")


def test_elements_models_and_tran():
    circuit = read("""V1 in 0 SIN(0 10 50)
R1 in a 1k
C1 a 0 10uF ic=2
L1 a GND 1m ic=0.1
D1 a b dmod 2
DZ b 0 zen
.model dmod D(Vfwd=0.7 Ron=10m IS=1e-14 N=1.8)
.model zen D(bv=5.1 rrev=2)
.tran 1u 1m 0 2u uic""")
    assert circuit.nodes == ["in", "a", "b"]
    v1, r1, c1, l1, d1, dz = circuit.elements
    assert isinstance(v1, VoltageSource) and v1.function == Sin(0, 10, 50, 0.0, 0.0, 0.0)
    assert isinstance(r1, Resistor) and r1.resistance == 1e3
    assert isinstance(c1, Capacitor) and c1.capacitance == 10e-6 and c1.initial_voltage == 2
    assert isinstance(l1, Inductor) and l1.nodes == ("a", "0") and l1.initial_current == 0.1
    assert isinstance(d1, Diode) and d1.area == 2 and d1.model.kind == "piecewise-linear"
    assert d1.model.forward_drop == 0.7 and d1.model.on_resistance == 10e-3
    assert dz.model.kind == "zener" and dz.model.breakdown_voltage == 5.1
    assert dz.model.breakdown_resistance == 2
    tran = circuit.analyses["tran"]
    assert (tran.step, tran.stop, tran.start, tran.max_step, tran.uic) == (1e-6, 1e-3, 0, 2e-6, True)


def test_source_functions_and_defaults():
    circuit = read("""V1 a 0 DC 5 AC 1
V2 b 0 PULSE(0 5 1m)
V3 c 0 PWL(0 0 1m 1 2m 1)
V4 d 0 EXP(0 1 1m 2m)
V5 e 0 pulse 0 1 0 0 0 1m 2m
I1 0 a 2m
R1 a b 1
R2 b c 1
R3 c d 1
R4 d e 1
R5 e 0 1""")
    functions = [e.function for e in circuit.elements[:6]]
    assert functions[0] == Dc(5)
    assert isinstance(functions[1], Pulse) and functions[1].rise is None
    assert functions[1].resolve(1e-6, 1e-2).rise == 1e-6
    assert functions[1].resolve(1e-6, 1e-2).width == 1e-2
    assert isinstance(functions[2], Pwl) and functions[2].times == (0, 1e-3, 2e-3)
    assert isinstance(functions[3], Exp)
    assert functions[4] == Pulse(0, 1, 0, 0, 0, 1e-3, 2e-3)
    assert functions[5] == Dc(2e-3)


SHOCKLEY_1N4148 = ".model d1n4148 D(Is=2.52n N=1.752 Rs=0.568 Cjo=4p M=0.4 tt=20n)"


def test_shockley_model_is_fitted_by_a_pwl_diode_and_diode_ideal_keeps_it_ideal():
    circuit = read("D1 a 0 d1n4148\nR1 a 0 1\n" + SHOCKLEY_1N4148)
    model = circuit.elements[0].model
    assert model.kind == "piecewise-linear" and model.off_resistance == 1e12
    assert "SPICE diode fit" in model.origin and "1e-05..1 A" in model.origin
    # the Shockley curve at 27 C, written out here: v = N kT/q ln(1 + i/Is) + Rs i; the
    # branches' voltage at a current (parallel branches: solve sum max(0, (v - Vj)/Rj) = i)
    vt = 1.380649e-23 * 300.15 / 1.602176634e-19
    branches = model.forward_branches
    assert 1 < len(branches) <= 6 and all(r > 0 for _, r in branches)

    def branch_voltage(current):
        low, high = 0.0, 10.0
        for _ in range(100):
            v = (low + high) / 2
            if sum(max(0.0, (v - knee) / r) for knee, r in branches) < current:
                low = v
            else:
                high = v
        return v

    for current in np.geomspace(1e-5, 1.0, 23):
        shockley = 1.752 * vt * math.log1p(current / 2.52e-9) + 0.568 * current
        # 5 decades at N = 1.752 with 6 branches: within 10 mV (the fit's stated error)
        assert branch_voltage(current) == pytest.approx(shockley, abs=0.010)
    ideal = read(".options diode=ideal\nD1 a 0 d1n4148\nR1 a 0 1\n" + SHOCKLEY_1N4148)
    model = ideal.elements[0].model
    assert model.kind == "ideal" and model.forward_drop == 0 and "diode=ideal" in model.origin


def test_pwlfit_option_moves_the_fit_range():
    model = read(".options pwlfit=10m\nD1 a 0 d1n4148\nR1 a 0 1\n" + SHOCKLEY_1N4148).elements[0].model
    assert "1e-07..0.01 A" in model.origin
    vt = 1.380649e-23 * 300.15 / 1.602176634e-19
    shockley = 1.752 * vt * math.log1p(5e-3 / 2.52e-9) + 0.568 * 5e-3
    assert float(model.forward_fit.voltage(5e-3)) == pytest.approx(shockley, abs=0.01)


def test_vendor_model_text_values_are_read():
    # LTspice standard.dio as copied in KiCad-Spice-Library Models/Diode/DIODE2.lib line 127
    model = read("D1 a 0 1n5819\nR1 a 0 1\n.model 1N5819 D(Is=31.7u Rs=.051 N=1.373 Cjo=110p M=.35 "
                 "Eg=.69 Xti=2 Iave=1 Vpk=40 mfg=OnSemi type=Schottky)").elements[0].model
    # a Schottky drop at Iave, the top of the fitted range
    assert 0.2 < float(model.forward_fit.voltage(1.0)) < 0.5 and model.forward_fit.high == 1.0
    with pytest.raises(NetlistError, match="ako"):
        read("D1 a 0 d\nR1 a 0 1\n.model d ako: 1N4007 d mfg=OnSemi")


@pytest.mark.parametrize(
    ("body", "pattern"),
    [
        ("T1 a 0 b 0 z0=50 td=1n", r"<text>:2: t1: transmission lines"),
        ("R1 a 0", r"<text>:2: r1: missing resistance"),
        ("R1 a 0 -5", r"resistance must be positive"),
        ("R1 a 0 abc", r"'abc' is not a number"),
        ("R1 a 0 1k foo=2", r"parameter 'foo' is not supported"),
        ("D1 a 0 nomodel\nR1 a 0 1", r"<text>:2: d1: diode model 'nomodel' is not defined"),
        ("D1 a 0 q\nR1 a 0 1\n.model q NPN(bf=100)", r"not a diode"),
        (".if (1 > 0)", r"\.if is never closed by \.endif"),
        ("B1 a 0 v={hertz*v(a)}", r"<text>:2: b1: 'hertz' is not available in a transient"),
        ("M1 d g s s nmos", r"<text>:2: m1: model .nmos. is not defined"),
        ("E1 a 0 value={v(b)*foo(v(a))}\nR1 a 0 1", r"e1: cannot represent the term foo\(v\(a\)\)"),
        ("G1 a 0 poly(1) b 0 0 1\nR1 a 0 1", r"\(POLY, LAPLACE, FREQ, .*\) is not supported"),
        (".bogus 1 2", r"unknown command \.bogus"),
        ("V1 a 0 SIN(0 1", r"no closing parenthesis"),
        ("V1 a 0 PWL(0 0 1m)", r"PWL needs time-value pairs"),
        ("V1 a 0 PWL(1m 0 0 1)", r"PWL times must not decrease"),
        ("V1 a 0 TRNOISE(1 1n 0 0)", r"TRNOISE sources are not supported"),
        ("V1 a 0 SIN(0)", r"SIN takes 2 to 7 numbers"),
        (".tran uic", r"\.tran takes TSTEP TSTOP"),
        (".tran 1u 1m 2m", r"TSTART"),
        (".ic v(nowhere)=1\nR1 a 0 1", r"\.ic names node 'nowhere'"),
        (".ic i(l1)=1", r"expected v\(node\)=value"),
        (".model z D(bv=5 vrev=6)", r"BV and Vrev disagree"),
        (".model z D(bv=-5)", r"breakdown voltage must be positive"),
        ("R1 a 0 1\nR1 a 0 2", r"element r1 is defined twice"),
        (".control\nrun", r"\.control block has no \.endc"),
    ],
)
def test_errors_name_the_line(body, pattern):
    with pytest.raises(NetlistError, match=pattern):
        read(body)


@pytest.mark.parametrize(
    ("body", "pattern"),
    [
        (".options reltol=1e-4 method=gear", r"\.options reltol=1e-4 method=gear ignored"),
        (".meas ac vmax max v(a)", r"\.meas ignored .*: \.meas ac vmax max v\(a\)"),
        (".print tran v(a)", r"\.print ignored"),
        (".model u D(Ilimit=1)", r"ilimit ignored"),
        (".model u D(foo=1)", r"unknown diode parameter 'foo'"),
        (".model u D(rrev=1)", r"Rrev ignored"),
        (".control\nrun\nplot v(a)\n.endc", r"\.control script: plot \(line 5\) not executed"),
        ("D1 a 0 m off\n.model m D", r"'off' ignored"),
        # ngspice's memristor.sp: .csparam hands a value to its .control script (before: refused)
        (".csparam stime=10n", r"\.csparam ignored \(it hands a parameter to the \.control script"),
        # ngspice's meas_expression.cir: a script's meas of its let vectors (before: the run stopped)
        (".control\nlet onevec = 1\nmeas tran t2 TRIG v(a) VAL=onevec-0.5 RISE=1 TARG v(a) VAL=0.5 RISE=2\n"
         ".endc", r"<text>:5: the \.control script's meas is not run: .*val=onevec-0\.5: not a number"),
        (".control\nlet vint = 0.9*v(a)\nmeas tran y2 FIND v(a) WHEN v(a)= vint\n.endc",
         r"<text>:5: the \.control script's meas is not run: it compares with 'vint', a vector of"),
    ],
)
def test_warnings_are_never_silent(body, pattern):
    with pytest.warns(NetlistWarning, match=pattern):
        read("R1 a 0 1\n" + body)


def test_unused_model_and_missing_end_warn():
    with pytest.warns(NetlistWarning, match=r"\.model q \(NPN\) is not used"):
        read("R1 a 0 1\n.model q NPN(bf=100)")
    with pytest.warns(NetlistWarning, match="no .end"):
        circuitnsds.read_netlist("t\nR1 a 0 1\n")


def test_models_may_follow_their_use_and_are_case_insensitive():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        circuit = read("D1 a 0 MyDiode\nR1 a 0 1\n.MODEL mydiode d (VFWD=0.6)")
    assert circuit.element("d1").model.forward_drop == 0.6


def test_missing_file_is_a_clean_error(tmp_path):
    with pytest.raises(NetlistError, match="cannot read the netlist"):
        circuitnsds.read_netlist(tmp_path / "missing.cir")
