"""Issue 7: circuit checks, well-posedness of each step's LCP, run-time failures, --strict."""

import warnings

import numpy as np
import pytest

import circuitnsds
from circuitnsds.checks.wellposed import EXACT_LIMIT, analyse
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import (
    Capacitor,
    Inductor,
    MutualInductance,
    Resistor,
    Switch,
    SwitchModel,
    VoltageSource,
)
from circuitnsds.cli.main import EXIT_STATUS, main
from circuitnsds.errors import (
    CircuitError,
    CircuitWarning,
    NetlistError,
    SimulationError,
    SourceLocation,
)
from circuitnsds.system.stimuli import Dc, Sin


def read(body: str, **kwargs):
    return circuitnsds.read_netlist(f"t\n{body}\n.end\n", **kwargs)


def circuit_warnings(circuit, call=lambda c: c.mlcs()) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        call(circuit)
    return [str(w.message) for w in caught if issubclass(w.category, CircuitWarning)]


def python_circuit(*elements) -> Circuit:
    circuit = Circuit()
    circuit.elements.extend(elements)
    for element in elements:
        circuit.nodes.extend(n for n in element.nodes if n != "0" and n not in circuit.nodes)
    return circuit


# ---------------------------------------------------------------- element checks and warnings


@pytest.mark.parametrize(("body", "expected"), [
    ("V1 a 0 1\nR1 a 0 1k\nR2 a b 1k",
     "<text>:4: node b is connected only to r2: a dangling terminal, no current flows through r2"),
    ("V1 a 0 1\nR1 a 0 1k\nC1 a 0 0", "<text>:4: c1: 0 F capacitor: it is an open circuit"),
    ("V1 a 0 1\nR1 a b 1k\nL1 b 0 0", "<text>:4: l1: 0 H inductor: it is a short circuit"),
    ("V1 a 0 1\nR1 a 0 1k\nR2 a a 1k", "<text>:4: r2: both terminals are node a"),
    ("V1 a 0 1\nR1 a 0 1k\nVg g 0 pulse(0 5 1m 1u 1u 1m 2m)\nS1 a 0 g 0 sw\n.model sw SW(VT=2.5 RON=0)",
     "v1, s1 form a loop of voltage sources and switches with RON=0: while s1 is closed"),
    ("I1 0 a 1m\nVg g 0 pulse(0 5 1m 1u 1u 1m 2m)\nR1 g 0 1k\nS1 a 0 g 0 sw\n.model sw SW(VT=2.5)",
     "node(s) a connect to the rest of the circuit only through i1, s1: while s1 is open, the "
     "current of i1 can flow only through ROFF"),
])
def test_suspicious_circuits_warn(body, expected):
    messages = circuit_warnings(read(body))
    assert any(expected in message for message in messages), messages


def test_each_warning_is_given_once_and_bundled_netlists_are_clean(netlists):
    circuit = read("V1 a 0 1\nR1 a 0 1k\nR2 a b 1k")
    assert len(circuit_warnings(circuit)) == 1
    assert circuit_warnings(circuit) == []  # stamped again: not repeated
    for path in sorted(netlists.glob("*.cir")):
        assert circuit_warnings(circuitnsds.read_netlist(path)) == [], path.name


def test_a_zero_henry_inductor_counts_as_a_voltage_source_in_loops():
    circuit = read("V1 a 0 1\nL1 a 0 0\nR1 a 0 1")
    with pytest.raises(CircuitError, match="v1 .*, l1 .* form a loop of voltage sources"):
        with pytest.warns(CircuitWarning, match="0 H inductor"):
            circuit.mlcs()


