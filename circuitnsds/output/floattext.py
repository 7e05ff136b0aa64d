"""Float64 values as text, compiled: the shortest decimal that reads back to the same double.

The text of each value is exactly Python's ``repr`` of it (``0.1``, ``1e-05``,
``1.7976931348623157e+308``, ``5e-324``, ``-0.0``, ``inf``, ``-inf``, ``nan``), so
``float(text) == x`` bit for bit, and a file written here is byte for byte the one the
Python writer (``%r``) writes; only faster (~20-50x per value, measured in
``benchmarks/csv_writers.py``).

**The digits** are found by the Schubfach method (R. Giulietti, *The Schubfach way to
render doubles*, 2020), written here from the paper's description. A finite nonzero
double is ``v = c·2^q`` (integer significand ``c``, binary exponent ``q``); the doubles
that read back to ``v`` are those of its rounding interval ``R = [u, w]``, the halfway
points to its neighbours ``(c ∓ 1/2)·2^q`` (``(c - 1/4)·2^q`` below when ``c = 2^52`` and
``v`` is not the smallest normal: the neighbour below is then half as far), closed when
``c`` is even (ties read back to even), open when it is odd. With
``k = floor(log10(2^q))`` (``floor(log10(3/4·2^q))`` in the asymmetric case), ``10^k`` is
at most the width of ``R`` and ``10^(k+1)`` exceeds it, so:

1. ``R`` holds at most one multiple of ``10^(k+1)``; if it holds one, that is the shortest
   decimal (trailing zeros dropped);
2. otherwise it holds ``s·10^k`` or ``(s+1)·10^k`` (``s = floor(v·10^-k)``), of equal length;
   if both, the one closer to ``v`` (on a tie the even one) — the same choice as
   ``repr`` (shortest, then closest: David Gay's ``dtoa`` mode 0).

``v·10^-k`` and the ends of ``R`` scaled alike are computed in 64-bit integers from a
126-bit approximation ``g`` of ``10^-k`` (``g = floor(10^e·2^(125 - floor(e·log2 10))) + 1``,
``e = -k``), keeping the integer part of each product and a sticky bit for a nonzero
fraction: the paper proves that this decides every comparison above exactly. The tables
(``g`` for ``e`` in -292..324, ``k`` and the shift for each binary exponent) are computed
with Python's exact integers at first use (~5 ms), not copied from anywhere.

**The layout** is ``repr``'s: plain notation when the decimal point falls between 4 digits
before and 16 digits after the first digit (``0.0001`` .. ``1234567890123456.0``, a
``.0`` for integers), otherwise ``d.ddde±XX`` (at least two exponent digits).

**What runs where.** The kernel (:func:`kernel`, :func:`_csv_block`) writes a whole block
of rows into a byte buffer without the GIL, the tables passed as arguments. It exists
three times, writing the same bytes (the tests check each against ``repr``):

* in C, ``_floattext_native.c`` beside this module: the same steps in the same 64-bit
  integer arithmetic, compiled into a shared library when the package is installed with a
  C compiler, loaded with ctypes (:mod:`circuitnsds.native`; ~0.05 µs per number, nothing
  to load but the library). Used whenever it is there;
* compiled by numba (:mod:`circuitnsds.jit`, cached per user; ~0.07-0.15 µs per
  number, but importing numba and loading the code costs ~1 s in a fresh process): used
  without the C library, for files large enough to pay for that
  (:func:`circuitnsds.output.csvfile.compiled_pays`);
* this module's Python code, run by the interpreter (tests, and numba's absence).

(Raw files' ASCII values keep ngspice's ``%.15e``, whose files they reproduce byte for
byte: not this text.)
"""

from __future__ import annotations

import numpy as np

from circuitnsds import native

E_MIN, E_MAX = -292, 324
"""Range of the decimal exponent ``e = -k`` of the table ``g`` (doubles need no more)."""
Q_MIN, Q_MAX = -1074, 971
"""Binary exponents ``q`` of ``c·2^q`` (subnormals have ``q = Q_MIN``)."""
MAX_CHARS = 24
"""Longest text of one value (``-2.2250738585072014e-308``)."""

_TABLES: tuple[np.ndarray, ...] | None = None


