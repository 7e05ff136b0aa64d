"""Netlist text -> :class:`Netlist` of :class:`Statement` (ngspice dialect, lexical level).

This stage knows the file syntax only: the title line, comments, ``+``
continuation lines, ``.end``, case folding and tokens. What a statement means
(an element, a model, an analysis) is decided by :mod:`circuitnsds.frontend.elaborate`.

Lexical rules (ngspice):

* the first line is the title, whatever it contains;
* ``*`` starts a comment line; ``;`` and ``//`` comment to the end of the line;
  ``$`` does too when it follows whitespace;
* a line starting with ``+`` continues the previous statement; blank and comment
  lines may sit inside a continuation block;
* everything is case-insensitive (tokens are lower-cased);
* ``(``, ``)`` and ``=`` are tokens of their own; commas separate like blanks;
* an expression in balanced braces ``{...}`` or in single quotes ``'...'`` is one token
  (braces or quotes kept, spaces inside kept), and so is a double-quoted ``"..."`` path;
* ``.end`` ends the netlist; lines after it are not read.

Included files have no title line (``parse_netlist(..., has_title=False)``).
"""

from __future__ import annotations

import os
import re
import stat
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path

from circuitnsds.errors import NetlistError, SourceLocation

_CLOSING = {"'": "'", '"': '"'}


class _TokenError(ValueError):
    """A brace or quote is not closed (the caller adds file:line)."""


@dataclass(frozen=True)
class Statement:
    """One logical netlist line.

    Attributes:
        tokens: lower-cased tokens; ``tokens[0]`` is the element name or the dot command.
        location: file and line of the statement's first physical line.
        text: the logical line as written (continuations joined), for messages.
    """

    tokens: tuple[str, ...]
    location: SourceLocation
    text: str

    @property
    def keyword(self) -> str:
        """The element name (``r1``) or dot command (``.tran``)."""
        return self.tokens[0]

    @property
    def is_command(self) -> bool:
        return self.keyword.startswith(".")


CONTROL_STATEMENTS = {"tran": ".tran", "ac": ".ac", "op": ".op", "dc": ".dc", "noise": ".noise",
                      "tf": ".tf", "pz": ".pz", "sens": ".sens", "disto": ".disto",
                      "meas": ".meas", "measure": ".measure", "save": ".save",
                      "option": ".options", "options": ".options", "pss": ".pss"}
"""Commands of a ``.control`` script that are read as the dot command of the same meaning in
ngspice (an analysis, a measurement, what is saved, an option): ``tran 10u 3m`` is ``.tran 10u 3m``."""

CONTROL_RUN = "run"
"""The script command that runs the netlist's analyses: circuitnsds runs them anyway."""


@dataclass
class ControlBlock:
    """An ngspice ``.control ... .endc`` script. Its analyses and the commands that set up or
    measure a run (:data:`CONTROL_STATEMENTS`) become statements; the rest is never executed,
    and the front end names each such command with its line, once per block.

    Attributes:
        location: the ``.control`` line.
        commands: the first word of each line of the script that is not executed.
        lines: the line number of each of ``commands``.
        taken: the first word of each line read as a statement.
        taken_lines: the line number of each of ``taken``.
    """

    location: SourceLocation
    commands: list[str] = field(default_factory=list)
    lines: list[int] = field(default_factory=list)
    taken: list[str] = field(default_factory=list)
    taken_lines: list[int] = field(default_factory=list)


@dataclass
class Netlist:
    """A netlist file as statements, in order.

    Attributes:
        title: the first line.
        statements: every statement up to ``.end`` (the ``.end`` itself excluded), outside
            ``.control`` blocks.
        file: the file name, or ``<text>`` for a string.
        ended: whether a ``.end`` line was found.
        control_blocks: the ``.control ... .endc`` scripts left out of ``statements``.
        included: the files read by ``.include``/``.lib`` (resolved paths), in order.
    """

    title: str
    statements: list[Statement] = field(default_factory=list)
    file: str = "<text>"
    ended: bool = False
    control_blocks: list[ControlBlock] = field(default_factory=list)
    included: tuple[str, ...] = ()


def strip_comment(line: str) -> str:
    """Remove ``;``, ``//`` and whitespace-``$`` comments from a physical line."""
    cut = len(line)
    for marker in (";", "//"):
        position = line.find(marker)
        if position != -1:
            cut = min(cut, position)
    dollar = re.search(r"\s\$", line)
    if dollar is not None:
        cut = min(cut, dollar.start())
    return line[:cut]


