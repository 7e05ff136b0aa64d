"""The MLCS's matrices as plain triplets (circuitnsds.system.triplets): the same numbers as
scipy.sparse builds from the same stamps, products as scipy's CSR product computes them,
and no operation that would mean something else than it does for scipy or numpy."""

from __future__ import annotations

import ast
import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.system.triplets import Triplets
from tests.conftest import pinned_copy

finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)


@st.composite
def stamped(draw):
    rows = draw(st.integers(1, 7))
    cols = draw(st.integers(1, 7))
    # few positions, many stamps: repeated positions are the rule (a node's diagonal)
    positions = st.tuples(st.integers(0, rows - 1), st.integers(0, cols - 1))
    stamps = draw(st.lists(st.tuples(positions, finite), max_size=25))
    return [(r, c, v) for (r, c), v in stamps], (rows, cols)


@given(stamped())
@settings(max_examples=300, deadline=None)
def test_the_stamps_sum_to_the_matrix_in_every_form(case):
    stamps, shape = case
    triplets = Triplets.from_stamps(stamps, shape)
    exact = np.zeros(shape)  # each position's exact sum, rounded once
    magnitude = np.zeros(shape)
    for r, c in {(r, c) for r, c, _ in stamps}:
        exact[r, c] = math.fsum(v for rr, cc, v in stamps if (rr, cc) == (r, c))
        magnitude[r, c] = sum(abs(v) for rr, cc, v in stamps if (rr, cc) == (r, c))
    # stamps added one after another: within (count - 1)·eps·Σ|v| of the exact sum
    assert np.all(np.abs(triplets.toarray() - exact) <= len(stamps) * 2.3e-16 * magnitude)
    stamped_in_order = np.zeros(shape)
    for r, c, v in stamps:
        stamped_in_order[r, c] += v
    assert np.array_equal(triplets.toarray(), stamped_in_order)  # in the order stamped
    reference = sp.csr_matrix(([v for *_, v in stamps], ([r for r, *_ in stamps], [c for _, c, _ in stamps])),
                              shape=shape, dtype=float)  # scipy: the same sums, to rounding
    assert np.all(np.abs(triplets.toarray() - reference.toarray()) <= len(stamps) * 4.5e-16 * magnitude)
    assert np.array_equal(triplets.tocsr().toarray(), triplets.toarray())  # bit for bit
    assert np.array_equal(triplets.tocsc().toarray(), triplets.toarray())
    position = triplets.rows * shape[1] + triplets.cols
    assert np.all(np.diff(position) > 0)  # canonical: sorted, each position once
    assert np.array_equal(triplets.diagonal(), np.diagonal(triplets.toarray()))
    for i in range(shape[0]):
        columns, values = triplets.row(i)
        dense = np.zeros(shape[1])
        dense[columns] = values
        assert np.array_equal(dense, triplets.toarray()[i])


@given(stamped(), st.data())
@settings(max_examples=300, deadline=None)
def test_products_are_scipys_csr_products_bit_for_bit(case, data):
    stamps, shape = case
    triplets = Triplets.from_stamps(stamps, shape)
    csr = triplets.tocsr()
    vector = np.array(data.draw(st.lists(finite, min_size=shape[1], max_size=shape[1])))
    assert np.array_equal(triplets @ vector, csr @ vector)
    k = data.draw(st.integers(0, 3))
    entries = data.draw(st.lists(finite, min_size=shape[1] * k, max_size=shape[1] * k))
    matrix = np.array(entries).reshape(shape[1], k)
    assert np.array_equal(triplets @ matrix, csr @ matrix)
    phasor = vector + 1j * vector[::-1]
    assert np.array_equal(triplets @ phasor, csr @ phasor)  # complex: not cast to real


def test_a_stamp_outside_the_matrix_is_refused():
    with pytest.raises(ValueError, match="outside"):
        Triplets.from_stamps([(2, 0, 1.0)], (2, 2))


def test_operations_with_another_meaning_raise_instead_of_answering():
    triplets = Triplets.from_stamps([(0, 0, 2.0), (1, 0, -1.0)], (2, 2))
    with pytest.raises(TypeError):
        triplets * 2.0  # noqa: B018 (scipy: scale; numpy: elementwise; here: neither)
    with pytest.raises(TypeError):
        abs(triplets)
    with pytest.raises(TypeError):
        triplets[0]  # noqa: B018
    with pytest.raises(ValueError, match="cannot multiply"):
        triplets @ np.ones(3)
    with pytest.raises((TypeError, ValueError)):
        np.ones(2) @ triplets  # noqa: B018
    assert not triplets.values.flags.writeable  # shared by everything that reads the MLCS


