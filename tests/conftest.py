"""Shared helpers for the engine tests.

Hypothesis runs reproducibly by default (``derandomize``: the same examples on every machine
and every run, so a failure in CI is one anyone can rerun); ``HYPOTHESIS_PROFILE=explore`` draws
new examples each run, to look for new failures (what a change to a solver or parser should be
run with before it lands)."""

import os
import re
from pathlib import Path

import pytest
from hypothesis import settings

import circuitnsds
from circuitnsds import native

settings.register_profile("reproducible", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "reproducible"))

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"


def circuit_from(body: str, title: str = "test circuit"):
    """A Circuit from netlist lines (title and .end added)."""
    return circuitnsds.read_netlist(f"{title}\n{body}\n.end\n")


def pinned(text: str, method: str = "theta") -> str:
    """Netlist ``text`` run by ``method`` whatever the default (``.options method=...`` before
    its ``.end``): for tests of one stepper's behaviour (the θ-method's step counts, its
    order, its loops) through the command line or a netlist file."""
    ends = list(re.finditer(r"^\.end\s*$", text, re.IGNORECASE | re.MULTILINE))
    assert ends, "a netlist with an .end line"
    at = ends[-1].start()
    return f"{text[:at]}.options method={method}\n{text[at:]}"


def pinned_copy(path: Path, folder: Path, method: str = "theta") -> Path:
    """A copy of the netlist file ``path`` in ``folder``, :func:`pinned` to ``method``."""
    copy = folder / path.name
    copy.write_text(pinned(path.read_text(), method))
    return copy


@pytest.fixture
def netlists() -> Path:
    return NETLISTS


NATIVE_BUILD = "python setup.py build_ext --inplace (or pip install -e .) with a C compiler"
"""How to build the C libraries, for the tests' failure messages."""


def assert_native_library_current(name: str):
    """The C library ``name`` (e.g. ``"solvers/_lu_native"``) is built, loads, and was built
    from the source beside it (its baked digest is the source's now); returns it loaded."""
    stem = native.PACKAGE / name
    assert native._built(stem) is not None, f"{name}.c is not built: {NATIVE_BUILD}"
    library = native.library(name)
    assert library is not None, f"{name} is built but not loaded (stale? {NATIVE_BUILD})"
    assert library.circuitnsds_source_digest().decode() == native.source_digest(stem.with_suffix(".c"))
    return library
