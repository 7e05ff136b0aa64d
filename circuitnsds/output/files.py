"""Writing output files safely: all or nothing, and never over an input or another output.

:func:`atomic_path` gives a temporary file in the destination's folder; only when
it is complete is it renamed over the destination (``os.replace``, atomic on one file
system). An interrupted or failed write leaves the previous file as it was, never a
truncated file that looks valid. Paths that are not regular files (``/dev/stdout``, a
named pipe) are written directly: renaming over them would replace the device.

:func:`check_outputs` refuses, before a run, an output that is the netlist, a file it
includes, or another output of the same run.
"""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
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
    descriptor, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.",
                                             suffix=f".tmp{target.suffix}")
    os.close(descriptor)
    try:
        os.chmod(temporary, _mode_for(target))
        yield Path(temporary)
        os.replace(temporary, target)
    except BaseException:
        try:
            os.unlink(temporary)
        except OSError:
            pass
        raise


def same_file(first: Path, second: Path) -> bool:
    """Whether two paths name one file (existing or not)."""
    try:
        if first.exists() and second.exists():
            return os.path.samefile(first, second)
    except OSError:
        pass
    return os.path.realpath(first) == os.path.realpath(second)


def check_outputs(outputs: Mapping[str, Path], inputs: Iterable[str | Path],
                  stdout: Iterable[str] = ()) -> None:
    """Raise :class:`OutputError` if an output is an input, two outputs are one file, or
    an output other than those of ``stdout`` is ``-`` (standard output).

    Args:
        outputs: option -> path (``{"-o": Path("out.csv"), "--plot": ...}``).
        inputs: the netlist and every file it includes.
        stdout: the options whose ``-`` means standard output (a text table: ``("-o",)``).
    """
    allowed = set(stdout)
    for label, path in outputs.items():
        if str(path) == "-" and label not in allowed:
            which = f"only {', '.join(sorted(allowed))} can" if allowed else "no output of this command can"
            raise OutputError(f"{label} cannot go to standard output ('-')", where=label,
                              hint=f"give {label} a path ({which} be '-')")
    files = {label: Path(path) for label, path in outputs.items() if str(path) != "-"}
    sources = [Path(p) for p in inputs if str(p) not in {"-", "<text>", "<stdin>"}]
    for label, path in files.items():
        for source in sources:
            if same_file(path, source):
                raise OutputError(f"{label} {path} would overwrite the netlist input {source}",
                                  where=str(path), hint="choose another output name")
    labels = list(files)
    for i, first in enumerate(labels):
        for second in labels[i + 1:]:
            if same_file(files[first], files[second]):
                raise OutputError(f"{first} and {second} name the same file {files[first]}",
                                  where=str(files[first]), hint="give each output its own file")


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
