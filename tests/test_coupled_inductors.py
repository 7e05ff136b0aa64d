"""Coupled inductors (``K``) against the linear ODE they describe, and their errors.

Two inductors coupled by ``K1 L1 L2 k`` (dot on the first node of each) obey
``[v1; v2] = Lm [i1'; i2']`` with ``Lm = [[L1, M], [M, L2]]``, ``M = k·sqrt(L1·L2)``.
"""

import math

import numpy as np
import pytest
from scipy.linalg import expm

import circuitnsds
from tests.conftest import circuit_from

L1, L2, K, R1, R2, V = 1e-3, 4e-3, 0.9, 10.0, 40.0, 1.0
M = K * math.sqrt(L1 * L2)
LM = np.array([[L1, M], [M, L2]])


def driven_pair(h: float, stop: float, theta: float = 1.0):
    """Primary: a 1 V step (UIC from zero currents) through R1 into L1; secondary: L2 into R2.

    With i1 through L1 (p -> 0) and i2 through L2 (s -> 0): v(p) = V - R1·i1 and
    v(s) = -R2·i2, so ``Lm x' = -R x + b`` with ``R = diag(R1, R2)``, ``b = [V, 0]``.
    """
    netlist = (f"V1 in 0 {V}\nR1 in p {R1}\nL1 p 0 {L1}\nL2 s 0 {L2}\nR2 s 0 {R2}\n"
               f"K1 L1 L2 {K}\n.tran {h} {stop} uic")
    waves = circuit_from(netlist).transient(theta=theta, method="theta")  # θ's recurrence, pinned
    return waves, np.column_stack([waves["i(l1)"], waves["i(l2)"]])


def theta_recurrence(count: int, h: float, theta: float) -> np.ndarray:
    """The θ-method on ``Lm x' = -R x + b`` (first step implicit Euler), computed with numpy."""
    R = np.diag([R1, R2])
    b = np.array([V, 0.0])
    x = np.zeros((count, 2))
    for k in range(1, count):
        th = 1.0 if k == 1 else theta
        x[k] = np.linalg.solve(LM + th * h * R, (LM - (1 - th) * h * R) @ x[k - 1] + h * b)
    return x


def exact(times: np.ndarray) -> np.ndarray:
    """Continuous solution ``x(t) = x_ss + expm(-Lm⁻¹R t)(x0 - x_ss)`` with x0 = 0, on a
    uniform grid (propagated with ``expm(A h)``, exact up to round-off)."""
    h = times[1] - times[0]
    np.testing.assert_allclose(np.diff(times), h, rtol=1e-9)
    A = -np.linalg.solve(LM, np.diag([R1, R2]))
    steady = np.array([V / R1, 0.0])
    propagator = expm(A * h)
    deviation = -steady
    x = np.empty((times.size, 2))
    for k in range(times.size):
        x[k] = steady + deviation
        deviation = propagator @ deviation
    return x


@pytest.mark.parametrize("theta", [1.0, 0.5, 0.75])
def test_coupled_pair_matches_the_theta_recurrence_exactly(theta):
    h = 1e-6
    waves, currents = driven_pair(h, 0.3e-3, theta)
    expected = theta_recurrence(waves.time.size, h, theta)
    scale = np.abs(expected).max()
    np.testing.assert_allclose(currents, expected, rtol=0, atol=1e-9 * scale)
    # the secondary is driven through M only: it starts negative (dot convention)
    assert currents[1, 1] < 0
    # and the node voltages are the branch voltages of the coupled equations
    np.testing.assert_allclose(waves["v(p)"][1:], V - R1 * currents[1:, 0], atol=1e-9)
    np.testing.assert_allclose(waves["v(s)"][1:], -R2 * currents[1:, 1], atol=1e-9)


@pytest.mark.parametrize(("theta", "order"), [(1.0, 1), (0.5, 2)])
def test_coupled_pair_converges_to_the_matrix_exponential(theta, order):
    errors = []
    for h in (2e-7, 1e-7):
        waves, currents = driven_pair(h, 0.2e-3, theta)
        errors.append(np.abs(currents - exact(waves.time)).max())
    # small in absolute terms (the fast, leakage mode has a time constant near 4 us) ...
    assert errors[-1] < 2e-3 * V / R1
    # ... and shrinking with the order of the method (first step IE is O(h^2) locally)
    assert errors[0] / errors[1] == pytest.approx(2**order, rel=0.15)


