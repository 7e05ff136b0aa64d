"""The compiled float -> text formatter writes exactly Python's ``repr``: the shortest
decimal that reads back to the same double (circuitnsds/output/floattext.py)."""

from __future__ import annotations

import io
import math
import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.output import csvfile, floattext


def _texts(values: np.ndarray) -> list[str]:
    text = floattext.csv_bytes(np.asarray(values, dtype=float).reshape(-1, 1)).decode("ascii")
    return text.split("\n")[:-1]


def _check(values) -> None:
    values = np.asarray(values, dtype=float)
    for x, text in zip(values.tolist(), _texts(values)):
        assert text == repr(x), (x.hex(), text)
        if not math.isnan(x):  # reads back bit for bit (the sign of zero included)
            assert struct.pack("<d", float(text)) == struct.pack("<d", x)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=200))
def test_any_doubles_read_back_and_equal_repr(values):
    _check(values)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 2**64 - 1), min_size=1, max_size=200))
def test_any_bit_patterns(patterns):
    _check(np.array(patterns, dtype=np.uint64).view(np.float64))


def test_random_bit_patterns():
    """Every exponent and significand (nan and inf patterns included) against ``repr``."""
    bits = np.random.default_rng(19).integers(0, 2**64, size=300_000, dtype=np.uint64, endpoint=False)
    values = bits.view(np.float64).reshape(-1, 3)
    expected = ("%r,%r,%r\n" * values.shape[0]) % tuple(values.ravel().tolist())
    assert floattext.csv_bytes(values).decode("ascii") == expected


def test_edge_values():
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
        _check(values)


def test_exponent_tables_are_exact():
    q = np.arange(floattext.Q_MIN, floattext.Q_MAX + 1)
    for fast, exact in zip(floattext.exponent_tables(q), floattext.exact_exponent_tables(q)):
        np.testing.assert_array_equal(fast, exact)


def test_python_version_matches():
    """The kernel's loop and layout run by the interpreter write the same bytes."""
    values = np.array([[0.1, -3.5e-310], [1e300, 12.0]])
    assert floattext.csv_bytes(values, compiled=False) == floattext.csv_bytes(values)


@pytest.mark.parametrize("block_rows", [3, 65_536])
def test_both_csv_writers_write_the_same_bytes(monkeypatch, block_rows):
    monkeypatch.setattr(csvfile, "BLOCK_ROWS", block_rows)
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


def test_the_formatter_is_chosen_by_size(monkeypatch):
    """Small files never load numba; large ones do only when the formatter is cached."""
    monkeypatch.setattr(floattext, "loaded", lambda: False)
    monkeypatch.setattr(csvfile, "_numba_in_use", lambda: False)
    assert not csvfile.compiled_pays(csvfile.COLD_VALUES - 1)
    monkeypatch.setattr(csvfile, "_numba_in_use", lambda: True)
    assert not csvfile.compiled_pays(csvfile.LOADED_VALUES - 1)
    monkeypatch.setattr(floattext, "ready_marker", lambda: None)
    assert not csvfile.compiled_pays(10**9)  # nothing cached: never compiled while writing


def test_an_uncached_formatter_is_compiled_in_the_background(monkeypatch, tmp_path):
    """A large file with the formatter not cached: written in Python, and the warm-up started."""
    from circuitnsds.engine import loop_choice

    started = []
    monkeypatch.setattr(floattext, "loaded", lambda: False)
    monkeypatch.setattr(csvfile, "_numba_in_use", lambda: True)
    monkeypatch.setattr(floattext, "ready_marker", lambda: tmp_path / "ready-missing")
    monkeypatch.setattr(loop_choice, "start_warmup", lambda: started.append(1))
    assert not csvfile.compiled_pays(10**7) and started == [1]
    (tmp_path / "ready-missing").touch()
    assert csvfile.compiled_pays(10**7) and started == [1]


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
