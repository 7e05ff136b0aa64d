"""Compile loops with numba, on first use and cached per user; run the same code in Python.

A foundation module: the engine's stepping loops and the CSV formatter of ``output/`` both
use it, and neither layer may import the other.

The mode loops (:mod:`circuitnsds.engine.dense_loop`, :mod:`circuitnsds.engine.sparse_loop`)
are written once as plain Python over numpy arrays. :func:`jit` wraps such a function in
a :class:`Compiled`: numba is imported, and the function compiled (no GIL) or loaded
from the cache, only when it is first called; :func:`python_version` gives the same
function's code run by the interpreter, with every compiled helper it calls replaced
by its Python original (and any helper the caller names replaced by another, e.g. a
numpy step instead of a scalar one). That is what ``stepping="numpy"`` runs, and what
runs without numba.

**Where the machine code is cached.** numba's own cache (``@njit(cache=True)``) goes to
the ``__pycache__`` folder next to the source when that folder is writable, that is
inside the installed package. pip does not know these files: after ``pip uninstall``
(or the reinstall of ``pip install -e``) the folder stays behind in ``site-packages``
and becomes a namespace package ``circuitnsds`` that shadows the real one. So the loops
get a cache of their own in a per-user folder (:func:`cache_root`), never in the
package, and only in a folder no other user can write to (mode 0700, owned by the
user); where no such folder is available they are compiled again in each process
(slower to start, still correct).

numba costs ~0.2 s to import and ~0.4 s to load a cached loop (its LLVM context),
~10 s to compile one; nothing here imports it before a loop is called compiled.

The dense table loop, the one every small circuit runs, also exists in C, built at install
(:mod:`circuitnsds.native`); where it was built, numba compiles only the sparse loop of
large circuits (and the CSV formatter, :mod:`circuitnsds.output.floattext`, until it has a
C twin), and the dense loop's numba version serves only installs without a C compiler.
"""

from __future__ import annotations

import importlib.util
import os
import stat
import sys
import tempfile
import types
from collections.abc import Callable
from pathlib import Path

__all__ = ["AVAILABLE", "Compiled", "cache_root", "jit", "python_version", "ready_marker",
           "start_warmup", "warmup_done"]

AVAILABLE = importlib.util.find_spec("numba") is not None
"""Whether numba is installed (the loops can run compiled); numba is not imported."""
CACHE_ENV = "CIRCUITNSDS_CACHE_DIR"
"""Environment variable naming the folder of circuitnsds's compiled code (overrides the default)."""


def numba_available() -> bool:
    """Whether numba can be imported (without importing it)."""
    return AVAILABLE


def _user_cache_home() -> Path:
    """The platform's per-user cache folder (XDG on Linux and BSD)."""
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


def _writable(folder: Path) -> bool:
    """Create ``folder`` and its missing parents, each with mode 0700 whatever the umask;
    whether it can be written."""
    missing = [folder, *folder.parents]
    missing = missing[:next((k for k, path in enumerate(missing) if path.is_dir()), len(missing))]
    try:
        for path in reversed(missing):
            try:
                path.mkdir(mode=0o700)
            except FileExistsError:  # made meanwhile by another process: checked by _unsafe
                continue
            os.chmod(path, 0o700)
    except OSError:
        return False
    return os.access(folder, os.W_OK | os.X_OK)


