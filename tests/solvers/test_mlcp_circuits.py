"""MLCPs stamped by hand from small diode circuits, with a singular or nearly singular A.

Conventions (docs/theory.md): diode current i from anode to cathode, v = v(anode) - v(cathode).
Ideal diode: 0 <= i ⊥ -v >= 0; piecewise-linear: 0 <= i ⊥ Ron*i + Vfwd - v >= 0.
MNA rows: Kirchhoff's current law (sum of currents leaving the node = 0) and the
source constraints. u = node voltages and source currents, z = diode currents,
w = D u + B z + b the diode's complementary variable. Expected answers are worked
out by hand in each test; Kirchhoff's laws are checked from the circuit, not from
the matrices.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.solvers import LCPNoSolution, MLCPSolver, solve_mlcp
from circuitnsds.solvers.testing import monotone_mlcp

ALL_METHODS = ["auto", "lemke", "enum", "newton"]


# --------------------------------------------------------------------------- circuits
def series_circuit(V: float, R: float = 2.0):
    """V source (node 1, ground) -> D1 (1 -> 2) -> D2 (2 -> 3) -> R (3 -> ground).

    Node 2 touches only the two ideal diodes, so its KCL row of A and its column are zero.
    u = [v1, v2, v3, iV] (iV: current leaving node 1 into the source's + terminal).
    """
    A = np.array(
        [
            [0, 0, 0, 1],  # KCL 1: iV + i1 = 0
            [0, 0, 0, 0],  # KCL 2: -i1 + i2 = 0
            [0, 0, 1 / R, 0],  # KCL 3: -i2 + v3/R = 0
            [1, 0, 0, 0],  # source: v1 - V = 0
        ],
        dtype=float,
    )
    C = np.array([[1, 0], [-1, 1], [0, -1], [0, 0]], dtype=float)
    D = np.array([[-1, 1, 0, 0], [0, -1, 1, 0]], dtype=float)  # w = -v for ideal diodes
    B = np.zeros((2, 2))
    a = np.array([0, 0, 0, -V], dtype=float)
    b = np.zeros(2)
    return A, C, D, B, a, b


def bridge_circuit(
    Vs: float, R: float = 10.0, Ron: float = 0.0, Vf: float = 0.0, gmin: float = 0.0
):
    """Full-wave bridge: floating source Vs between nodes a and b, load R from p to ground.

    D1: a -> p, D2: b -> p, D3: ground -> a, D4: ground -> b.
    u = [va, vb, vp, iV]; iV leaves node a into the source and enters node b.
    With gmin > 0 a conductance gmin is put across every diode (SPICE's trick), which
    makes A invertible but very ill-conditioned.
    """
    Dv = np.array([[1, 0, -1, 0], [0, 1, -1, 0], [-1, 0, 0, 0], [0, -1, 0, 0]], dtype=float)
    C = np.array([[1, 0, -1, 0], [0, 1, 0, -1], [-1, -1, 0, 0], [0, 0, 0, 0]], dtype=float)
    A = np.array(
        [
            [0, 0, 0, 1],
            [0, 0, 0, -1],
            [0, 0, 1 / R, 0],
            [1, -1, 0, 0],
        ],
        dtype=float,
    )
    A = A + gmin * (C @ Dv)  # diode k's gmin current gmin*v_k leaves its anode node
    D = -Dv
    B = Ron * np.eye(4)
    b = Vf * np.ones(4)
    a = np.array([0, 0, 0, -Vs], dtype=float)
    return A, C, D, B, a, b


def bridge_kcl(u, z, R, gmin=0.0):
    """KCL residuals and source constraint of the bridge, written from the circuit."""
    va, vb, vp, iV = u
    i1, i2, i3, i4 = z
    v = np.array([va - vp, vb - vp, -va, -vb])
    ig = gmin * v  # gmin currents, anode -> cathode
    return np.array(
        [
            iV + i1 + ig[0] - i3 - ig[2],  # node a
            -iV + i2 + ig[1] - i4 - ig[3],  # node b
            -i1 - ig[0] - i2 - ig[1] + vp / R,  # node p
        ]
    ), va - vb


def check_complementarity(z, w, tol=1e-9):
    assert z.min() >= -tol
    assert w.min() >= -tol
    assert np.max(np.minimum(np.abs(z), np.abs(w))) <= tol


# ---------------------------------------------------------------------------- tests
@pytest.mark.parametrize("method", ALL_METHODS)
def test_series_diodes_conducting_with_floating_node(method: str) -> None:
    A, C, D, B, a, b = series_circuit(V=1.0, R=2.0)
    assert np.linalg.matrix_rank(A) < 4  # singular A
    res = solve_mlcp(A, C, D, B, a, b, method=method)
    v1, v2, v3, iV = res.u
    # both ideal diodes conduct: v1 = v2 = v3 = 1 V, current 1 V / 2 Ω
    np.testing.assert_allclose([v1, v2, v3], [1.0, 1.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(res.z, [0.5, 0.5], atol=1e-12)
    assert iV == pytest.approx(-0.5, abs=1e-12)
    assert res.active.tolist() == [True, True]
    check_complementarity(res.z, res.w)
    assert res.residual <= 1e-9


@pytest.mark.parametrize("method", ALL_METHODS)
def test_series_diodes_blocking_floating_node_is_any_admissible_value(method: str) -> None:
    A, C, D, B, a, b = series_circuit(V=-1.0)
    res = solve_mlcp(A, C, D, B, a, b, method=method)
    v1, v2, v3, iV = res.u
    np.testing.assert_allclose(res.z, 0.0, atol=1e-12)
    assert v1 == pytest.approx(-1.0, abs=1e-12)
    assert v3 == pytest.approx(0.0, abs=1e-12)
    assert iV == pytest.approx(0.0, abs=1e-12)
    # v2 is not determined by the ideal circuit; both diodes must be reverse biased
    assert -1.0 - 1e-9 <= v2 <= 1e-9
    check_complementarity(res.z, res.w)


@pytest.mark.parametrize("method", ALL_METHODS)
@pytest.mark.parametrize("Vs", [5.0, -5.0])
def test_bridge_rectifier_piecewise_linear_diodes(method: str, Vs: float) -> None:
    R, Ron, Vf = 10.0, 0.1, 0.7
    A, C, D, B, a, b = bridge_circuit(Vs, R=R, Ron=Ron, Vf=Vf)
    assert np.linalg.matrix_rank(A) < 4
    res = solve_mlcp(A, C, D, B, a, b, method=method)
    # hand solution: two diodes in series with the load
    current = (abs(Vs) - 2 * Vf) / (R + 2 * Ron)
    drop = Vf + Ron * current
    vp = current * R
    if Vs > 0:  # D1 and D4 conduct
        expected_z = [current, 0, 0, current]
        expected_u = [vp + drop, -drop, vp, -current]
    else:  # D2 and D3 conduct
        expected_z = [0, current, current, 0]
        expected_u = [-drop, vp + drop, vp, current]
    np.testing.assert_allclose(res.z, expected_z, atol=1e-10)
    np.testing.assert_allclose(res.u, expected_u, atol=1e-10)
    kcl, src = bridge_kcl(res.u, res.z, R)
    np.testing.assert_allclose(kcl, 0.0, atol=1e-12)
    assert src == pytest.approx(Vs, abs=1e-12)
    check_complementarity(res.z, res.w)


@pytest.mark.parametrize("method", ALL_METHODS)
def test_bridge_ideal_all_blocking_has_singular_a(method: str) -> None:
    # Vs below the two forward drops: no diode conducts; va - vb = Vs but the common
    # mode of the floating source is not fixed by the ideal circuit
    R, Vf, Vs = 10.0, 0.7, 1.0
    A, C, D, B, a, b = bridge_circuit(Vs, R=R, Vf=Vf)
    res = solve_mlcp(A, C, D, B, a, b, method=method)
    va, vb, vp, iV = res.u
    np.testing.assert_allclose(res.z, 0.0, atol=1e-12)
    assert va - vb == pytest.approx(Vs, abs=1e-12)
    assert vp == pytest.approx(0.0, abs=1e-12)
    # every diode voltage is below its forward drop
    v = np.array([va - vp, vb - vp, -va, -vb])
    assert np.all(v <= Vf + 1e-9)
    check_complementarity(res.z, res.w)


@pytest.mark.parametrize("method", ["auto", "lemke", "enum"])
@pytest.mark.parametrize("Vs", [1.0, -1.0, 0.0, 0.3])
def test_bridge_with_gmin_resolves_the_floating_node(method: str, Vs: float) -> None:
    """A nearly singular (cond ~1e12) A: the tiny conductances fix the source's common mode.

    Expected by symmetry of the four equal gmin conductances: va = Vs/2, vb = -Vs/2.
    Returning va = 0.7, say, would satisfy the ideal equations up to ~1e-12 but
    violate Kirchhoff's law at the floating nodes by 100 % of the gmin currents.
    """
    R, Vf, gmin = 10.0, 0.7, 1e-12
    A, C, D, B, a, b = bridge_circuit(Vs, R=R, Vf=Vf, gmin=gmin)
    assert np.linalg.cond(A) > 1e10
    res = solve_mlcp(A, C, D, B, a, b, method=method)
    np.testing.assert_allclose(res.z, 0.0, atol=1e-12)
    np.testing.assert_allclose(res.u[:2], [Vs / 2, -Vs / 2], atol=1e-6)
    kcl, src = bridge_kcl(res.u, res.z, R, gmin)
    # KCL holds relative to the size of the gmin currents themselves
    assert np.abs(kcl).max() <= 1e-6 * gmin * (1 + abs(Vs))
    assert src == pytest.approx(Vs, abs=1e-12)


@pytest.mark.parametrize("method", ["auto", "lemke", "enum", "newton"])
def test_bridge_with_gmin_conducting(method: str) -> None:
    R, Ron, Vf, gmin, Vs = 10.0, 0.1, 0.7, 1e-12, 12.0
    A, C, D, B, a, b = bridge_circuit(Vs, R=R, Ron=Ron, Vf=Vf, gmin=gmin)
    res = solve_mlcp(A, C, D, B, a, b, method=method)
    current = (Vs - 2 * Vf) / (R + 2 * Ron)
    np.testing.assert_allclose(res.z, [current, 0, 0, current], rtol=1e-9, atol=1e-9)
    kcl, _ = bridge_kcl(res.u, res.z, R, gmin)
    np.testing.assert_allclose(kcl, 0.0, atol=1e-12)


@pytest.mark.parametrize("Vz", [5.0, 0.0])
@pytest.mark.parametrize("method", ALL_METHODS)
def test_zener_two_pairs(method: str, Vz: float) -> None:
    """V -> R -> node z; ideal Zener from ground (anode) to z (cathode), two pairs.

    i = i_f - i_r; 0 <= i_f ⊥ -v >= 0, 0 <= i_r ⊥ Vz + v >= 0, v = 0 - vz.
    With Vz = 0 the two pairs can both carry current (non-unique split).
    u = [v1, vz, iV].
    """
    V, R = 10.0, 1000.0
    A = np.array([[1 / R, -1 / R, 1], [-1 / R, 1 / R, 0], [1, 0, 0]])
    C = np.array([[0, 0], [-1, 1], [0, 0]], dtype=float)  # Zener current leaves z as -i_f + i_r
    D = np.array([[0, 1, 0], [0, -1, 0]], dtype=float)  # w_f = vz, w_r = Vz - vz
    B = np.zeros((2, 2))
    a = np.array([0, 0, -V])
    b = np.array([0, Vz])
    res = solve_mlcp(A, C, D, B, a, b, method=method)
    v1, vz, iV = res.u
    i_zener = res.z[0] - res.z[1]
    assert v1 == pytest.approx(V, abs=1e-9)
    assert vz == pytest.approx(Vz, abs=1e-9)
    assert -i_zener == pytest.approx((V - Vz) / R, rel=1e-9)  # reverse current
    check_complementarity(res.z, res.w)


def test_sparse_blocks_give_the_dense_answer() -> None:
    R, Ron, Vf = 10.0, 0.1, 0.7
    A, C, D, B, a, b = bridge_circuit(5.0, R=R, Ron=Ron, Vf=Vf)
    dense = solve_mlcp(A, C, D, B, a, b)
    for fmt in (sp.csr_array, sp.csc_matrix, sp.coo_array):
        for method in ALL_METHODS:
            res = solve_mlcp(fmt(A), fmt(C), fmt(D), fmt(B), a, b, method=method)
            np.testing.assert_allclose(res.u, dense.u, atol=1e-10)
            np.testing.assert_allclose(res.z, dense.z, atol=1e-10)
    # mixed dense / sparse blocks
    res = solve_mlcp(sp.csr_array(A), C, D, sp.csr_array(B), a, b)
    np.testing.assert_allclose(res.z, dense.z, atol=1e-10)


def test_infeasible_mlcp_raises_no_solution() -> None:
    # u = 1 forced, w = -u - 1 + 0*z can never be >= 0
    A = np.array([[1.0]])
    C = np.zeros((1, 1))
    D = np.array([[-1.0]])
    B = np.zeros((1, 1))
    with pytest.raises(LCPNoSolution) as info:
        solve_mlcp(A, C, D, B, np.array([-1.0]), np.array([-1.0]))
    assert info.value.confirmed_by_enumeration


def test_no_complementarity_pairs() -> None:
    A = np.array([[2.0, 1.0], [1.0, 3.0]])
    res = solve_mlcp(
        A, np.zeros((2, 0)), np.zeros((0, 2)), np.zeros((0, 0)), np.array([1.0, 2.0]), []
    )
    np.testing.assert_allclose(A @ res.u + [1.0, 2.0], 0.0, atol=1e-14)


# ------------------------------------------------------------ random monotone MLCPs
@settings(max_examples=30, deadline=None)
@given(
    n=st.integers(0, 12),
    m=st.integers(1, 10),
    seed=st.integers(0, 2**32 - 1),
    singular_a=st.booleans(),
)
def test_random_monotone_mlcp_every_method(n: int, m: int, seed: int, singular_a: bool) -> None:
    rng = np.random.default_rng(seed)
    A, C, D, B, a, b = monotone_mlcp(n, m, rng, singular_a and n > 0)
    K = np.block([[A, C], [D, B]])
    for method in ALL_METHODS:
        res = solve_mlcp(A, C, D, B, a, b, method=method)
        x = np.concatenate([res.u, res.z])
        scale = np.abs(np.concatenate([a, b])).max() + np.abs(K).sum(axis=1).max() * np.abs(x).max()
        np.testing.assert_allclose(A @ res.u + C @ res.z + a, 0.0, atol=1e-9 * scale)
        w = D @ res.u + B @ res.z + b
        np.testing.assert_allclose(res.w, w, atol=1e-12 * scale)
        check_complementarity(res.z * np.abs(K).sum(axis=1).max(), w, tol=1e-9 * scale)


def test_solver_reuses_matrices_for_many_right_hand_sides() -> None:
    rng = np.random.default_rng(7)
    A, C, D, B, _, _ = monotone_mlcp(6, 5, rng, singular_a=True)
    solver = MLCPSolver(A, C, D, B)
    guess = None
    for _ in range(20):
        a = rng.standard_normal(6)
        b = rng.standard_normal(5)
        res = solver.solve(a, b, guess=guess)
        ref = solve_mlcp(A, C, D, B, a, b, method="enum")
        np.testing.assert_allclose(res.z, ref.z, atol=1e-8)
        guess = res.active
    assert solver.stats["calls"] == 20
