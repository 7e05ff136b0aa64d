"""Sweeps and Monte Carlo: parameter overrides, .step, the random functions, the table,
execution in-process and on a real Dask cluster (scheduler and workers as processes)."""

from __future__ import annotations

import json
import math
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.errors import CircuitError, NetlistError, NetlistWarning
from circuitnsds.frontend.build import CircuitBuilder
from circuitnsds.netlist.expressions import ExpressionError, evaluate
from circuitnsds.netlist.steps import (
    LazyGenerator,
    StepSyntaxError,
    count_values,
    linear_values,
    parse_param_option,
    point_generator,
)
from circuitnsds.output import measure

ROOT = Path(__file__).resolve().parent.parent
BUCK = ROOT / "netlists" / "sweeps" / "buck_param.cir"
MONTE_CARLO = ROOT / "netlists" / "sweeps" / "buck_monte_carlo.cir"

# A synchronous buck's power stage: an ideal 24 V PWM source into L, C and the load, with
# tolerances (10 %, 3 sigma) drawn by ngspice's agauss. Short run, few steps, ideal edges on the
# step grid (one step size: one factorisation per run): 200 runs stay fast.
POWER_STAGE = """Synchronous buck power stage with tolerances on L, C and the load
.options seed=17
.param L=agauss(100u, 10u, 3) C=agauss(100u, 10u, 3) Rl=agauss(5, 0.5, 3)
Vsw sw 0 PULSE(0 24 0 0 0 5u 10u)
L1 sw out {L} ic=2.4
C1 out 0 {C} ic=12
Rload out 0 {Rl}
.tran 1u 40u uic
.end
"""
RIPPLE = "ripple(v(out), 20u, 40u)"


# ---------------------------------------------------------------- parameters in

def test_params_override_param_lines_and_reach_subcircuits():
    text = """params reach subcircuit bodies
.param R=1k
.subckt div a b
.param rlow=500
R1 a b {R}
R2 b 0 {rlow}
.ends
V1 in 0 DC 3
X1 in out div
.tran 1u 2u
.end
"""
    default = circuitnsds.read_netlist(text)
    changed = circuitnsds.read_netlist(text, params={"R": 2e3, "RLOW": 2e3})
    assert default.element("x1.r1").resistance == 1e3 and default.element("x1.r2").resistance == 500
    assert changed.element("x1.r1").resistance == 2e3 and changed.element("x1.r2").resistance == 2e3
    # the divider's output, computed from the values (1/2 of 3 V)
    assert changed.operating_point()["v(out)"] == pytest.approx(1.5)


def test_duty_override_sets_the_gate_pulse():
    for duty in (0.25, 0.6):
        circuit = circuitnsds.read_netlist(BUCK, params={"d": duty})
        pulse = circuit.element("vgate").function
        # above VT = 2.5 V for PW + (TR + TF)/2 = D/fsw
        assert pulse.width + (pulse.rise + pulse.fall) / 2 == pytest.approx(duty * 10e-6)


def test_an_unused_parameter_is_warned_about():
    with pytest.warns(NetlistWarning, match="'dutty' is given, and the netlist neither defines nor uses"):
        circuitnsds.read_netlist(BUCK, params={"dutty": 0.3})


def test_a_builder_reads_once_and_builds_many():
    builder = CircuitBuilder.load(BUCK)
    source = builder.source()
    rebuilt = CircuitBuilder.from_source(source)  # what a worker does: no file read
    for duty in (0.3, 0.7):
        a, b = builder.build({"D": duty}), rebuilt.build({"D": duty})
        assert a.element("vgate").function == b.element("vgate").function
    # messages still name the original file and line
    assert source.locations[0] == (str(BUCK), 4)


# ---------------------------------------------------------------- .func, if, ternary

def test_func_if_and_ternary_in_a_netlist():
    text = """.func and if()
.func par(a, b) {a*b/(a+b)}
.func clamp(x, lo, hi) {x < lo ? lo : (x > hi ? hi : x)}
.param r=par(2k, 2k) big=if(r >= 1k, 1, 0) c=clamp(5, 1, 3) z=0
.param safe={z != 0 ? 1/z : 7} both={(1 < 2) && !(2 < 1) || 0}
R1 a 0 {r}
R2 a 0 {1k*(big + c + safe + both)}
V1 a 0 DC 1
.tran 1u 2u
.end
"""
    circuit = circuitnsds.read_netlist(text)
    assert circuit.element("r1").resistance == 1000.0
    assert circuit.element("r2").resistance == 1000.0 * (1 + 3 + 7 + 1)


