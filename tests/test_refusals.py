"""Issue 32: every refusal that remains names what is unsupported and says what to write instead.

Two checks: the source of the netlist readers (every ``raise`` whose message says something is
not supported carries a hint, or says in the message itself what to write), and a catalogue of
the constructs still refused, each read from text and its message checked.
"""

import ast
import re
from pathlib import Path

import pytest

import circuitnsds
from circuitnsds.errors import NetlistError

PACKAGE = Path(circuitnsds.__file__).resolve().parent
REFUSAL = re.compile(r"not supported|unsupported|cannot represent|is refused", re.IGNORECASE)
INSTRUCTION = re.compile(r"\b(write|leave|use|add|remove|give|keep|model|define|put|replace|"
                         r"split|scale|set|start|drop)\b", re.IGNORECASE)
HINTED = {"fail"}
"""Error makers that add the hint themselves (``.meas``'s list of the forms it reads)."""


def _text(node: ast.AST) -> str:
    """The literal text of a message argument (f-string parts and concatenations)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr):
        return "".join(_text(part) for part in node.values)
    if isinstance(node, ast.BinOp):
        return _text(node.left) + _text(node.right)
    return ""


def _refusals_without_advice():
    found = []
    for path in [*(PACKAGE / "netlist").rglob("*.py"), *(PACKAGE / "frontend").rglob("*.py")]:
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Raise) and isinstance(node.exc, ast.Call)):
                continue
            call = node.exc
            message = " ".join(_text(a) for a in call.args)
            if not REFUSAL.search(message):
                continue
            name = call.func.attr if isinstance(call.func, ast.Attribute) else getattr(call.func, "id", "")
            hinted = name in HINTED or any(k.arg == "hint" for k in call.keywords)
            if not hinted and not INSTRUCTION.search(message.split("not supported")[-1]):
                found.append(f"{path.relative_to(PACKAGE)}:{node.lineno}: {message[:90]}")
    return found


def test_every_refusal_in_the_readers_says_what_to_write():
    assert _refusals_without_advice() == []


CATALOGUE = [
    # (netlist lines, what the message must name)
    ("R1 a 0 r={v(a)*2}", r"r1: a resistance that depends on v\(a\) is a smooth nonlinear element"),
    ("B1 a 0 V={ddt(abs(v(b)))}\nR2 b 0 1", r"b1: cannot represent the term ddt\(abs\(v\(b\)\)\).*issue 33"),
    # (before: "unknown function ddt()", as though ddt were not read at all)
    ("B1 c 0 I={ddt(v(a)*v(c))}\nR2 c 0 1", r"b1: ddt\(\) of a nonlinear value"),
    ("G1 a 0 POLY(1) b 0 0 1\nR2 b 0 1", r"g1: .*POLY"),
    ("A1 a b ff\n.model ff slew(rise_slope=1)", r"a1: .*slew"),
    (".if (nosuch > 0)\nR2 a 0 1\n.endif", r"\.if: undefined parameter 'nosuch'"),
    ("L1 a 0 1m\nL2 b 0 1m\nK1 L1 L2 1 core\n.model core CORE\nR2 b 0 1", r"k1: 'core' after the coupling"),
    ("D1 a 0 dm foo=2\n.model dm D", r"d1: instance parameter 'foo' is not supported"),
    ("V2 b 0 TRNOISE(1 1n 0 0)\nR2 b 0 1", r"v2: TRNOISE sources are not supported"),
    # Xyce's VSWITCH/VswitchHyst1.cir (before: "unknown parameter 'vhon'", the hint naming SW's)
    ("S1 a b a 0 sw\nR2 b 0 1\n.model sw VSWITCH(RON=1 ROFF=100 VON=1 VHON=0.55 VOFF=0 VHOFF=0.45)",
     r"\.model sw VSWITCH: VHON, VHOFF \(Xyce's hysteresis of its switch\) is not supported"),
]


@pytest.mark.parametrize(("lines", "names"), CATALOGUE)
def test_each_remaining_refusal_names_the_construct_and_what_to_write(lines, names):
    text = f"refused\nV1 a 0 SIN(0 1 1k)\nR1 a 0 1k\n{lines}\n.tran 10u 1m\n.end\n"
    with pytest.raises(NetlistError) as error:
        circuitnsds.read_netlist(text)
    message = str(error.value)
    assert re.search(names, message, re.IGNORECASE), message
    assert error.value.hint and INSTRUCTION.search(error.value.hint.split("; in:")[0]), message


def test_xyce_generic_switch_is_refused_with_the_switch_to_write():
    # Xyce's GSWITCH/gswitch.cir: before, "undefined parameter 'time' in 'if(time>2u,1,0)'"
    with pytest.raises(NetlistError, match=r"sw1: Xyce's generic switch \(CONTROL=\{expression\}\)") as error:
        circuitnsds.read_netlist("g\nV1 1 0 1\nSW1 1 2 SW OFF CONTROL={if(time>2u,1,0)}\nR2 2 0 1\n"
                                 ".MODEL SW SWITCH (ON=1 OFF=0 RON=1 ROFF=1E6)\n.tran 1u 4u\n.end\n")
    assert "SW1 n+ n- ctl 0 MODEL" in error.value.hint