def _unsafe(folder: Path) -> str:
    """Why another user could place code in ``folder`` (empty when none could).

    Loading numba's cache unpickles its files: whoever can write them runs code in this
    process. So the folder must belong to this user and be writable by no one else (it is
    created with mode 0700), and each folder above it must
    belong to this user or to root and be writable by no one else, unless it has the
    sticky bit (``/tmp``: others cannot rename or remove what is this user's there).
    """
    if not hasattr(os, "getuid"):  # Windows: per-user folders, ACLs not checked here
        return ""
    uid = os.getuid()
    try:
        info = os.stat(folder)
    except OSError as exc:
        return f"cannot be checked ({exc.strerror})"
    if info.st_uid != uid:
        return f"belongs to user id {info.st_uid}, not to you ({uid})"
    if info.st_mode & 0o022:
        return f"has mode {stat.S_IMODE(info.st_mode):04o}: others may write to it (make it 0700)"
    for parent in folder.parents:
        try:
            above = os.stat(parent)
        except OSError as exc:
            return f"cannot be checked ({parent}: {exc.strerror})"
        if above.st_uid not in (uid, 0):
            return f"is inside {parent}, which belongs to user id {above.st_uid}"
        if above.st_mode & 0o022 and not above.st_mode & stat.S_ISVTX:
            return f"is inside {parent}, which others may write to (mode {stat.S_IMODE(above.st_mode):04o})"
    return ""


_refused: set[Path] = set()


def _refuse(folder: Path, why: str) -> None:
    """One note (a :class:`~circuitnsds.errors.RunNote` warning) per folder and process: the
    compiled code is not cached there."""
    import warnings

    from circuitnsds.errors import RunNote

    if folder in _refused:
        return
    _refused.add(folder)
    warnings.warn(RunNote(f"compiled code is not cached: {folder} {why}; remove it, or set "
                          f"{CACHE_ENV} to a folder of yours"), stacklevel=3)


def cache_candidates() -> list[Path]:
    """Folders for compiled code, in order of preference: ``$CIRCUITNSDS_CACHE_DIR``, then
    numba's ``$NUMBA_CACHE_DIR`` (the user's choice for all numba code), then
    ``<user cache>/circuitnsds/numba`` (``$XDG_CACHE_HOME`` or ``~/.cache`` on Linux), then
    ``<temp>/circuitnsds-<user>/numba``."""
    candidates = [Path(os.environ[name]) for name in (CACHE_ENV, "NUMBA_CACHE_DIR")
                  if os.environ.get(name)]
    try:
        candidates.append(_user_cache_home() / "circuitnsds" / "numba")
    except RuntimeError:  # no home directory
        pass
    user = os.environ.get("USER") or os.environ.get("USERNAME") or str(getattr(os, "getuid", int)())
    candidates.append(Path(tempfile.gettempdir()) / f"circuitnsds-{user}" / "numba")
    return candidates


def cache_root() -> Path | None:
    """The first writable folder of :func:`cache_candidates` (created with mode 0700), or
    ``None``: also when that folder is one another user could write to (see
    :func:`_unsafe`; a one-line note, a :class:`~circuitnsds.errors.RunNote`, says so), as another user's
    pickles in it would run as this user."""
    package = Path(__file__).resolve().parent
    for folder in cache_candidates():
        resolved = folder.expanduser().resolve()
        if resolved == package or package in resolved.parents:
            continue  # never inside the package, whatever the environment says
        if _writable(resolved):
            why = _unsafe(resolved)
            if why:
                _refuse(resolved, why)
                return None
            return resolved
    return None


def ready_marker(sources: tuple[Path, ...] = ()) -> Path | None:
    """A file under :func:`cache_root` whose existence says that the loops of this very
    source (the engine's loop modules), numba and Python were compiled and cached
    (written by :mod:`circuitnsds.engine.warmup`); ``None`` without a cache folder.
    ``sources``: the marker of other compiled modules instead (the CSV formatter's), keyed
    by their source and this module's."""
    import hashlib
    from importlib.metadata import PackageNotFoundError, version

    root = cache_root()
    if root is None:
        return None
    digest = hashlib.sha256(sys.version.encode())
    try:
        digest.update(version("numba").encode())
    except PackageNotFoundError:
        return None
    folder = Path(__file__).resolve().parent / "engine"  # where the stepping loops are
    this = Path(__file__).resolve()
    files = [*sources, this] if sources else [folder / "dense_loop.py", folder / "sparse_loop.py", this]
    digest.update((str(folder) if not sources else "|".join(map(str, sources))).encode())  # numba's
    # cache is per source path as well
    for path in files:
        digest.update(Path(path).read_bytes())
    return root / f"ready-{digest.hexdigest()[:20]}"