@pytest.mark.parametrize("text, value", [
    ("1 < 2", 1.0), ("2 <= 2", 1.0), ("3 > 4", 0.0), ("1 == 1", 1.0), ("1 != 1", 0.0),
    ("!0", 1.0), ("!3", 0.0), ("1 && 0", 0.0), ("0 || 2", 1.0), ("1 ? 2 : 3", 2.0),
    ("0 ? 2 : 0 ? 3 : 4", 4.0), ("if(0, 1/0, 5)", 5.0), ("ternary_fcn(1, 6, 1/0)", 6.0),
    ("1 + 2 > 2 ? 10 : 20", 10.0), ("-1 < 0", 1.0),
])
def test_conditions(text, value):
    assert evaluate(text) == value


def test_func_errors():
    with pytest.raises(ExpressionError, match=r"f\(\) takes 1 argument, got 2"):
        evaluate("f(1, 2)", functions={"f": _function("f", ("x",), "x")})
    with pytest.raises(ExpressionError, match="calls itself"):
        evaluate("f(1)", functions={"f": _function("f", ("x",), "f(x)")})
    with pytest.raises(NetlistError, match=r"x.cir:2: \.func f: argument 'a' is named twice"):
        circuitnsds.read_netlist(_file("t\n.func f(a, a) {a}\nR1 1 0 1\n.tran 1u 2u\n"))


def _function(name, parameters, body):
    from circuitnsds.netlist.expressions import UserFunction

    return UserFunction(name, parameters, body)


def _file(text: str) -> Path:
    import tempfile

    path = Path(tempfile.mkdtemp()) / "x.cir"
    path.write_text(text)
    return path


# ---------------------------------------------------------------- the random functions

# ngspice manual, "Using random param(eters)": agauss(nom, avar, sigma) is nom plus a Gaussian
# draw of standard deviation avar/sigma; gauss the same with avar = nom*rvar; aunif(nom, avar)
# uniform in +-avar; unif(nom, rvar) uniform in +-nom*rvar; limit(nom, avar) nom +- avar.
# LTspice: mc(x, tol) uniform between x(1-tol) and x(1+tol).
N_DRAWS = 20000


def draws(text: str) -> np.ndarray:
    generator = point_generator(5, 0)
    return np.array([evaluate(text, random=generator) for _ in range(N_DRAWS)])


@pytest.mark.parametrize("text, mean, std, low, high", [
    ("agauss(1, 0.3, 3)", 1.0, 0.1, None, None),
    ("gauss(2, 0.15, 3)", 2.0, 0.1, None, None),
    ("aunif(1, 0.5)", 1.0, 0.5 / math.sqrt(3), 0.5, 1.5),
    ("unif(10, 0.1)", 10.0, 1.0 / math.sqrt(3), 9.0, 11.0),
    ("mc(10, 0.1)", 10.0, 1.0 / math.sqrt(3), 9.0, 11.0),
    ("gauss(0.2)", 0.0, 0.2, None, None),
])
def test_random_functions_have_the_documented_distributions(text, mean, std, low, high):
    values = draws(text)
    # sampling error of the mean is std/sqrt(N) = 0.7 % of std; 5 of those is a safe bound
    assert values.mean() == pytest.approx(mean, abs=5 * std / math.sqrt(N_DRAWS))
    assert values.std() == pytest.approx(std, rel=0.03)
    if low is not None:
        assert low <= values.min() and values.max() < high


def test_limit_takes_either_end():
    values = draws("limit(1, 0.25)")
    assert set(np.unique(values)) == {0.75, 1.25}
    assert abs((values > 1).mean() - 0.5) < 0.02


def test_a_param_is_drawn_once_a_call_each_time():
    text = """draws
.param x=agauss(1k, 100, 1)
R1 a 0 {x}
R2 a 0 {x}
R3 a 0 {agauss(1k, 100, 1)}
R4 a 0 {agauss(1k, 100, 1)}
V1 a 0 DC 1
.tran 1u 2u
.end
"""
    circuit = circuitnsds.read_netlist(text)
    r = [circuit.element(f"r{k}").resistance for k in range(1, 5)]
    assert r[0] == r[1] and len({r[0], r[2], r[3]}) == 3
    again = circuitnsds.read_netlist(text)  # same seed (default 1), same point: same draws
    assert [again.element(f"r{k}").resistance for k in range(1, 5)] == r
    other = circuitnsds.read_netlist(text, random=point_generator(1, 1))
    assert other.element("r1").resistance != r[0]
    # the default (created only when first drawn from) is point 0 of the default seed 1
    point0 = circuitnsds.read_netlist(text, random=point_generator(1, 0))
    assert [point0.element(f"r{k}").resistance for k in range(1, 5)] == r


