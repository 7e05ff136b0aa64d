"""The compiled float -> text formatter writes exactly Python's ``repr``: the shortest
decimal that reads back to the same double (circuitnsds/output/floattext.py), in C
(_floattext_native.c, built at install) and compiled by numba alike."""

from __future__ import annotations

import io
import math
import os
import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds import native
from circuitnsds.output import csvfile, floattext

COMPILED = ("native", "numba")
"""The compiled kernels: C (built at install; the tests need it) and numba."""


def _texts(values: np.ndarray, kind: str) -> list[str]:
    text = floattext.csv_bytes(np.asarray(values, dtype=float).reshape(-1, 1), kind=kind).decode("ascii")
    return text.split("\n")[:-1]


def _check(values, kind: str = "native") -> None:
    values = np.asarray(values, dtype=float)
    texts = _texts(values, kind)
    assert len(texts) == values.size
    for x, text in zip(values.tolist(), texts):
        assert text == repr(x), (x.hex(), text)
        if not math.isnan(x):  # reads back bit for bit (the sign of zero included)
            assert struct.pack("<d", float(text)) == struct.pack("<d", x)


def test_the_c_formatter_is_built_and_loaded():
    """The install builds the C kernel (setup.py; CI has gcc): a missing or stale library
    fails here rather than leaving every CSV to numba or Python unnoticed."""
    assert os.environ.get(native.DISABLE_ENV, "1") != "0", f"{native.DISABLE_ENV}=0 is set"
    assert native.library(floattext.NATIVE) is not None, (
        "circuitnsds/output/_floattext_native.c is not built from this source: "
        "pip install -e . (or python setup.py build_ext --inplace)")
    assert floattext.has_native() and floattext.kernel() is floattext.kernel("native")


@pytest.mark.parametrize("kind", COMPILED)
@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=200))
def test_any_doubles_read_back_and_equal_repr(kind, values):
    _check(values, kind)


@pytest.mark.parametrize("kind", COMPILED)
@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 2**64 - 1), min_size=1, max_size=200))
def test_any_bit_patterns(kind, patterns):
    _check(np.array(patterns, dtype=np.uint64).view(np.float64), kind)


def _bits(value: float) -> int:
    return struct.unpack("<Q", struct.pack("<d", value))[0]


_PATTERNS = st.one_of(
    st.integers(0, 2**64 - 1),  # anything: every exponent, nan payloads
    st.integers(0, 2**52 - 1).map(lambda c: c | (2**63 if c % 2 else 0)),  # subnormals, ±0
    st.integers(-325, 308).map(lambda e: _bits(float(10**e) if e >= 0 else 10.0**e)),  # 10^e
    st.tuples(st.integers(-323, 308), st.integers(-2, 2)).map(  # 10^e's neighbours
        lambda t: _bits(float(f"1e{t[0]}")) + t[1] if 0 < _bits(float(f"1e{t[0]}")) + t[1] else 0),
    st.sampled_from([_bits(v) for v in (0.0, -0.0, math.inf, -math.inf, math.nan, -math.nan)]),
    st.integers(0, 2**11 - 1).map(lambda e: (e << 52) | (2**63 if e % 2 else 0)),  # 2^q, c = 2^52
    st.floats(width=32, allow_nan=True).map(_bits),  # float32 values (few significant bits)
    st.integers(-2**53, 2**53).map(lambda n: _bits(float(n))),  # integers
)