def _floor_log10(numerator: int, denominator: int) -> int:
    """``floor(log10(numerator / denominator))``, exact (positive integers)."""
    k = len(str(numerator)) - len(str(denominator))
    while numerator * 10 ** max(-k, 0) < denominator * 10 ** max(k, 0):
        k -= 1
    while numerator * 10 ** max(-k - 1, 0) >= denominator * 10 ** max(k + 1, 0):
        k += 1
    return k


def _floor_log2_pow10(e: int) -> int:
    """``floor(e·log2(10))``, exact."""
    return (10**e).bit_length() - 1 if e >= 0 else -((10**-e).bit_length())


def exponent_tables(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``floor(log10(2^q))`` and ``floor(log10(3/4·2^q))`` for the binary exponents ``q``
    (int64), from float64 logarithms: for ``|q| <= 1074`` their arguments lie at least
    1e-4 from an integer (checked against exact integer arithmetic over the whole range
    by the tests), far beyond the float64 error (~1e-13)."""
    q = np.asarray(q, dtype=np.float64)
    return (np.floor(q * np.log10(2.0)).astype(np.int64),
            np.floor(np.log10(3.0) + (q - 2) * np.log10(2.0)).astype(np.int64))


def exact_exponent_tables(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`exponent_tables` by exact integer arithmetic (slow: for the tests)."""
    return (np.array([_floor_log10(2**max(v, 0), 2**max(-v, 0)) for v in q.tolist()], dtype=np.int64),
            np.array([_floor_log10(3 * 2**max(v - 2, 0), 2**max(2 - v, 0)) for v in q.tolist()],
                     dtype=np.int64))


def _shifts(q: np.ndarray, k: np.ndarray, log2_pow10: np.ndarray) -> np.ndarray:
    """``h = q + floor(-k·log2 10) + 2`` (the shift that puts ``c·2^q·10^-k`` at the scale of
    the table's ``g``); ``log2_pow10[e - E_MIN] = floor(e·log2 10)``."""
    h = q + log2_pow10[-k - E_MIN] + 2
    assert ((0 <= h) & (h <= 8)).all()
    return h


def tables() -> tuple[np.ndarray, ...]:
    """``(g_high, g_low, k, h, k_asym, h_asym)``: the 63-bit halves of ``g`` for ``e`` in
    ``E_MIN..E_MAX`` (uint64), and for each ``q`` in ``Q_MIN..Q_MAX`` the decimal exponent
    ``k`` and the shift ``h = q + floor(-k·log2 10) + 2`` (int64), for the symmetric
    interval and for the asymmetric one (``c = 2^52``). Computed once, exactly."""
    global _TABLES
    if _TABLES is None:
        g_high, g_low, log2_pow10 = [], [], []
        for e in range(E_MIN, E_MAX + 1):
            log2_pow10.append(_floor_log2_pow10(e))
            r = 125 - log2_pow10[-1]
            if e >= 0:
                g = (10**e << r) if r >= 0 else (10**e >> -r)
            else:
                g = (1 << r) // 10**-e
            g += 1
            assert 2**125 <= g < 2**126
            g_high.append(g >> 63)
            g_low.append(g & (2**63 - 1))
        q = np.arange(Q_MIN, Q_MAX + 1)
        ks, ka = exponent_tables(q)
        log2 = np.array(log2_pow10, dtype=np.int64)
        _TABLES = (np.array(g_high, dtype=np.uint64), np.array(g_low, dtype=np.uint64),
                   ks, _shifts(q, ks, log2), ka, _shifts(q, ka, log2))
    return _TABLES


_M32 = np.uint64(0xFFFFFFFF)
_M52 = np.uint64((1 << 52) - 1)
_M63 = np.uint64((1 << 63) - 1)
_U0, _U1, _U2, _U10, _U100, _U1E8 = (np.uint64(v) for v in (0, 1, 2, 10, 100, 10**8))
_S32, _S52, _S63 = np.uint64(32), np.uint64(52), np.uint64(63)


def _multiply_high(a, b):
    """The high 64 bits of the 128-bit product of two uint64."""
    a_lo, a_hi = a & _M32, a >> _S32
    b_lo, b_hi = b & _M32, b >> _S32
    low = a_lo * b_lo
    cross1 = a_lo * b_hi
    cross2 = a_hi * b_lo
    middle = (low >> _S32) + (cross1 & _M32) + (cross2 & _M32)
    return a_hi * b_hi + (cross1 >> _S32) + (cross2 >> _S32) + (middle >> _S32)


def _round_odd(g_high, g_low, cp):
    """``floor(g·cp / 2^127)``, its last bit set when the fraction is nonzero (the sticky bit)."""
    x1 = _multiply_high(g_low, cp)
    y0 = g_high * cp
    y1 = _multiply_high(g_high, cp)
    z = (y0 >> _U1) + x1
    vbp = y1 + (z >> _S63)
    return vbp | (((z & _M63) + _M63) >> _S63)


def _shortest(bits, g_high, g_low, ks, hs, ka, ha):
    """``(f, e)``, ``f·10^e`` the shortest nearest decimal of the finite positive double whose
    IEEE bits (sign cleared) are ``bits`` (uint64)."""
    biased = np.int64(bits >> _S52)
    fraction = bits & _M52
    if biased == 0:
        c, q, symmetric = fraction, Q_MIN, True
    else:
        c, q = fraction | (_U1 << _S52), biased - 1075
        symmetric = fraction != _U0 or biased == 1
    out = c & _U1
    cb = c << _U2
    cbr = cb + _U2
    if symmetric:
        cbl = cb - _U2
        k, h = ks[q - Q_MIN], hs[q - Q_MIN]
    else:
        cbl = cb - _U1
        k, h = ka[q - Q_MIN], ha[q - Q_MIN]
    index = -k - E_MIN
    g1, g0 = g_high[index], g_low[index]
    shift = np.uint64(h)
    vb = _round_odd(g1, g0, cb << shift)
    vbl = _round_odd(g1, g0, cbl << shift)
    vbr = _round_odd(g1, g0, cbr << shift)
    s = vb >> _U2
    sp10 = (s // _U10) * _U10
    tp10 = sp10 + _U10
    upin = vbl + out <= (sp10 << _U2)
    wpin = (tp10 << _U2) + out <= vbr
    if upin != wpin:
        return (sp10 if upin else tp10), k
    t = s + _U1
    uin = vbl + out <= (s << _U2)
    win = (t << _U2) + out <= vbr
    if uin != win:
        return (s if uin else t), k
    middle = (s + t) << _U1  # 4·(s + 1/2)
    if vb < middle or (vb == middle and (s & _U1) == _U0):
        return s, k
    return t, k


def _put_text(bits, buffer, position, g_high, g_low, ks, hs, ka, ha, digits):
    """Write ``repr`` of the double whose IEEE bits are ``bits`` (uint64) as ASCII into
    ``buffer`` from ``position``; returns the end."""
    negative = (bits >> _S63) != _U0
    magnitude = bits & _M63
    if magnitude >= np.uint64(0x7FF0000000000000):
        if magnitude > np.uint64(0x7FF0000000000000):  # nan (repr drops its sign)
            buffer[position], buffer[position + 1], buffer[position + 2] = 110, 97, 110
            return position + 3
        if negative:
            buffer[position] = 45
            position += 1
        buffer[position], buffer[position + 1], buffer[position + 2] = 105, 110, 102
        return position + 3
    if negative:
        buffer[position] = 45
        position += 1
    if magnitude == _U0:
        buffer[position], buffer[position + 1], buffer[position + 2] = 48, 46, 48
        return position + 3
    f, e = _shortest(magnitude, g_high, g_low, ks, hs, ka, ha)
    while f % _U1E8 == _U0:  # trailing zeros dropped, eight at a time, then one
        f //= _U1E8
        e += 8
    while f % _U10 == _U0:
        f //= _U10
        e += 1
    n = 0
    while f >= _U100:  # digits, last first, two per division
        pair = np.int64(f % _U100)
        f //= _U100
        digits[n] = 48 + pair % 10
        digits[n + 1] = 48 + pair // 10
        n += 2
    last = np.int64(f)
    if last >= 10:
        digits[n] = 48 + last % 10
        digits[n + 1] = 48 + last // 10
        n += 2
    else:
        digits[n] = 48 + last
        n += 1
    point = n + e  # value = 0.d1..dn × 10^point
    if -4 < point <= 16:
        if point <= 0:
            buffer[position], buffer[position + 1] = 48, 46
            position += 2
            for _ in range(-point):
                buffer[position] = 48
                position += 1
            for j in range(n - 1, -1, -1):
                buffer[position] = digits[j]
                position += 1
        elif point >= n:
            for j in range(n - 1, -1, -1):
                buffer[position] = digits[j]
                position += 1
            for _ in range(point - n):
                buffer[position] = 48
                position += 1
            buffer[position], buffer[position + 1] = 46, 48
            position += 2
        else:
            for j in range(n - 1, n - 1 - point, -1):
                buffer[position] = digits[j]
                position += 1
            buffer[position] = 46
            position += 1
            for j in range(n - 1 - point, -1, -1):
                buffer[position] = digits[j]
                position += 1
        return position
    buffer[position] = digits[n - 1]
    position += 1
    if n > 1:
        buffer[position] = 46
        position += 1
        for j in range(n - 2, -1, -1):
            buffer[position] = digits[j]
            position += 1
    exponent = point - 1
    buffer[position] = 101
    buffer[position + 1] = 45 if exponent < 0 else 43
    position += 2
    exponent = abs(exponent)
    if exponent >= 100:
        buffer[position] = 48 + exponent // 100
        position += 1
    buffer[position] = 48 + (exponent // 10) % 10
    buffer[position + 1] = 48 + exponent % 10
    return position + 2


def _csv_block(bits, buffer, g_high, g_low, ks, hs, ka, ha):
    """Rows of ``bits`` (2-D, the uint64 view of float64 values) as CSV lines (``,``
    between values, ``\\n`` after each row) into ``buffer`` (uint8, at least
    ``bits.size · (MAX_CHARS + 1)`` long);
    returns the bytes written."""
    digits = np.empty(20, dtype=np.uint8)
    position = 0
    rows, columns = bits.shape
    for i in range(rows):
        for j in range(columns):
            position = _put_text(bits[i, j], buffer, position, g_high, g_low, ks, hs, ka, ha,
                                 digits)
            buffer[position] = 44 if j < columns - 1 else 10
            position += 1
    return position


KINDS = ("native", "numba", "python")
"""The kernels: C (the library built at install), numba, the interpreter."""
NATIVE = "output/_floattext_native"
"""The C kernel's library (:func:`circuitnsds.native.library`), built from ``_floattext_native.c``."""

_KERNELS: dict[str, object] = {}
_HELPERS = ("_multiply_high", "_round_odd", "_shortest", "_put_text")


def _native_kernel():
    """The C kernel with :func:`_csv_block`'s arguments, or ``None`` (library not built,
    disabled or stale: :func:`circuitnsds.native.library`)."""
    import ctypes

    function = native.function(NATIVE, "circuitnsds_csv_block",
                               [ctypes.c_void_p, ctypes.c_int64, ctypes.c_int64, ctypes.c_void_p,
                                *[ctypes.c_void_p] * 6, ctypes.c_int64, ctypes.c_int64], ctypes.c_int64)
    if function is None:
        return None
    table_types = (np.uint64, np.uint64, np.int64, np.int64, np.int64, np.int64)
    table_sizes = (E_MAX - E_MIN + 1,) * 2 + (Q_MAX - Q_MIN + 1,) * 4

    def native_block(bits, buffer, g_high, g_low, ks, hs, ka, ha):
        """:func:`_csv_block` run by the C library (ctypes releases the GIL for the call). The
        C code trusts its arguments: the types, layouts and sizes are checked here."""
        bits = np.ascontiguousarray(bits, dtype=np.uint64)
        if bits.ndim != 2:
            raise ValueError("bits must be 2-D (rows × columns)")
        if buffer.dtype != np.uint8 or not buffer.flags.c_contiguous or not buffer.flags.writeable \
                or buffer.size < bits.size * (MAX_CHARS + 1):
            raise ValueError(f"buffer must be a writable contiguous uint8 array of at least "
                             f"{bits.size * (MAX_CHARS + 1)} bytes")
        arrays = (g_high, g_low, ks, hs, ka, ha)
        for array, dtype, size in zip(arrays, table_types, table_sizes):
            if array.dtype != dtype or array.shape != (size,) or not array.flags.c_contiguous:
                raise ValueError("the tables must be floattext.tables()")
        return int(function(bits.ctypes.data, bits.shape[0], bits.shape[1], buffer.ctypes.data,
                            *[array.ctypes.data for array in arrays], E_MIN, Q_MIN))

    return native_block


def _bind_numba() -> None:
    """Bind the numba kernel and the Python one (the helpers inlined into the compiled
    kernel: a call per number would cost the arrays' reference counts)."""
    from circuitnsds.jit import AVAILABLE, jit, python_version

    if AVAILABLE:
        from numba import njit

        namespace = globals()
        for helper in _HELPERS:
            namespace[helper] = njit(inline="always")(namespace[helper])
    _KERNELS["numba"] = jit(_csv_block)
    _KERNELS["python"] = python_version(_KERNELS["numba"])


def has_native() -> bool:
    """Whether the C kernel is there (loads its library: a few ms, no compiler)."""
    if "native" not in _KERNELS:
        _KERNELS["native"] = _native_kernel()
    return _KERNELS["native"] is not None


def kernel(kind: str | None = None):
    """:func:`_csv_block` as the ``kind`` of :data:`KINDS` runs it, all with its arguments
    and the same bytes: ``"native"`` the C library built at install (no load cost beyond
    opening it; releases the GIL); ``"numba"`` compiled by numba (no GIL, cached per user,
    ~0.4 s to import numba and ~0.6 s to load the cached code at its first call in a
    process; without numba installed, the Python code); ``"python"`` its Python original.
    ``None``: the C kernel if its library is there, numba otherwise.
    :mod:`circuitnsds.jit` is imported only for numba's and Python's.

    Raises:
        RuntimeError: ``"native"`` asked for and the library is not there.
    """
    if kind is None:
        kind = "native" if has_native() else "numba"
    if kind not in KINDS:
        raise ValueError(f"kernel kind must be one of {KINDS}, not {kind!r}")
    if kind == "native":
        if not has_native():
            raise RuntimeError(f"circuitnsds's C formatter {NATIVE} is not built or not loadable "
                               f"(reinstall circuitnsds with a C compiler; {native.DISABLE_ENV}=0 "
                               "disables it)")
    elif kind not in _KERNELS:
        _bind_numba()
    return _KERNELS[kind]


def csv_bytes(values: np.ndarray, *, kind: str | None = None) -> bytes:
    """CSV lines of the rows of ``values`` (2-D float64), each number as ``repr`` writes it,
    by the kernel ``kind`` (:func:`kernel`)."""
    values = np.ascontiguousarray(values, dtype=np.float64)
    if values.ndim != 2:
        raise ValueError("values must be 2-D (rows × columns)")
    buffer = np.empty(values.size * (MAX_CHARS + 1), dtype=np.uint8)
    end = kernel(kind)(values.view(np.uint64), buffer, *tables())
    return buffer[:end].tobytes()


def text(value: float, *, kind: str | None = None) -> str:
    """``repr(value)`` computed by this module's method (for tests and checks)."""
    return csv_bytes(np.array([[value]]), kind=kind)[:-1].decode("ascii")


def loaded() -> bool:
    """Whether the numba kernel has been loaded in this process."""
    return getattr(_KERNELS.get("numba"), "loaded", False)


def ready_marker():
    """The file whose existence says that the numba kernel of this very source is in the per-user
    cache (written by :func:`main` after :func:`warm`), or ``None``."""
    from pathlib import Path

    from circuitnsds.jit import ready_marker as marker

    return marker((Path(__file__).resolve(),))


def warm() -> None:
    """Compile (or load from the cache) the numba kernel, for the types the writers pass."""
    csv_bytes(np.array([[0.1, -2.5e-300]]), kind="numba")


def main() -> None:
    """Compile (or load) the numba kernel and mark the cache ready for it, unless the C kernel
    is built (the writers then never use numba's): run in a background process
    (:func:`circuitnsds.jit.start_warmup`) when a large file is written without either."""
    if has_native():
        return
    warm()
    marker = ready_marker()
    if marker is not None:
        marker.touch()
