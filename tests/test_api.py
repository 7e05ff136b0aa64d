"""The Python API: read_netlist from a path or text, transient(), Waveforms."""

import numpy as np
import pytest

import circuitnsds
from tests.conftest import NETLISTS


def test_read_netlist_accepts_path_str_and_text():
    path = NETLISTS / "half_wave_rectifier.cir"
    from_path = circuitnsds.read_netlist(path)
    from_str = circuitnsds.read_netlist(str(path))
    from_text = circuitnsds.read_netlist(path.read_text())
    assert from_path.nodes == from_str.nodes == from_text.nodes == ["in", "out"]
    assert from_path.file.endswith("half_wave_rectifier.cir") and from_text.file == "<text>"


def test_transient_overrides_and_waveforms_access():
    circuit = circuitnsds.read_netlist(NETLISTS / "half_wave_rectifier.cir")
    waves = circuit.transient(step=1e-4, stop=1e-2, start=5e-3)
    assert waves.time[0] == pytest.approx(5e-3) and waves.time[-1] == pytest.approx(1e-2)
    assert waves["V(OUT)"] is waves["v(out)"]
    assert "i(d1)" in waves and "v(nowhere)" not in waves
    with pytest.raises(KeyError, match="available"):
        waves["v(nowhere)"]
    chosen = waves.select(["v(out)"])
    assert chosen.names == ["v(out)"]
    frame = waves.to_dataframe()
    assert list(frame.columns) == waves.names
    np.testing.assert_array_equal(frame["v(out)"].to_numpy(), waves["v(out)"])
    assert waves.stats["steps"] == 100


def test_mlcs_is_printable():
    text = str(circuitnsds.read_netlist(NETLISTS / "bridge_rectifier.cir").mlcs())
    assert "m = 4 complementarity pairs" in text and "d1, d2, d3, d4" in text


def test_signals_are_computed_when_read_and_behave_as_a_dict():
    """A transient's signals are a LazySignals: each column is computed on first access (the
    values themselves are checked by every other test), can be replaced, added or deleted
    like a dict entry, and the whole thing pickles as a plain dict."""
    import pickle

    circuit = circuitnsds.read_netlist(NETLISTS / "half_wave_rectifier.cir")
    waves = circuit.transient()
    signals = waves.signals
    assert not signals._values  # nothing computed yet
    out = waves["v(out)"]
    assert list(signals._values) == ["v(out)"]
    restored = pickle.loads(pickle.dumps(waves))
    assert isinstance(restored.signals, dict) and list(restored.signals) == list(signals)
    np.testing.assert_array_equal(restored["v(out)"], out)
    signals["twice"] = 2 * out
    assert "twice" in waves and waves.names[-1] == "twice"
    del signals["twice"]
    assert "twice" not in waves


def test_stepping_option_is_checked():
    """``stepping`` names one of the three paths; anything else is a clear error, not a default."""
    circuit = circuitnsds.read_netlist("half-wave rectifier\nV1 a 0 SIN(0 1 1k)\nD1 a b dd\nR1 b 0 1k\n"
                                       "C1 b 0 1u\n.model dd D(Ron=1)\n.tran 10u 3m\n.end\n")
    # (the θ-method's three stepping paths: pinned to it, the default may be auto)
    paths = {path: circuit.transient(stepping=path, method="theta") for path in ("compiled", "numpy", "mlcp")}
    assert paths["compiled"].stats["mapped_steps"] > 0.5 * paths["compiled"].stats["steps"]
    assert paths["mlcp"].stats["mapped_steps"] == 0
    for path in ("numpy", "mlcp"):  # one scheme: the same numbers to rounding
        np.testing.assert_allclose(paths[path]["v(b)"], paths["compiled"]["v(b)"], rtol=0, atol=1e-9)
    with pytest.raises(circuitnsds.CircuitError, match="stepping"):
        circuit.transient(stepping="fast")


@pytest.mark.parametrize("argument, value", [
    ("tol", -1.0), ("tol", 0.0), ("tol", float("nan")), ("max_step", 0.0), ("max_step", -1e-6),
    ("max_step", float("inf")), ("step", -1e-5), ("step", float("nan")), ("stop", float("inf")),
    ("stop", 0.0)])
def test_bad_transient_arguments_are_errors_naming_them(argument, value):
    """A non-positive or non-finite tol, max_step, step or stop is a CircuitError naming the
    argument, before any work: tol=-1 used to be reported as "the DC operating point has no
    solution", and max_step=0 was taken as "not given" (while .tran's TMAX = 0 is an error)."""
    circuit = circuitnsds.read_netlist(NETLISTS / "half_wave_rectifier.cir")
    with pytest.raises(circuitnsds.CircuitError, match=rf"^.*\b{argument} = .* must be positive and finite"):
        circuit.transient(**{argument: value})


def test_a_source_too_fast_for_any_grid_is_one_error_naming_it_without_a_refinement_note():
    # before: a note "integrated with a step of 5e-302 s (TSTEP/2000...0)" (a 300-digit factor)
    # came first, then an error blaming "the units of TSTEP/TMAX and TSTOP"
    import warnings

    circuit = circuitnsds.read_netlist("sin\nV1 a 0 SIN(0 1 1e300)\nR1 a 0 1k\n.tran 1u 1m\n.end\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(circuitnsds.CircuitError, match=r"steps requested.*v1 needs a step of at most "
                           r"5e-302 s") as error:
            circuit.transient()
    assert "frequencies of the sources" in error.value.hint
    assert not [w for w in caught if "TSTEP/" in str(w.message)]
