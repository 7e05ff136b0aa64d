"""Property tests: mutated netlists only ever raise circuitnsds's own errors.

The mutations and the checks are those of ``benchmarks/fuzz.py`` (which runs 10 000
cases); here hypothesis runs a few hundred, with shorter "very long" lines so that
the suite stays fast. A failure prints the mutated input (hypothesis shrinks it).
"""

import random
import subprocess
import sys

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmarks.fuzz import corpus, make_case, run_case
from tests.conftest import NETLISTS

SEEDS = corpus()
SHORT_REPEATS = (100, 2000)


@pytest.fixture(scope="module")
def case_dir(tmp_path_factory):
    directory = tmp_path_factory.mktemp("fuzz")
    for lib in NETLISTS.glob("*.lib"):
        (directory / lib.name).write_bytes(lib.read_bytes())
    return directory


@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(rng=st.randoms(use_true_random=False), cli=st.integers(0, 3))
def test_mutated_netlists_raise_only_project_errors(case_dir, rng, cli):
    _, data = make_case(rng, SEEDS, SHORT_REPEATS)
    run_case(data, case_dir, cli=cli == 0)  # AssertionError = finding (see benchmarks/fuzz.py)


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(max_size=400))
def test_random_bytes_raise_only_project_errors(case_dir, data):
    run_case(data, case_dir, cli=True)


@pytest.mark.parametrize("content", [
    b"",
    b"\x00\x01binary\xff",
    b"title\nR1 a 0 " + b"9" * 100_000 + b"\n.end\n",
    b"title\n" + b"R1 a 0 1k " * 50_000 + b"\n.tran 1u 1m\n.end\n",
    b"title\nV1 a 0 SIN(0 nan 50)\nR1 a 0 1k\n.tran 1u 1m\n.end\n",
], ids=["empty", "binary", "huge number", "long line", "nan"])
def test_the_command_never_prints_a_traceback(tmp_path, content):
    path = tmp_path / "case.cir"
    path.write_bytes(content)
    result = subprocess.run([sys.executable, "-m", "circuitnsds", "run", str(path), "-q",
                             "-o", str(tmp_path / "out.csv")], capture_output=True, text=True)
    assert result.returncode == 1
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr
    errors = [line for line in result.stderr.splitlines() if not line.startswith("circuitnsds: warning")]
    assert 1 <= len(errors) <= 2 and errors[0].startswith("circuitnsds: error: ")
    assert all(len(line) <= 500 for line in errors)


def test_the_generator_covers_every_mutation():
    rng = random.Random(1)
    kinds = set()
    for _ in range(400):
        name, data = make_case(rng, SEEDS, SHORT_REPEATS)
        kinds.add("empty" if len(data) < 20 else "binary" if b"\0" in data else "text")
    assert kinds == {"empty", "binary", "text"}