def closing_position(text: str, start: int) -> int:
    """Index of the brace or quote closing the one at ``start`` (braces nest), or -1."""
    if text[start] in _CLOSING:
        return text.find(_CLOSING[text[start]], start + 1)
    depth = 0
    for index in range(start, len(text)):
        depth += {"{": 1, "}": -1}.get(text[index], 0)
        if depth == 0:
            return index
    return -1


_PLAIN = re.compile(r"[^{}'\"(),=]*")
"""A line without braces, quotes, parentheses, commas or ``=``: its tokens are its words."""


def tokenize(text: str, strict: bool = True) -> tuple[str, ...]:
    """Split a logical line into lower-cased tokens.

    ``(``, ``)`` and ``=`` are tokens; blanks and commas separate; ``{...}`` (balanced
    braces), ``'...'`` and ``"..."`` starting a token are single tokens including their
    delimiters (inside a word, a quote is an ordinary character).

    Args:
        text: one logical line, comments removed.
        strict: raise for an unclosed brace or quote; when false (titles, ngspice
            ``.control`` scripts) the opening character is read as part of a word.

    Raises:
        ValueError: for an unclosed brace or quote (only when ``strict``).
    """
    if _PLAIN.fullmatch(text):  # the common line: words and blanks only
        return tuple(text.lower().split())
    tokens: list[str] = []
    position, length = 0, len(text)
    while position < length:
        char = text[position]
        if char.isspace() or char == ",":
            position += 1
            continue
        if char in "()=":
            tokens.append(char)
            position += 1
            continue
        if char == "{" or char in _CLOSING:
            end = closing_position(text, position)
            if end != -1:
                tokens.append(text[position:end + 1].lower())
                position = end + 1
                continue
            if strict:
                what = "'{' has no matching '}'" if char == "{" else f"the quote {char} is not closed"
                raise _TokenError(f"{what} in {text[position:position + 40]!r}")
        end = position + 1
        while end < length and not text[end].isspace() and text[end] not in "(),=":
            end += 1
        tokens.append(text[position:end].lower())
        position = end
    return tuple(tokens)


def _check_visible(tokens: tuple[str, ...], location: SourceLocation) -> None:
    """Refuse a control or format character (a zero-width space, a soft hyphen, a BOM, a
    bell...) inside a token outside quotes: it would become part of a name nobody can type
    back (``R\u200b1`` is not ``r1``). Tabs are blanks; quoted strings may hold anything."""
    for token in tokens:
        if token.isprintable() or token[0] in _CLOSING:
            continue
        for char in token:
            if char != "\t" and unicodedata.category(char) in {"Cc", "Cf"}:
                raise NetlistError(f"invisible character U+{ord(char):04X} in {token!r}",
                                   where=location, hint="delete it (it is not a blank either: "
                                   "use a space or a tab between fields)")


def physical_lines(text: str) -> list[str]:
    """Split at ``\\n``, ``\\r\\n`` and ``\\r`` only, as ngspice does: ``str.splitlines`` also
    splits at form feeds and other separators that may sit inside a line."""
    lines = re.split(r"\r\n|\r|\n", text)
    return lines[:-1] if lines and lines[-1] == "" else lines


@dataclass(frozen=True)
class LogicalLine:
    """Physical lines grouped into one statement (or one comment/blank line).

    Attributes:
        number: 1-based line number of the first physical line.
        physical: the physical lines as written; comment and blank lines inside a ``+``
            continuation block travel with the statement.
        text: the statement's content, comments removed and continuations joined with a
            blank; empty for a comment or blank line. It starts with ``+`` only for a
            continuation line with nothing to continue.
    """

    number: int
    physical: tuple[str, ...]
    text: str


