"""Mixed LCP solver for fixed matrices and changing right-hand sides.

Problem (Acary & Brogliato, *Numerical Methods for Nonsmooth Dynamical Systems*, eq. 1.66)::

    A u + C z + a = 0,      w = D u + B z + b,      0 <= z ⊥ w >= 0,   u free,

``A`` ``(n, n)`` — possibly singular —, ``C`` ``(n, m)``, ``D`` ``(m, n)``,
``B`` ``(m, m)``. Dense and scipy.sparse blocks are accepted; the pivoting and
the factorisations work on a dense copy of ``K = [[A, C], [D, B]]`` (the sizes
of a circuit's per-step problem), the Newton method keeps sparse input sparse.

:meth:`MLCPSolver.solve` tries, in order:

1. **Mode reuse** (when a guess is given): one back-substitution with the cached
   LU factors of the bordered matrix ``K_α`` of the guessed active set,
   accepted when the scaled residual is ``<= tol`` (which checks ``z_α >= 0``,
   ``w_ᾱ >= 0`` and the equations). See :mod:`circuitnsds.solvers.mode`.
   From :data:`PIVOTING_MIN_PAIRS` pairs on, **block principal pivoting** from the
   guess (or from no pair active) follows, with the same acceptance test
   (:mod:`circuitnsds.solvers.pivoting`).
2. **Lemke on a principal pivot transform.** A *start basis* ``α0`` with a
   well-conditioned ``K_α0`` is eliminated: ``α0 = ∅`` when ``A`` is
   well-conditioned (reciprocal condition >= ``1e-8``), which gives the Schur
   complement LCP ``M = B - D A⁻¹ C``, ``q = b - D A⁻¹ a``; otherwise (``A``
   singular or nearly so) ``α0`` is chosen to complete the rank of ``A`` with
   columns of ``C`` (rank-revealing QR on the left/right null spaces of ``A``).
   Lemke's method on the resulting ``m``-dimensional LCP only *chooses* the
   active set; ``u, z`` are then recomputed from the bordered system of that
   set (accurate even when ``M`` is badly conditioned) and verified.
   Eliminating ``α0`` is a principal pivot transform, which keeps P-matrices
   P-matrices and positive semidefinite matrices positive semidefinite, so
   Lemke's guarantees carry over. If the first start basis fails, the next
   one is tried.
3. **Enumeration** of the active sets when ``m <= 10`` (complete: when it finds
   nothing, the problem has no solution).
4. **Semismooth Newton** (Fischer–Burmeister) on the whole mixed system.

Degenerate pairs (``z_i ≈ 0`` and ``w_i ≈ 0`` at the tolerance) make several
active sets valid. The normwise residual cannot tell them apart when tiny
conductances (``gmin ~ 1e-12``) decide the physics, so an accepted answer with
degenerate pairs whose componentwise residual exceeds :data:`CTOL` is compared
with the answers obtained by flipping the labels of those pairs, and the one
with the smallest componentwise residual is returned (see
:func:`circuitnsds.solvers.residual.componentwise_residual`).

Nothing is returned unverified; when every method fails the solver raises
:class:`LCPNoSolution` (a Lemke secondary ray — with, for ``m <= 10``, an
exhaustive search that confirms it) or :class:`LCPSolverFailure`.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from ._inputs import as_mask, as_vector, bordered
from .enumeration import MAX_ENUM, enumerate_mlcp
from .lemke import LemkeTableau
from .linalg import LU, SIGN_TOL, factorise, factorise_sparse
from .mode import Mode, ModeCache
from .newton import fb_newton_mlcp
from .pivot_transform import PivotTransform, completion_mask
from .pivoting import TRIALS, BlockPivoting
from .residual import componentwise_residual, evaluate, kappa_of, mlcp_residual, scaled_column_max
from .result import LCPError, LCPNoSolution, LCPSolverFailure, MLCPResult
from .uniqueness import certified_p_matrix

__all__ = ["MLCPSolver", "negative_current_harmless", "solve_mlcp"]

#: ``A`` with a reciprocal condition estimate below this is treated as (nearly)
#: singular and not eliminated directly by the Lemke fallback.
A_RCOND_GOOD = 1e-8
#: Largest number of pairs for which the fallback chain enumerates active sets.
ENUM_FALLBACK_MAX = 10
#: When a verified answer has degenerate pairs and its componentwise residual
#: exceeds this, the labels of the degenerate pairs are flipped one at a time and
#: the verified answer with the smallest componentwise residual is kept.
CTOL = 1e-6
#: From this many pairs on, block principal pivoting from the guess (or from no pair
#: active) runs before Lemke: each trial is one factorisation, where Lemke's pivots cost
#: O(m²) each and number O(m) (seconds at 1000 pairs).
PIVOTING_MIN_PAIRS = 50
#: At most this many degenerate pairs are tried by that search.
MAX_FLIPS = 8
#: Sparse problems with more unknowns and pairs than this are never made dense: every
#: factorisation is sparse, Lemke runs only up to :data:`SPARSE_LEMKE_MAX` pairs (its tableau
#: is ``m × m``), the enumeration and the rank completion of a singular ``A`` (an SVD) not at
#: all. A dense ``K`` of 50,000 unknowns would take 20 GB.
DENSE_LIMIT = 2000
#: Largest number of pairs Lemke is given in a problem kept sparse.
SPARSE_LEMKE_MAX = 500

_METHODS = ("auto", "lemke", "direct", "enum", "newton")
_NOISE = 1e3 * np.finfo(float).eps  # relative size treated as rounding noise in M̂, q̂


def negative_current_harmless(lu: Any, sel: np.ndarray, n: int, z: np.ndarray,
                              mask: np.ndarray, w_scale: np.ndarray) -> bool:
    """Whether the negative ``z_i`` of the active pairs are too small to matter where they act.

    Removing a wrong-signed ``z_i`` (turning pair ``i`` off) moves that pair's ``w_i``
    by ``z_i / g_i``, where ``g_i = ∂z_i/∂w_i`` is the diagonal entry of the bordered
    matrix's inverse at the pair (``K_α x = -c + δ e_i`` when ``w_i = δ`` is imposed):
    ``1 / g_i`` is the resistance the pair sees. The violation is harmless when that
    shift is within :data:`SIGN_TOL` of the pair's own scale ``w_scale[i]``
    (``|K_i||x| + |c_i|``). A test against the rows ``z_i`` enters is not enough: a node
    held only by off-conductances (``1e-12`` S) moves 160 V for ``-1.6e-10`` A, a current
    that is noise beside the amperes of the node's other terms (the floating AC side of a
    bridge rectifier). ``lu`` factorises ``K_α`` (rows/columns ``sel`` of ``[u; z]``).
    """
    negative = np.flatnonzero(mask & (z < 0.0))
    if not negative.size:
        return True
    where = np.searchsorted(sel, n + negative)
    unit = np.zeros((sel.size, negative.size))
    unit[where, np.arange(negative.size)] = 1.0
    gain = np.abs(lu.solve(unit)[where, np.arange(negative.size)])
    with np.errstate(divide="ignore"):
        shift = np.where(gain > 0.0, -z[negative] / gain, np.inf)
    return bool((shift <= SIGN_TOL * w_scale[negative]).all())


class _StartBasis(PivotTransform):
    """:class:`~circuitnsds.solvers.pivot_transform.PivotTransform` at a start basis ``α0``,
    with the rounding noise of the elimination removed from ``M̂`` (as ``Mhat``; ``M`` keeps
    the values computed, which the certificate of :meth:`MLCPSolver.unique_solutions` judges)
    and ``q̂``, and Lemke's scaled tableau of ``M̂`` (:meth:`lemke`)."""

    __slots__ = ("Mhat", "_lemke")

    def __init__(self, K: np.ndarray, n: int, mask: np.ndarray, lu: LU) -> None:
        super().__init__(K, n, mask, lu)
        Mhat = self.M.copy()
        # entries at rounding level are noise of the elimination; zero them so that
        # Lemke's scaling cannot blow them up into pivot candidates
        if self.m:
            Mhat[np.abs(Mhat) < _NOISE * float(np.abs(Mhat).max())] = 0.0
        self.Mhat = Mhat
        self._lemke: LemkeTableau | None = None

    def lemke(self) -> LemkeTableau:
        """Lemke's tableau of ``M̂`` (its scaling computed on the first call, then kept)."""
        if self._lemke is None:
            self._lemke = LemkeTableau(self.Mhat)
        return self._lemke

    def rhs(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(q̂, r0)`` for ``c = [a; b]`` (``r0`` = basic values at ``ẑ = 0``)."""
        qhat, r0 = super().rhs(c)
        # rounding-level negatives (a degenerate pair computed as -1e-16) would
        # otherwise make a feasible problem look infeasible
        big = max(
            float(np.abs(r0).max()) if r0.size else 0.0, float(np.abs(c).max()) if c.size else 0.0
        )
        qhat[(qhat < 0.0) & (qhat > -_NOISE * big)] = 0.0
        return qhat, r0


def _equilibrate_pair_columns(
    K: np.ndarray, Ks: Any, n: int
) -> tuple[np.ndarray, Any, np.ndarray | None]:
    """Scale each ``z`` column of ``K`` by ``1 / max(1, max |column|)``.

    The solver then works with ``ẑ = s z``. Without it a pair whose column holds a
    huge entry (a diode's ``Ron/h ~ 1e9`` beside node rows of order one) inflates
    ``κ = ||K||_∞`` so much that a constraint violated by volts still passes the
    normwise residual test. Returns ``(K, Ks, s)`` with ``s = None`` when no column
    needed scaling.
    """
    if K.shape[1] == n:
        return K, Ks, None
    if isinstance(K, np.ndarray):
        scale = np.maximum(1.0, np.abs(K[:, n:]).max(axis=0))
    else:
        scale = np.maximum(1.0, np.asarray(abs(K[:, n:]).max(axis=0).todense()).ravel())
    if np.all(scale == 1.0):
        return K, Ks, None
    factors = np.concatenate([np.ones(n), 1.0 / scale])
    if isinstance(K, np.ndarray) and Ks is None:
        return K * factors, None, scale
    import scipy.sparse as sp

    K = K * factors if isinstance(K, np.ndarray) else (K @ sp.diags(factors)).tocsr()
    if Ks is not None:
        Ks = (Ks @ sp.diags(factors)).tocsr()
    return K, Ks, scale


class MLCPSolver:
    """Reusable MLCP solver for fixed ``A, C, D, B`` and changing ``a, b``.

    Args:
        A, C, D, B: blocks (dense or scipy.sparse) with shapes ``(n, n)``,
            ``(n, m)``, ``(m, n)``, ``(m, m)``; ``n = 0`` gives a plain LCP.
        cache_size: number of active-set factorisations kept (LRU).
        tol: largest accepted scaled residual
            (:func:`circuitnsds.solvers.residual.mlcp_residual`).
        max_pivots: Lemke pivot limit (default ``50 * (m + 1)``).

    Attributes:
        n, m: sizes.
        stats: counters — ``calls``, ``cache_hits``, ``cache_misses``,
            ``factorisations``, ``evictions``, ``direct_accepted``,
            ``direct_rejected``, ``fallbacks`` (calls that were not answered by
            mode reuse), ``lemke_fallbacks`` (calls that ran Lemke),
            ``lemke_pivots``, ``start_bases`` (Lemke start bases built),
            ``enum_fallbacks``, ``newton_fallbacks``, ``degenerate_flips``
            (answers replaced by a componentwise better one), ``failures``.
    """

    def __init__(
        self,
        A: Any,
        C: Any,
        D: Any,
        B: Any,
        *,
        cache_size: int = 16,
        tol: float = 1e-9,
        max_pivots: int | None = None,
    ) -> None:
        K, Ks, n, m, _ = bordered(A, C, D, B, dense_limit=DENSE_LIMIT)
        #: a large sparse problem is kept sparse (see DENSE_LIMIT): ``_K`` is then CSR
        self.sparse_only = K is None
        if K is None:
            K = Ks.tocsr()
        K, Ks, self._z_scale = _equilibrate_pair_columns(K, Ks, n)
        self.n, self.m = n, m
        self.tol = float(tol)
        self.max_pivots = max_pivots
        self._N = n + m
        self._K = K
        self._Ks = Ks
        self._kappa = kappa_of(K)
        self.stats: dict[str, int] = dict.fromkeys(
            (
                "calls",
                "cache_hits",
                "cache_misses",
                "factorisations",
                "evictions",
                "direct_accepted",
                "direct_rejected",
                "fallbacks",
                "pivoting_solves",
                "lemke_fallbacks",
                "lemke_pivots",
                "start_bases",
                "enum_fallbacks",
                "newton_fallbacks",
                "degenerate_flips",
                "failures",
            ),
            0,
        )
        self._cache = ModeCache(None if self.sparse_only else K, n, cache_size, self.stats, Ks)
        self._starts: dict[bytes, _StartBasis | None] = {}
        self._start_order: list[np.ndarray] | None = None
        self._rcond_a: float | None = None
        self._absK: np.ndarray | None = None
        self._unique: bool | None = None

    # ------------------------------------------------------------------ helpers
    @property
    def size(self) -> dict[str, int]:
        return {"n": self.n, "m": self.m}

    def _rhs(self, a: Any, b: Any, check: bool = True) -> np.ndarray:
        """``c = [a; b]``; ``check=False`` (hot path) skips the NaN test (the residual sees NaN)."""
        c = np.empty(self._N)
        if check:
            c[: self.n] = as_vector(a, self.n, "a")
            c[self.n :] = as_vector(b, self.m, "b")
            return c
        av = np.asarray(a, dtype=float)
        bv = np.asarray(b, dtype=float)
        if av.shape != (self.n,) or bv.shape != (self.m,):
            return self._rhs(a, b, True)
        c[: self.n] = av
        c[self.n :] = bv
        return c

    def _result(
        self,
        x: np.ndarray,
        w: np.ndarray,
        active: np.ndarray,
        method: str,
        iterations: int,
        res: float,
    ) -> MLCPResult:
        n = self.n
        if self._z_scale is not None:
            x[n:] /= self._z_scale  # back from the equilibrated unknowns
        return MLCPResult(
            u=x[:n], z=x[n:], w=w, active=active, method=method, iterations=iterations, residual=res
        )

    def _try_mode(self, mode: Mode, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
        """Solve the bordered system of ``mode`` and evaluate the scaled residual.

        Returns ``(x, w, residual, scale)``; written out (rather than calling
        :func:`~circuitnsds.solvers.residual.evaluate`) because it is the hot path.
        """
        n, m, kappa = self.n, self.m, self._kappa
        x = np.zeros(self._N)
        sel = mode.sel
        if sel.size:
            x[sel] = mode.lu.solve(np.negative(c[sel]))
        r = self._K @ x
        r += c
        w = r[n:]
        num = 0.0
        if m:
            num = float(np.abs(np.minimum(x[n:] * kappa, w)).max())
        if n:
            num = max(num, float(np.abs(r[:n]).max()))
        if self._N == 0:
            return x, w, 0.0, 0.0
        scale = float(np.abs(c).max()) + kappa * float(np.abs(x).max())
        if not np.isfinite(np.dot(r, r)):
            return x, w, float("inf"), float(scale)
        if num == 0.0:
            return x, w, 0.0, float(scale)
        res = num / scale if scale > 0.0 else float("inf")
        return x, w, float(res), float(scale)

    def _signs_hold(self, x: np.ndarray, w: np.ndarray, c: np.ndarray, mode: Mode) -> bool:
        """Sign test of a guessed mode against each pair's own row scale.

        The normwise residual compares a pair's violation with the largest entry of
        the whole system: in a mains transformer (``L/h ~ 5e4``, 325 V) a blocked
        diode forward-biased by 15 mV passed it. Here a negative ``w_i`` is measured
        against ``s_i = |K_i||x| + |c_i|`` and a negative ``z_i`` against the rows it
        enters, as in :func:`componentwise_residual`; beyond :data:`SIGN_TOL` the
        guess is rejected and the full solver decides.

        A negative ``z_i`` of an active pair must also be harmless where it acts: see
        :func:`negative_current_harmless`.
        """
        n = self.n
        z = x[n:]
        if not (w < 0.0).any() and not (z < 0.0).any():
            return True
        if self._absK is None:
            self._absK = abs(self._K)
        scale = self._absK @ np.abs(x) + np.abs(c)
        safe = np.where(scale > 0.0, scale, 1.0)
        if (w < -SIGN_TOL * safe[n:]).any():
            return False
        entering = scaled_column_max(self._absK, n, safe)
        if (z * entering < -SIGN_TOL).any():
            return False
        return negative_current_harmless(mode.lu, mode.sel, n, z, mode.mask, scale[n:])

    def _degenerate(
        self, x: np.ndarray, w: np.ndarray, mask: np.ndarray, scale: float
    ) -> np.ndarray:
        """Indices of pairs that are zero on both sides at the tolerance."""
        thr = self.tol * scale
        z = x[self.n :]
        deg = np.where(mask, self._kappa * np.abs(z) <= thr, np.abs(w) <= thr)
        return np.flatnonzero(deg)

    def _consistent(
        self,
        x: np.ndarray,
        w: np.ndarray,
        mask: np.ndarray,
        res: float,
        scale: float,
        c: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """Among verified answers differing in degenerate labels, keep the componentwise best.

        Called only with an answer that passed ``residual <= tol``. Cheap when no
        pair is degenerate (the usual case).
        """
        deg = self._degenerate(x, w, mask, scale)
        if deg.size == 0:
            return x, w, mask, res
        if self._absK is None:
            self._absK = abs(self._K)
        absK, n = self._absK, self.n

        def rho(xv: np.ndarray, wv: np.ndarray) -> float:
            r = np.empty(self._N)
            r[n:] = wv
            if n:
                r[:n] = self._K[:n] @ xv + c[:n]
            return componentwise_residual(absK, n, c, xv, r)

        best_rho = rho(x, w)
        if best_rho <= CTOL:
            return x, w, mask, res
        best = (x, w, mask, res)
        deg = deg[:MAX_FLIPS]
        trials: list[np.ndarray | int] = [deg] if deg.size > 1 else []
        trials.extend(int(i) for i in deg)
        for flip in trials:
            trial = best[2].copy()
            trial[flip] = ~trial[flip]
            mode = self._cache.get(trial)
            if not mode.lu.ok:
                continue
            x2, w2, res2, _ = self._try_mode(mode, c)
            if not res2 <= self.tol:
                continue
            r2 = rho(x2, w2)
            if r2 < best_rho:
                self.stats["degenerate_flips"] += 1
                best_rho, best = r2, (x2, w2, mode.mask.copy(), res2)
                if best_rho <= CTOL:
                    break
        return best

    @property
    def rcond_a(self) -> float:
        """Reciprocal condition estimate of ``A`` (1.0 when ``n == 0``)."""
        if self._rcond_a is None:
            if not self.n:
                self._rcond_a = 1.0
            elif self.sparse_only:
                self._rcond_a = factorise_sparse(self._K[: self.n, : self.n]).rcond
            else:
                self._rcond_a = factorise(self._K[: self.n, : self.n]).rcond
        return self._rcond_a

    def unique_solutions(self) -> bool:
        """Whether every right-hand side has exactly one solution, certified: the LCP of the
        pairs at the first start basis (a principal pivot transform of ``B - D A⁻¹ C``,
        which keeps P-matrices P) passes :func:`~circuitnsds.solvers.uniqueness.certified_p_matrix`,
        its error bounded by ``eps / rcond`` of the start basis's factorisation. Computed
        once. ``False`` for a problem kept sparse or without a usable start basis."""
        if self._unique is None:
            self._unique = False
            if not self.sparse_only:
                sb = next(iter(self._start_bases()), None)
                if sb is not None:
                    error = np.finfo(float).eps / max(sb.lu.rcond, np.finfo(float).tiny)
                    self._unique = certified_p_matrix(sb.M, error)
        return self._unique

    # ------------------------------------------------------------ start bases
    def _completion_mask(self) -> np.ndarray | None:
        """Active set that completes the rank of a (nearly) singular ``A`` (dense problems
        only: it takes an SVD of ``A``)."""
        if self.sparse_only:
            return None
        return completion_mask(self._K, self.n)

    def _make_start(self, mask: np.ndarray) -> _StartBasis | None:
        sel = np.concatenate([np.arange(self.n), self.n + np.flatnonzero(mask)])
        if self.sparse_only:
            lu = factorise_sparse(self._K[sel][:, sel])
        else:
            lu = factorise(self._K[np.ix_(sel, sel)])
        if not lu.ok:
            return None
        self.stats["start_bases"] += 1
        return _StartBasis(self._K, self.n, mask.copy(), lu)

    def _start_bases(self) -> Iterator[_StartBasis]:
        """Start bases in order of preference, each built on first use and then kept."""
        if self._start_order is None:
            empty = np.zeros(self.m, dtype=bool)
            order: list[np.ndarray] = []
            if self.rcond_a >= A_RCOND_GOOD:
                order.append(empty)
            else:
                comp = self._completion_mask()
                if comp is not None and comp.any():
                    order.append(comp)
                order.append(empty)
            self._start_order = order
        for mask in self._start_order:
            key = mask.tobytes()
            if key not in self._starts:
                self._starts[key] = self._make_start(mask)
            sb = self._starts[key]
            if sb is not None:
                yield sb

    # ---------------------------------------------------------------- methods
    def _lemke_from(
        self, sb: _StartBasis, c: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, float, tuple | None]:
        """Lemke from start basis ``sb``: ``(x, w, active, pivots, residual, evaluated)``;
        ``evaluated``: ``(mode, x, w, residual)`` of the answer's active set as
        :meth:`_try_mode` gave them (``x`` a copy), when the answer is that evaluation, else
        ``None`` (what :meth:`_settled` would compute again)."""
        qhat, r0 = sb.rhs(c)
        try:
            zhat, act_hat, pivots = sb.lemke().pivot(qhat, self.max_pivots)
        except LCPNoSolution as err:
            if sb.aidx.size and getattr(err, "ray_z", None) is not None:
                rz, rw = err.ray_z, err.ray_w
                err.ray_z = np.where(sb.mask, rw, rz)
                err.ray_w = np.where(sb.mask, rz, rw)
                err.evidence.update(ray_z=err.ray_z, ray_w=err.ray_w)
            err.size = self.size
            err.evidence["start_basis"] = sb.mask.copy()
            raise
        except LCPSolverFailure as err:
            err.size = self.size
            raise
        self.stats["lemke_pivots"] += pivots
        active = act_hat ^ sb.mask
        best: tuple[float, np.ndarray, np.ndarray, float] | None = None
        mode = self._cache.get(active)
        evaluated = None
        if mode.lu.ok:
            x, w, res, scale = self._try_mode(mode, c)
            best = (res, x, w, scale)
            evaluated = (mode, x, w, res)
        if best is None or best[0] > self.tol:
            x = sb.recover(zhat, r0)
            res, w, scale = evaluate(self._K, self.n, c, x, self._kappa)
            if best is None or res < best[0]:
                best = (res, x, w, scale)
        res, x, w, scale = best
        if not res <= self.tol:
            raise LCPSolverFailure(
                "Lemke's active set does not verify (numerical trouble)",
                method="lemke",
                size=self.size,
                pivots=pivots,
                residual=float(res),
                reason="residual above tol",
                tol=self.tol,
                start_basis=sb.mask.copy(),
            )
        checked_x = x
        x, w, active, res = self._consistent(x, w, active, res, scale, c)
        if evaluated is not None and not (evaluated[1] is x is checked_x):
            evaluated = None  # (the answer is another evaluation's)
        elif evaluated is not None:
            evaluated = (mode, x.copy(), w, evaluated[3])  # (_result scales x in place)
        return x, w, active, pivots, float(res), evaluated

    def _lemke_chain(self, c: np.ndarray) -> tuple[MLCPResult | None, list[LCPError], tuple | None]:
        """Lemke from each start basis in turn: ``(result, errors, evaluated)`` (``evaluated``:
        see :meth:`_lemke_from`; ``result`` ``None`` when every start basis failed)."""
        errors: list[LCPError] = []
        for sb in self._start_bases():
            try:
                x, w, active, pivots, res, evaluated = self._lemke_from(sb, c)
            except LCPNoSolution as err:
                # a ray proves infeasibility only for copositive-plus transforms;
                # another start basis is cheap to try
                errors.append(err)
                continue
            except LCPSolverFailure as err:
                errors.append(err)
                continue
            return self._result(x, w, active, "lemke", pivots, res), errors, evaluated
        if not errors:
            errors.append(
                self._failure("no usable start basis for Lemke (every tried bordered matrix is singular)",
                              "lemke", "singular start basis", rcond_a=self.rcond_a)
            )
        return None, errors, None

    def _failure(self, message: str, method: str, reason: str, residual: float = float("inf"),
                 **evidence: Any) -> LCPSolverFailure:
        """A failure before any pivot (``evidence`` as for :class:`LCPError`)."""
        return LCPSolverFailure(message, method=method, size=self.size, pivots=0, residual=residual,
                                reason=reason, **evidence)

    def _no_active_set(self, method: str, prefix: str = "") -> LCPNoSolution:
        """Exhaustive enumeration found no active set (``prefix`` starts the message)."""
        return LCPNoSolution(prefix + "no active set solves the MLCP (exhaustive enumeration)",
                             method=method, size=self.size, pivots=2**self.m, residual=float("inf"),
                             confirmed_by_enumeration=True)

    def _enum(self, c: np.ndarray, force: bool = False) -> MLCPResult | None:
        found = enumerate_mlcp(self._K, self.n, c, tol=self.tol, force=force)
        if found is None:
            return None
        x, mask, tried, res = found
        res, w, scale = evaluate(self._K, self.n, c, x, self._kappa)
        x, w, mask, res = self._consistent(x, w, mask, res, scale, c)
        return self._result(x, w, mask, "enum", tried, res)

    def _newton(self, c: np.ndarray) -> MLCPResult:
        K = self._Ks if self._Ks is not None else self._K
        x, active, it, res = fb_newton_mlcp(K, self.n, c, tol=self.tol)
        res, w = mlcp_residual(self._K, self.n, c, x, self._kappa)
        return self._result(x, w, active, "newton", it, res)

    def _pivoting(self, c: np.ndarray, start: np.ndarray) -> MLCPResult | None:
        """Block principal pivoting from ``start`` (:mod:`.pivoting`); each trial's answer is
        accepted only as a guessed mode's is (residual and signs). ``None`` when it fails."""
        n = self.n
        pivoting = BlockPivoting(start)
        # a conducting front crossing a ladder of m diodes moves tens of pairs per trial
        for trial in range(1, max(TRIALS, self.m // 20) + 1):
            mode = self._cache.get(pivoting.mask)
            if not mode.lu.ok:
                if trial == 1 and start.any():  # a singular guess: start from no pair active
                    pivoting = BlockPivoting(np.zeros(self.m, dtype=bool))
                    continue
                return None
            x, w, res, scale = self._try_mode(mode, c)
            if not np.isfinite(res):
                return None
            if res <= self.tol and self._signs_hold(x, w, c, mode):
                active = mode.mask.copy()
                if np.hypot(x[n:] * self._kappa, w).min() <= self.tol * scale:
                    x, w, active, res = self._consistent(x, w, active, res, scale, c)
                self.stats["pivoting_solves"] += 1
                return self._result(x, w, active, "pivoting", trial, res)
            violated = np.flatnonzero(np.where(mode.mask, x[n:] < 0.0, w < 0.0))
            if not violated.size:  # signs right but the residual is not: leave it to Lemke
                return None
            pivoting.update(violated)
        return None

    def _settled(self, result: MLCPResult, c: np.ndarray, evaluated: tuple | None = None
                 ) -> MLCPResult:
        """``result`` (verified by the normwise residual) if its active set also passes the
        sign test of a guessed mode (:meth:`_signs_hold`); otherwise the answer of block
        principal pivoting started from it, when that finds one.

        Lemke works on the Schur complement, whose entries reach ``1/gmin`` where a node
        is held only by off-conductances: it can return a pair conducting a wrong-signed
        current that the normwise residual cannot see but that holds the node 160 V away
        from where the off-conductances put it (see :func:`negative_current_harmless`).
        """
        mask = np.asarray(result.active, dtype=bool)
        mode = self._cache.get(mask)
        if not mode.lu.ok:
            return result
        if evaluated is not None and evaluated[0] is mode:  # (what _try_mode gives again)
            _, x, w, res = evaluated
        else:
            x, w, res, _ = self._try_mode(mode, c)
        if not np.isfinite(res) or self._signs_hold(x, w, c, mode):
            return result
        better = self._pivoting(c, mask)
        if better is None:
            return result
        better.method = result.method + "->pivoting"
        return better

    def _fallback(self, c: np.ndarray, prefix: str, start: np.ndarray | None = None) -> MLCPResult:
        if not np.all(np.isfinite(c)):
            raise ValueError("a or b contains NaN or inf")
        st = self.stats
        st["fallbacks"] += 1
        if self.m >= PIVOTING_MIN_PAIRS or (self.sparse_only and self.m):
            result = self._pivoting(c, np.zeros(self.m, dtype=bool) if start is None else start)
            if result is not None:
                result.method = prefix + result.method
                return result
            prefix += "pivoting->"
        errors: list[LCPError] = []
        chain = prefix.removesuffix("->")
        if not (self.sparse_only and self.m > SPARSE_LEMKE_MAX):
            st["lemke_fallbacks"] += 1
            result, errors, evaluated = self._lemke_chain(c)
            if result is not None:
                result.method = prefix + "lemke"
                return self._settled(result, c, evaluated)
            chain = prefix + "lemke"
        ray = next((e for e in errors if isinstance(e, LCPNoSolution)), None)
        if self.m <= ENUM_FALLBACK_MAX and not self.sparse_only:
            st["enum_fallbacks"] += 1
            result = self._enum(c)
            if result is not None:
                result.method = chain + "->enum"
                return self._settled(result, c)
            st["failures"] += 1
            if ray is None:
                ray = self._no_active_set(chain + "->enum", "no solution: ")
            else:
                ray.method = chain + "->enum"
                ray.message = (
                    "no solution: Lemke ended on a secondary ray and enumeration "
                    "of all active sets found none"
                )
            ray.confirmed_by_enumeration = True
            ray.evidence["confirmed_by_enumeration"] = True
            raise ray
        st["newton_fallbacks"] += 1
        chain = f"{chain}->newton" if chain else "newton"
        try:
            result = self._newton(c)
        except LCPSolverFailure as err:
            errors.append(err)
            st["failures"] += 1
            if ray is not None:
                ray.method = chain
                ray.message = (
                    "Lemke ended on a secondary ray (no solution if the problem is "
                    "copositive-plus) and semismooth Newton did not converge"
                )
                raise ray from err
            best = min((e.residual for e in errors if e.residual is not None), default=float("inf"))
            raise LCPSolverFailure(
                "no method produced a verified MLCP solution ("
                + chain
                + "): "
                + "; ".join(e.message for e in errors),
                method=chain,
                size=self.size,
                pivots=sum(e.pivots or 0 for e in errors),
                residual=best,
                reason="all methods failed",
                rcond_a=self.rcond_a,
            ) from err
        result.method = chain
        return result

    # ------------------------------------------------------------- public API
    def solve(self, a: Any, b: Any, guess: Any = None) -> MLCPResult:
        """Solve for new right-hand sides ``a`` (n,), ``b`` (m,).

        Args:
            a, b: right-hand sides.
            guess: boolean mask or index array of the pairs expected active
                (typically the previous call's ``result.active``).

        Returns:
            :class:`MLCPResult` (``method`` ``"direct"`` with ``iterations == 0``
            when the guess was right).

        Raises:
            LCPNoSolution, LCPSolverFailure: see the module docstring.
        """
        c = self._rhs(a, b, check=False)
        self.stats["calls"] += 1
        if guess is not None:
            mask = (
                guess
                if (
                    isinstance(guess, np.ndarray)
                    and guess.dtype == bool
                    and guess.shape == (self.m,)
                )
                else as_mask(guess, self.m)
            )
            mode = self._cache.get(mask)
            if mode.lu.ok:
                x, w, res, scale = self._try_mode(mode, c)
                if res <= self.tol and self._signs_hold(x, w, c, mode):
                    self.stats["direct_accepted"] += 1
                    active = mode.mask.copy()
                    if self.m and np.hypot(x[self.n :] * self._kappa, w).min() <= self.tol * scale:
                        x, w, active, res = self._consistent(x, w, active, res, scale, c)
                    return self._result(x, w, active, "direct", 0, res)
            self.stats["direct_rejected"] += 1
            return self._fallback(c, "direct->", mask)
        return self._fallback(c, "")

    def solve_direct(self, a: Any, b: Any, guess: Any) -> MLCPResult:
        """Mode reuse only: solve the bordered system of ``guess``; no fallback.

        Raises:
            ValueError: ``guess`` is ``None``.
            LCPSolverFailure: the guessed active set is singular or not a solution.
        """
        if guess is None:
            raise ValueError('method "direct" needs a guess of the active set')
        c = self._rhs(a, b)
        self.stats["calls"] += 1
        mask = as_mask(guess, self.m)
        mode = self._cache.get(mask)
        if not mode.lu.ok:
            self.stats["direct_rejected"] += 1
            raise self._failure("the bordered matrix of the guessed active set is singular", "direct",
                                "singular mode", rcond=mode.lu.rcond, guess=mask.copy())
        x, w, res, _ = self._try_mode(mode, c)
        if not res <= self.tol:
            self.stats["direct_rejected"] += 1
            raise self._failure("the guessed active set is not a solution", "direct", "guess rejected",
                                residual=float(res), guess=mask.copy())
        self.stats["direct_accepted"] += 1
        return self._result(x, w, mode.mask.copy(), "direct", 0, res)

    def solve_lemke(self, a: Any, b: Any) -> MLCPResult:
        """Lemke on the principal pivot transform (see module docstring), no other fallback."""
        c = self._rhs(a, b)
        self.stats["calls"] += 1
        self.stats["lemke_fallbacks"] += 1
        result, errors, _ = self._lemke_chain(c)
        if result is None:
            self.stats["failures"] += 1
            ray = next((e for e in errors if isinstance(e, LCPNoSolution)), None)
            raise ray if ray is not None else errors[-1]
        return result

    def solve_enum(self, a: Any, b: Any, *, force: bool = False) -> MLCPResult:
        """Enumeration of all ``2**m`` active sets (``m <= 12`` unless ``force``).

        Raises:
            ValueError: ``m > 12`` without ``force``.
            LCPNoSolution: no active set is a solution.
        """
        if self.m > MAX_ENUM and not force:
            raise ValueError(f"enumeration of {self.m} pairs needs force=True")
        c = self._rhs(a, b)
        self.stats["calls"] += 1
        result = self._enum(c, force=force)
        if result is None:
            raise self._no_active_set("enum")
        return result

    def solve_newton(self, a: Any, b: Any) -> MLCPResult:
        """Semismooth Newton (Fischer–Burmeister) on the whole mixed system."""
        c = self._rhs(a, b)
        self.stats["calls"] += 1
        return self._newton(c)


def solve_mlcp(
    A: Any,
    C: Any,
    D: Any,
    B: Any,
    a: Any,
    b: Any,
    *,
    method: str = "auto",
    guess: Any = None,
    tol: float = 1e-9,
    max_pivots: int | None = None,
) -> MLCPResult:
    """Solve ``A u + C z + a = 0, w = D u + B z + b, 0 <= z ⊥ w >= 0`` once.

    Args:
        A, C, D, B: blocks (dense or scipy.sparse), shapes ``(n,n), (n,m), (m,n), (m,m)``.
        a, b: right-hand sides, shapes ``(n,)``, ``(m,)``.
        method: ``"auto"`` (mode reuse if ``guess``, then Lemke, enumeration,
            Newton), ``"lemke"``, ``"direct"`` (needs ``guess``), ``"enum"``
            (``m <= 12``), ``"newton"``.
        guess: boolean mask or index array of the expected active pairs.
        tol: largest accepted scaled residual.
        max_pivots: Lemke pivot limit (default ``50 * (m + 1)``).

    Returns:
        :class:`MLCPResult`.

    Raises:
        LCPNoSolution, LCPSolverFailure, ValueError (bad input or method).

    For repeated solves with the same matrices use :class:`MLCPSolver`.
    """
    if method not in _METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {_METHODS}")
    solver = MLCPSolver(A, C, D, B, tol=tol, max_pivots=max_pivots)
    if method == "auto":
        return solver.solve(a, b, guess)
    if method == "direct":
        return solver.solve_direct(a, b, guess)
    if method == "lemke":
        return solver.solve_lemke(a, b)
    if method == "enum":
        return solver.solve_enum(a, b)
    return solver.solve_newton(a, b)