@pytest.mark.parametrize("drawn_first", [False, True])
def test_lazy_generator_copies_and_pickles_as_the_generator_it_stands_for(drawn_first):
    """The default Monte Carlo generator (numpy.random created on first use) survives
    copy.deepcopy and pickle (a dask worker, a copied scope) and keeps drawing what
    point_generator(seed, index) draws."""
    import copy
    import pickle

    lazy, reference = LazyGenerator(3, 2), point_generator(3, 2)
    if drawn_first:
        assert lazy.standard_normal() == reference.standard_normal()
    for clone in (copy.deepcopy(lazy), pickle.loads(pickle.dumps(lazy))):
        assert clone.standard_normal(4).tolist() == copy.deepcopy(reference).standard_normal(4).tolist()


# ---------------------------------------------------------------- .step and --param

# The examples of LTspice's help, ".STEP -- Parameter Sweeps"
# (ltspicehelpmanual.azurewebsites.net/STEP--ParameterSweeps.htm): .step param RLOAD LIST 5 10 15,
# .step oct v1 1 20 5, .step I1 10u 100u 10u, .step NPN 2N2222(VAF) 50 100 25, .step temp -55 125 10.
STEPPED = """stepped RC
.param rload=1k c=1u
.step param RLOAD LIST 5 10 15
.step dec param c 1u 100u 2
V1 in 0 PULSE(0 1 0 1u 1u 1m 2m)
R1 in out {rload}
C1 out 0 {c}
.tran 1u 20u
.end
"""


def test_step_lines_in_ltspice_syntax_parse_and_nest():
    builder = CircuitBuilder.load(STEPPED)
    assert [s.name for s in builder.steps] == ["RLOAD", "c"]
    assert builder.steps[0].values == (5.0, 10.0, 15.0)
    assert builder.steps[1].values == pytest.approx(tuple(10 ** (-6 + k / 2) for k in range(5)))
    table = circuitnsds.sweep(STEPPED, workers=0, measure=["max(v(out))"])
    assert list(table["RLOAD"]) == [5, 5, 5, 5, 5, 10, 10, 10, 10, 10, 15, 15, 15, 15, 15]
    assert list(table["c"][:5]) == list(builder.steps[1].values)
    assert (table["status"] == "ok").all()
    # an RC low-pass charged for 20 us from a 1 V step: the output stays in [0, 1] and is the
    # lower the longer the time constant
    assert table["max(v(out))"].between(0, 1).all()
    tau = (table["RLOAD"] * table["c"]).to_numpy()
    by_tau = table["max(v(out))"].to_numpy()[np.argsort(tau)]
    assert np.all(np.diff(by_tau) < 0)


@pytest.mark.parametrize("line, message", [
    (".step oct v1 1 20 5", "only parameters are stepped"),
    (".step I1 10u 100u 10u", "only parameters are stepped"),
    (".step NPN 2N2222(VAF) 50 100 25", "only parameters are stepped"),
    (".step temp -55 125 10", "only parameters are stepped"),
    (".step param x 1 10 -1", "goes away from the stop value"),
    (".step param x 1 10 0", "the increment is 0"),
    (".step dec param x 0 10 5", "positive start and stop"),
    (".step param x 1 2", "expected START STOP INCR, got 2 values"),
    (".step param x list", "list has no values"),
    (".step param x file=values.txt", "values from a file are not read"),
])
def test_step_errors(line, message):
    with pytest.raises(NetlistError, match=message):
        CircuitBuilder.load(f"t\n.param x=1\n{line}\nR1 a 0 {{x}}\n.tran 1u 2u\n")


def test_the_bundled_monte_carlo_netlist_is_200_seeded_runs():
    builder = CircuitBuilder.load(MONTE_CARLO)
    assert [(s.name, s.values) for s in builder.steps] == [("run", tuple(float(k) for k in range(1, 201)))]
    assert builder.seed == 17
    first, second = (builder.build({"run": k + 1}, point_generator(17, k)) for k in range(2))
    assert first.element("l1").inductance != second.element("l1").inductance


def test_step_param_lin_includes_the_stop_value():
    builder = CircuitBuilder.load("t\n.param r=1\n.step param R 1k 10k 1k\nR1 a 0 {r}\n.tran 1u 2u\n")
    values = builder.steps[0].values
    assert len(values) == 10 and values[0] == 1e3 and values[-1] == 1e4
    # the kind may follow the name (.STEP PARAM <variable> DEC ..., as other readers write it)
    builder = CircuitBuilder.load("t\n.param r=1\n.step param R dec 1 100 1\nR1 a 0 {r}\n.tran 1u 2u\n")
    assert builder.steps[0].values == (1.0, 10.0, 100.0)


@settings(max_examples=200, deadline=None)
@given(start=st.floats(-1e6, 1e6, allow_nan=False), stop=st.floats(-1e6, 1e6, allow_nan=False),
       count=st.integers(2, 500))
