"""The examples run (fast settings), write their figures, and agree with the textbook estimates."""

import importlib.util
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_fast(name: str, tmp_path: Path):
    figure = tmp_path / f"{name}.png"
    rows = load(name).main(["--fast", "--out", str(figure)])
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return rows


def test_the_examples_are_there():
    # (the ngspice comparison example is tested with the comparison itself)
    expected = {"ripple_vs_capacitance", "buck_duty_sweep", "zener_line_regulation"}
    assert expected <= {p.stem for p in EXAMPLES.glob("*.py")}


def test_bridge_ripple_follows_the_textbook_estimate():
    rows = load("ripple_vs_capacitance").ripple_table([220e-6, 470e-6, 1000e-6])
    ripples = [ripple for _, _, ripple, _ in rows]
    assert ripples == sorted(ripples, reverse=True)
    for _, mean, ripple, estimate in rows:
        # the estimate ignores the conduction interval, so it is a little pessimistic
        assert ripple == pytest.approx(estimate, rel=0.15)
        assert ripple < estimate
        # peak of 325 V less two diode drops (2 x 0.8 V) and the ohmic drops
        assert 300 < mean < 325 - 1.6


def test_ripple_example_fast(tmp_path):
    rows = run_fast("ripple_vs_capacitance", tmp_path)
    ripples = [ripple for _, _, ripple, _ in rows]
    assert ripples == sorted(ripples, reverse=True)
    for _, _, ripple, estimate in rows:
        assert ripple == pytest.approx(estimate, rel=0.2)


def test_buck_example_fast(tmp_path):
    rows = run_fast("buck_duty_sweep", tmp_path)
    assert [r["duty"] for r in rows] == [0.25, 0.5, 0.75]
    for r in rows:
        assert r["vout"] < r["duty"] * 12.0  # losses: diode drop, resistances
        assert r["vout"] == pytest.approx(r["duty"] * 12.0, rel=0.2)
        assert r["ripple"] == pytest.approx(r["ripple_estimate"], rel=0.05)
        assert r["efficiency"] == pytest.approx(r["efficiency_estimate"], abs=0.015)
    efficiencies = [r["efficiency"] for r in rows]
    assert efficiencies == sorted(efficiencies) and 0.75 < efficiencies[0] < efficiencies[-1] < 1


def test_zener_example_fast(tmp_path):
    rows = run_fast("zener_line_regulation", tmp_path)
    for r in rows:
        assert r["regulation"] == pytest.approx(r["regulation_estimate"], rel=1e-3)
        assert r["knee"] == pytest.approx(r["knee_estimate"], abs=0.1)  # 0.05 V input steps
        assert 5.1 < r["vout_at_12"] < 5.6
