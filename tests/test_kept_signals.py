"""A run that keeps only some signals goes in segments: the same waveforms as one run, with
memory bounded by what is kept (issue 19)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import circuitnsds
import circuitnsds.analyses.recorders as recorders
import circuitnsds.engine.theta_stepper as theta_stepper
from tests.conftest import NETLISTS, pinned

FLYBACK = NETLISTS.parent / "benchmarks" / "netlists" / "flyback_coss.cir"


@pytest.mark.parametrize(("netlist", "stop", "theta", "start", "names"), [
    ("buck_converter.cir", 0.3e-3, 0.5, None, ["V(out)", "i(d1)"]),  # scheduled switch, θ < 1
    ("buck_converter.cir", 0.3e-3, 1.0, 0.1e-3, ["V(out)", "i(d1)"]),  # TSTART in segment 2
    ("bridge_rectifier.cir", 30e-3, 1.0, None, ["V(out)", "i(d1)"]),  # diodes changing mode
    # ringing at θ = 0.5: mode changes found in the table, restarts after each switching; a
    # segment starting after a switching needs the active set last seen in that switch state
    (FLYBACK, 20e-6, 0.5, None, ["V(out)", "i(do)"]),
])
def test_segments_give_the_waveforms_of_one_run(monkeypatch, netlist, stop, theta, start, names):
    circuit = circuitnsds.read_netlist(pinned(Path(NETLISTS / netlist).read_text()))  # θ's segments
    whole = circuit.transient(stop=stop, theta=theta, start=start)
    sizes = []
    original = theta_stepper.integrate

    def recording(mlcs, grid, *args, **kwargs):
        sizes.append(grid.size)
        return original(mlcs, grid, *args, **kwargs)

    monkeypatch.setattr(theta_stepper, "integrate", recording)
    monkeypatch.setattr(recorders, "segment_steps", lambda mlcs: 700)
    kept = circuit.transient(stop=stop, theta=theta, start=start, signals=names)
    assert len(sizes) >= 3 and max(sizes) == 701  # bounded segments, not one run
    assert kept.names == [name.lower() for name in names]
    np.testing.assert_array_equal(kept.time, whole.time)
    assert kept.stats["steps"] == whole.stats["steps"]
    # the segments share one stepping state (solvers, maps, mode table) and take a segment's
    # first step in the mode loop, as one run does: the same arithmetic, bit for bit here
    # (before: each segment built its modes again and solved its first step as an MLCP,
    # 1e-13 apart and 5x the modes)
    for name in kept.names:
        np.testing.assert_array_equal(kept[name], whole[name])
    assert kept.stats["modes"] == whole.stats["modes"]
    assert kept.stats["mlcp_steps"] == whole.stats["mlcp_steps"]
    assert kept.residual.shape == whole.residual.shape


def test_unknown_kept_signal_is_an_error():
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    with pytest.raises(circuitnsds.CircuitError, match=r"unknown signal\(s\) v\(nowhere\)"):
        circuit.transient(stop=1e-5, signals=["v(nowhere)"])


def test_a_finished_segment_is_freed_without_the_garbage_collector(monkeypatch):
    """Memory bounded by one segment: nothing (no reference cycle) keeps a segment's
    trajectory alive once its signals are taken (a cycle kept ~160 MB per segment of a
    1,000-section ladder until Python's cycle collector happened to run)."""
    import gc
    import weakref

    circuit = circuitnsds.read_netlist(NETLISTS / "bridge_rectifier.cir")
    arrays = []
    original = theta_stepper.integrate

    def recording(mlcs, grid, *args, **kwargs):
        trajectory = original(mlcs, grid, *args, **kwargs)
        arrays.append(weakref.ref(trajectory.y))
        return trajectory

    monkeypatch.setattr(theta_stepper, "integrate", recording)
    monkeypatch.setattr(recorders, "segment_steps", lambda mlcs: 300)
    gc.collect()
    gc.disable()
    try:
        kept = circuit.transient(stop=20e-3, signals=["v(out)"], method="theta")  # θ's segments
        assert len(arrays) >= 3
        assert [ref() is None for ref in arrays] == [True] * len(arrays)
    finally:
        gc.enable()
    assert kept.time.size > 3 * 300