def test_lossless_lc_k_lc_conserves_energy_with_the_trapezoidal_rule():
    # C1 || L1 coupled to C2 || L2, C1 charged to 1 V.  The θ = 1/2 step is the implicit
    # midpoint rule on E x' = A x with E = diag(C, Lm) and A skew: it conserves x·E x
    # exactly.  The first step is implicit Euler (it loses a little); from then on the
    # energy is constant to round-off.
    la, lb, k, ca, cb, h = 1e-3, 2e-3, 0.6, 1e-6, 3e-6, 1e-6
    mutual = k * math.sqrt(la * lb)
    lm = np.array([[la, mutual], [mutual, lb]])
    netlist = (f"C1 a 0 {ca} ic=1\nL1 a 0 {la}\nC2 b 0 {cb}\nL2 b 0 {lb}\nK1 L1 L2 {k}\n"
               f".tran {h} 2m uic")
    circuit = circuit_from(netlist)

    def energy(waves):
        i = np.column_stack([waves["i(l1)"], waves["i(l2)"]])
        return (0.5 * ca * waves["v(a)"] ** 2 + 0.5 * cb * waves["v(b)"] ** 2
                + 0.5 * np.einsum("ti,ij,tj->t", i, lm, i))

    # (the trapezoidal rule's and implicit Euler's energies: pinned to θ)
    trapezoidal = energy(circuit.transient(theta=0.5, method="theta"))
    assert trapezoidal[0] == pytest.approx(0.5 * ca, rel=1e-12)
    assert trapezoidal[1] < trapezoidal[0]  # the implicit Euler first step
    np.testing.assert_allclose(trapezoidal[1:], trapezoidal[1], rtol=1e-11)
    # the energy really moves between the tanks (the coupling is active)
    waves = circuit.transient(theta=0.5, method="theta")
    assert (0.5 * cb * waves["v(b)"] ** 2).max() > 0.1 * trapezoidal[1]
    # implicit Euler dissipates monotonically
    euler = energy(circuit.transient(theta=1.0, method="theta"))
    assert np.all(np.diff(euler) <= 1e-18)
    assert euler[-1] < 0.99 * euler[1]


def test_negative_coupling_reverses_the_secondary():
    h = 1e-6
    base = (f"V1 in 0 {V}\nR1 in p {R1}\nL1 p 0 {L1}\nL2 s 0 {L2}\nR2 s 0 {R2}\n"
            f".tran {h} 0.1m uic\n")
    plus = circuit_from(base + f"K1 L1 L2 {K}").transient()
    minus = circuit_from(base + f"K1 L1 L2 {-K}").transient()
    swapped = circuit_from(base.replace("L2 s 0", "L2 0 s") + f"K1 L1 L2 {K}").transient()
    np.testing.assert_allclose(minus["v(s)"], -plus["v(s)"], atol=1e-12)
    np.testing.assert_allclose(swapped["v(s)"], -plus["v(s)"], atol=1e-12)
    np.testing.assert_allclose(minus["i(l1)"], plus["i(l1)"], atol=1e-12)


def test_coupling_order_and_netlist_position_do_not_matter():
    base = f"V1 in 0 {V}\nR1 in p {R1}\nL1 p 0 {L1}\nL2 s 0 {L2}\nR2 s 0 {R2}\n.tran 1u 50u uic\n"
    first = circuit_from(f"K1 L1 L2 {K}\n" + base).transient()  # K before the inductors
    second = circuit_from(base + f"K1 L2 L1 {K}").transient()
    np.testing.assert_allclose(first["i(l2)"], second["i(l2)"], atol=1e-14)


