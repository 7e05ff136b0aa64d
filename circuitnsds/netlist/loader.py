"""The whole netlist front end: read, expand includes, evaluate parameters, flatten.

    file or text --parse--> Netlist --includes--> Netlist --flatten--> flat Netlist

The flat :class:`~circuitnsds.netlist.parser.Netlist` is what
:func:`circuitnsds.frontend.elaborate.elaborate` reads.
"""

from __future__ import annotations

from pathlib import Path

from circuitnsds.netlist.includes import expand_includes
from circuitnsds.netlist.node_spellings import warn_node_spellings
from circuitnsds.netlist.parser import Netlist, parse_netlist, read_netlist_file
from circuitnsds.netlist.subcircuits import flatten


def preprocess(netlist: Netlist, directory: str | Path | None = None) -> Netlist:
    """Expand the includes of a parsed netlist, then its parameters and subcircuits.

    Args:
        netlist: as returned by :func:`parse_netlist` or :func:`read_netlist_file`.
        directory: where relative include paths start; by default the netlist file's
            directory, or the current directory for text.

    Raises:
        NetlistError: with file:line (see :func:`expand_includes` and :func:`flatten`).
    """
    expanded = expand_includes(netlist, directory)
    warn_node_spellings(expanded.statements)
    return flatten(expanded)


def load_netlist(path: str | Path) -> Netlist:
    """Read a netlist file and return it flat (includes, parameters and subcircuits expanded).

    Raises:
        NetlistError: the file cannot be read, or its content is malformed (with file:line).
    """
    return preprocess(read_netlist_file(path))


def load_netlist_text(text: str, file: str = "<text>", directory: str | Path | None = None) -> Netlist:
    """Parse netlist text (title line first) and return it flat.

    Args:
        text: the netlist.
        file: name used in messages.
        directory: where relative include paths start (default: the current directory).

    Raises:
        NetlistError: malformed content (with file:line).
    """
    return preprocess(parse_netlist(text, file=file), directory if directory is not None else Path.cwd())