@settings(max_examples=300, deadline=None)
@given(st.lists(_PATTERNS, min_size=1, max_size=100))
def test_c_kernel_writes_repr_of_any_double(patterns):
    """The C kernel against ``repr``: random bit patterns, subnormals, powers of ten and
    their neighbours, powers of two (the asymmetric interval), ±0, ±inf, nan, values of
    float32 and integers, in rows of 1-3 columns."""
    values = np.array(patterns, dtype=np.uint64).view(np.float64)
    _check(values)
    columns = 1 + len(patterns) % 3
    rows = values[: values.size // columns * columns].reshape(-1, columns)
    expected = "".join(",".join(repr(v) for v in row) + "\n" for row in rows.tolist())
    assert floattext.csv_bytes(rows, kind="native").decode("ascii") == expected


@pytest.mark.parametrize("kind", COMPILED)
def test_random_bit_patterns(kind):
    """Every exponent and significand (nan and inf patterns included) against ``repr``."""
    bits = np.random.default_rng(19).integers(0, 2**64, size=300_000, dtype=np.uint64, endpoint=False)
    values = bits.view(np.float64).reshape(-1, 3)
    expected = ("%r,%r,%r\n" * values.shape[0]) % tuple(values.ravel().tolist())
    assert floattext.csv_bytes(values, kind=kind).decode("ascii") == expected


@pytest.mark.parametrize("kind", COMPILED)
def test_edge_values(kind):
    tiny = np.arange(1, 3000, dtype=np.uint64).view(np.float64)  # the smallest subnormals
    largest_subnormals = (np.uint64(2**52) - np.arange(1, 1000, dtype=np.uint64)).view(np.float64)
    powers = np.ldexp(1.0, np.arange(-1074, 1024))  # c = 2^52: the asymmetric rounding interval
    around_powers = np.concatenate([np.nextafter(powers, 0), np.nextafter(powers, np.inf)])
    integers = np.arange(-10_000, 10_000, dtype=float)
    decimals = np.array([k / 10.0**j for j in range(1, 25) for k in (1, 3, 7, 9, 11, 123)])
    special = [0.0, -0.0, math.inf, -math.inf, math.nan, 1e16, 1e15, 9999999999999998.0, 1e-4,
               1e-5, 0.0001234, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, 2.0**53 + 2,
               0.1 + 0.2, 1 / 3, 2 / 3, 123456789012345678.0, 1e22, 1e23, 5e-310, 9.5367431640625e-07]
    for values in (tiny, largest_subnormals, powers[np.isfinite(powers)], around_powers, integers,
                   decimals, special, -decimals):
        _check(values, kind)


def test_exponent_tables_are_exact():
    q = np.arange(floattext.Q_MIN, floattext.Q_MAX + 1)
    for fast, exact in zip(floattext.exponent_tables(q), floattext.exact_exponent_tables(q)):
        np.testing.assert_array_equal(fast, exact)


def test_the_three_kernels_match():
    """The kernel's loop and layout run by the interpreter, by numba and by C write the same
    bytes."""
    values = np.array([[0.1, -3.5e-310], [1e300, 12.0], [-0.0, math.nan]])
    assert floattext.csv_bytes(values, kind="python") == floattext.csv_bytes(values, kind="numba") \
        == floattext.csv_bytes(values, kind="native") == b"0.1,-3.5e-310\n1e+300,12.0\n-0.0,nan\n"


def test_the_c_kernel_checks_its_arguments():
    """The C code trusts pointers and sizes: what ctypes would hand it wrongly is refused."""
    block = floattext.kernel("native")
    bits = np.zeros((4, 2), dtype=np.uint64)
    with pytest.raises(ValueError, match="buffer"):
        block(bits, np.empty(4 * 2 * floattext.MAX_CHARS, dtype=np.uint8), *floattext.tables())
    with pytest.raises(ValueError, match="tables"):
        block(bits, np.empty(1000, dtype=np.uint8), *floattext.tables()[:5], floattext.tables()[5][:-1])
    with pytest.raises(ValueError, match="kind"):
        floattext.kernel("fortran")
    strided = np.arange(12.0).reshape(4, 3)[:, ::2].view(np.uint64)  # not contiguous: copied
    buffer = np.zeros(200, dtype=np.uint8)
    end = block(strided, buffer, *floattext.tables())
    assert buffer[:end].tobytes() == b"0.0,2.0\n3.0,5.0\n6.0,8.0\n9.0,11.0\n"


@pytest.mark.parametrize("block_rows", [3, 65_536])
@pytest.mark.parametrize("kind", COMPILED)
def test_both_csv_writers_write_the_same_bytes(monkeypatch, block_rows, kind):
    """A file written by the compiled formatter (C, or numba without it) is the Python
    writer's, byte for byte."""
    monkeypatch.setattr(csvfile, "BLOCK_ROWS", block_rows)
    if kind == "numba":
        monkeypatch.setattr(floattext, "has_native", lambda: False)
    assert floattext.kernel() is floattext.kernel(kind)
    rng = np.random.default_rng(7)
    time = np.cumsum(rng.random(1000) * 1e-7)
    columns = [rng.normal(size=1000) * 10.0 ** rng.integers(-30, 30, size=1000),
               np.round(rng.normal(size=1000), 3), np.full(1000, np.nan)]
    written = []
    for compiled, stream in ((True, io.BytesIO()), (False, io.BytesIO()), (True, io.StringIO())):
        csvfile.write_csv(stream, time, ["v(a)", "i(l1)", "x"], columns, compiled=compiled)
        value = stream.getvalue()
        written.append(value.encode("ascii") if isinstance(value, str) else value)
    assert written[0] == written[1] == written[2]
    lines = written[0].decode("ascii").splitlines()
    assert lines[0] == "time,v(a),i(l1),x" and len(lines) == 1001
    assert lines[1] == ",".join(repr(float(v)) for v in (time[0], columns[0][0], columns[1][0], math.nan))


def test_with_the_c_formatter_any_file_is_compiled(monkeypatch):
    """The C kernel costs nothing to load: even a one-number file uses it, numba's cache or
    warm-up never consulted."""
    from circuitnsds import jit

    monkeypatch.setattr(floattext, "loaded", lambda: False)
    monkeypatch.setattr(csvfile, "_numba_in_use", lambda: False)
    monkeypatch.setattr(floattext, "ready_marker", lambda: pytest.fail("numba's marker consulted"))
    monkeypatch.setattr(jit, "start_warmup", lambda module: pytest.fail("warm-up started"))
    assert csvfile.compiled_pays(1) and csvfile.compiled_pays(10**9)


WRITE_WITHOUT_NUMBA = """
import sys
import numpy as np
from circuitnsds.output.csvfile import CsvStream
from circuitnsds.output.waveforms import Waveforms
rows = 800_000  # 1.6M numbers: more than numba's threshold (COLD_VALUES)
t = np.linspace(0.0, 0.1, rows)
v = 12.0 + 0.3 * np.sin(1e5 * t)
Waveforms(time=t, signals={"v(out)": v}).to_csv(sys.argv[1])
stream = CsvStream(sys.argv[2], ["v(out)"])
stream.expect(rows)
for start in range(0, rows, 300_000):  # streamed: formatted in the background thread
    stream.append(t[start:start + 300_000], [v[start:start + 300_000]])
stream.commit()
print("numba" in sys.modules, stream.compiled)
"""


def test_writing_a_csv_does_not_import_numba(tmp_path):
    """With the C kernel, a CSV written whole or streamed (even a large one) never imports
    numba (its import and load cost ~1 s per process), and holds ``repr`` of each value."""
    import subprocess
    import sys
    from pathlib import Path

    root = str(Path(__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([root, os.environ.get("PYTHONPATH", "")]))
    env.pop(native.DISABLE_ENV, None)
    whole, streamed = tmp_path / "whole.csv", tmp_path / "streamed.csv"
    result = subprocess.run([sys.executable, "-c", WRITE_WITHOUT_NUMBA, str(whole), str(streamed)],
                            capture_output=True, text=True, env=env, cwd=tmp_path, timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["False", "True"], result.stdout + result.stderr
    t = np.linspace(0.0, 0.1, 800_000)
    v = 12.0 + 0.3 * np.sin(1e5 * t)
    expected = "time,v(out)\n" + ("%r,%r\n" * t.size) % tuple(np.column_stack([t, v]).ravel().tolist())
    assert whole.read_text() == streamed.read_text() == expected


def test_the_formatter_is_chosen_by_size(monkeypatch):
    """Without the C kernel, small files never load numba; large ones do only when the
    formatter is cached."""
    monkeypatch.setattr(floattext, "has_native", lambda: False)
    monkeypatch.setattr(floattext, "loaded", lambda: False)
    monkeypatch.setattr(csvfile, "_numba_in_use", lambda: False)
    assert not csvfile.compiled_pays(csvfile.COLD_VALUES - 1)
    monkeypatch.setattr(csvfile, "_numba_in_use", lambda: True)
    assert not csvfile.compiled_pays(csvfile.LOADED_VALUES - 1)
    monkeypatch.setattr(floattext, "ready_marker", lambda: None)
    assert not csvfile.compiled_pays(10**9)  # nothing cached: never compiled while writing


def test_an_uncached_formatter_is_compiled_in_the_background(monkeypatch, tmp_path):
    """A large file with the formatter not cached: written in Python, and the formatter's
    warm-up started (its own: the stepping loops are not compiled for it)."""
    from circuitnsds import jit

    started = []
    monkeypatch.setattr(floattext, "has_native", lambda: False)
    monkeypatch.setattr(floattext, "loaded", lambda: False)
    monkeypatch.setattr(csvfile, "_numba_in_use", lambda: True)
    monkeypatch.setattr(floattext, "ready_marker", lambda: tmp_path / "ready-missing")
    monkeypatch.setattr(jit, "start_warmup", started.append)
    assert not csvfile.compiled_pays(10**7) and started == ["circuitnsds.output.floattext"]
    (tmp_path / "ready-missing").touch()
    assert csvfile.compiled_pays(10**7) and started == ["circuitnsds.output.floattext"]


@pytest.mark.parametrize("compiled", [True, False])
def test_any_text_stream_gets_text(compiled):
    """``Waveforms.to_csv`` takes "an open text stream": also one that is not an
    ``io.TextIOBase`` (a text-mode ``SpooledTemporaryFile``, an object with ``write(str)``);
    before, those got bytes and raised TypeError."""
    import tempfile

    from circuitnsds.output.waveforms import Waveforms

    waves = Waveforms(time=np.array([0.0, 0.5]), signals={"v(a)": np.array([1.0, -2.5e-300])})
    expected = "time,v(a)\n0.0,1.0\n0.5,-2.5e-300\n"

    class Collect:
        def __init__(self):
            self.parts = []

        def write(self, text):
            self.parts.append(text)

    collect = Collect()
    csvfile.write_csv(collect, waves.time, ["v(a)"], [waves["v(a)"]], compiled=compiled)
    assert "".join(collect.parts) == expected
    with tempfile.SpooledTemporaryFile(mode="w+") as text, tempfile.SpooledTemporaryFile(mode="w+b") as raw:
        waves.to_csv(text)
        waves.to_csv(raw)
        text.seek(0)
        raw.seek(0)
        assert text.read() == expected and raw.read() == expected.encode("ascii")