def test_the_mlcs_of_a_netlist_matches_its_dense_stamping(tmp_path):
    """The bundled bridge's MLCS: every product the engine forms from triplets equals the
    dense product, and the dense step system is the sparse one made dense."""
    from circuitnsds import read_netlist
    from circuitnsds.engine.step_system import step_system

    mlcs = read_netlist("netlists/bridge_rectifier.cir").mlcs()
    y = np.linspace(-1.0, 2.0, mlcs.n)
    assert np.array_equal(mlcs.E @ y, mlcs.E.toarray() @ y)
    dense, sparse = step_system(mlcs, 1e-5, dense=True), step_system(mlcs, 1e-5)
    assert dense.is_dense and not sparse.is_dense
    for name in ("A", "K", "E", "S", "B", "C", "D"):
        assert np.array_equal(getattr(dense, name), getattr(sparse, name).toarray()), name
    for name in ("carry", "source_next", "source_now"):
        assert np.array_equal(getattr(dense, name), getattr(sparse, name).toarray()), name


def test_a_small_circuit_runs_without_importing_scipy(tmp_path):
    """The point of the triplets: `circuitnsds run` of the bundled bridge (CSV and PNG) and
    of a switched buck through the Python API import no scipy module."""
    # (the θ-method's start-up; the exact integrator imports scipy.linalg for its QZ: pinned to θ)
    bridge = pinned_copy(_bundled("bridge_rectifier.cir"), tmp_path)
    script = textwrap.dedent(f"""
        import sys
        from circuitnsds.cli.main import main
        status = main(["run", {str(bridge)!r}, "-o", {str(tmp_path / "b.csv")!r},
                       "--plot", {str(tmp_path / "b.png")!r}])
        import circuitnsds
        waves = circuitnsds.read_netlist({str(_bundled("buck_converter.cir"))!r}).transient(1e-6, 2e-4,
                                                                                         method="theta")
        loaded = sorted(m for m in sys.modules if m == "scipy" or m.startswith("scipy."))
        print(status, len(waves.time), loaded[:5])
    """)
    # the C libraries enabled, as installed (without them the LU falls back to scipy's LAPACK)
    environment = {k: v for k, v in os.environ.items() if k != "CIRCUITNSDS_NATIVE"}
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120,
                          env=environment)
    assert done.returncode == 0, done.stderr
    status, points, loaded = done.stdout.split(" ", 2)
    assert status == "0" and int(points) > 100
    assert loaded.strip() == "[]", f"scipy was imported: {loaded}"


def _bundled(name: str):
    from pathlib import Path

    return Path(__file__).resolve().parent.parent / "netlists" / name


@st.composite
def switched(draw):
    """A matrix of stamps and switches whose rows may hold other elements' stamps and whose
    open and closed rows may share columns (each row's columns distinct, as the elements
    build them)."""
    n = draw(st.integers(2, 6))
    column = st.integers(0, n - 1)
    stamps = draw(st.lists(st.tuples(column, column, finite), max_size=20))
    rows = draw(st.lists(column, unique=True, min_size=1, max_size=3))
    entries = st.lists(st.tuples(column, finite), max_size=4, unique_by=lambda entry: entry[0])
    switches = [(row, tuple(draw(entries)), tuple(draw(entries))) for row in rows]
    closed = tuple(draw(st.lists(st.booleans(), min_size=len(rows), max_size=len(rows))))
    return n, stamps, switches, closed


@given(switched())
@settings(max_examples=200, deadline=None)
def test_a_closed_switch_writes_its_row_over_the_open_one(case):
    """``system_matrix``: in a closed switch's row, the entries at the columns of its open and
    closed rows are those of the closed row (whatever another stamp put there), every other
    entry stays; written here on a dense copy, as ``A.tolil()`` did before the triplets."""
    from circuitnsds.system.mlcs import MLCS, SwitchRelation

    n, stamps, switches, closed = case
    A = Triplets.from_stamps(stamps, (n, n))
    relations = [SwitchRelation(f"s{j}", row, open_row, closed_row, (), None, 0.0, 0.0)
                 for j, (row, open_row, closed_row) in enumerate(switches)]
    empty = Triplets.from_stamps([], (n, 0))
    mlcs = MLCS(E=A, A=A, B=empty, C=Triplets.from_stamps([], (0, n)), D=Triplets.from_stamps([], (0, 0)),
                e=np.zeros(0), S=empty, stimuli=[], unknowns=[f"v({j})" for j in range(n)], pairs=[],
                pair_devices=[], output_names=[], Y_out=empty, L_out=empty, switches=relations)
    expected = A.toarray()
    for (row, open_row, closed_row), on in zip(switches, closed):
        if on:
            for column, _ in open_row:
                expected[row, column] = 0.0
            for column, value in closed_row:
                expected[row, column] = value
    assert np.array_equal(mlcs.system_matrix(closed).toarray(), expected)