def logical_lines(lines: list[str], first_number: int = 1) -> list[LogicalLine]:
    """Group physical lines into statements, as ngspice does (see the module docstring)."""
    groups: list[LogicalLine] = []
    pending: list[str] = []
    content_parts: list[str] = []
    trailing: list[str] = []  # comment lines that may sit inside a continuation block
    start = trailing_start = first_number

    def flush() -> None:
        if pending:
            groups.append(LogicalLine(start, tuple(pending), " ".join(content_parts).strip()))
            pending.clear()
            content_parts.clear()

    def flush_trailing() -> None:
        groups.extend(LogicalLine(trailing_start + k, (line,), "") for k, line in enumerate(trailing))
        trailing.clear()

    for number, raw in enumerate(lines, start=first_number):
        stripped = raw.strip()
        content = "" if stripped.startswith("*") else strip_comment(stripped).strip()
        if not content:
            if not trailing:
                trailing_start = number
            trailing.append(raw)
            continue
        if content.startswith("+") and pending:
            pending.extend(trailing)
            trailing.clear()
            pending.append(raw)
            content_parts.append(content[1:].strip())
            continue
        flush()
        flush_trailing()
        start = number
        pending.append(raw)
        content_parts.append(content)
    flush()
    flush_trailing()
    return groups


def parse_netlist(text: str, file: str = "<text>", has_title: bool = True) -> Netlist:
    """Parse netlist text.

    Args:
        text: the whole netlist, title line first (unless ``has_title`` is false).
        file: name used in error messages.
        has_title: whether the first line is a title (true for a netlist, false for an
            included file, whose first line is a statement and which may be empty).

    Raises:
        NetlistError: for a continuation line with nothing to continue, an unclosed
            ``{`` or quote, or an empty netlist.
    """
    lines = physical_lines(text)
    if not lines and has_title:
        raise NetlistError("the netlist is empty", where=file,
                           hint="the first line of a netlist is its title, then elements and .tran")
    netlist = Netlist(title=lines[0].strip() if has_title else "", file=file)
    first = 2 if has_title else 1
    in_control: SourceLocation | None = None
    for line in logical_lines(lines[first - 1:], first):
        if not line.text:
            continue
        location = SourceLocation(file, line.number)
        if line.text.startswith("+"):
            raise NetlistError("continuation line '+' has no statement to continue", where=location,
                               hint="a '+' line must follow an element or command line")
        keyword = line.text.split(None, 1)[0].lower()
        if keyword == ".end":
            netlist.ended = True
            break
        if in_control is not None:  # an ngspice script: its analyses become statements
            if keyword == ".endc":
                in_control = None
            elif keyword in CONTROL_STATEMENTS:
                text = CONTROL_STATEMENTS[keyword] + line.text[len(keyword):]
                netlist.control_blocks[-1].taken.append(keyword)
                netlist.control_blocks[-1].taken_lines.append(line.number)
                netlist.statements.append(_statement(text, location))
            elif keyword != CONTROL_RUN:
                netlist.control_blocks[-1].commands.append(keyword)
                netlist.control_blocks[-1].lines.append(line.number)
            continue
        if keyword == ".control":
            in_control = location
            netlist.control_blocks.append(ControlBlock(location))
            continue
        if line.text == ")" and netlist.statements and _open_parentheses(netlist.statements[-1]):
            netlist.statements[-1] = _statement(netlist.statements[-1].text + " )",
                                                netlist.statements[-1].location)
            continue  # ngspice reads a lone ')' as a comment (with a warning): the '(' stays open
        netlist.statements.append(_statement(line.text, location))
    if in_control is not None:
        raise NetlistError(".control block has no .endc", where=in_control,
                           hint="close the block with a .endc line")
    return netlist


def _statement(text: str, location: SourceLocation) -> Statement:
    """The statement of one logical line (text without comments, continuations joined)."""
    keyword = text.split(None, 1)[0].lower()
    try:
        tokens = tokenize(text, strict=keyword != ".title")
    except _TokenError as exc:
        raise NetlistError(f"cannot read {text!r}: {exc}", where=location,
                           hint="expressions are written {a*2} or 'a*2', paths \"my file.lib\"") from None
    _check_visible(tokens, location)
    if not tokens or tokens[0] in {"(", ")", "="}:
        raise NetlistError(f"cannot read {text!r}: a statement starts with "
                           "an element name or a dot command", where=location)
    return Statement(tokens, location, text)


def _open_parentheses(statement: Statement) -> bool:
    """Whether ``statement`` has more ``(`` tokens than ``)`` (a ``.model`` closed on the
    next line by a lone ``)``, which LTspice and ngspice's library files write)."""
    return statement.tokens.count("(") > statement.tokens.count(")")


MAX_SOURCE_BYTES = 256 * 2**20
"""Largest netlist or included file read [bytes]: reading stops there (``/dev/zero`` or a
runaway file would otherwise fill the memory)."""

