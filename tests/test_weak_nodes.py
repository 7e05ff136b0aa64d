"""Nodes held only by off-conductances (issue 20, item 1).

When every diode of a bridge rectifier blocks, the AC side (the source and its two
terminals) is tied to the rest only by the diodes' off-conductances ``g`` (gmin,
1e-12 S). Its common mode then follows from KCL on that supernode: the four currents
``g·(v(acp) - v(out)) + g·(v(acn) - v(out)) + g·v(acp) + g·v(acn)`` sum to zero, so
``v(acp) + v(acn) = v(out)`` exactly, whatever g. A pair kept "conducting" with a
wrong-signed current of -6e-10 A (noise beside the amperes in the node's row) once
held v(acp) at -0.8 V instead, then let it jump 160 V in one step.
"""

import numpy as np
import pytest

import circuitnsds
from tests.conftest import NETLISTS
from tests.test_switches import _run_paths


def _blocking(waves, names):
    """Grid points where every listed diode carries less than a microampere."""
    currents = np.column_stack([waves[f"i({name})"] for name in names])
    return np.all(np.abs(currents) < 1e-6, axis=1)


def test_bridge_ac_side_follows_the_common_mode_on_every_path(monkeypatch):
    circuit = circuitnsds.read_netlist(NETLISTS / "bridge_rectifier.cir")
    for path, waves in _run_paths(circuit, monkeypatch, 50e-3).items():
        acp, acn, out = waves["v(acp)"], waves["v(acn)"], waves["v(out)"]
        blocking = _blocking(waves, ["d1", "d2", "d3", "d4"])
        assert blocking.sum() > 0.5 * blocking.size, path   # a reservoir rectifier mostly blocks
        # KCL on the floating AC side (module docstring); 0.1 V leaves room for the 0.5 ohm
        # source resistance and the tolerance of the steps solved as MLCPs
        assert np.abs((acp + acn - out)[blocking]).max() < 0.1, path
        # the common mode moves with v(out) only: no step-to-step jump (it was 160 V)
        assert np.abs(np.diff(0.5 * (acp + acn))).max() < 1.0, path


def test_weakly_held_node_is_not_pinned_by_a_wrong_signed_current():
    """The same mechanism without a source across the diodes: node x is held only by the
    off-conductances of two diodes (one to a 100 V rail, one to ground), so it sits at
    the midpoint 50 V; a 1 nF capacitor to a sine keeps a mode loop running. Neither diode
    may be reported conducting, nor x pinned at a diode's threshold."""
    circuit = circuitnsds.read_netlist("""weak node
V1 rail 0 100
V2 drive 0 SIN(0 1 1k)
D1 x rail dd
D2 0 x dd
R1 drive y 1k
C1 y 0 1u
.model dd D(Vfwd=0.7 Roff=1e12)
.tran 10u 3m
.end""")
    waves = circuit.transient()
    assert np.allclose(waves["v(x)"], 50.0, atol=1e-3)
    assert np.abs(waves["i(d1)"]).max() < 1e-9 and np.abs(waves["i(d2)"]).max() < 1e-9


@pytest.mark.ngspice
def test_bridge_ac_side_agrees_with_ngspice_with_junction_capacitance():
    """ngspice 39 runs the bridge once its diodes have a junction capacitance (without it:
    "Timestep too small", see test_compare_ngspice.py); equal capacitances split the
    floating AC side as equal off-conductances do, so v(acp) must agree closely (it was
    ~12 % RMS off)."""
    import warnings

    from circuitnsds.compare import compare
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = compare(NETLISTS / "bridge_rectifier.cir", cjo=100e-12)
    assert comparison.run.ok, comparison.run.ngspice.message
    for signal in ("v(acp)", "v(acn)", "v(out)"):
        assert comparison.metrics[signal].nrms < 0.01, (signal, comparison.metrics[signal].nrms)
