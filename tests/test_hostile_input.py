"""Hostile or absurd input gets a clear error, never "internal error" (issue 20, items 6-8)."""

import os

import pytest

from circuitnsds.cli.main import main
from circuitnsds.errors import NetlistError
from circuitnsds.netlist.expressions import MAX_DEPTH, ExpressionError, evaluate
from tests.conftest import NETLISTS, circuit_from


def _run(tmp_path, capsys, text, *args):
    netlist = tmp_path / "hostile.cir"
    netlist.write_text(text)
    status = main(["run", str(netlist), "-o", str(tmp_path / "out.csv"), "-q", *args])
    err = capsys.readouterr().err
    assert "internal error" not in err
    return status, err


# --- item 7: deep nesting --------------------------------------------------------------------

def test_parentheses_nested_to_the_limit_evaluate_and_deeper_is_an_error():
    assert evaluate("(" * MAX_DEPTH + "2" + ")" * MAX_DEPTH) == 2.0
    assert evaluate("sqrt(" * 50 + "16" + ")" * 50) == pytest.approx(1.0 + 16 ** (2.0 ** -50) - 1.0)
    with pytest.raises(ExpressionError, match="nested more than 100 levels"):
        evaluate("(" * 300 + "1" + ")" * 300)


def test_any_number_of_unary_signs():
    assert evaluate("-" * 20000 + "1") == 1.0
    assert evaluate("-" * 20001 + "1") == -1.0
    assert evaluate("2^" + "-" * 5001 + "1") == 0.5


def test_deep_parentheses_in_a_netlist_are_a_netlist_error(tmp_path, capsys):
    text = "deep\n.param p=" + "(" * 300 + "1" + ")" * 300 + "\nR1 a 0 {p}\nV1 a 0 1\n.tran 1u 10u\n.end\n"
    status, err = _run(tmp_path, capsys, text)
    assert status == 1 and "hostile.cir:2" in err and "nested more than 100 levels" in err
    assert len(err) < 1000                           # the 601-character line is not echoed whole


def test_long_chains_of_parameters():
    forward = "\n".join([".param p0=1"] + [f".param p{i}={{p{i - 1}+1}}" for i in range(1, 3000)])
    circuit = circuit_from(forward + "\nR1 a 0 {p2999}\nV1 a 0 1")
    assert circuit.elements[0].resistance == 3000.0     # defined in order: evaluated in order
    backward = "\n".join(f".param p{i}={{p{i - 1}+1}}" for i in range(300, 0, -1)) + "\n.param p0=1"
    with pytest.raises(NetlistError, match="chain of more than 50 parameters"):
        circuit_from(backward + "\nR1 a 0 {p300}\nV1 a 0 1")


# --- item 7: figures ---------------------------------------------------------------------------

def test_unknown_figure_format_is_refused_before_simulating(tmp_path, capsys):
    status, err = _run(tmp_path, capsys, (NETLISTS / "diode_clamp.cir").read_text(),
                       "--plot", str(tmp_path / "x.xyz"))
    assert status == 1 and "'.xyz' is not a figure format" in err and ".png" in err
    assert not (tmp_path / "out.csv").exists()       # refused before the run, not after


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="/dev/full is Linux's full device")
def test_a_figure_that_cannot_be_written_is_an_error(tmp_path, capsys):
    status, err = _run(tmp_path, capsys, (NETLISTS / "diode_clamp.cir").read_text(),
                       "--plot", "/dev/full")
    assert status == 1 and "No space left on device" in err


# --- item 6: bounded resources -------------------------------------------------------------------

@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="/dev/zero is a Unix device")
@pytest.mark.parametrize("how", ["run", "include"])
def test_dev_zero_is_refused_at_once(tmp_path, capsys, how):
    if how == "run":
        status = main(["run", "/dev/zero", "-o", str(tmp_path / "out.csv"), "-q"])
        err = capsys.readouterr().err
    else:
        status, err = _run(tmp_path, capsys, "inc\n.include /dev/zero\n.end\n")
    kind = "binary file" if how == "run" else "is a device, not a regular file"  # (issue 37)
    assert status == 1 and kind in err and "not found" not in err


def test_an_endless_text_source_is_read_only_up_to_the_limit(tmp_path, monkeypatch):
    from circuitnsds.netlist import parser
    monkeypatch.setattr(parser, "MAX_SOURCE_BYTES", 1000)
    path = tmp_path / "big.cir"
    path.write_text("title\n" + "R1 a 0 1k\n" * 200)
    with pytest.raises(NetlistError, match="larger than"):
        parser.read_source_text(path)