READ_CHUNK = 2**16
"""First read [bytes]: a binary file (a NUL byte) is refused before reading more."""


def _open_regular(path: Path, what: str, where: object):
    """``path`` opened for reading without blocking (a FIFO with no writer would wait for
    ever), refused unless it is a regular file.

    Raises:
        NetlistError: a FIFO, a device, a socket.
        OSError: as ``open`` raises them.
    """
    descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    mode = os.fstat(descriptor).st_mode
    if not stat.S_ISREG(mode):
        os.close(descriptor)
        if stat.S_ISDIR(mode):
            raise IsADirectoryError(path)
        kind = ("a FIFO (named pipe)" if stat.S_ISFIFO(mode) else "a device" if stat.S_ISCHR(mode)
                or stat.S_ISBLK(mode) else "a socket" if stat.S_ISSOCK(mode) else "not a regular file")
        raise NetlistError(f"the {what} {str(path)!r} is {kind}, not a regular file: not read",
                           where=where, hint="includes and libraries are read from files; copy the "
                           "text into one")
    os.set_blocking(descriptor, True)
    return os.fdopen(descriptor, "rb")


def read_source_text(path: str | Path, where: object | None = None, what: str = "netlist",
                     regular_only: bool = False) -> str:
    """The text of a netlist or library file (UTF-8; ASCII is UTF-8).

    Args:
        path: the file.
        where: location reported on failure (the including statement); the path if None.
        what: what the file is, for messages (``netlist``, ``included file``).
        regular_only: refuse FIFOs and devices, opened without blocking (for included files:
            the netlist named on the command line may be a pipe, ``<(command)``).

    Raises:
        NetlistError: the file is missing or unreadable, binary, larger than
            :data:`MAX_SOURCE_BYTES`, or not UTF-8 text; with ``regular_only``, not a
            regular file.
    """
    path = Path(path)
    where = str(path) if where is None else where
    try:
        with (_open_regular(path, what, where) if regular_only else open(path, "rb")) as handle:
            data = handle.read(READ_CHUNK)
            if b"\0" not in data and len(data) == READ_CHUNK:
                data += handle.read(MAX_SOURCE_BYTES + 1 - READ_CHUNK)
    except FileNotFoundError:
        raise NetlistError(f"cannot read the {what} {str(path)!r}: no such file", where=where,
                           hint="check the name and its case; relative paths start from the "
                           "directory of the file that names them") from None
    except IsADirectoryError:
        raise NetlistError(f"the {what} {str(path)!r} is a directory, not a file", where=where) from None
    except OSError as exc:
        raise NetlistError(f"cannot read the {what} {str(path)!r}: {exc.strerror}", where=where) from None
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise NetlistError(f"the {what} {str(path)!r} is UTF-16 text; circuitnsds reads UTF-8", where=where,
                           hint=f"convert it, e.g. iconv -f utf-16 -t utf-8 {path.name} > "
                           f"{path.stem}-utf8{path.suffix}")
    if b"\0" in data:
        raise NetlistError(f"the {what} {str(path)!r} is a binary file, not netlist text", where=where,
                           hint="a netlist is plain text; check that the right file is named")
    if len(data) > MAX_SOURCE_BYTES:
        kind = "" if path.is_file() else " (not a regular file: a device or a pipe)"
        raise NetlistError(f"the {what} {str(path)!r}{kind} is larger than "
                           f"{MAX_SOURCE_BYTES // 2**20} MiB: not read", where=where,
                           hint="a netlist of a million elements takes about 30 MiB; check that the "
                           "right file is named")
    data = data.removeprefix(b"\xef\xbb\xbf")  # a UTF-8 byte-order mark is not text
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise NetlistError(f"the {what} {str(path)!r} is not UTF-8 text (byte 0x{data[exc.start]:02x} "
                           f"on its line {line})", where=where,
                           hint=f"convert it, e.g. iconv -f latin1 -t utf-8 {path.name} > "
                           f"{path.stem}-utf8{path.suffix}") from None


def read_netlist_file(path: str | Path) -> Netlist:
    """Read and parse a netlist file (lexical level only: includes are not expanded).

    Raises:
        NetlistError: when the file cannot be read or is not UTF-8 text.
    """
    return parse_netlist(read_source_text(path), file=str(path))