def test_a_switch_shorted_on_one_node_carries_no_current():
    """A switch with both terminals on node b is warned about as having no effect, and its
    current is 0 in both states (open: Goff·0 - i = 0; closed: 0 - Ron·i = 0). Before the
    triplets its closed row wrote the -1 of n- over the +1 of n+ at the same column, and the
    closed switch reported i = -v(b)/Ron = -2.5 A."""
    from circuitnsds import read_netlist
    from circuitnsds.errors import CircuitWarning

    text = ("switch across one node\nV1 a 0 PULSE(0 5 1u 1n 1n 5u 10u)\nR1 a b 1k\n"
            "S1 b b a 0 sw\nR2 b 0 1k\n.model sw sw(vt=2.5 ron=1 roff=1meg)\n.tran 0.1u 20u\n.end\n")
    with pytest.warns(CircuitWarning, match="shorted"):
        waves = read_netlist(text).transient()
    assert sum(event.state for event in waves.events) >= 2  # it did close
    assert np.array_equal(waves["i(s1)"], np.zeros(waves.time.size))
    np.testing.assert_allclose(waves["v(b)"].max(), 2.5, rtol=1e-12)  # the divider, untouched


def test_a_plain_run_imports_only_what_its_netlist_uses(tmp_path):
    """Start-up (issue 19): `run -o out.csv --signals v(out)` of the bundled buck, which has no
    controlled sources, no behavioural sources, XSPICE blocks or MOSFETs, no current source, no
    .meas and no --measure, is small, and streams its CSV, builds none of the modules it does
    not use; then, in the same process, netlists that use them still find their classes and
    their checks: an E source's gain, a B source with a max(), the digital-node check of an inverter fed by
    an analog node, and the unused-model warnings naming a code model's and a MOSFET's type."""
    unused = ["circuitnsds.circuit.elements.controlled", "circuitnsds.frontend.cards.meas",
              "circuitnsds.output.measure", "subprocess", "concurrent.futures",
              "circuitnsds.circuit.elements.behavioural", "circuitnsds.circuit.elements.mosfet",
              "circuitnsds.frontend.cards.behavioural", "circuitnsds.frontend.cards.mosfets",
              "circuitnsds.frontend.cards.xspice", "circuitnsds.frontend.cards.xspice_digital",
              "circuitnsds.frontend.cards.xspice_ports", "circuitnsds.netlist.behavioural",
              "circuitnsds.engine.sparse_loop", "circuitnsds.checks.wellposed"]
    controlled = tmp_path / "e.cir"
    controlled.write_text("E gain\nV1 in 0 DC 1\nR1 in 0 1k\nE1 out 0 in 0 3\nR2 out 0 1k\n"
                          ".tran 1u 10u\n.end\n")
    behavioural = tmp_path / "b.cir"
    behavioural.write_text("B max\nV1 in 0 DC 3\nR1 in 0 1k\nB1 out 0 V=max(v(in), 5)-2*v(in)\n"
                           "R2 out 0 1k\n.tran 1u 10u\n.end\n")
    digital = tmp_path / "d.cir"
    digital.write_text("analog into a gate\nV1 a 0 1\nA1 a y inv\n.model inv d_inverter\nR1 y 0 1k\n"
                       ".tran 1u 10u\n.end\n")
    unused_models = tmp_path / "m.cir"
    unused_models.write_text("unused models\nV1 a 0 1\nR1 a 0 1k\n.model g gain(gain=2)\n"
                             ".model q VDMOS(vto=2 kp=1)\n.tran 1u 10u\n.end\n")
    # (the θ-method's start-up; the exact integrator's loads numba and what it imports: pinned)
    buck = pinned_copy(_bundled("buck_converter.cir"), tmp_path)
    script = textwrap.dedent(f"""
        import sys, warnings
        from circuitnsds.cli.main import main
        status = main(["run", {str(buck)!r}, "-o", {str(tmp_path / "b.csv")!r},
                       "--signals", "v(out)", "-q"])
        loaded = [m for m in {unused!r} if m in sys.modules]
        import circuitnsds
        gain = float(circuitnsds.read_netlist({str(controlled)!r}).transient()["v(out)"][-1])
        square = float(circuitnsds.read_netlist({str(behavioural)!r}).transient()["v(out)"][-1])
        try:
            circuitnsds.read_netlist({str(digital)!r})
            refused = "accepted"
        except circuitnsds.NetlistError as error:
            refused = "refused" if "is a digital input" in str(error) else str(error)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            circuitnsds.read_netlist({str(unused_models)!r})
        told = sorted(str(w.message).split(": ", 1)[1] for w in caught if "is not used" in str(w.message))
        print(repr((status, loaded, gain, square, refused, told)))
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    status, loaded, gain, square, refused, told = ast.literal_eval(done.stdout.strip().splitlines()[-1])
    assert status == 0 and loaded == [], f"imported although unused: {loaded}"
    assert gain == pytest.approx(3.0) and square == pytest.approx(-1.0)
    assert refused == "refused"
    assert told == [".model g (GAIN) is not used", ".model q (MOSFET) is not used"]