@pytest.mark.parametrize(("elements", "message"), [
    ((VoltageSource("v1", ("a", "0"), function=Dc(1.0)), Resistor("r1", ("a", "0"), resistance=0.0)),
     "r1: resistance must be positive, got 0"),
    ((VoltageSource("v1", ("a", "0"), function=Dc(1.0)), Resistor("r1", ("a", "0"), resistance=np.nan)),
     "r1: resistance is nan (not a finite number)"),
    ((VoltageSource("v1", ("a", "0"), function=Dc(np.inf)), Resistor("r1", ("a", "0"))),
     "v1: function.level is inf (not a finite number)"),
    ((VoltageSource("v1", ("a", "0"), function=Dc(1.0)), Resistor("r1", ("a", "0")),
      Resistor("r1", ("a", "0"))), "element r1 is defined twice"),
    ((VoltageSource("v1", ("a", "0"), function=Dc(1.0)), Inductor("l1", ("a", "b")),
      Resistor("r1", ("b", "0")), MutualInductance("k1", (), inductors=("l1", "l2"))),
     "k1: 'l2' is not an inductor of this circuit"),
    ((VoltageSource("v1", ("a", "0"), function=Dc(1.0)), Resistor("r1", ("a", "b")),
      Switch("w1", ("b", "0"), model=SwitchModel("csw", current_controlled=True), control="vx")),
     "w1: controlling source 'vx' does not exist"),
    ((VoltageSource("v1", ("a", "0"), function=Dc(1.0)), Capacitor("c1", ("a", "0"), capacitance=-1.0)),
     "c1: capacitance must not be negative"),
])
def test_element_errors_in_circuits_built_in_python(elements, message):
    with pytest.raises(CircuitError, match=message.replace("(", r"\(").replace(")", r"\)")):
        python_circuit(*elements).mlcs()


