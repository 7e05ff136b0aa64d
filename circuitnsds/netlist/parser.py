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

import re
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


@dataclass
class Netlist:
    """A netlist file as statements, in order.

    Attributes:
        title: the first line.
        statements: every statement up to ``.end`` (the ``.end`` itself excluded).
        file: the file name, or ``<text>`` for a string.
        ended: whether a ``.end`` line was found.
    """

    title: str
    statements: list[Statement] = field(default_factory=list)
    file: str = "<text>"
    ended: bool = False


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


def physical_lines(text: str) -> list[str]:
    """Split at ``\\n``, ``\\r\\n`` and ``\\r`` only, as ngspice does: ``str.splitlines`` also
    splits at form feeds and other separators that may sit inside a line."""
    lines = re.split(r"\r\n|\r|\n", text)
    return lines[:-1] if lines and lines[-1] == "" else lines


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
    pending: list[str] = []
    pending_line = 0
    in_control = False

    def flush() -> None:
        nonlocal in_control
        if not pending:
            return
        joined = " ".join(pending).strip()
        keyword = joined.split(None, 1)[0].lower()
        in_control = (in_control or keyword == ".control") and keyword != ".endc"
        try:
            tokens = tokenize(joined, strict=not in_control and keyword != ".title")
        except _TokenError as exc:
            raise NetlistError(f"cannot read {joined!r}: {exc}", where=SourceLocation(file, pending_line),
                               hint="expressions are written {a*2} or 'a*2', paths \"my file.lib\"") from None
        if not tokens or tokens[0] in {"(", ")", "="}:
            raise NetlistError(f"cannot read {joined!r}: a statement starts with "
                               "an element name or a dot command",
                               where=SourceLocation(file, pending_line))
        netlist.statements.append(Statement(tokens, SourceLocation(file, pending_line), joined))
        pending.clear()

    first = 2 if has_title else 1
    for number, raw in enumerate(lines[first - 1:], start=first):
        stripped = raw.strip()
        if not stripped or stripped.startswith("*"):
            continue
        content = strip_comment(stripped).strip()
        if stripped.startswith("+"):
            if not pending:
                raise NetlistError(
                    "continuation line '+' has no statement to continue",
                    where=SourceLocation(file, number),
                    hint="a '+' line must follow an element or command line",
                )
            pending.append(content[1:].strip() if content.startswith("+") else content)
            continue
        if not content:
            continue
        flush()
        if content.split(None, 1)[0].lower() == ".end":
            netlist.ended = True
            break
        pending.append(content)
        pending_line = number
    flush()
    return netlist


def read_source_text(path: str | Path, where: object | None = None, what: str = "netlist") -> str:
    """The text of a netlist or library file (UTF-8; ASCII is UTF-8).

    Args:
        path: the file.
        where: location reported on failure (the including statement); the path if None.
        what: what the file is, for messages (``netlist``, ``included file``).

    Raises:
        NetlistError: the file is missing or unreadable, binary, or not UTF-8 text.
    """
    path = Path(path)
    where = str(path) if where is None else where
    try:
        data = path.read_bytes()
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
