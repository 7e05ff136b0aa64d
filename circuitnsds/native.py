"""The package's C code: compiled when the package is installed, loaded with ctypes.

Hot loops exist in C as well as in Python (:mod:`circuitnsds.engine.dense_loop`'s
table loop, the exact integrator's event loop and first-event search of
:mod:`circuitnsds.engine.exact.loop` and :mod:`circuitnsds.engine.exact.first_event`
(``engine/exact/_exact_native.c``), :mod:`circuitnsds.output.floattext`'s CSV formatter,
the dense LU of :mod:`circuitnsds.solvers.linalg` and Lemke's pivoting of
:mod:`circuitnsds.solvers.lemke`, which share one library). ``pip install`` compiles
each ``<name>.c`` next to its module into a shared library ``<name><EXT_SUFFIX>`` (see
``setup.py``; the build is optional: without a C compiler the install goes on and the
loops run compiled by numba, or in Python). The libraries use no Python API: they take
pointers to numpy arrays and release the GIL while they run (ctypes calls them so).

A library is used only when it was built from the very source beside it: ``setup.py``
bakes a digest of the ``.c`` file and of the shared ``native.h`` into it
(``circuitnsds_source_digest()``: their CRC-32 and length, which catches any edit; it is
no defence against a deliberate forgery, which needs write access to the package anyway),
and :func:`library` compares that with their digest now. An editable install whose C
source changed since the last ``pip install -e .`` thus warns and falls back to numba,
never runs stale machine code.

Setting the environment variable ``CIRCUITNSDS_NATIVE=0`` disables the libraries (the
benchmarks use it to time the numba loops against them).
"""

from __future__ import annotations

import ctypes
import importlib.machinery
import os
import warnings
import zlib
from pathlib import Path

__all__ = ["DISABLE_ENV", "function", "library", "source_digest"]

DISABLE_ENV = "CIRCUITNSDS_NATIVE"
"""Environment variable: ``0`` disables the compiled C libraries."""

PACKAGE = Path(__file__).resolve().parent

_LIBRARIES: dict[str, ctypes.CDLL | None] = {}


HEADER = PACKAGE / "native.h"
"""The header every library includes (export macro, ``circuitnsds_source_digest``)."""


def source_digest(source: Path) -> str:
    """The digest ``setup.py`` bakes into a library: the CRC-32 (8 hex digits) and the length
    of its C source's bytes followed by :data:`HEADER`'s. (Not SHA-256: ``hashlib`` loads
    OpenSSL, 5 ms of every run, and the digest only has to notice an edited source.)"""
    content = Path(source).read_bytes() + HEADER.read_bytes()
    return f"{zlib.crc32(content):08x}-{len(content)}"


def _built(stem: Path) -> Path | None:
    """The shared library built from ``stem.c`` (``stem`` without suffix), if any."""
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        candidate = stem.with_name(stem.name + suffix)
        if candidate.is_file():
            return candidate
    return None


def library(name: str) -> ctypes.CDLL | None:
    """The loaded library ``name`` (a path in the package without suffix, e.g.
    ``"engine/_dense_native"``), or ``None``: not built (no compiler at install), disabled by
    :data:`DISABLE_ENV`, not loadable, or built from another source than the one beside it
    (then a warning says to reinstall). Loaded once per process."""
    if name in _LIBRARIES:
        return _LIBRARIES[name]
    loaded = None
    stem = PACKAGE / name
    path = _built(stem) if os.environ.get(DISABLE_ENV, "1") != "0" else None
    if path is not None:
        try:
            candidate = ctypes.CDLL(str(path))
            candidate.circuitnsds_source_digest.restype = ctypes.c_char_p
            built_from = candidate.circuitnsds_source_digest().decode()
        except (OSError, AttributeError) as error:
            warnings.warn(f"circuitnsds: cannot load {path.name} ({error}); its loop runs without it "
                          "(reinstall circuitnsds to rebuild it)", RuntimeWarning, stacklevel=2)
        else:
            source = stem.with_suffix(".c")
            if source.is_file() and HEADER.is_file() and source_digest(source) != built_from:
                warnings.warn(f"circuitnsds: {path.name} was built from another version of "
                              f"{source.name}; its loop runs without it until the package is "
                              "reinstalled (pip install -e . in a checkout)", RuntimeWarning, stacklevel=2)
            else:
                loaded = candidate
    _LIBRARIES[name] = loaded
    return loaded


def function(name: str, symbol: str, argtypes: list, restype: object):
    """The function ``symbol`` of the library ``name`` (see :func:`library`) with its argument
    and result types declared, or ``None`` when the library is not loaded (callers on a hot
    path keep what it returns)."""
    loaded = library(name)
    if loaded is None:
        return None
    found = getattr(loaded, symbol)
    found.argtypes, found.restype = argtypes, restype
    return found