def test_subcircuit_fan_out_is_refused_before_expanding():
    lines = [".subckt l0 a b", "R1 a b 1k", ".ends"]
    for k in range(1, 31):          # 2^30 resistors from 95 lines
        lines += [f".subckt l{k} a b", f"X1 a m l{k - 1}", f"X2 m b l{k - 1}", ".ends"]
    with pytest.raises(NetlistError, match="would make 1,073,741,824 more statements"):
        circuit_from("\n".join(lines + ["X0 in 0 l30", "V1 in 0 1"]))
    small = circuit_from("\n".join(lines[:3 + 4 * 4] + ["X0 in 0 l4", "V1 in 0 1"]))
    assert sum(e.name.endswith("r1") for e in small.elements) == 16   # 2^4, as written


def test_a_run_whose_results_cannot_fit_in_memory_is_refused_before_starting(monkeypatch):
    import circuitnsds.analyses.memory as memory
    from circuitnsds.errors import CircuitError
    monkeypatch.setattr(memory, "available_memory", lambda: 100 * 2**20)   # 100 MiB
    circuit = circuit_from("V1 a 0 1\n" + "\n".join(f"R{k} a n{k} 1k\nC{k} n{k} 0 1n" for k in range(100))
                           + "\n.tran 1n 1m")
    # 1,000,001 points × (102 unknowns + 1 source value + 4 per-point numbers) × 8 bytes = 0.797 GiB
    with pytest.raises(CircuitError, match=r"would take 0\.797 GiB \(1,000,001 time points × 102"):
        circuit.transient()


def test_a_periodic_steady_state_that_cannot_fit_in_memory_is_refused_before_starting(monkeypatch):
    """pss kept no check: 1e6 steps per period peaked at 1 GB, 1e7 grew 25 MB/s until stopped."""
    import circuitnsds.analyses.memory as memory
    from circuitnsds.errors import CircuitError
    monkeypatch.setattr(memory, "available_memory", lambda: 100 * 2**20)   # 100 MiB
    circuit = circuit_from("V1 in 0 SIN(0 1 1k)\nR1 in out 1k\nC1 out 0 1u\n.tran 1u 1m")
    unknowns = circuit.mlcs().n
    # 1,000,000 steps × 4 × (unknowns + 1 source value + 4 per-point numbers) × 8 bytes
    expected = 4 * 1_000_001 * 8 * (unknowns + 5) / 2**30
    with pytest.raises(CircuitError, match=rf"periodic steady state would take {expected:.3g} GiB "
                       rf"\(1,000,000 steps per period, {unknowns} unknowns and 0 pairs\)"):
        circuit.pss(period=1e-3, step=1e-9)
    with pytest.raises(CircuitError, match=r"\(1,000 steps per period, warm-up 20,000,000 steps"):
        circuit.pss(period=1e-3, step=1e-6, periods_warmup=20_000)   # the warm-up run: ~1 GB


def test_reading_is_linear_in_the_number_of_elements():
    """Circuit.add once scanned every element (16k elements: 13.7 s). Counted, not timed:
    the element lookups a read makes do not grow with the circuit."""
    from circuitnsds.circuit.circuit import Circuit
    from circuitnsds.circuit.elements import Resistor
    circuit = Circuit()
    for k in range(20000):
        circuit.add(Resistor(f"r{k}", (f"n{k}", f"n{k + 1}"), resistance=1.0))
    assert len(circuit.nodes) == 20001 and circuit.element("R19999").nodes == ("n19999", "n20000")
    with pytest.raises(NetlistError, match="defined twice"):
        circuit.add(Resistor("r5", ("a", "b"), resistance=1.0))
    circuit.elements.append(Resistor("extra", ("x", "0"), resistance=1.0))   # changed directly
    assert circuit.element("extra").nodes == ("x", "0")


# --- item 8: messages ------------------------------------------------------------------------------

def test_terminal_escapes_in_a_netlist_are_not_echoed_raw(tmp_path, capsys):
    status, err = _run(tmp_path, capsys, "esc\nR1 a 0 \x1b[31mred\x1b[0m\nV1 a 0 1\n.end\n")
    assert status == 1 and "\x1b" not in err and "\\x1b[31mred" in err


def test_a_long_message_keeps_every_clause():
    from circuitnsds.errors import CircuitError
    devices = ", ".join(f"d{k}" for k in range(3000))
    text = str(CircuitError("step failed", hint=f"devices: {devices}; look for a diode in series "
                                                  "with a current source"))
    assert len(text) < 500 and text.endswith("look for a diode in series with a current source")
    assert "devices: d0, d1" in text and "d2999" in text


def test_a_value_too_small_for_a_double_says_so(tmp_path, capsys):
    status, err = _run(tmp_path, capsys, "t\nR1 a 0 1e-400\nV1 a 0 1\n.tran 1u 1m\n.end\n")
    assert status == 1 and "'1e-400' is too small" in err
    with pytest.raises(SystemExit):
        main(["run", str(NETLISTS / "diode_clamp.cir"), "--step", "1e-400"])
    assert "too small for a double" in capsys.readouterr().err