def test_values_whose_equations_overflow_are_refused():
    with pytest.raises(CircuitError, match="r1: its equations hold numbers that are not finite"):
        read("V1 a 0 1\nR1 a 0 1e-320").mlcs()
    with pytest.raises(CircuitError, match=r"v1: PULSE period 1e-15 s repeats 1e\+12 times before 0.001 s"):
        read("V1 a 0 pulse(0 1 0 0 0 0.5f 1f)\nR1 a 0 1\n.tran 1u 1m").mlcs()
    circuit = read("V1 a 0 1\nR1 a b 1\nC1 b 0 1u\n.tran 1u 1m")
    with pytest.raises(SimulationError, match=r"\(h = 1e-320 s\) gives equations that are not finite"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            circuit.transient(1e-320, 1e-319, method="theta")  # (θ's step matrix C/h: pinned)


def test_duplicate_name_in_a_netlist_names_both_lines():
    with pytest.raises(NetlistError, match=r"<text>:3: element r1 is defined twice \(first at <text>:2\)"):
        read("R1 a 0 1\nR1 a 0 2\nV1 a 0 1")


# ---------------------------------------------------------------- start-up checks (UIC)


def test_inconsistent_initial_conditions_in_a_source_capacitor_loop_warn_only_under_uic():
    body = "V1 a 0 5\nC1 a 0 1u ic={ic}\nR1 a 0 1k\n.tran 1u 5u{uic}"

    def run(circuit):
        circuit.transient()

    assert circuit_warnings(read(body.format(ic=5, uic=" uic")), run) == []
    assert circuit_warnings(read(body.format(ic=2, uic="")), run) == []
    messages = circuit_warnings(read(body.format(ic=2, uic=" uic")), run)
    assert len(messages) == 1
    assert ("<text>:3: c1, v1 form a loop of voltage sources and capacitors whose initial "
            "voltages (UIC) do not add up (they miss by 3 V)") in messages[0]


def test_inconsistent_initial_currents_in_a_source_inductor_cutset_warn_under_uic():
    circuit = read("I1 0 a 2\nL1 a 0 1m ic=0.5\n.tran 1u 5u uic")
    messages = circuit_warnings(circuit, lambda c: c.transient())
    assert len(messages) == 1
    assert "connect to the rest of the circuit only through i1, l1, whose initial currents" in messages[0]
    assert "miss by 1.5 A" in messages[0]


# ---------------------------------------------------------------- strict mode


def test_strict_makes_netlist_and_circuit_warnings_errors():
    with pytest.raises(NetlistError, match=r"<text>:3: .options reltol=1e-3 ignored(.|\n)*--strict"):
        read("V1 a 0 1\n.options reltol=1e-3\nR1 a 0 1", strict=True)
    circuit = read("V1 a 0 1\nR1 a 0 1k\nR2 a b 1k\n.tran 1u 5u", strict=True)
    assert circuit.strict
    for _ in range(2):  # not forgotten after the first refusal
        with pytest.raises(CircuitError, match="node b is connected only to r2"):
            circuit.transient()
    read("V1 a 0 1\nR1 a 0 1k\n.tran 1u 5u", strict=True).transient()  # clean: runs


def test_cli_strict_refuses_before_writing_and_info_reports_first(tmp_path, capsys):
    path = tmp_path / "w.cir"
    path.write_text("t\nV1 a 0 1\nR1 a 0 1k\nR2 a b 1k\n.tran 1u 5u\n.end\n")
    csv = tmp_path / "w.csv"
    assert main(["run", str(path), "-o", str(csv), "-q"]) == 0
    assert "warning: " in capsys.readouterr().err
    csv.unlink()
    assert main(["run", str(path), "-o", str(csv), "-q", "--strict"]) == 1
    err = capsys.readouterr().err
    assert "error: " in err and "node b is connected only to r2" in err and "--strict" in err
    assert not csv.exists()
    assert main(["info", str(path), "--strict"]) == 1
    captured = capsys.readouterr()
    assert "well-posedness" in captured.out
    assert "the warnings above are errors under --strict" in captured.err


def test_exit_statuses_are_documented():
    assert set(EXIT_STATUS) == {0, 1, 2, 129, 130, 143}
    from pathlib import Path

    usage = (Path(__file__).resolve().parent.parent / "docs" / "usage.md").read_text()
    for status in EXIT_STATUS:
        assert f"| {status} |" in usage


# ---------------------------------------------------------------- NetlistError fields


def test_netlist_error_has_file_line_column_and_text():
    with pytest.raises(NetlistError) as info:
        read("R1 a 0 1k\nD1 a 0 nomodel")
    error = info.value
    assert (error.file, error.line, error.column) == ("<text>", 3, 8)
    assert error.text == "D1 a 0 nomodel"
    first, second = str(error).splitlines()
    assert first == "<text>:3: d1: diode model 'nomodel' is not defined"
    assert second.startswith("  hint: add a line such as: .model nomodel D()")
    assert second.endswith("; in: D1 a 0 nomodel")


def test_long_offending_text_is_cut_around_the_column():
    error = NetlistError("bad", where=SourceLocation("f.cir", 2), text="R1 a 0 " + "x" * 500 + " oops",
                         column=510)
    line = str(error).splitlines()[1]
    assert line.startswith("  in: ...") and line.endswith("oops") and len(line) < 120


# ---------------------------------------------------------------- well-posedness


def verdicts(circuit, **kwargs):
    return [(r.verdict, r.devices) for r in circuit.well_posedness(**kwargs)]


def test_rectifiers_and_zeners_are_p_matrices(netlists):
    for name in ("bridge_rectifier", "half_wave_rectifier", "zener_regulator", "cockcroft_walton"):
        reports = circuitnsds.read_netlist(netlists / f"{name}.cir").well_posedness()
        assert [r.verdict for r in reports] == ["P"], name
        assert reports[0].exact and reports[0].ok


def test_two_ideal_diodes_in_a_loop_without_resistance_are_not_p():
    circuit = read("V1 a 0 sin(0 1 50)\nR1 a x 1k\nD1 x b d\nD2 b x d\nR2 b 0 1k\n.model d D\n.tran 10u 1m")
    (report,) = circuit.well_posedness()
    assert report.verdict == "PSD" and not report.p_matrix and report.psd
    assert set(report.failing_pairs) == {"d1", "d2"}
    assert "d1, d2 see no resistance" in report.summary()
    # with Ron the loop has a resistance: P
    circuit = read("V1 a 0 sin(0 1 50)\nR1 a x 1k\nD1 x b d\nD2 b x d\nR2 b 0 1k\n"
                   ".model d D(Ron=1)\n.tran 10u 1m")
    assert verdicts(circuit) == [("P", ())]


def test_an_ideal_diode_across_a_voltage_source_is_not_p_and_fails_when_forward_biased():
    assert verdicts(read("V1 a 0 -1\nD1 a 0 d\n.model d D\n.tran 1u 5u")) == [("PSD", ("d1",))]
    with pytest.raises(SimulationError, match="operating point has no solution"):
        read("V1 a 0 1\nD1 a 0 d\n.model d D\n.tran 1u 5u").transient()


def test_ideal_diode_in_series_with_a_current_source_is_flagged_for_one_sign():
    body = "I1 0 a sin(0 1m 50)\nD1 a b d\nR1 b 0 1k\n.model d D\n.tran 100u 20m"
    (report,) = read(body).well_posedness()
    assert report.verdict == "P"  # with Roff the step is solvable ...
    assert not report.ok and len(report.forced) == 1  # ... but not in the ideal limit
    assert "the current of i1 into node(s) a can pass only through d1" in report.forced[0]
    # forward (first half period) the diode conducts; reversed (from 10 ms) the current could
    # only go through Roff (-I·Roff, -1e8 V): the ideal model has no answer, and the run is
    # refused before simulating rather than returning that (issue 20, item 2)
    with pytest.raises(CircuitError, match=r"i1 drives .* out of node\(s\) a at t = 0\.010"):
        read(body).transient()
    forward = read(body.replace("20m", "9m")).transient()
    np.testing.assert_allclose(forward["i(d1)"], 1e-3 * np.sin(2 * np.pi * 50 * forward.time),
                               atol=1e-9)


def test_negative_resistance_is_neither_and_names_the_device():
    circuit = read("I1 0 a 1m\nD1 a 0 d\nR1 a 0 2k\nG1 a 0 a 0 -1m\n.model d D\n.tran 10u 1m")
    (report,) = circuit.well_posedness()
    assert report.verdict == "neither" and report.negative_pairs == ("d1",)
    assert report.failing_pairs == ("d1",) and report.failing_minor == -1.0


def test_switch_states_are_examined_and_a_shorted_source_is_singular():
    circuit = read("V1 a 0 1\nR1 a b 1\nD1 b 0 d\nVg g 0 pulse(0 5 1m 1u 1u 1m 2m)\n"
                   "S1 a 0 g 0 sw\n.model sw SW(VT=2.5 RON=0)\n.model d D\n.tran 1u 5m")
    with pytest.warns(CircuitWarning, match="loop of voltage sources and switches with RON=0"):
        reports = circuit.well_posedness()
    assert [r.switch_states for r in reports] == [{"s1": False}, {"s1": True}]
    assert reports[0].verdict == "P"
    assert reports[1].verdict == "singular"
    assert set(reports[1].singular_unknowns) >= {"i(v1)", "i(s1)"}
    assert [r.verdict for r in circuit.well_posedness(states=[(True,)])] == ["singular"]


def test_exclusive_zener_pairs_and_large_problems():
    # the two pairs of an ideal Zener never conduct together: still P
    circuit = read("V1 a 0 sin(0 10 50)\nR1 a b 1k\nDZ b 0 z\n.model z D(BV=5)\n.tran 10u 20m")
    assert verdicts(circuit) == [("P", ())]
    # more pairs than the exact test handles: the sufficient test decides
    body = "V1 a 0 sin(0 1 50)\n" + "".join(f"R{k} a n{k} 1k\nD{k} n{k} 0 d\n" for k in range(14))
    (report,) = read(body + ".model d D(Ron=1)\n.tran 10u 1m").well_posedness()
    assert len(report.pairs) == 14 > EXACT_LIMIT
    assert report.verdict == "P" and not report.exact


def test_analyse_takes_an_mlcs_and_a_step():
    mlcs = read("V1 a 0 1\nR1 a b 1\nD1 b 0 d\n.model d D").mlcs()
    report = analyse(mlcs, 1e-6)
    assert report.verdict == "P" and report.M.shape == (1, 1)
    assert report.M[0, 0] == pytest.approx(1.0, rel=1e-9)  # R1 in parallel with Roff


def test_info_prints_the_well_posedness(netlists, capsys):
    assert main(["info", str(netlists / "buck_converter.cir")]) == 0
    out = capsys.readouterr().out
    assert "well-posedness of each step's LCP (h = 100 ns):" in out
    assert "s1 open: P-matrix (1 pair, exact test)" in out
    assert "s1 closed: P-matrix (1 pair, exact test)" in out


# ---------------------------------------------------------------- run-time failures

NEGATIVE = ("negative resistance drives an ideal diode\nI1 0 a sin(0 1m 50)\nD1 a 0 d\nR1 a 0 2k\n"
            "G1 a 0 a 0 -1m\n.model d D\n.tran 100u 40m\n.end\n")


def test_a_step_without_solution_stops_with_time_devices_hint_and_partial_waveforms():
    with pytest.raises(SimulationError) as info:
        circuitnsds.read_netlist(NEGATIVE).transient()
    error = info.value
    assert error.time == pytest.approx(10.1e-3)
    assert error.devices == ()  # nothing conducted before: the current reversed
    message = str(error)
    assert message.startswith("t = 0.0101 s: the time step from t = 0.01 s to 0.0101 s has no "
                              "solution with ideal devices (conducting before it: none)")
    assert "hint: this step's LCP: neither P nor positive semidefinite" in message
    assert "d1 sees a negative resistance" in message
    partial = error.partial
    assert partial.time[-1] == pytest.approx(10e-3) and partial.time.size == 101
    np.testing.assert_allclose(partial["v(a)"], 2e3 * 1e-3 * np.sin(2 * np.pi * 50 * partial.time) * -1,
                               atol=1e-9)


def test_cli_writes_the_waveforms_before_a_failed_step(tmp_path, capsys):
    path = tmp_path / "neg.cir"
    path.write_text(NEGATIVE)
    csv, png = tmp_path / "neg.csv", tmp_path / "neg.png"
    assert main(["run", str(path), "-o", str(csv), "--plot", str(png), "-q"]) == 1
    err = capsys.readouterr().err
    assert "wrote the results up to t = 0.01 s (before the failure)" in err
    assert "circuitnsds: error: t = 0.0101 s: the time step" in err and "Traceback" not in err
    assert csv.read_text().startswith("# partial: the run stopped at t = 0.01 s (before the failure)")
    data = np.loadtxt(csv, delimiter=",", skiprows=2)
    assert data.shape[0] == 101 and data[-1, 0] == pytest.approx(10e-3)
    assert png.exists()


def test_non_finite_state_is_caught_at_the_step_it_appears():
    circuit = read("I1 0 a pulse(0 1m 0 1u 1u 1m 1)\nC1 a 0 1u\nR1 a 0 2k\nG1 a 0 a 0 -1m\n.tran 1m 3")
    # (implicit Euler's growth 2 per step overflows at 1.025 s, the exact e^{500 t} later:
    # pinned to θ; test_exact_stepper checks the exact integrator's own instant)
    with pytest.raises(SimulationError, match=r"the state is not finite at t = 1.025 s \(v\(a\) = inf\)"):
        circuit.transient(method="theta")
    try:
        circuit.transient(method="theta")
    except SimulationError as error:
        assert error.time == pytest.approx(1.025)
        assert np.isfinite(error.partial["v(a)"]).all() and error.partial.time[-1] == pytest.approx(1.024)


def test_a_run_keeping_some_signals_gets_the_advice_of_a_whole_run():
    # before: only the whole run's error got the hint of its cause; a run keeping some signals
    # (one driver loop of its own) raised the bare message
    circuit = read("I1 0 a pulse(0 1m 0 1u 1u 1m 1)\nC1 a 0 1u\nR1 a 0 2k\nG1 a 0 a 0 -1m\n.tran 1m 3")
    errors = []
    for signals in (None, ["v(a)"]):
        with pytest.raises(SimulationError) as caught:
            circuit.transient(signals=signals)
        errors.append(caught.value)
    assert errors[1].hint == errors[0].hint and "the circuit is unstable" in errors[1].hint
    np.testing.assert_array_equal(errors[1].partial["v(a)"], errors[0].partial["v(a)"])


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_non_finite_source_value_is_caught_before_the_first_step():
    circuit = python_circuit(VoltageSource("v1", ("a", "0"), function=Sin(1e308, 1e308, 50.0)),
                             Resistor("r1", ("a", "0")))
    # (θ samples every source on its grid before the first step; the exact integrator stops at
    # the same instant on the state that is not finite, test_exact_stepper: pinned to θ)
    with pytest.raises(SimulationError, match=r"a source function is inf at t = 0.003 s \(source v1"):
        circuit.transient(1e-3, 10e-3, method="theta")


@pytest.mark.parametrize("keywords, message", [
    ({"step": -1.0}, "step = -1 must be positive and finite"),
    ({"step": 0.0}, "step = 0 must be positive and finite"),
    ({"step": float("inf")}, "step = inf must be positive and finite"),
    ({"theta": 2.0}, r"theta = 2 is outside \[0.5, 1\]")])
def test_well_posedness_refuses_a_bad_step_or_theta(keywords, message):
    # before: step=-1 (a negative K) and theta=2 returned verdicts, step=0 was taken as "not given"
    circuit = read("V1 a 0 SIN(0 1 1k)\nD1 a b dd\nR1 b 0 1k\nC1 b 0 1u\n.model dd D(Ron=1)\n.tran 10u 3m")
    assert circuit.well_posedness()  # the defaults work
    with pytest.raises(circuitnsds.CircuitError, match=message):
        circuit.well_posedness(**keywords)
