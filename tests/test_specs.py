"""Analysis specs (circuitnsds/specs.py): the front end reads the analysis lines into
them, and a source's omitted fields take their values from the analysis being run
(ngspice's rule: PULSE TR = TF = TSTEP, PW = PER = TSTOP), not from the circuit."""

import pytest

import circuitnsds
from circuitnsds import CircuitError, SourceDefaults, TransientSpec
from circuitnsds.analyses.transient import transient_spec

NETLIST = """pulse into a resistor
V1 a 0 PULSE(0 1)
R1 a 0 1k
.tran 2u 1m 0.1m 5u uic
.ac lin 3 1k 3k
.end
"""


def read(text=NETLIST):
    return circuitnsds.read_netlist(text)


def pulse(mlcs):
    return mlcs.stimuli[mlcs.stimulus_column("v1")]


def test_the_front_end_reads_each_analysis_line_into_its_spec():
    circuit = read()
    tran = circuit.analyses["tran"]
    assert (tran.step, tran.stop, tran.start, tran.max_step, tran.uic) == (2e-6, 1e-3, 1e-4, 5e-6, True)
    assert tran.theta is None and tran.refine_step and tran.location.line == 4
    assert list(circuit.analyses["ac"].frequencies()) == [1e3, 2e3, 3e3]
    assert "pss" not in circuit.analyses


def test_source_defaults_come_from_the_analysis_not_the_circuit():
    circuit = read()
    from_tran = pulse(circuit.mlcs())  # no analysis given: the netlist's .tran, as ngspice runs it
    assert (from_tran.rise, from_tran.fall, from_tran.width, from_tran.period) == (2e-6, 2e-6, 1e-3, 1e-3)
    other = pulse(circuit.mlcs(SourceDefaults(step=1e-6, stop=4e-3)))
    assert (other.rise, other.fall, other.width, other.period) == (1e-6, 1e-6, 4e-3, 4e-3)
    spec = transient_spec(circuit, stop=3e-3)  # a run to 3 ms: PER = its TSTOP
    assert pulse(circuit.mlcs(spec.source_defaults)).period == 3e-3


def test_arguments_replace_the_fields_of_the_tran_line():
    circuit = read()
    assert transient_spec(circuit) == TransientSpec(step=2e-6, stop=1e-3, start=1e-4, max_step=5e-6,
                                                    uic=True, theta=1.0,
                                                    location=circuit.analyses["tran"].location)
    longer = transient_spec(circuit, stop=3e-3, uic=False)
    assert (longer.step, longer.stop, longer.uic, longer.refine_step) == (2e-6, 3e-3, False, True)
    assert not transient_spec(circuit, step=1e-6).refine_step  # a step given is obeyed, not refined
    assert transient_spec(read(NETLIST.replace(".end", ".options theta=0.5\n.end"))).theta == 0.5
    assert transient_spec(circuit, theta=0.6).theta == 0.6
    with pytest.raises(TypeError, match="no field"):
        transient_spec(circuit, tstop=1.0)


def test_a_transient_without_tran_line_needs_step_and_stop():
    circuit = read(NETLIST.replace(".tran 2u 1m 0.1m 5u uic\n", ""))
    with pytest.raises(CircuitError, match="no .tran line and no step/stop given"):
        transient_spec(circuit, stop=1e-3)
    spec = transient_spec(circuit, step=1e-5, stop=1e-4)
    assert (spec.step, spec.stop, spec.start, spec.uic, spec.refine_step) == (1e-5, 1e-4, 0.0, False, False)
    assert pulse(circuit.mlcs()).period == 1.0  # no analysis and no .tran: a 1 s time scale


def test_the_old_attributes_read_the_specs_with_a_deprecation_warning():
    circuit = read()
    with pytest.deprecated_call(match="analyses.get"):
        assert circuit.tran is circuit.analyses["tran"]
    with pytest.deprecated_call():
        assert circuit.ac_spec is circuit.analyses["ac"]
    with pytest.deprecated_call():
        assert circuit.pss_spec is None
    assert circuitnsds.TranSpec is TransientSpec


def test_the_removed_step_stop_form_of_mlcs_is_refused_with_the_new_form():
    with pytest.raises(TypeError, match=r"mlcs\(SourceDefaults\(step=TSTEP, stop=TSTOP\)\)"):
        read().mlcs(2e-6)