def test_param_range_has_count_values_and_both_ends(start, stop, count):
    step = parse_param_option(f"Duty={start!r}:{stop!r}:{count}")
    assert step.name == "Duty" and len(step.values) == count
    assert step.values[0] == start and step.values[-1] == stop
    differences = np.diff(step.values)
    assert np.all(differences >= 0) if stop >= start else np.all(differences <= 0)


@settings(max_examples=200, deadline=None)
@given(values=st.lists(st.floats(-1e12, 1e12, allow_nan=False), min_size=1, max_size=20))
def test_param_list_gives_the_values_written(values):
    step = parse_param_option("r_1=" + ",".join(repr(v) for v in values))
    assert step.values == tuple(values)


@settings(max_examples=200, deadline=None)
@given(start=st.floats(-1e3, 1e3, allow_nan=False), increment=st.floats(1e-3, 1e3),
       count=st.integers(1, 300), up=st.booleans())
def test_step_linear_values_land_on_the_stop_value(start, increment, count, up):
    sign = 1 if up else -1
    stop = start + sign * increment * (count - 1)
    values = linear_values(start, stop, sign * increment)
    assert len(values) == count and values[0] == start
    assert values[-1] == pytest.approx(stop, abs=1e-9 * increment * count)


@settings(max_examples=100, deadline=None)
@given(text=st.text(max_size=30))
def test_param_option_refuses_or_reads(text):
    try:
        step = parse_param_option(text)
    except StepSyntaxError:
        return
    assert step.values and all(math.isfinite(v) for v in step.values)


@settings(max_examples=100, deadline=None)
@given(values=st.lists(st.floats(-1e12, 1e12, allow_nan=False), min_size=1, max_size=10),
       name=st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,8}", fullmatch=True),
       keyword=st.sampled_from(["list", "LIST", "List"]))
def test_step_list_lines_give_the_values_and_the_name_as_written(values, name, keyword):
    line = f".step param {name} {keyword} " + " ".join(repr(v) for v in values)
    builder = CircuitBuilder.load(f"t\n{line}\nR1 a 0 {{{name}}}\n.tran 1u 2u\n")
    assert builder.steps[0].name == name and builder.steps[0].values == tuple(values)


def test_param_option_errors():
    for text, message in [("D", "expected NAME=START"), ("D=", "no values"), ("1D=3", "expected NAME"),
                          ("D=1:2", "START:STOP:COUNT"), ("D=1:2:0", "positive integer"),
                          ("D=1:2:1", "one value"), ("D=a,b", "not a number")]:
        with pytest.raises(StepSyntaxError, match=message):
            parse_param_option(text)
    assert count_values(0.2, 0.8, 13)[6] == pytest.approx(0.5)


# ---------------------------------------------------------------- the table

def test_duty_sweep_table_matches_single_runs():
    duties = [0.3, 0.5, 0.7]
    expressions = ["mean(v(out), 1.5m, 2m)", "max(i(l1))"]
    table = circuitnsds.sweep(BUCK, {"D": duties}, measure=expressions, workers=0, stop=2e-3)
    assert list(table.columns) == ["D", *expressions, "status", "error", "warnings"]
    assert list(table["D"]) == duties and (table["status"] == "ok").all()
    for row, duty in zip(table.itertuples(index=False), duties):
        circuit = circuitnsds.read_netlist(BUCK, params={"D": duty})  # the plain way, one by one
        waves = circuit.transient()
        assert row[1] == measure.mean(waves, "v(out)", 1.5e-3, 2e-3)
        assert row[2] == measure.maximum(waves, "i(l1)")
        # ideal buck, continuous conduction: the mean output is D * 24 V (within the settling)
        assert row[1] == pytest.approx(24 * duty, rel=0.03)


def test_a_pss_sweep_measures_the_settled_period():
    table = circuitnsds.sweep(BUCK, {"D": [0.3, 0.6]}, analysis="pss", measure=["mean(v(out))"],
                              workers=0)
    assert list(table["status"]) == ["ok", "ok"], list(table["error"])
    # ideal buck in continuous conduction, settled: mean output D * 24 V (switch and diode
    # resistances of 10 mohm and 1 mohm against 5 ohm: < 0.3 %)
    assert list(table["mean(v(out))"]) == pytest.approx([0.3 * 24, 0.6 * 24], rel=0.005)


ILL_POSED = """Voltage source shorted by an ideal switch when G puts its gate above VT
.param G=0
.step param G list 0 1 0.2
Vin in 0 DC 10
Rload in 0 1k
S1 in 0 ctrl 0 smod
Vc ctrl 0 DC {G}
.model smod SW(VT=0.5 VH=0 RON=0 ROFF=1e9)
.tran 1u 10u
.end
"""


