"""ngspice's conditional netlist: ``.if (cond)`` ... ``.elseif (cond)`` ... ``.else`` ... ``.endif``.

The lines of the first branch whose condition holds are kept, the others dropped, before
subcircuits are expanded (as ngspice's numparam does). A condition is an expression of the
``.param`` values defined above it, outside subcircuits, and of ``.func`` definitions; it holds
when it is not zero. ``=`` alone compares, as ngspice reads ``.elseif (select2 = 2)``. Blocks
nest. A condition on a name that is not such a parameter (a subcircuit's own parameter) is
an error naming it.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from circuitnsds.errors import NetlistError
from circuitnsds.netlist.expressions import ExpressionError, Random, evaluate
from circuitnsds.netlist.params import Scope, func_definition, param_definitions
from circuitnsds.netlist.parser import Statement

KEYWORDS = frozenset({".if", ".elseif", ".else", ".endif"})
_EQUALS = re.compile(r"(?<![=<>!])=(?!=)")
"""A lone ``=``: ngspice's equality in a condition."""


def resolve_conditionals(statements: list[Statement], overrides: Mapping[str, float],
                         random: Random | None = None) -> list[Statement]:
    """``statements`` without the ``.if`` blocks' lines that are not chosen (and without the
    ``.if`` lines themselves); the same list when there is no ``.if``.

    Raises:
        NetlistError: an ``.elseif``/``.else``/``.endif`` without its ``.if``, an ``.elseif``
            or a second ``.else`` after its block's ``.else``, an ``.if`` never closed, or a
            condition that cannot be evaluated (with file:line).
    """
    if not any(statement.keyword in KEYWORDS for statement in statements):
        return statements
    kept: list[Statement] = []
    blocks: list[list] = []  # [parent taking, this branch taking, a branch taken, .if statement,
    #                          its .else statement or None]
    for statement in statements:
        keyword = statement.keyword
        taking = all(block[1] for block in blocks)
        if keyword == ".if":
            holds = taking and _holds(statement, kept, overrides, random)
            blocks.append([taking, holds, holds, statement, None])
        elif keyword in {".elseif", ".else", ".endif"}:
            if not blocks:
                raise NetlistError(f"{keyword} without an .if above it", where=statement.location,
                                   hint="open the block with .if (condition), or remove the line")
            block = blocks[-1]
            if keyword != ".endif" and block[4] is not None:
                earlier = block[4].location
                raise NetlistError(f"{keyword} after the .else of its block"
                                   + (f" (line {earlier.line})" if earlier else ""),
                                   where=statement.location,
                                   hint="a block has one .else, its last branch: close it with "
                                   ".endif first, or make the earlier .else an .elseif")
            if keyword == ".endif":
                blocks.pop()
            elif keyword == ".else":
                block[1], block[2], block[4] = block[0] and not block[2], True, statement
            else:
                holds = block[0] and not block[2] and _holds(statement, kept, overrides, random)
                block[1], block[2] = holds, block[2] or holds
        elif taking:
            kept.append(statement)
    if blocks:
        raise NetlistError(".if is never closed by .endif", where=blocks[-1][3].location,
                           hint="end the block with .endif")
    return kept


def _holds(statement: Statement, above: list[Statement], overrides: Mapping[str, float],
           random: Random | None) -> bool:
    """Whether the condition of an ``.if``/``.elseif`` line is not zero, with the parameters of
    the lines kept above it (outside subcircuits) and ``overrides``."""
    condition = statement.text.split(None, 1)[1].strip() if " " in statement.text.strip() else ""
    if not condition:
        raise NetlistError(f"{statement.keyword} needs a condition", where=statement.location,
                           hint=f"write {statement.keyword} (name == value)")
    scope = Scope(random=random)
    depth = 0
    for line in above:
        if line.keyword == ".subckt":
            depth += 1
        elif line.keyword == ".ends":
            depth = max(0, depth - 1)
        elif depth == 0 and line.keyword == ".param":
            for definition in param_definitions(line):
                if definition.name not in overrides:
                    scope.define(definition)
        elif depth == 0 and line.keyword == ".func":
            scope.define_function(func_definition(line), line.location)
    for name, value in overrides.items():
        scope.set_value(name, value)
    try:
        scope.evaluate_all()
        return evaluate(_EQUALS.sub("==", condition), scope.lookup, functions=scope.function) != 0
    except ExpressionError as exc:
        raise NetlistError(f"{statement.keyword}: {exc}", where=statement.location,
                           hint="a condition reads the .param values defined above it (outside "
                           "subcircuits): define the name there with .param") from None
