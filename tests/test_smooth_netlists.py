"""The netlists of ``netlists/smooth`` (issue 33's held-out style): they read as written, with
their BJTs as smooth relations and the rest ideal; their recorded ngspice answers are
ngspice's (marker ``ngspice``: rerunning ngspice gives the recorded waveforms)."""

import subprocess
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest

import circuitnsds
from tests.conftest import NETLISTS

SMOOTH = NETLISTS / "smooth"
CASES = {
    "npn_lowside_inductive": (("q1",), ("d1",), "v(c) v(b) i(l1)", 20),
    "bjt_totem_gate_driver": (("q1", "q2"), ("m1",), "v(e) v(g) v(d)", 2),
}


@pytest.mark.parametrize("name", CASES)
def test_netlist_reads_with_its_bjts_smooth_and_the_rest_ideal(name):
    smooth, ideal, _, _ = CASES[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuitnsds.read_netlist(SMOOTH / f"{name}.cir")
        mlcs = circuit.mlcs()
    assert tuple(relation.name for relation in mlcs.smooth) == smooth
    assert all(circuit.element(element).junction is not None for element in ideal)


@pytest.mark.ngspice
@pytest.mark.parametrize("name", CASES)
def test_recorded_answer_is_ngspice_s(name):
    _, _, vectors, every = CASES[name]
    recorded = np.loadtxt(SMOOTH / f"{name}.ngspice.csv", delimiter=",", skiprows=1)
    with tempfile.TemporaryDirectory(prefix="smooth_netlists_") as folder:
        data = Path(folder) / "out.txt"
        text = (SMOOTH / f"{name}.cir").read_text().replace(
            "\n.end\n", f"\n.control\nset wr_singlescale\nset wr_vecnames\noption numdgt=7\nrun\n"
            f"linearize {vectors}\nwrdata {data} {vectors}\n.endc\n.end\n")
        deck = Path(folder) / "deck.cir"
        deck.write_text(text)
        subprocess.run(["ngspice", "-b", str(deck)], capture_output=True, timeout=120)
        fresh = np.loadtxt(data, skiprows=1)[::every]
    np.testing.assert_allclose(fresh, recorded, rtol=1e-5, atol=1e-9)


# --- each netlist run as written by the Newton stepper, against ngspice 39 -----------------------

def _relative_rms(ours, time: np.ndarray, theirs: np.ndarray, signal: str) -> float:
    """RMS of (ours − ngspice) over ngspice's grid, relative to ngspice's RMS value."""
    mine = np.interp(time, ours.time, np.asarray(ours[signal]))
    return float(np.sqrt(np.mean((mine - theirs) ** 2) / np.mean(theirs**2)))


def _run(path: Path, stop: float):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return circuitnsds.read_netlist(path).transient(stop=stop)


# a stretch of each recorded run long enough to switch twice (npn: 2 base periods; gate
# driver: 1.5 periods of its 10 µs drive)
RECORDED_STOP = {"npn_lowside_inductive": 100e-6, "bjt_totem_gate_driver": 15e-6}


@pytest.mark.ngspice
@pytest.mark.parametrize("name", CASES)
def test_netlist_runs_as_written_and_agrees_with_ngspice_s_recording(name):
    stop = RECORDED_STOP[name]
    _, _, vectors, _ = CASES[name]
    recorded = np.loadtxt(SMOOTH / f"{name}.ngspice.csv", delimiter=",", skiprows=1)
    recorded = recorded[recorded[:, 0] <= stop * (1 + 1e-9)]
    ours = _run(SMOOTH / f"{name}.cir", stop)
    assert ours.time[-1] == pytest.approx(stop)
    errors = {signal: _relative_rms(ours, recorded[:, 0], recorded[:, 1 + k], signal)
              for k, signal in enumerate(vectors.split())}
    assert np.median(list(errors.values())) <= 0.05, errors
    assert max(errors.values()) <= 0.10, errors


LIVE = {  # netlist: (signals, stop [s])
    "exponential_source_switch": (("v(x)", "v(y)", "i(vin)"), 3e-3),
    "multiplier_rectifier": (("v(m)", "v(p)", "v(out)", "i(d1)"), 20e-3),
}


@pytest.mark.ngspice
@pytest.mark.parametrize("name", LIVE)
def test_behavioural_netlist_runs_as_written_and_agrees_with_ngspice(name):
    from circuitnsds.compare import compare

    signals, stop = LIVE[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = compare(SMOOTH / f"{name}.cir", signals=list(signals))
    run = report.run
    assert run.ok, run.ngspice.message
    assert report.circuitnsds.time[-1] == pytest.approx(stop)
    assert set(run.metrics) == set(signals)  # nothing missing
    errors = {signal: run.metrics[signal].rrms for signal in signals}
    assert np.median(list(errors.values())) <= 0.05, errors
