"""Writing output files safely: all or nothing, and never over an input or another output.

:func:`atomic_path` gives a temporary file in the destination's folder; only when
it is complete is it renamed over the destination (:func:`replaced_together` does so
for a set of outputs: all are renamed once all are written) (``os.replace``, atomic on one file
system). An interrupted or failed write leaves the previous file as it was, never a
truncated file that looks valid. Paths that are not regular files (``/dev/stdout``, a
named pipe) are written directly: renaming over them would replace the device.

:func:`check_outputs` refuses, before a run, an output whose folder is missing or not
writable, and one that is the netlist, a file it includes, standard input's file, or
another output of the same run.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import ExitStack, contextmanager
from pathlib import Path

from circuitnsds.errors import CircuitnsdsError


class OutputError(CircuitnsdsError):
    """An output file cannot be written, or would overwrite an input or another output."""


def _mode_for(target: Path) -> int:
    """Permission bits of the file to be replaced, or the umask's default for a new file."""
    try:
        return stat.S_IMODE(target.stat().st_mode)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a path to write instead of ``path``; on success it replaces ``path`` at once.

    The temporary file is in the same folder (so the rename does not cross file
    systems), hidden, and keeps the extension (writers that choose the format by
    the extension, as matplotlib does, see the real one). On any exception
    (``KeyboardInterrupt`` included) it is removed and ``path`` is untouched.
    A symbolic link is followed: the file it points to is replaced.
    """
    target = Path(os.path.realpath(path))
    if target.exists() and not target.is_file():  # a device or a pipe: no rename over it
        yield Path(path)
        return
    temporary = None
    try:  # made inside the try: a signal right after mkstemp still removes it
        descriptor, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.",
                                                 suffix=f".tmp{target.suffix}")
        os.close(descriptor)
        os.chmod(temporary, _mode_for(target))
        yield Path(temporary)
        os.replace(temporary, target)
    except BaseException:
        if temporary is not None:
            try:
                os.unlink(temporary)
            except OSError:
                pass
        raise


@contextmanager
def replaced_together() -> Iterator[Callable[[str | Path], Path]]:
    """Write several outputs as one set: all replaced, or none.

    Yields ``temporary(path)``, which gives the file to write instead of ``path`` (as
    :func:`atomic_path` does). When the block ends normally every temporary file is
    renamed over its destination, one after the other at the end (renames in one folder
    do not run out of space); when it raises (a full disk, Ctrl-C, SIGTERM) every
    temporary file is removed and every destination keeps its previous content.
    """
    with ExitStack() as stack:
        yield lambda path: stack.enter_context(atomic_path(path))


def same_file(first: Path, second: Path) -> bool:
    """Whether two paths name one file (existing or not)."""
    try:
        if first.exists() and second.exists():
            return os.path.samefile(first, second)
    except OSError:
        pass
    return os.path.realpath(first) == os.path.realpath(second)


def check_outputs(outputs: Mapping[str, Path], inputs: Iterable[str | Path],
                  stdout: Iterable[str] = (), folders: Iterable[str] = ()) -> None:
    """Refuse, before a run, every output that cannot be written or would destroy something.

    Raises :class:`OutputError` when an output's folder is missing or not writable, an
    output is a folder (or, for ``folders``, a file), an output is an input (the netlist, an
    included file, or standard input's file when an input is ``-``), two outputs are one
    file, a folder output contains an input or another output, or an output other than
    those of ``stdout`` is ``-`` (standard output).

    Args:
        outputs: option -> path (``{"-o": Path("out.csv"), "--plot": ...}``).
        inputs: the netlist and every file it includes; ``-`` (or ``<stdin>``) for a netlist
            read from standard input, whose file (``run - < net.cir``) is then an input too.
        stdout: the options whose ``-`` means standard output (a text table: ``("-o",)``).
        folders: the options that name a folder the command fills (sweep's ``--waveforms``),
            made if missing.
    """
    allowed, folder_labels = set(stdout), set(folders)
    for label, path in outputs.items():
        if str(path) == "-" and label not in allowed:
            which = f"only {', '.join(sorted(allowed))} can" if allowed else "no output of this command can"
            raise OutputError(f"{label} cannot go to standard output ('-')", where=label,
                              hint=f"give {label} a path ({which} be '-')")
    files = {label: Path(path) for label, path in outputs.items() if str(path) != "-"}
    for label, path in files.items():
        _check_writable(label, path, folder=label in folder_labels)
    sources = [Path(p) for p in inputs if str(p) not in {"-", "<text>", "<stdin>"}]
    stdin = _stdin_file() if any(str(p) in {"-", "<stdin>"} for p in inputs) else None
    for label, path in files.items():
        for source in sources:
            if same_file(path, source):
                raise OutputError(f"{label} {path} would overwrite the netlist input {source}",
                                  where=str(path), hint="choose another output name")
        if stdin is not None and _identity(path) == stdin:
            raise OutputError(f"{label} {path} is the file standard input reads the netlist from",
                              where=str(path), hint="choose another output name")
    labels = list(files)
    for i, first in enumerate(labels):
        for second in labels[i + 1:]:
            if same_file(files[first], files[second]):
                raise OutputError(f"{first} and {second} name the same file {files[first]}",
                                  where=str(files[first]), hint="give each output its own file")
    for label in folder_labels & files.keys():
        folder = os.path.realpath(files[label])
        others = [("the netlist input", source) for source in sources] + \
            [(f"the {other} output", path) for other, path in files.items() if other != label]
        for what, path in others:
            if os.path.dirname(os.path.realpath(path)) == folder:
                raise OutputError(f"{label} {files[label]} holds {what} {path}, which its files "
                                  "could replace", where=str(files[label]),
                                  hint=f"give {label} a folder of its own, e.g. {label} waveforms")


def _check_writable(label: str, path: Path, folder: bool = False) -> None:
    """An output's folder exists and can be written; the output itself is not a folder
    (``folder``: is not a file; a missing one is made later, under an existing writable folder)."""
    if folder:
        if path.exists() and not path.is_dir():
            raise OutputError(f"{label} {path} is a file, not a folder", where=str(path),
                              hint=f"give {label} a folder (made if missing)")
        existing = path
        while not existing.exists() and existing != existing.parent:
            existing = existing.parent
        if existing.is_dir() and not os.access(existing, os.W_OK | os.X_OK):
            raise OutputError(f"{label}: the folder {existing} is not writable", where=str(path),
                              hint="choose a folder you can write to")
        return
    if path.is_dir():
        raise OutputError(f"cannot write {path}: {os.strerror(errno.EISDIR)}", where=str(path),
                          hint=f"give {label} a file name, e.g. {path / ('out' + (path.suffix or '.csv'))}")
    parent = path.parent
    if not parent.is_dir():
        what = "is a file, not a folder" if parent.exists() else "does not exist"
        raise OutputError(f"{label}: cannot write {path}: the folder {parent} {what}",
                          hint=f"create it first (mkdir -p {parent}) or write elsewhere; "
                          "nothing was run")
    if not os.access(parent, os.W_OK | os.X_OK) and not (path.exists() and not path.is_file()):
        raise OutputError(f"{label}: cannot write {path}: the folder {parent} is not writable",
                          hint="choose a folder you can write to; nothing was run")


def _identity(path: Path) -> tuple[int, int] | None:
    """(device, inode) of an existing file, else ``None``."""
    try:
        info = os.stat(path)
    except OSError:
        return None
    return info.st_dev, info.st_ino


def _stdin_file() -> tuple[int, int] | None:
    """(device, inode) of standard input when it is a regular file (``< net.cir``), else ``None``."""
    try:
        info = os.fstat(0)
    except OSError:
        return None
    return (info.st_dev, info.st_ino) if stat.S_ISREG(info.st_mode) else None


@contextmanager
def writing(path: str | Path, error: type[CircuitnsdsError] = OutputError) -> Iterator[None]:
    """Turn a failure to write ``path`` (an :class:`OSError` inside the block) into a clean
    ``error`` naming the file (``OutputError`` unless the caller has its own class). A broken
    pipe (standard output piped into ``head``) is not turned: the command ends quietly."""
    try:
        yield
    except BrokenPipeError:
        raise
    except OSError as exc:
        raise error(f"cannot write {path}: {exc.strerror or exc}", where=str(path),
                    hint="check that the folder exists and is writable") from None
