"""Netlist expressions: the evaluator, its errors, the tokenizer's {...}/'...' tokens, .param."""

import math

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.errors import NetlistError
from circuitnsds.netlist import load_netlist_text, parse_netlist
from circuitnsds.netlist.expressions import FUNCTIONS, ExpressionError, UndefinedNameError, evaluate
from circuitnsds.netlist.params import parse_assignments
from circuitnsds.netlist.parser import tokenize

# ---------------------------------------------------------------- the evaluator


@pytest.mark.parametrize("text, value", [
    ("4.7k", 4700.0), ("10u", 1e-5), ("2.2meg", 2.2e6), ("1e-3", 1e-3), ("10uF", 1e-5), (".5", 0.5),
    ("1+2*3", 7.0), ("(1+2)*3", 9.0), ("8/4/2", 1.0), ("2-3-4", -5.0),
    ("2^3", 8.0), ("2**3", 8.0), ("2^3^2", 64.0), ("2**3**2", 64.0),
    ("2^(3^2)", 512.0), ("-2^2", -4.0), ("(-2)^2", 4.0), ("2^-1", 0.5),
    ("-+-3", 3.0), ("2*-3", -6.0), ("1k*2m", 2.0), (" 1 +\t2 ", 3.0), ("PI", math.pi),
    ("sqrt(16)", 4.0), ("exp(0)", 1.0), ("log(exp(2))", 2.0), ("ln(exp(3))", 3.0), ("log10(1k)", 3.0),
    ("sin(0)", 0.0), ("cos(0)", 1.0), ("tan(0)", 0.0), ("abs(-2.5)", 2.5), ("min(3, 1, 2)", 1.0),
    ("max(3,1,2)", 3.0), ("pow(2, 10)", 1024.0), ("asin(1)", math.pi / 2), ("acos(1)", 0.0),
    ("atan(1)*4", math.pi), ("sinh(0)", 0.0), ("cosh(0)", 1.0), ("tanh(0)", 0.0), ("floor(-1.5)", -2.0),
    ("ceil(1.2)", 2.0), ("sgn(-3)", -1.0), ("sgn(0)", 0.0),
    ("1/(2*pi*1k*1u)", 1 / (2 * math.pi * 1e3 * 1e-6)),
])
def test_values(text, value):
    assert evaluate(text) == value


def test_every_function_is_tested_above():
    tested = {"sqrt", "exp", "log", "ln", "log10", "sin", "cos", "tan", "abs", "min", "max", "pow", "asin",
              "acos", "atan", "sinh", "cosh", "tanh", "floor", "ceil", "sgn"}
    assert set(FUNCTIONS) == tested


def test_names_from_a_mapping_or_a_function_and_pi_can_be_a_parameter():
    assert evaluate("a*b + c", {"a": 2.0, "b": 3.0, "c": 1.0}) == 7.0
    assert evaluate("R_load/2", lambda name: 10.0 if name == "r_load" else None) == 5.0
    assert evaluate("pi", {"pi": 3.0}) == 3.0


@pytest.mark.parametrize("text, message", [
    ("1/0", "division by zero in '1/0'"),
    ("1/(a-a)", "division by zero"),
    ("0^-1", r"division by zero: 0\^-1"),
    ("sqrt(-1)", r"sqrt\(-1\) is undefined \(domain error\)"),
    ("log(0)", r"log\(0\) is undefined"),
    ("(-8)^(1/3)", "a negative base needs an integer exponent"),
    ("exp(1000)", r"exp\(1000\) overflows"),
    ("1e300*1e300", "not a finite number"),
    ("10^400", "overflows"),
    ("1 +", "syntax error: expected a number, a name or '\\(', found the end after '1 \\+'"),
    ("(1+2", "expected '\\)', found the end"),
    ("1 2", "expected an operator, found '2'"),
    ("2 $ 3", "unexpected character '\\$'"),
    ("foo(1)", r"unknown function foo\(\)"),
    ("pow(2)", r"pow\(\) takes 2 arguments, got 1"),
    ("min(1)", r"min\(\) takes at least 2 arguments"),
    ("sqrt(1, 2)", r"sqrt\(\) takes 1 argument, got 2"),
    ("sqrt", r"sqrt is a function: write sqrt\(...\)"),
    ("", "empty expression"),
    ("a + 1", "undefined parameter 'a' in 'a \\+ 1'"),
])
def test_errors_say_what_and_show_the_text(text, message):
    with pytest.raises(ExpressionError, match=message):
        evaluate(text, {"a": 1.0} if "a-a" in text else None)


