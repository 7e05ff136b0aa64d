"""Compile the engine's loops with numba when it is installed, and run the same code in Python.

The mode loops (:mod:`circuitnsds.engine.dense_loop`, :mod:`circuitnsds.engine.sparse_loop`)
are written once as plain Python over numpy arrays. :func:`jit` compiles such a function
(cached on disk, no GIL); :func:`python_version` gives the same function object code run by
the interpreter, with every compiled helper it calls replaced by its Python original (and
any helper the caller names replaced by another, e.g. a numpy step instead of a scalar
one). That is what ``stepping="numpy"`` runs, and what runs without numba.
"""

from __future__ import annotations

import types
from collections.abc import Callable

try:  # numba makes the loops ~50x faster; nothing else depends on it
    from numba import njit
except ImportError:  # pragma: no cover - numba is a dependency; the Python versions are tested
    njit = None

__all__ = ["AVAILABLE", "jit", "python_version"]

AVAILABLE = njit is not None
"""Whether numba is installed (the loops run compiled)."""


def jit(function: Callable) -> Callable:
    """``function`` compiled by numba (``cache=True, nogil=True``), or itself without numba.

    Structured arguments are passed as plain tuples (``tuple(named)``) and unpacked by
    position inside: numba types a named tuple argument by its slow path at every call."""
    return njit(cache=True, nogil=True)(function) if AVAILABLE else function


def python_version(function: Callable, **replacements: Callable) -> Callable:
    """``function``'s code run by the interpreter, calling the Python originals of the
    compiled helpers of its module (their ``py_func``) and the given ``replacements``.

    Call it after the module has bound its compiled helpers (at the end of the module)."""
    original = getattr(function, "py_func", function)
    namespace = dict(original.__globals__)
    for name, value in list(namespace.items()):
        if hasattr(value, "py_func") and callable(value):
            namespace[name] = value.py_func
    namespace.update(replacements)
    return types.FunctionType(original.__code__, namespace, original.__name__ + "_python",
                              original.__defaults__, original.__closure__)
