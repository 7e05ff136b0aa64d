"""``.include`` and ``.lib``: splicing other files into a netlist's statements.

* ``.include FILE`` (or ``.inc FILE``) inserts the statements of FILE (which has no
  title line) where the line stands.
* ``.lib FILE SECTION`` inserts the statements between ``.lib SECTION`` and ``.endl``
  in FILE (ngspice library sections); the rest of FILE is not read.
* ``.lib NAME`` ... ``.endl`` in a file is a section definition: skipped where it is
  written, read only when some ``.lib FILE NAME`` asks for it.
* ``.lib FILE`` with one argument and no ``.endl`` after it includes the whole file
  (the PSpice form that vendors' netlists use).

Paths are relative to the directory of the file that names them (the current
directory for netlist text); ``~/`` at the start of a path is the user's home folder
(``$HOME``), as in ngspice; quotes around a path (``"my models.lib"``) are allowed
and the path keeps its case. Included files may include others; a file (or library
section) that includes itself, directly or not, is an error naming the chain.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

from circuitnsds.errors import NetlistError, NetlistWarning
from circuitnsds.netlist.parser import ControlBlock, Netlist, Statement, parse_netlist, read_source_text

INCLUDE_COMMANDS = frozenset({".include", ".inc"})


def path_arguments(statement: Statement) -> list[str]:
    """The arguments of an ``.include``/``.lib`` line as written (case kept, quotes removed)."""
    parts = statement.text.split(None, 1)
    rest = parts[1].strip() if len(parts) > 1 else ""
    arguments: list[str] = []
    while rest:
        if rest[0] in "\"'":
            end = rest.find(rest[0], 1)
            if end == -1:
                raise NetlistError(f"{statement.keyword}: the quote {rest[0]} is not closed",
                                   where=statement.location, hint=f"in: {statement.text}")
            arguments.append(rest[1:end])
            rest = rest[end + 1:].strip()
        else:
            word, *tail = rest.split(None, 1)
            arguments.append(word)
            rest = tail[0].strip() if tail else ""
    return arguments


def _spaced_path(statement: Statement, arguments: list[str], directory: Path) -> list[str]:
    """``arguments``, or, when they are more words than the command takes and the words (all,
    or all but the last: a ``.lib`` section) are the name of an existing file written
    without quotes (``.lib C:/My Models/diodes.lib``), that name (and the section), with a
    warning: ngspice needs the quotes."""
    takes = 2 if statement.keyword == ".lib" else 1
    if len(arguments) <= takes or any(word[:1] in "\"'" for word in statement.text.split()[1:]):
        return arguments
    readings = [(arguments, [])] + ([(arguments[:-1], arguments[-1:])] if takes == 2 else [])
    for words, rest in readings:
        name = " ".join(words)
        if (directory / name).is_file():
            warnings.warn(f"{statement.location}: {statement.keyword}: the unquoted path {name!r} "
                          f'(it has spaces) is read as one file name; write it in quotes ("{name}"), '
                          "which ngspice needs", NetlistWarning, stacklevel=2)
            return [name, *rest]
    return arguments


@dataclass(frozen=True)
class _Open:
    """A file (or one library section of it) being read: for cycle detection."""

    key: tuple[Path, str | None]
    shown: str


def _next_section_end(statements: list[Statement], start: int) -> int | None:
    """Index of the ``.endl`` closing a ``.lib NAME`` at ``start``, or None if it is an include."""
    for index in range(start + 1, len(statements)):
        keyword = statements[index].keyword
        if keyword == ".endl":
            return index
        if keyword == ".lib" and len(path_arguments(statements[index])) == 1:
            return None
    return None


class _Expander:
    def __init__(self) -> None:
        self.control_blocks: list[ControlBlock] = []
        self.files: dict[str, None] = {}  # every file read, in order

    def expand(self, statements: list[Statement], directory: Path, stack: list[_Open]) -> list[Statement]:
        """``statements`` with every include replaced by what it names (recursively)."""
        result: list[Statement] = []
        index = 0
        while index < len(statements):
            statement = statements[index]
            keyword = statement.keyword
            if keyword in INCLUDE_COMMANDS or keyword == ".lib":
                arguments = _spaced_path(statement, path_arguments(statement), directory)
            if keyword in INCLUDE_COMMANDS:
                if len(arguments) != 1:
                    raise NetlistError(f"{keyword} takes one file name, got {len(arguments)} words",
                                       where=statement.location,
                                       hint=f'write {keyword} FILE (quote a path with spaces: "my file.lib")')
                result.extend(self.include(statement, arguments[0], None, directory, stack))
            elif keyword == ".lib":
                if len(arguments) == 2:
                    result.extend(self.include(statement, arguments[0], arguments[1].lower(),
                                               directory, stack))
                elif len(arguments) == 1 and (end := _next_section_end(statements, index)) is not None:
                    index = end  # a section definition: read only when asked for
                elif len(arguments) == 1:
                    result.extend(self.include(statement, arguments[0], None, directory, stack))
                else:
                    raise NetlistError(f".lib takes a file and a section name, got {len(arguments)} words",
                                       where=statement.location,
                                       hint="write .lib FILE SECTION to read a section, "
                                       ".lib NAME ... .endl to define one; quote a path with "
                                       'spaces: .lib "my models.lib"')
            elif keyword == ".endl":
                raise NetlistError(".endl without a .lib section to close", where=statement.location,
                                   hint="a library section is .lib NAME ... .endl")
            else:
                result.append(statement)
            index += 1
        return result

    def include(self, statement: Statement, name: str, section: str | None, directory: Path,
                stack: list[_Open]) -> list[Statement]:
        """The statements of file ``name`` (or of its library ``section``), expanded."""
        keyword = statement.keyword
        path = directory / _home_expanded(name)
        shown = os.path.normpath(str(path))
        if not path.exists() or path.is_dir():  # a device or pipe is read (bounded) and judged
            problem = "is a directory" if path.is_dir() else "not found"
            raise NetlistError(f"{keyword}: file {name!r} {problem} (looked for {shown})",
                               where=statement.location,
                               hint=f"paths are relative to the directory of the file that names them "
                               f"({os.path.normpath(str(directory))}); check the name and its case, "
                               "or give an absolute path")
        key = (path.resolve(), section)
        self.files[str(key[0])] = None
        opened = _Open(key, shown + (f" section {section}" if section else ""))
        if any(entry.key == key for entry in stack):
            chain = " -> ".join(entry.shown for entry in stack) + f" -> {opened.shown}"
            raise NetlistError(f"{keyword}: {opened.shown} includes itself ({chain})",
                               where=statement.location, hint="remove the include that closes the cycle")
        what = "library" if keyword == ".lib" else "included file"
        text = read_source_text(path, where=statement.location, what=what, regular_only=True)
        included = parse_netlist(text, file=shown, has_title=False)
        self.control_blocks.extend(included.control_blocks)
        statements = included.statements
        if section is not None:
            statements = _section(statements, section, statement, shown)
        return self.expand(statements, path.parent, [*stack, opened])


def _home_expanded(name: str) -> Path:
    """``~/m.lib`` (and ``~user/m.lib``) in the user's home folder, as ngspice reads it
    (``$HOME``); any other name as written (``./~/m.lib`` is in a folder named ``~``)."""
    return Path(os.path.expanduser(name))  # not Path.expanduser: Path("./~") is Path("~")


def _section(statements: list[Statement], section: str, statement: Statement, shown: str) -> list[Statement]:
    """The statements of library section ``section`` (between ``.lib section`` and ``.endl``)."""
    names: list[str] = []
    for index, candidate in enumerate(statements):
        if candidate.keyword != ".lib":
            continue
        arguments = path_arguments(candidate)
        if len(arguments) != 1:
            continue
        names.append(arguments[0].lower())
        if arguments[0].lower() != section:
            continue
        for end in range(index + 1, len(statements)):
            if statements[end].keyword == ".endl":
                return statements[index + 1:end]
        raise NetlistError(f".lib section {section!r} has no .endl", where=candidate.location,
                           hint="end a library section with .endl")
    listed = f"its sections: {', '.join(names)}" if names else "it has no .lib NAME ... .endl sections"
    raise NetlistError(f".lib: section {section!r} not found in {shown}", where=statement.location,
                       hint=f"{listed}; section names are not case-sensitive"
                       + ("; to include the whole file write .include FILE" if not names else ""))


def expand_includes(netlist: Netlist, directory: str | Path | None = None) -> Netlist:
    """Replace ``.include``/``.lib`` lines by the statements they name.

    Args:
        netlist: the parsed top-level netlist.
        directory: the directory its relative paths start from; by default the directory
            of ``netlist.file``, or the current directory for netlist text (``<text>``).

    Raises:
        NetlistError: with the including line's file:line, for a missing, unreadable,
            binary or non-UTF-8 file, a missing section, or an include cycle.
    """
    top_file = Path(netlist.file)
    is_file = netlist.file != "<text>" and top_file.is_file()
    if directory is None:
        directory = top_file.parent if is_file else Path.cwd()
    stack = [_Open((top_file.resolve(), None), netlist.file)] if is_file else []
    expander = _Expander()
    statements = expander.expand(netlist.statements, Path(directory), stack)
    return replace(netlist, statements=statements,
                   control_blocks=netlist.control_blocks + expander.control_blocks,
                   included=netlist.included + tuple(expander.files))
