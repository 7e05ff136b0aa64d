"""Issue 18 against ngspice itself (marker ``ngspice``): digit-named nodes, switches at their
threshold, LTspice PWL diodes in ngspice's LTspice mode."""

import warnings

import pytest

from circuitnsds.compare import compare
from tests.conftest import NETLISTS

pytestmark = pytest.mark.ngspice
EXTERNAL = NETLISTS / "external"


def quiet_compare(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return compare(*args, **kwargs)


def test_compare_reads_nodes_named_by_numbers():
    # problem 1: ngspice names these vectors V(1), V(2), V(3); before, compare looked for 1, 2, 3
    comparison = quiet_compare(EXTERNAL / "numbered_nodes_rectifier.cir", n=0.05)
    metrics = comparison.run.metrics
    assert {"v(1)", "v(2)", "v(3)"} <= metrics.keys()
    assert "not provided by ngspice" not in comparison.table()
    assert metrics["v(3)"].error < 0.01  # N = 0.05 is close to the ideal diode


@pytest.mark.parametrize("name", ["buck_sw_ron_only", "buck_csw_ron_only"])
def test_switch_at_threshold_agrees_with_ngspice(name):
    # problem 2: ngspice 39 opens the RON-only switch at a 0 V gate; so does circuitnsds now
    comparison = quiet_compare(EXTERNAL / f"{name}.cir", window=(0.8e-3, 1e-3),
                               signals=["v(out)", "i(l1)"])
    assert comparison.run.ok
    out = comparison.run.metrics["v(out)"]
    assert out.dc_like and out.rrms < 0.005           # was 12 V against 4.8 V
    assert comparison.run.metrics["i(l1)"].rrms < 0.01


def test_ltspice_diode_runs_in_ngspice_lta_mode():
    # problem 7: the LTspice PWL diode is ngspice's sidiode under ngbehavior=lta; both give
    # -3 A at -5 V (Rrev = Ron) and 4 A at +5 V
    comparison = quiet_compare(EXTERNAL / "ngspice_simple_diode.cir")
    assert any("ngbehavior=lta" in note for note in comparison.notes)
    assert comparison.run.ok
    current = comparison.run.metrics["i(d1)"]
    assert current.nmax < 1e-3
    assert current.mean_other == pytest.approx(current.mean_ref, abs=1e-3)