@pytest.mark.parametrize(("body", "named", "innocent"), [
    ("V1 a 0 1\nR1 a b 1e-15\nC1 b 0 1u\nR2 b 0 1k", "r1 (R = 1e-15 Ω)", "nothing in the circuit determines"),
    ("V1 a 0 1\nR1 a b 1e-300\nC1 b 0 1u\nD1 b 0 dd\n.model dd D", "r1 (R = 1e-300 Ω)", ".ic"),
    ("V1 a 0 SIN(0 1 1k)\nR1 a b 1k\nC1 b 0 1u\nD1 b 0 dd\n.model dd D\n.options gmin=1e300",
     "d1 (Roff = 1e-300 Ω)", "orientation"),
    ("V1 a 0 SIN(0 1 1k)\nR1 a b 1k\nC1 b 0 1e300\nD1 b 0 dd\n.model dd D\n.tran 1u 10u uic",
     "c1 (C = 1e+300 F)", "orientation"),
])
def test_extreme_values_are_named_not_innocent_nodes(body, named, innocent):
    from circuitnsds.errors import SimulationError
    text = body if ".tran" in body else body + "\n.tran 1u 10u"
    with pytest.raises(SimulationError) as caught:
        circuit_from(text).transient()
    message = str(caught.value)
    assert named in message and "double precision" in message and innocent not in message


def test_an_ic_contradicting_a_source_names_the_node():
    from circuitnsds.errors import SimulationError
    with pytest.raises(SimulationError, match=r":5: \.ic v\(a\)=2 contradicts the sources, which hold "
                                              r"a at 1 V"):
        circuit_from("V1 a 0 1\nR1 a b 1k\nC1 b 0 1u\n.ic v(a)=2\n.tran 1u 10u").transient()


def test_a_command_on_the_title_line_is_named_when_it_is_not_read(tmp_path, capsys):
    # the first line is the title, whatever it holds (as in SPICE): a netlist whose first line
    # is its .tran failed with "no .tran line" and nothing saying why the line was not read
    path = tmp_path / "untitled.cir"
    path.write_text(".tran 1u 1m\nV1 a 0 1\nR1 a 0 1k\n.end\n")
    assert main(["run", str(path), "-q", "-o", str(tmp_path / "o.csv")]) == 1
    err = capsys.readouterr().err
    assert (f"warning: {path}:1: the first line is the title and is not read, as in SPICE: "
            "'.tran 1u 1m'") in err
    assert "no .tran line" in err
    # a title that merely starts with a dot is a title like any other
    path.write_text(".title RC\nV1 a 0 1\nR1 a 0 1k\n.tran 1u 10u\n.end\n")
    assert main(["run", str(path), "-q", "-o", str(tmp_path / "o.csv")]) == 0
    assert capsys.readouterr().err == ""


def test_a_bad_sin_argument_is_not_explained_with_pwl_options():
    with pytest.raises(NetlistError) as error:
        circuit_from("V1 a 0 SIN(0 \u221210 50)\nR1 a 0 1\n.tran 1u 1m")
    assert "SIN argument '\u221210' is not a number" in str(error.value)
    assert "PWL" not in str(error.value)
    with pytest.raises(NetlistError, match=r"PWL argument 'x' is not a number\n"):
        circuit_from("V1 a 0 PWL(0 0 1m 1 x)\nR1 a 0 1\n.tran 1u 1m")  # (r= and td= are read)


def test_an_ic_given_twice_with_two_values_is_a_warning():
    # before: the second value silently replaced the first
    import warnings as python_warnings

    import circuitnsds

    with python_warnings.catch_warnings(record=True) as caught:
        python_warnings.simplefilter("always")
        circuit = circuit_from("V1 a 0 1\nR1 a b 1k\nC1 b 0 1u\n.ic v(b)=1\n.ic v(b)=2 v(b)=2\n"
                               ".tran 1u 1m uic")
    messages = [str(w.message) for w in caught if issubclass(w.category, circuitnsds.NetlistWarning)]
    assert messages == ["<text>:6: .ic v(b) is given twice, 1 (at <text>:5) and 2: the last one is used"]
    assert circuit.initial_voltages["b"][0] == 2.0


@pytest.mark.parametrize("invisible", ["\u200b", "\u00ad", "\ufeff", "\x07"])
def test_an_invisible_character_in_a_name_is_an_error_at_its_line(invisible):
    # before: "R\u200b1" was an element of its own, its name (with the zero-width space) in the
    # CSV header, where nobody could type it back (--signals i(r1) did not find it)
    import circuitnsds

    text = f"t\nV1 a 0 1\nR{invisible}1 a 0 1k\n.tran 1u 10u\n.end\n"
    with pytest.raises(NetlistError, match=rf"U\+{ord(invisible):04X}") as error:
        circuitnsds.read_netlist(text)
    assert error.value.where.line == 3 and "delete it" in error.value.hint
    # the title and comments may hold anything
    circuitnsds.read_netlist(f"t{invisible}\n* c{invisible}\nV1 a 0 1\nR1 a 0 1k\n.tran 1u 10u\n.end\n")