def test_a_failing_point_shows_its_error_in_its_row():
    table = circuitnsds.sweep(ILL_POSED, measure=["mean(v(in))"], workers=0)
    assert list(table["status"]) == ["ok", "failed", "ok"]
    assert "no solution" in table["error"][1] and table["error"][0] == table["error"][2] == ""
    assert math.isnan(table["mean(v(in))"][1])
    assert list(table["mean(v(in))"][[0, 2]]) == pytest.approx([10.0, 10.0], rel=1e-12)
    assert "loop of voltage sources and switches" in table["warnings"][1]


def test_bad_arguments_are_clear_errors():
    with pytest.raises(CircuitError, match="neither defines nor uses the swept parameter"):
        circuitnsds.sweep(BUCK, {"duty": [0.1]}, workers=0)
    with pytest.raises(CircuitError, match="unknown analysis 'ac'"):
        circuitnsds.sweep(BUCK, {"D": [0.1]}, analysis="ac", workers=0)
    if not hasattr(circuitnsds.Circuit, "pss"):
        with pytest.raises(CircuitError, match="analysis 'pss' is not available"):
            circuitnsds.sweep(BUCK, {"D": [0.1]}, analysis="pss", workers=0)
    else:
        with pytest.raises(CircuitError, match="analysis 'pss' takes no stop"):
            circuitnsds.sweep(BUCK, {"D": [0.1]}, analysis="pss", stop=1e-3, workers=0)
    with pytest.raises(CircuitError, match="scheduler and workers are both given"):
        circuitnsds.sweep(BUCK, {"D": [0.1]}, scheduler="tcp://127.0.0.1:9", workers=0)
    with pytest.raises(circuitnsds.CircuitnsdsError, match="cannot read the measurement"):
        circuitnsds.sweep(BUCK, {"D": [0.1]}, measure=["average v(out)"], workers=0)


def test_waveforms_kept_or_written(tmp_path):
    table = circuitnsds.sweep(POWER_STAGE, {"run": [1, 2]}, signals=["v(out)"], keep_waveforms=True,
                              workers=0)
    waves = table["waveforms"][1]
    assert waves.names == ["v(out)"] and waves.time[-1] == pytest.approx(40e-6)
    written = circuitnsds.sweep(POWER_STAGE, {"run": [1, 2]}, keep_waveforms=tmp_path / "w", workers=0)
    assert [Path(f).name for f in written["file"]] == ["point_0000.csv", "point_0001.csv"]
    header = Path(written["file"][1]).read_text().splitlines()[0]
    assert header.startswith("time,") and "v(out)" in header


def test_signals_without_waveforms_and_a_waveforms_file_are_errors_before_the_run(tmp_path, capsys):
    # before: signals without keep_waveforms were dropped without a word (--signals v(zz) ran and
    # exited 0), and --waveforms naming a file ran every point, then crashed in mkdir
    # (FileExistsError, exit status 2)
    from circuitnsds.cli.main import main

    with pytest.raises(CircuitError, match="signals select the waveforms kept.*none are kept"):
        circuitnsds.sweep(BUCK, {"D": [0.5]}, signals=["v(out)"], workers=0)
    a_file = tmp_path / "taken"
    a_file.write_text("")
    with pytest.raises(circuitnsds.CircuitnsdsError, match=f"cannot write {a_file}: not a folder"):
        circuitnsds.sweep(BUCK, {"D": [0.5]}, keep_waveforms=a_file, workers=0)
    base = ["sweep", str(BUCK), "--param", "D=0.5", "--workers", "0", "-q", "--stop", "20u"]
    assert main([*base, "--signals", "v(out)"]) == 1
    assert "error: --signals: signals select the waveforms kept" in capsys.readouterr().err
    assert main([*base, "--waveforms", str(a_file)]) == 1
    assert f"error: {a_file}: --waveforms {a_file} is a file, not a folder" in capsys.readouterr().err
    assert a_file.read_text() == ""


def test_a_negative_seed_is_refused_before_the_run():
    # before: every point failed with "internal error: ValueError: the seed and the point index
    # are non-negative integers"
    with pytest.raises(CircuitError, match="seed=-1 must be a non-negative integer"):
        circuitnsds.sweep(BUCK, {"D": [0.5]}, seed=-1, workers=0, stop=20e-6)


