"""Edge cases across the pipeline: extreme Ron/h ratios, UIC start-up, TSTART, bad lines,
unwritable outputs, denormal sources, odd names and line ends. Each once gave a wrong answer
or a traceback."""

import numpy as np
import pytest

import circuitnsds
from circuitnsds.cli.main import main
from circuitnsds.errors import CircuitError, NetlistError
from tests.conftest import NETLISTS, circuit_from
from tests.device_checks import assert_device_laws

RON_CIRCUIT = """V1 1 0 SIN(2 1 1k)
D9 1 2 dd
C1 2 0 0.1u
R2 2 0 10k
.model dd D(Ron={ron})
.tran 1u 3m"""


@pytest.mark.parametrize(("ron", "h"), [(1e3, 1e-6), (100, 2.5e-7), (1e6, 1e-7), (0.01, 1e-6)])
def test_diode_with_large_ron_over_h_obeys_its_law(ron, h):
    """Ron/h of 1e9 beside O(1) rows once let a forward-biased diode stay off."""
    circuit = circuit_from(RON_CIRCUIT.format(ron=ron))
    assert_device_laws(circuit, circuit.transient(step=h))


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
@pytest.mark.parametrize("h", [1e-7, 1e-5])
def test_clamp_and_rectifier_across_scales(scale, h):
    circuit = circuit_from(f"""V1 in 0 SIN(0 {scale} 1k)
R1 in out 1k
D1 out ref ideal
Vref ref 0 DC {0.4 * scale}
D2 0 out pwl
C1 out 0 1u
Rl out 0 10k
.model ideal D
.model pwl D(Vfwd={0.3 * scale} Ron=0.01)
.tran {h} 2m""")
    assert_device_laws(circuit, circuit.transient())


def test_uic_capacitor_without_ic_starts_from_its_node_ics():
    waves = circuit_from("C1 a 0 1u ic=5\nC2 a 0 1u\nR1 a 0 1meg\n.tran 1u 5u uic").transient()
    # C2 starts at 0 V (its nodes have no .ic): the charge of C1 is shared at once
    assert waves["v(a)"][0] == pytest.approx(5.0)
    assert waves["v(a)"][1] == pytest.approx(2.5, rel=1e-5)


def test_output_starts_exactly_at_tstart():
    waves = circuit_from("V1 a 0 1\nR1 a 0 1\n.tran 1m 10m 2.5m").transient()
    assert waves.time[0] == pytest.approx(2.5e-3, abs=1e-15)


@pytest.mark.parametrize(
    ("body", "pattern"),
    [
        (",", "cannot read"),
        ("V1 a 0 1e400\nR1 a 0 1", "unexpected '1e400'"),
        ("R1 a 0 1e400", "'1e400' is too large"),
        (".model dd D(Ron=1) Vfwd=0.7", r"expected '\)' at the end"),
        (".ic v(0)=5", "cannot set the ground node"),
        (".model dd D(Ron=1 ron=2)", "given twice"),
        ("V1 a 0 DC 1 DC 2\nR1 a 0 1", "DC value is given twice"),
        ("V1 a 0 EXP(0 1 0 -1)\nR1 a 0 1", "must not be negative"),
    ],
)
def test_bad_lines_are_clean_errors(body, pattern):
    with pytest.raises(NetlistError, match=pattern):
        circuit_from(body)


def test_absurd_step_count_is_a_clean_error():
    with pytest.raises(CircuitError, match="far too small"):
        circuit_from("V1 a 0 1\nR1 a 0 1\n.tran 1m 10m 0 1e-300").transient()


def test_unwritable_outputs_are_clean_errors(tmp_path, capsys):
    netlist = tmp_path / "x.cir"
    netlist.write_text("t\nV1 a 0 1\nR1 a 0 1\n.tran 1m 2m\n.end\n")
    missing = tmp_path / "no" / "such"
    for args in (["run", str(netlist), "-o", str(missing / "x.csv")],
                 ["run", str(netlist), "-o", str(tmp_path / "x.csv"), "--plot",
                  str(missing / "x.png")],
                 ["info", str(netlist), "--matrices", str(missing / "m.npz")]):
        assert main(args) == 1
        err = capsys.readouterr().err
        assert "cannot write" in err and "Traceback" not in err


def test_time_in_signals_is_not_written_twice(tmp_path):
    netlist = tmp_path / "x.cir"
    netlist.write_text("t\nV1 a 0 1\nR1 a 0 1\n.tran 1m 2m\n.end\n")
    out = tmp_path / "x.csv"
    assert main(["run", str(netlist), "-o", str(out), "--signals", "time,v(a)", "-q"]) == 0
    assert out.read_text().splitlines()[0] == "time,v(a)"
    assert np.loadtxt(out, delimiter=",", skiprows=1).shape == (3, 2)


def test_denormal_source_amplitude_is_not_a_crash():
    # fuzzing: 0/0 ratios in Lemke's ratio test crashed with a numpy ValueError
    text = (NETLISTS / "half_wave_rectifier.cir").read_text()
    text = "\n".join("V1 in 0 SIN(0 1e-320 50)" if line.lower().startswith("v1 ") else line
                     for line in text.splitlines())
    try:
        waves = circuitnsds.read_netlist(text + "\n").transient(20e-6, 200e-6)
    except circuitnsds.CircuitnsdsError:
        return  # a clear project error is acceptable; any other exception fails the test
    assert np.all(np.isfinite(waves["v(in)"]))
    assert np.max(np.abs(waves["v(in)"])) < 1e-300


def test_a_name_ending_with_the_hierarchy_separator_is_not_an_element():
    # fuzzing: "fig." has an empty type letter, and "" in "rcl" is true
    with pytest.raises(circuitnsds.NetlistError, match=r"<text>:2: fig\.: not an element name"):
        circuitnsds.read_netlist("title\nfig. a b\nR1 a 0 1\n")


def test_a_form_feed_does_not_end_a_line():
    # fuzzing: str.splitlines() split the title at a form feed and made "fig." a statement
    circuit = circuitnsds.read_netlist("Title \x0c Fig. 1\nR1 a 0 1\nV1 a 0 1\n.tran 1m 2m\n.end\n")
    assert [element.name for element in circuit.elements] == ["r1", "v1"]
    assert "Fig. 1" in circuit.title