def test_undefined_name_is_specific():
    with pytest.raises(UndefinedNameError) as info:
        evaluate("2*fc", {"f": 1.0})
    assert info.value.name == "fc"


# Random expression trees, rendered with as few parentheses as the grammar allows and
# evaluated here independently (Python floats and math) from the tree itself.

LEAVES = [("4.7k", 4700.0), ("10u", 1e-5), ("2.2meg", 2.2e6), ("1e-3", 1e-3), ("0.5", 0.5), ("3", 3.0),
          ("pi", math.pi), ("a", 1.5), ("b_2", -2.0), ("100", 100.0), ("7", 7.0)]
PARAMS = {"a": 1.5, "b_2": -2.0}
PRECEDENCE = {"+": 1, "-": 1, "*": 2, "/": 2, "neg": 3, "^": 4}


def trees():
    leaf = st.sampled_from(LEAVES).map(lambda pair: ("leaf",) + pair)

    def extend(children):
        return st.one_of(
            st.tuples(st.sampled_from(["+", "-", "*", "/", "^"]), children, children),
            st.tuples(st.just("neg"), children),
            st.tuples(st.just("call"), st.sampled_from(["sqrt", "exp", "log", "sin", "cos", "abs", "tan"]),
                      children),
            st.tuples(st.just("call2"), st.sampled_from(["min", "max", "pow"]), children, children),
        )
    return st.recursive(leaf, extend, max_leaves=12)


def precedence(tree) -> int:
    return PRECEDENCE.get(tree[0], 5)


def signed_atom(tree) -> bool:
    """Whether the tree renders as an atom with optional leading signs."""
    if tree[0] == "neg":
        return signed_atom(tree[1])
    return tree[0] in {"leaf", "call", "call2"}


def render(tree, spaces) -> str:
    gap = " " if next(spaces) else ""
    kind = tree[0]
    if kind == "leaf":
        return tree[1]
    if kind == "call":
        return f"{tree[1]}({gap}{render(tree[2], spaces)})"
    if kind == "call2":
        return f"{tree[1]}({render(tree[2], spaces)},{gap}{render(tree[3], spaces)})"
    if kind == "neg":
        operand = render(tree[1], spaces)
        # unary minus binds looser than ^ but tighter than * and +
        return "-" + (operand if precedence(tree[1]) >= PRECEDENCE["neg"] else f"({operand})")
    left, right = render(tree[1], spaces), render(tree[2], spaces)
    mine = PRECEDENCE[kind]
    if kind == "^":
        # left-associative (2^3^2 = (2^3)^2, as ngspice-39); the exponent is an atom with
        # optional signs (2^-1)
        left = left if precedence(tree[1]) >= mine else f"({left})"
        right = right if signed_atom(tree[2]) else f"({right})"
        return f"{left}{gap}{'^' if next(spaces) else '**'}{gap}{right}"
    left = left if precedence(tree[1]) >= mine else f"({left})"
    right = right if precedence(tree[2]) > mine else f"({right})"
    return f"{left}{gap}{kind}{gap}{right}"


class Undefined(Exception):
    pass


def reference(tree) -> float:
    """Evaluate the tree with Python floats; Undefined where the evaluator must refuse."""
    kind = tree[0]
    try:
        if kind == "leaf":
            return tree[2]
        if kind == "neg":
            return -reference(tree[1])
        if kind == "call":
            function = {"sqrt": math.sqrt, "exp": math.exp, "log": math.log, "sin": math.sin,
                        "cos": math.cos, "abs": abs, "tan": math.tan}[tree[1]]
            value = function(reference(tree[2]))
        elif kind == "call2":
            x, y = reference(tree[2]), reference(tree[3])
            value = {"min": min, "max": max, "pow": math.pow}[tree[1]](x, y)
        else:
            x, y = reference(tree[1]), reference(tree[2])
            if kind == "^":
                if x == 0 and y < 0:
                    raise Undefined
                value = math.pow(x, y)
            elif kind == "+":
                value = x + y
            elif kind == "-":
                value = x - y
            elif kind == "*":
                value = x * y
            else:
                value = x / y
    except (ValueError, OverflowError, ZeroDivisionError):
        raise Undefined from None
    if not math.isfinite(value):
        raise Undefined
    return value