def test_points_need_no_file_includes_are_shipped_resolved(tmp_path):
    (tmp_path / "models.lib").write_text(".model dfree D(Ron=1m)\n.param Rl=5\n")
    netlist = tmp_path / "top.cir"
    netlist.write_text(BUCK.read_text().replace(".model dfree D(Ron=1m)", ".include models.lib")
                       .replace(" Rl=5", ""))
    builder = CircuitBuilder.load(netlist)
    (tmp_path / "models.lib").unlink()  # the points must not read it
    table = circuitnsds.sweep(builder, {"D": [0.5]}, measure=["mean(v(out), 1.5m, 2m)"], workers=0)
    assert list(table["status"]) == ["ok"]
    assert table["mean(v(out), 1.5m, 2m)"][0] == pytest.approx(12.0, rel=0.03)
    bad = circuitnsds.sweep(builder, {"D": [0.5]}, signals=["v(nowhere)"], keep_waveforms=True,
                            workers=0, stop=20e-6)
    assert "unknown signal(s) v(nowhere)" in bad["error"][0] and "available: v(in)" in bad["error"][0]


# ---------------------------------------------------------------- Monte Carlo

def test_monte_carlo_200_runs_equal_a_plain_loop_over_the_same_seeds():
    table = circuitnsds.sweep(POWER_STAGE, samples=200, measure=[RIPPLE], workers=0)
    assert list(table["run"]) == list(range(1, 201)) and (table["status"] == "ok").all()
    assert table.attrs["seed"] == 17  # .options seed
    reference = []
    for index in range(200):  # the plain way: one circuit per run, the generator of its index
        circuit = circuitnsds.read_netlist(POWER_STAGE, random=point_generator(17, index))
        reference.append(measure.ripple(circuit.transient(), "v(out)", 20e-6, 40e-6))
    ripple = table[RIPPLE].to_numpy()
    assert ripple.tolist() == reference
    assert ripple.mean() == np.mean(reference) and ripple.std() == np.std(reference)
    assert len(set(reference)) == 200  # every run drew its own L, C and load


def test_same_seed_same_table_other_seed_other_table():
    first = circuitnsds.sweep(POWER_STAGE, samples=5, measure=[RIPPLE], workers=0, seed=3)
    again = circuitnsds.sweep(POWER_STAGE, samples=5, measure=[RIPPLE], workers=0, seed=3)
    other = circuitnsds.sweep(POWER_STAGE, samples=5, measure=[RIPPLE], workers=0, seed=4)
    assert first.equals(again)
    assert not np.any(first[RIPPLE].to_numpy() == other[RIPPLE].to_numpy())


# ---------------------------------------------------------------- Dask

def test_import_and_run_do_not_import_dask(tmp_path):
    arguments = ["run", str(BUCK), "--stop", "20u", "-q", "-o", str(tmp_path / "a.csv")]
    code = ("import sys, circuitnsds\n"
            "from circuitnsds.cli.main import main\n"
            f"assert main({arguments!r}) == 0\n"
            "print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('dask', 'distributed', 'pandas'))))\n")
    output = subprocess.run([sys.executable, "-c", "import json\n" + code], capture_output=True, text=True,
                            env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120, check=True)
    assert json.loads(output.stdout.strip().splitlines()[-1]) == []


