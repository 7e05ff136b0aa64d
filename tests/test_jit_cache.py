"""Compiled code is cached per user, never inside the installed package (issue 19).

numba's default cache writes ``__pycache__/*.nbi`` next to the source; after pip removes
the package that folder stays and shadows the next install as a namespace package.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

import circuitnsds
from circuitnsds import jit
from circuitnsds.engine import dense_loop, sparse_loop
from circuitnsds.errors import RunNote
from tests.conftest import NETLISTS

PACKAGE = Path(circuitnsds.__file__).resolve().parent


def _package_files_since(started: float) -> list[Path]:
    """Files under the package written since ``started`` or that numba caches write
    (``*.nbi``, ``*.nbc``), whenever they were written."""
    found = []
    for path in PACKAGE.rglob("*"):
        if path.is_file() and (path.suffix in {".nbi", ".nbc"} or path.stat().st_mtime >= started):
            found.append(path)
    return found


def test_a_compiled_run_writes_nothing_in_the_package():
    started = time.time() - 1.0  # file systems with coarse timestamps
    # (θ's compiled mode loops and their cache: pinned to θ)
    waves = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir").transient(stop=50e-6,
                                                                                stepping="compiled",
                                                                                method="theta")
    assert waves.stats["mapped_steps"] > 0
    # the loops' caches are where jit says, outside the package
    root = jit.cache_root()
    assert root is not None and PACKAGE not in root.parents
    for loop in (dense_loop._compiled, sparse_loop._compiled):
        cache_path = Path(loop.dispatcher()._cache.cache_path)
        assert root in cache_path.parents
    stray = [p for p in _package_files_since(started) if p.suffix != ".pyc"]
    assert stray == [], f"written inside the package: {stray}"


def test_cache_root_prefers_the_environment_and_never_the_package(tmp_path, monkeypatch):
    monkeypatch.setenv(jit.CACHE_ENV, str(tmp_path / "mine"))
    assert jit.cache_root() == (tmp_path / "mine").resolve()
    monkeypatch.setenv(jit.CACHE_ENV, str(PACKAGE / "__pycache__"))  # refused: inside the package
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    root = jit.cache_root()
    assert root is not None and PACKAGE not in root.parents and root != PACKAGE
    if os.name == "posix":
        assert root == (tmp_path / "xdg" / "circuitnsds" / "numba").resolve()


def test_cache_root_falls_back_when_unwritable(tmp_path, monkeypatch):
    blocker = tmp_path / "a file"  # no folder can be made under a file, even by root
    blocker.write_text("")
    monkeypatch.setenv(jit.CACHE_ENV, str(blocker / "numba"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    if os.name == "posix":
        assert jit.cache_root() == (tmp_path / "xdg" / "circuitnsds" / "numba").resolve()


def test_no_writable_folder_means_no_cache(monkeypatch):
    monkeypatch.setattr(jit, "cache_candidates", lambda: [])
    assert jit.cache_root() is None

    def add(a, b):
        return a + b

    compiled = jit.jit(add)
    assert type(compiled.dispatcher()._cache).__name__ == "NullCache"  # numba's: nothing written


def test_a_short_run_does_not_load_numba():
    code = ("import sys, circuitnsds; from tests.conftest import NETLISTS\n"
            # (θ's C loop loads no numba; the exact integrator's loop is numba's: pinned to θ)
            "w = circuitnsds.read_netlist(NETLISTS / 'bridge_rectifier.cir').transient(method='theta')\n"
            "assert w.stats['mapped_steps'] > 1000\n"
            "print('numba' in sys.modules)")
    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(PACKAGE.parent), str(root)]))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          cwd=root, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"


@pytest.mark.parametrize("dense", [True, False])
def test_the_warmup_compiles_the_signature_a_run_uses(monkeypatch, dense):
    """The background warm-up must compile the very version a run calls, or the run
    would compile again (~10 s) after waiting for it."""
    from circuitnsds.engine import integrate, warmup

    (warmup.warm_dense if dense else warmup.warm_sparse)()
    loop = (dense_loop._compiled if dense else sparse_loop._compiled).dispatcher()
    assert len(loop.signatures) == 1
    if not dense:
        monkeypatch.setattr(integrate, "DENSE_MAP_LIMIT", 0)
    for netlist in ("buck_converter.cir", "diode_clamp.cir"):
        waves = circuitnsds.read_netlist(NETLISTS / netlist).transient(stop=20e-6, stepping="compiled",
                                                                      method="theta")  # θ's loops
        assert waves.stats["mapped_steps"] > 0
    assert len(loop.signatures) == 1, loop.signatures


def test_the_warmup_process_does_not_run_the_users_files(tmp_path, monkeypatch):
    """The background compilation is a ``python -c`` child: without ``-P`` it would put the
    folder the command runs in first on its path, and a user's ``numpy.py`` there would be
    imported (run) in place of numpy."""
    from circuitnsds.engine import loop_choice

    marker = tmp_path / "ran"
    (tmp_path / "numpy.py").write_text(f"open({str(marker)!r}, 'w').close()\nraise SystemExit(0)\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CIRCUITNSDS_CACHE_DIR", str(tmp_path / "cache"))  # a stopped child harms no cache
    monkeypatch.setattr(jit, "_warmups", {})
    loop_choice.start_warmup()
    child = jit._warmups[loop_choice.WARMUP]
    assert child is not None
    try:
        deadline = time.monotonic() + 3.0  # the child imports numpy within a fraction of this
        while child.poll() is None and time.monotonic() < deadline and not marker.exists():
            time.sleep(0.05)
        assert not marker.exists()
    finally:
        child.kill()
        child.wait()


# --- only a folder no other user can write to (issue 37) ----------------------------------------


def _use_only(monkeypatch, folder: Path) -> None:
    monkeypatch.setattr(jit, "cache_candidates", lambda: [folder])
    monkeypatch.setattr(jit, "_refused", set())


@pytest.mark.skipif(os.name != "posix", reason="owners and modes are POSIX")
def test_a_new_cache_folder_is_private_whatever_the_umask(tmp_path, monkeypatch):
    _use_only(monkeypatch, tmp_path / "new" / "numba")
    previous = os.umask(0)
    try:
        root = jit.cache_root()
    finally:
        os.umask(previous)
    assert root == (tmp_path / "new" / "numba").resolve()
    assert root.stat().st_mode & 0o777 == 0o700


@pytest.mark.skipif(os.name != "posix", reason="owners and modes are POSIX")
@pytest.mark.parametrize("mode", [0o777, 0o770, 0o702])
def test_a_folder_others_can_write_is_refused_with_a_note(mode, tmp_path, monkeypatch):
    planted = tmp_path / "numba"
    planted.mkdir()
    os.chmod(planted, mode)
    _use_only(monkeypatch, planted)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert jit.cache_root() is None
        assert jit.cache_root() is None
    assert [type(w.message) for w in caught] == [RunNote]  # one note, not one per call
    assert "compiled code is not cached" in str(caught[0].message) and str(planted) in str(caught[0].message)


@pytest.mark.skipif(os.name != "posix", reason="owners and modes are POSIX")
def test_a_folder_of_another_user_is_refused(tmp_path, monkeypatch):
    # the planted folder of the issue: /tmp/circuitnsds-<user>/numba made first by someone else
    monkeypatch.setattr(jit.tempfile, "gettempdir", lambda: str(tmp_path))
    monkeypatch.delenv(jit.CACHE_ENV, raising=False)
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    blocker = tmp_path / "a file"
    blocker.write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker))  # the user's cache cannot be made
    monkeypatch.setattr(jit, "_refused", set())
    planted = jit.cache_candidates()[-1]
    planted.mkdir(parents=True, mode=0o700)
    other = os.getuid() + 4242
    real_stat = os.stat

    def stat_as_planted(path, *args, **kwargs):
        info = real_stat(path, *args, **kwargs)
        if Path(path) in (planted, planted.parent):
            values = list(info)
            values[4] = other  # st_uid
            return os.stat_result(values)
        return info

    monkeypatch.setattr(jit.os, "stat", stat_as_planted)
    with pytest.warns(RunNote, match=f"belongs to user id {other}"):
        assert jit.cache_root() is None


@pytest.mark.skipif(os.name != "posix", reason="owners and modes are POSIX")
def test_a_private_folder_inside_a_folder_others_can_write_is_refused(tmp_path, monkeypatch):
    shared = tmp_path / "shared"
    (shared / "numba").mkdir(parents=True, mode=0o700)
    os.chmod(shared, 0o777)  # not sticky: anyone may rename numba/ and put their own there
    _use_only(monkeypatch, shared / "numba")
    with pytest.warns(RunNote, match="which others may write to"):
        assert jit.cache_root() is None
    os.chmod(shared, 0o1777)  # sticky, as /tmp: only the owner may rename it
    assert jit.cache_root() == (shared / "numba").resolve()