@settings(max_examples=200, deadline=None)
@given(tree=trees(), spaces=st.lists(st.booleans(), min_size=200, max_size=200))
def test_random_expression_trees_match_an_independent_evaluation(tree, spaces):
    text = render(tree, iter(spaces + [False] * 1000))
    try:
        expected = reference(tree)
    except Undefined:
        with pytest.raises(ExpressionError):
            evaluate(text, PARAMS)
        return
    assert evaluate(text, PARAMS) == expected, text
    assert evaluate(text.upper(), PARAMS) == expected


@settings(max_examples=100, deadline=None)
@given(value=st.floats(allow_nan=False, allow_infinity=False, min_value=1e-300, max_value=1e300))
def test_substituted_values_lose_no_precision(value):
    netlist = load_netlist_text(f"t\n.param x={value!r}\nR1 a 0 {{x}}\nR2 a 0 'x*1'\n")
    assert [s.tokens[3] for s in netlist.statements] == [repr(value)] * 2
    assert float(netlist.statements[0].tokens[3]) == value


# ---------------------------------------------------------------- tokens


def test_braces_and_quotes_are_single_tokens():
    assert tokenize("R1 a b {1/(2*pi * fc)} m='a + b'") == (
        "r1", "a", "b", "{1/(2*pi * fc)}", "m", "=", "'a + b'")
    assert tokenize("V1 in 0 SIN(0 {VP} {f*2})") == (
        "v1", "in", "0", "sin", "(", "0", "{vp}", "{f*2}", ")")
    assert tokenize("x1 a b sub r={max(1, {2})}") == ("x1", "a", "b", "sub", "r", "=", "{max(1, {2})}")
    assert tokenize('.include "My Models.lib"') == (".include", '"my models.lib"')
    assert tokenize("node's") == ("node's",)  # a quote inside a word is a character


def test_unclosed_brace_or_quote_is_an_error_with_location():
    with pytest.raises(NetlistError, match=r"x.cir:3: cannot read .*'\{' has no matching '\}'"):
        parse_netlist("t\nR1 a 0 1\nR2 a 0 {1+2\n", file="x.cir")
    with pytest.raises(NetlistError, match=r"x.cir:2: .*the quote ' is not closed"):
        parse_netlist("t\nR2 a 0 '1+2\n", file="x.cir")
    # titles and .control scripts are read leniently
    netlist = parse_netlist("t\n.title Bob's {circuit\n.control\necho 'hi\n.endc\n")
    assert netlist.statements[0].text == ".title Bob's {circuit"


def test_expression_split_over_continuation_lines():
    netlist = parse_netlist("t\nR1 a b {1 +\n* a comment\n\n+ 2}\n")
    assert netlist.statements[0].tokens == ("r1", "a", "b", "{1 + 2}")


words = st.sampled_from(["r1", "a", "b", "1k", "d(", ")", "x=1", "{1 + 2*3}", "'a * b'", "{max(1, 2)}",
                         "sin(0", "{vp}", "m", "=", "'2'", ".model", "bv=5.1", "{ (1) }"])


@settings(max_examples=150, deadline=None)
@given(statement=st.lists(words, min_size=1, max_size=12), cuts=st.lists(st.booleans(), min_size=12,
       max_size=12), comments=st.lists(st.sampled_from(["", "* c", "", "*", "   ", "* {"]), min_size=12,
       max_size=12))
def test_random_continuation_splitting_gives_the_same_tokens(statement, cuts, comments):
    """A statement split over '+' lines anywhere between words, with blank and comment lines
    between, reads as the same tokens as on one line."""
    assume(not statement[0].startswith(("=", "(", ")")))
    one_line = parse_netlist("t\n" + " ".join(statement) + "\n").statements[0].tokens
    lines = [statement[0]]
    for word, cut, comment in zip(statement[1:], cuts, comments):
        if cut:
            if comment:
                lines.append(comment)
            lines.append("+ " + word)
        else:
            lines[-1] += " " + word
    netlist = parse_netlist("t\n" + "\n".join(lines) + "\n.end\n")
    assert len(netlist.statements) == 1
    assert netlist.statements[0].tokens == one_line


def test_model_over_many_continuation_lines_with_comments():
    text = """t
.MODEL DZ D(IS=2.61E-15
+ N=1.05
* junction capacitance

+ CJO=180P VJ=0.75 ; trailing
*
+ BV={5 + 0.1} )
"""
    assert load_netlist_text(text).statements[0].tokens == (
        ".model", "dz", "d", "(", "is", "=", "2.61e-15", "n", "=", "1.05", "cjo", "=", "180p", "vj", "=",
        "0.75", "bv", "=", "5.1", ")")


