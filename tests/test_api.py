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