@pytest.mark.parametrize(
    ("body", "line", "words"),
    [
        ("L1 a 0 1m\nL2 b 0 1m\nR1 a b 1\nR2 b 0 1\nK1 L1 L2 1.5", 6, ["k1", "1.5"]),
        ("L1 a 0 1m\nL2 b 0 1m\nR1 a b 1\nR2 b 0 1\nK1 L1 L2 -1.01", 6, ["k1", "-1.01"]),
        ("L1 a 0 1m\nL2 b 0 1m\nR1 a b 1\nR2 b 0 1\nK1 L1 L2 0", 6, ["k1"]),
        # three couplings, each fine alone, jointly not PD: 1 - 2·0.6 < 0
        ("L1 a 0 1m\nL2 b 0 1m\nL3 c 0 1m\nR1 a b 1\nR2 b c 1\nR3 c 0 1\n"
         "K1 L1 L2 -0.6\nK2 L2 L3 -0.6\nK3 L1 L3 -0.6", 10, ["positive semidefinite", "l1, l2, l3"]),
        ("L1 a 0 1m\nR1 a 0 1\nK1 L1 L9 0.5", 4, ["l9", "not an inductor"]),
        ("L1 a 0 1m\nR1 a 0 1\nR2 a 0 1\nK1 L1 R2 0.5", 5, ["r2", "not an inductor"]),
        ("L1 a 0 1m\nL2 b 0 1m\nR1 a b 1\nR2 b 0 1\nK1 L1 L2 0.5\nK2 L2 L1 0.3", 7,
         ["k2", "already coupled", "k1"]),
        ("L1 a 0 1m\nR1 a 0 1\nK1 L1 L1 0.5", 4, ["itself"]),
        ("L1 a 0 1m\nL2 b 0 1m\nR1 a b 1\nR2 b 0 1\nK1 L1 L2", 6, ["missing"]),
    ],
)
def test_invalid_couplings_are_errors_naming_the_line(body, line, words):
    with pytest.raises(circuitnsds.NetlistError) as info:
        circuit_from(body)
    message = str(info.value).lower()
    assert f"<text>:{line}:" in message
    for word in words:
        assert word in message


def test_three_winding_transformer_that_is_positive_definite_is_accepted():
    # k12 = k13 = k23 = 0.45: eigenvalues 1.9, 0.55, 0.55 (times 1 mH): fine
    body = ("L1 a 0 1m\nL2 b 0 1m\nL3 c 0 1m\nR1 a b 1\nR2 b c 1\nR3 c 0 1\n"
            "K1 L1 L2 0.45\nK2 L2 L3 0.45\nK3 L1 L3 0.45")
    circuit = circuit_from(body)
    assert sum(1 for e in circuit.elements if e.name.startswith("k")) == 3


@pytest.mark.parametrize("k", [1.0, -1.0])
def test_perfect_coupling_is_an_ideal_transformer(k):
    """|k| = 1 is accepted, as ngspice accepts it (issue 20, item 9): with L2 = 4·L1 the
    secondary voltage is exactly k·sqrt(L2/L1) = 2k times the primary's, at every instant,
    whatever the load (v2 = M di1/dt + L2 di2/dt = k·sqrt(L2/L1)·v1 when M² = L1·L2)."""
    waves = circuit_from(f"V1 a 0 SIN(0 1 1k)\nR1 a b 1\nL1 b 0 1m\nL2 c 0 4m\nR2 c 0 100\n"
                         f"K1 L1 L2 {k}\n.tran 10u 2m").transient()
    np.testing.assert_allclose(waves["v(c)"], 2 * k * waves["v(b)"], rtol=0, atol=1e-9)
    assert np.abs(waves["v(c)"]).max() > 0.5


def test_ltspice_multi_inductor_coupling_couples_every_pair():
    # LTspice: K1 L1 L2 L3 k couples all three pairs with the same k
    body = ("V1 a 0 SIN(0 1 1k)\nL1 a 0 1m\nL2 b 0 1m\nL3 c 0 4m\nR2 b 0 1k\nR3 c 0 1k\n"
            "K1 L1 L2 L3 0.9\n.tran 1u 1m")
    circuit = circuit_from(body)
    couplings = [e for e in circuit.elements if type(e).__name__ == "MutualInductance"]
    assert sorted(c.inductors for c in couplings) == [("l1", "l2"), ("l1", "l3"), ("l2", "l3")]
    assert {c.coupling for c in couplings} == {0.9}
    assert [c.mutual for c in couplings if c.inductors == ("l2", "l3")] == [pytest.approx(0.9 * 2e-3)]
