"""Netlist text -> :class:`Netlist` of :class:`Statement` (ngspice dialect, lexical level).

This stage knows the file syntax only: the title line, comments, ``+``
continuation lines, ``.end``, case folding and tokens. What a statement means
(an element, a model, an analysis) is decided by :mod:`circuitnsds.elaborate`.

Lexical rules (ngspice):

* the first line is the title, whatever it contains;
* ``*`` starts a comment line; ``;`` and ``//`` comment to the end of the line;
  ``$`` does too when it follows whitespace;
* a line starting with ``+`` continues the previous statement; blank and comment
  lines may sit inside a continuation block;
* everything is case-insensitive (tokens are lower-cased);
* ``(``, ``)`` and ``=`` are tokens of their own; commas separate like blanks;
* ``.end`` ends the netlist; lines after it are not read.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from circuitnsds.errors import NetlistError, SourceLocation

_TOKEN = re.compile(r"[()=]|[^\s(),=]+")


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


def _strip_comment(line: str) -> str:
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


def tokenize(text: str) -> tuple[str, ...]:
    """Split a logical line into lower-cased tokens (parentheses and ``=`` separate)."""
    return tuple(token.lower() for token in _TOKEN.findall(text))


def parse_netlist(text: str, file: str = "<text>") -> Netlist:
    """Parse netlist text.

    Args:
        text: the whole netlist, title line first.
        file: name used in error messages.

    Raises:
        NetlistError: for a continuation line with nothing to continue.
    """
    lines = text.splitlines()
    if not lines:
        raise NetlistError("the netlist is empty", where=file,
                           hint="the first line of a netlist is its title, then elements and .tran")
    netlist = Netlist(title=lines[0].strip(), file=file)
    pending: list[str] = []
    pending_line = 0

    def flush() -> None:
        if pending:
            joined = " ".join(pending)
            tokens = tokenize(joined)
            if not tokens or tokens[0] in {"(", ")", "="}:
                raise NetlistError(f"cannot read {joined.strip()!r}: a statement starts with "
                                   "an element name or a dot command",
                                   where=SourceLocation(file, pending_line))
            netlist.statements.append(
                Statement(tokens, SourceLocation(file, pending_line), joined.strip())
            )
            pending.clear()

    for number, raw in enumerate(lines[1:], start=2):
        stripped = raw.strip()
        if not stripped or stripped.startswith("*"):
            continue
        content = _strip_comment(stripped).strip()
        if stripped.startswith("+"):
            if not pending:
                raise NetlistError(
                    "continuation line '+' has no statement to continue",
                    where=SourceLocation(file, number),
                    hint="a '+' line must follow an element or command line",
                )
            pending.append(content[1:] if content.startswith("+") else content)
            continue
        if not content:
            continue
        flush()
        if tokenize(content)[:1] == (".end",):
            netlist.ended = True
            break
        pending.append(content)
        pending_line = number
    flush()
    return netlist


def read_netlist_file(path: str | Path) -> Netlist:
    """Read and parse a netlist file.

    Raises:
        NetlistError: when the file cannot be read.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise NetlistError(f"cannot read the netlist: {exc.strerror}", where=str(path)) from None
    return parse_netlist(text, file=str(path))
