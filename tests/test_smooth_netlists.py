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