def test_included_files_have_no_title():
    netlist = parse_netlist("R1 a 0 1\n", file="inc.lib", has_title=False)
    assert netlist.title == "" and netlist.statements[0].location.line == 1
    assert parse_netlist("", has_title=False).statements == []


# ---------------------------------------------------------------- .param


@pytest.mark.parametrize("text, pairs", [
    ("a=1 b={a*2} c='a+b'", [("a", "1"), ("b", "a*2"), ("c", "a+b")]),
    ("A = 1  B = a + 2 * 3  C= max(a, b)", [("a", "1"), ("b", "a + 2 * 3"), ("c", "max(a, b)")]),
    ("x=1, y=2", [("x", "1"), ("y", "2")]),
    ("f = { 1/(2*pi) } g=(1)", [("f", "1/(2*pi)"), ("g", "(1)")]),
    ("", []),
])
def test_assignments(text, pairs):
    assert parse_assignments(text) == pairs


def test_params_in_order_forward_references_and_substitution_everywhere():
    text = """params
.param vp=10 f=50
.param tau = r*c  r=1k
.param c={1/(2*pi*fc*r)} fc=f
V1 in 0 SIN(0 {vp} {f})
R1 in out {r}
C1 out 0 {c} ic={vp/2}
D1 out 0 dz
.model dz D(BV={vp/2} Ron='r/1k')
.tran {1/(f*100)} {2/f} uic
.ic v(out)={vp/4}
.end
"""
    netlist = load_netlist_text(text, file="p.cir")
    tokens = {s.keyword: s.tokens for s in netlist.statements}
    c = 1 / (2 * math.pi * 50.0 * 1000.0)
    assert tokens["v1"] == ("v1", "in", "0", "sin", "(", "0", "10.0", "50.0", ")")
    assert tokens["c1"] == ("c1", "out", "0", repr(c), "ic", "=", "5.0")
    assert tokens[".model"][4:] == ("bv", "=", "5.0", "ron", "=", "1.0", ")")
    assert tokens[".tran"] == (".tran", repr(1 / 5000), "0.04", "uic")
    assert tokens[".ic"] == (".ic", "v", "(", "out", ")", "=", "2.5")
    assert ".param" not in tokens
    circuit = circuitnsds.read_netlist(text)
    assert circuit.element("c1").capacitance == c


@pytest.mark.parametrize("body, message", [
    (".param a={b*2}\nR1 x 0 {a}", r"p.cir:2: parameter 'a': undefined parameter 'b' in 'b\*2'"),
    ("R1 x 0 {rr}", r"p.cir:2: r1: undefined parameter 'rr' in 'rr'"),
    (".param a={b}\n.param b={c+1}\n.param c={a}", r"p.cir:2: parameters refer to each other in a cycle: "
     r"a -> b -> c -> a"),
    (".param a={a+1}", "cycle: a -> a"),
    (".param a=1\n.param a=2",
     r"p.cir:3: parameter 'a' is defined twice at the top level \(first at p.cir:2\)"),
    (".param a=1/0", r"p.cir:2: parameter 'a': division by zero in '1/0'"),
    (".param", r"p.cir:2: .param defines nothing"),
    (".param a", r"p.cir:2: .param: expected name=value, found 'a'"),
    (".param a=", r"p.cir:2: .param: a= has no value"),
    (".param a={1+2", r"p.cir:2: cannot read"),
    ("R1 x 0 {sqrt(-4)}", r"p.cir:2: r1: sqrt\(-4\) is undefined"),
    (".tran {1/0} 1", r"p.cir:2: .tran: division by zero"),
])
def test_parameter_errors_name_the_line_and_the_text(body, message):
    with pytest.raises(NetlistError, match=message):
        load_netlist_text(f"t\n{body}\n", file="p.cir")


def test_unused_commands_and_run_time_expressions_are_not_evaluated():
    netlist = load_netlist_text("t\n.meas tran x find v(a) when v(b)='vdd/2'\nR1 a 0 1\n"
                                "B1 a 0 v={time*2}\nE1 a 0 value={v(b)*2}\nG1 a 0 cur='i(v1)'\n")
    # behavioural expressions are read (parameters substituted, names renamed) and written back
    assert [s.tokens[-1] for s in netlist.statements] == ["'vdd/2'", "1", "{(time*2.0)}",
                                                         "{(v(b)*2.0)}", "{i(v1)}"]