def _start(arguments: list[str], log: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    handle = log.open("w")
    return subprocess.Popen([sys.executable, "-m", *arguments], stdout=handle, stderr=subprocess.STDOUT,
                            env=env, start_new_session=True)


def test_a_real_dask_cluster_gives_the_in_process_table_bit_for_bit(tmp_path):
    from distributed import Client

    with socket.socket() as probe:  # a free port, so that workers start with the scheduler
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    processes = [_start(["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
                         "--no-dashboard"], tmp_path / "s.log")]
    try:
        for k in range(2):  # they retry until the scheduler listens
            processes.append(_start(["distributed.cli.dask_worker", address, "--nthreads", "1",
                                     "--nworkers", "1", "--no-dashboard", "--host", "127.0.0.1"],
                                    tmp_path / f"w{k}.log"))
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        arguments = dict(params={"run": list(range(1, 11)), "Rl": [2.0, 5.0]},
                         measure=[RIPPLE, "mean(v(out))"])
        remote = circuitnsds.sweep(POWER_STAGE, scheduler=address, **arguments)
        local = circuitnsds.sweep(POWER_STAGE, workers=0, **arguments)
        assert len(remote) == 20 and (remote["status"] == "ok").all()
        assert remote.equals(local)  # same values to the last bit, same order, same strings
        with Client(address) as client:  # both workers took part, each parsed the netlist once
            calls = client.run(lambda: __import__("circuitnsds.sweeps.task").sweeps.task.builder_for
                               .cache_info()[:2])
        assert len(calls) == 2 and all(misses == 1 for hits, misses in calls.values()), calls
        assert sum(hits + misses for hits, misses in calls.values()) == 20, calls
    finally:
        for process in reversed(processes):
            if process.poll() is None:
                process.terminate()
        for process in reversed(processes):
            try:
                process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(timeout=5)


def test_the_default_local_cluster_gives_the_in_process_table(tmp_path):
    # a script without a __main__ guard: on Linux the workers are forked, not re-imported
    script = tmp_path / "script.py"
    script.write_text(
        "import circuitnsds, json\n"
        f"power_stage = {POWER_STAGE!r}\n"
        "arguments = dict(params={'run': [1, 2, 3, 4]}, measure=['ripple(v(out), 20u, 40u)'])\n"
        "local = circuitnsds.sweep(power_stage, workers=2, **arguments)\n"
        "serial = circuitnsds.sweep(power_stage, workers=0, **arguments)\n"
        "print(json.dumps([local.equals(serial), list(local['status'])]))\n")
    output = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300,
                            env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert output.returncode == 0, output.stderr[-2000:]
    assert json.loads(output.stdout.strip().splitlines()[-1]) == [True, ["ok"] * 4]


def test_an_unreachable_scheduler_is_a_clear_error(monkeypatch):
    from circuitnsds.sweeps import execute
    from circuitnsds.sweeps.execute import ExecutorError

    monkeypatch.setattr(execute, "CONNECT_TIMEOUT", 1.0)

    with pytest.raises(ExecutorError, match="cannot reach the Dask scheduler at tcp://127.0.0.1:9"):
        circuitnsds.sweep(POWER_STAGE, {"run": [1]}, scheduler="tcp://127.0.0.1:9")


# ---------------------------------------------------------------- command line

def test_cli_sweep_writes_the_table_and_the_figure(tmp_path, capsys):
    from circuitnsds.cli.main import main

    table, figure = tmp_path / "t.csv", tmp_path / "t.png"
    status = main(["sweep", str(BUCK), "--param", "D=0.2:0.8:3", "--param", "Rl=2,5", "--measure",
                   "mean(v(out), 1.5m, 2m)", "--workers", "0", "-o", str(table), "--plot", str(figure),
                   "--stop", "2m"])
    assert status == 0
    lines = table.read_text().splitlines()
    assert lines[0] == 'D,Rl,"mean(v(out), 1.5m, 2m)",status,error,warnings'
    assert [line.split(",")[:2] for line in lines[1:]] == [["0.2", "2"], ["0.2", "5"], ["0.5", "2"],
                                                          ["0.5", "5"], ["0.8", "2"], ["0.8", "5"]]
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "mean(v(out), 1.5m, 2m)" in capsys.readouterr().out


def test_cli_run_on_a_step_netlist_is_a_sweep_and_fails_with_the_failed_points(tmp_path, capsys):
    from circuitnsds.cli.main import main

    path = tmp_path / "ill.cir"
    path.write_text(ILL_POSED)
    status = main(["run", str(path), "--measure", "mean(v(in))", "--workers", "0", "-o",
                   str(tmp_path / "t.csv"), "-q"])
    assert status == 1
    captured = capsys.readouterr()
    assert "1 of 3 points failed" in captured.err
    assert "failed" in captured.out and "no solution" in captured.out
    import pandas as pd

    written = pd.read_csv(tmp_path / "t.csv", keep_default_na=False)
    assert list(written["status"]) == ["ok", "failed", "ok"] and "no solution" in written["error"][1]


def test_cli_run_on_a_step_netlist_refuses_every_option_that_has_no_table_meaning(tmp_path, capsys):
    # before: --events, --losses, --tstart, --tstop, --every, --mark-events and --ascii were
    # dropped without a word on a netlist whose .step lines make `run` a sweep (exit 0)
    from circuitnsds.cli.main import main

    path = tmp_path / "stepped.cir"
    path.write_text("stepped\n.param R=1\n.step param R 1 2 1\nV1 a 0 1\nR1 a 0 {R}\n"
                    ".tran 1u 10u\n.end\n")
    base = ["run", str(path), "--workers", "0", "-q", "-o", str(tmp_path / "t.csv")]
    for option in (["--events", str(tmp_path / "e.csv")], ["--losses-csv", str(tmp_path / "l.csv")],
                   ["--tstart", "1u"],
                   ["--tstop", "5u"], ["--every", "2"], ["--mark-events"], ["--ascii"],
                   ["-r", str(tmp_path / "t.raw")], ["--uic"]):
        assert main([*base, *option]) == 1, option
        err = capsys.readouterr().err
        assert f"error: {path}: {option[0]}" in err and "not available when .step lines make" in err
    assert not (tmp_path / "t.csv").exists()
    assert main([*base, "--measure", "mean(i(r1))"]) == 0
    assert main([*base, "--losses"]) == 0  # issue 35: a column per loss figure
    assert "losses_W" in (tmp_path / "t.csv").read_text().splitlines()[0]


def test_cli_table_to_standard_output_with_dash(tmp_path, capsys, monkeypatch):
    # before: `-o -` wrote the table to a file named "-" in the current folder
    from circuitnsds.cli.main import main

    monkeypatch.chdir(tmp_path)
    path = tmp_path / "stepped.cir"
    path.write_text("stepped\n.param R=1\n.step param R 1 2 1\nV1 a 0 1\nR1 a 0 {R}\n"
                    ".tran 1u 10u\n.end\n")
    for argv in (["run", str(path)], ["sweep", str(path), "--param", "R=1,2"]):
        assert main([*argv, "--workers", "0", "-q", "--measure", "mean(i(r1))", "-o", "-"]) == 0
        captured = capsys.readouterr()
        assert captured.out.splitlines() == ["R,mean(i(r1)),status,error,warnings", "1,1,ok,,",
                                             "2,0.5,ok,,"]
        assert "mean(i(r1))" in captured.err  # the table for people, on stderr
        assert sorted(p.name for p in tmp_path.iterdir()) == ["stepped.cir"]


def test_cli_run_on_a_step_netlist_obeys_strict_and_prints_each_warning_whole(tmp_path, capsys):
    # before: --strict was ignored (the points' warnings printed, exit 0, table written), and a
    # warning holding "; " was cut in two lines (the points' warnings were joined with "; ")
    from circuitnsds.cli.main import main

    path = tmp_path / "stepped.cir"
    path.write_text("stepped\n.param R=1\n.step param R 1 2 1\nV1 a 0 1\nR1 a 0 {R}\n"
                    ".print tran v(a)\n.tran 1u 10u\n.end\n")
    base = ["run", str(path), "--workers", "0", "-q", "--measure", "mean(i(r1))", "-o",
            str(tmp_path / "t.csv")]
    assert main(base) == 0
    err = capsys.readouterr().err
    warning = [line for line in err.splitlines() if "warning" in line]
    assert len(warning) == 1 and warning[0].endswith("choose columns with --signals or .save): "
                                                     ".print tran v(a)")
    (tmp_path / "t.csv").unlink()
    assert main([*base, "--strict"]) == 1
    err = capsys.readouterr().err
    assert "error: the warnings above are errors under --strict" in err
    assert not (tmp_path / "t.csv").exists()


def test_cli_monte_carlo_histogram(tmp_path):
    from circuitnsds.cli.main import main

    path = tmp_path / "mc.cir"
    path.write_text(POWER_STAGE)
    figure = tmp_path / "mc.png"
    assert main(["sweep", str(path), "--samples", "8", "--measure", RIPPLE, "--workers", "0",
                 "--plot", str(figure), "-q"]) == 0
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_bad_param_is_a_usage_error(capsys):
    from circuitnsds.cli.main import main

    with pytest.raises(SystemExit) as info:
        main(["sweep", str(BUCK), "--param", "D=0.2:0.8"])
    assert info.value.code == 2
    assert "a range is START:STOP:COUNT" in capsys.readouterr().err


def test_a_shipped_netlist_keeps_its_control_block_warning():
    text = "t\nR1 a 0 1k\nV1 a 0 DC 1\n.control\nrun\nplot v(a)\n.endc\n.tran 1u 2u\n.end\n"
    builder = CircuitBuilder.from_source(CircuitBuilder.load(text).source())
    with pytest.warns(NetlistWarning, match=r"\.control script: plot \(line 6\) not executed"):
        builder.build()


def test_the_progress_bar_counts_finished_points():
    import io

    from circuitnsds.cli.progress import CountBar, format_count

    assert format_count(5, 20, 10.0).split("  ")[1:] == ["25%", "5/20 points", "0.5 points/s", "30 s left"]
    ticks = iter([0.0, 2.0, 4.0])
    stream = io.StringIO()
    bar = CountBar(stream, enabled=True, delay=1.0, clock=lambda: next(ticks))
    bar(1, 2)  # 2 s after the start: drawn
    bar(2, 2)
    bar.close()
    lines = stream.getvalue().split("\r")
    assert "1/2 points" in lines[1] and "2/2 points" in lines[2] and stream.getvalue().endswith("\n")


def test_waveforms_to_standard_output_is_refused_before_the_run(tmp_path, capsys, monkeypatch):
    # before: sweep --waveforms - ran every point and wrote them into a folder named "-"
    from circuitnsds.cli.main import main

    monkeypatch.chdir(tmp_path)
    base = ["sweep", str(BUCK), "--param", "D=0.5", "--workers", "0", "-q", "--stop", "20u"]
    assert main([*base, "--waveforms", "-"]) == 1
    err = capsys.readouterr().err
    assert "--waveforms cannot go to standard output ('-')" in err and "give --waveforms a path" in err
    assert not (tmp_path / "-").exists()
    assert main([*base, "-o", "same", "--waveforms", "same"]) == 1
    assert "-o and --waveforms name the same file" in capsys.readouterr().err
    assert not (tmp_path / "same").exists()