_warmups: dict[str, object] = {}
"""Module -> its background warm-up process (a ``subprocess.Popen``; ``None`` when none could
be started), each started at most once per process."""


def start_warmup(module: str) -> None:
    """Start (once per process) ``main()`` of ``module`` (which compiles its loops into the
    cache and marks them ready, e.g. :mod:`circuitnsds.engine.warmup`) in a background Python
    process, on this very package (not whatever ``circuitnsds`` the child would find first
    on its path)."""
    if module in _warmups:
        return
    import subprocess  # (here: a run that never warms numba up does not import it)

    package_parent = str(Path(__file__).resolve().parents[1])
    code = (f"import sys; sys.path.insert(0, {package_parent!r}); "
            f"from {module} import main; main()")
    try:
        _warmups[module] = subprocess.Popen(
            # -P: not the current folder first on the path (a user's numpy.py or pickle.py
            # there would be imported and run in place of the module)
            [sys.executable, "-P", "-c", code], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, close_fds=True)
    except OSError:  # no process can be started here: stay in Python
        _warmups[module] = None


def warmup_done(module: str) -> bool:
    """Whether the background warm-up of ``module`` has finished successfully."""
    process = _warmups.get(module)
    return process is not None and process.poll() == 0


def _cache_for(function: Callable, root: Path):
    """A numba function cache for ``function`` that keeps its files under ``root`` only."""
    from numba.core import caching

    class Locator(caching.UserProvidedCacheLocator):
        def __init__(self, py_func, py_file):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = str(root / self.get_suitable_cache_subpath(py_file))

        @classmethod
        def from_function(cls, py_func, py_file):
            # the source-file locator's checks (file exists, folder writable), not the
            # parent's test of numba's NUMBA_CACHE_DIR
            return caching._SourceFileBackedLocatorMixin.from_function.__func__(cls, py_func, py_file)

    class Impl(caching.CompileResultCacheImpl):
        _locator_classes = [Locator]

    class Cache(caching.FunctionCache):
        _impl_class = Impl

    return Cache(function)


def _with_globals(function: Callable, namespace: dict) -> Callable:
    """``function``'s code with the globals ``namespace`` (same name, qualname, module)."""
    copy = types.FunctionType(function.__code__, namespace, function.__name__, function.__defaults__,
                              function.__closure__)
    copy.__qualname__, copy.__module__ = function.__qualname__, function.__module__
    return copy


class Compiled:
    """A function compiled by numba (``nogil``) when first called, its machine code cached
    under :func:`cache_root` (not cached when no folder is writable, or when this numba has
    no such cache machinery). ``py_func`` is the Python original."""

    def __init__(self, function: Callable):
        self.py_func = function
        self._dispatcher = None
        self.__name__ = function.__name__
        self.__doc__ = function.__doc__

    @property
    def loaded(self) -> bool:
        """Whether numba has been imported for it in this process."""
        return self._dispatcher is not None

    def dispatcher(self):
        """The numba dispatcher (imports numba; compiles or loads at its first call).

        Raises:
            ImportError: numba is not installed.
        """
        if self._dispatcher is None:
            from numba import njit

            # the compiled helpers it calls by global name, as numba dispatchers
            called = set(self.py_func.__code__.co_names)
            namespace = {name: value.dispatcher() if isinstance(value, Compiled) and name in called
                         and value is not self else value
                         for name, value in self.py_func.__globals__.items()}
            function = _with_globals(self.py_func, namespace)
            dispatcher = njit(nogil=True)(function)
            root = cache_root()
            if root is not None:
                try:
                    dispatcher._cache = _cache_for(function, root)
                except Exception:  # noqa: BLE001 - another numba's internals: compile without a cache
                    pass
            self._dispatcher = dispatcher
        return self._dispatcher

    def __call__(self, *args):
        return self.dispatcher()(*args)


def jit(function: Callable) -> Callable:
    """``function`` as a :class:`Compiled` (compiled on first call), or itself without numba."""
    return Compiled(function) if AVAILABLE else function


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
