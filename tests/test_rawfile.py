"""SPICE raw files: ngspice's own layout, read back by ngspice, by us, and by spicelib."""

import re
import shutil
import subprocess

import numpy as np
import pytest

import circuitnsds
from circuitnsds.cli.main import main
from circuitnsds.output.rawfile import RawFileError, read_raw, write_raw
from circuitnsds.output.waveforms import Waveforms
from tests.conftest import NETLISTS


def ngspice() -> str:
    """The ngspice program; missing, the test fails with the install command (marker ``ngspice``)."""
    path = shutil.which("ngspice")
    if path is None:
        pytest.fail("ngspice is not installed: apt-get install ngspice (to leave these tests out "
                    "on purpose: python -m pytest -m \"not ngspice\")", pytrace=False)
    return path


@pytest.fixture(scope="module")
def waves() -> Waveforms:
    circuit = circuitnsds.read_netlist(NETLISTS / "half_wave_rectifier.cir")
    return circuit.transient(step=200e-6, stop=20e-3)


def test_header_layout(tmp_path, waves):
    path = tmp_path / "hw.raw"
    write_raw(waves, path, ["v(out)", "i(v1)"], binary=False, date="Sat Nov 21 12:47:11  2026")
    lines = path.read_text().splitlines()
    assert lines[:11] == [
        f"Title: {waves.title}",
        "Date: Sat Nov 21 12:47:11  2026",
        "Plotname: Transient Analysis",
        "Flags: real",
        "No. Variables: 3",
        f"No. Points: {waves.time.size}",
        "Variables:",
        "\t0\ttime\ttime",
        "\t1\tv(out)\tvoltage",
        "\t2\ti(v1)\tcurrent",
        "Values:",
    ]
    assert lines[11] == f" 0\t{waves.time[0]:.15e}"
    assert lines[12] == f"\t{waves['v(out)'][0]:.15e}"
    assert lines[14] == ""  # a blank line after each point


@pytest.mark.parametrize("binary", [True, False])
def test_round_trip(tmp_path, waves, binary):
    path = tmp_path / "hw.raw"
    waves.to_raw(path, binary=binary)
    back = read_raw(path)
    assert back.names == waves.names
    assert back.title == waves.title
    tolerance = 0 if binary else 1e-15  # ASCII keeps 16 significant digits, as ngspice
    np.testing.assert_allclose(back.time, waves.time, rtol=tolerance, atol=0)
    for name in waves.names:
        np.testing.assert_allclose(back[name], waves[name], rtol=tolerance, atol=1e-300)


def test_binary_values_are_point_major_little_endian_doubles(tmp_path, waves):
    path = tmp_path / "hw.raw"
    write_raw(waves, path, ["v(in)", "v(out)"])
    blob = path.read_bytes()
    values = np.frombuffer(blob[blob.index(b"Binary:\n") + 8:], dtype="<f8")
    assert values.size == 3 * waves.time.size
    np.testing.assert_array_equal(values[0::3], waves.time)
    np.testing.assert_array_equal(values[2::3], waves["v(out)"])


@pytest.mark.ngspice
@pytest.mark.parametrize("binary", [True, False])
def test_files_identical_to_what_ngspice_writes(tmp_path, binary):
    """ngspice writes a raw file; we read it and write it again: the same bytes."""
    netlist = tmp_path / "rl.cir"
    theirs, ours = tmp_path / "ngspice.raw", tmp_path / "ours.raw"
    netlist.write_text(
        "rl circuit\nV1 in 0 SIN(0 10 50)\nR1 in out 1k\nL1 out 0 1\n.tran 1m 5m\n"
        f".control\nset filetype={'binary' if binary else 'ascii'}\nrun\nwrite {theirs}\n.endc\n.end\n")
    # (ngspice -b exits 1 here: "no .plot lines", although it ran and wrote the file)
    subprocess.run([ngspice(), "-b", str(netlist)], capture_output=True, timeout=60)
    text = theirs.read_bytes()
    date = re.search(rb"^Date: (.*)$", text, re.MULTILINE).group(1).decode()
    write_raw(read_raw(theirs), ours, binary=binary, date=date)
    assert ours.read_bytes() == text


@pytest.mark.ngspice
@pytest.mark.parametrize("binary", [True, False])
def test_ngspice_loads_our_file_and_prints_the_same_numbers(tmp_path, waves, binary):
    raw, table = tmp_path / "hw.raw", tmp_path / "table.txt"
    waves.to_raw(raw, binary=binary)
    k = 37
    control = tmp_path / "load.cir"
    control.write_text(
        f"load test\n.control\nload {raw}\ndisplay\nset numdgt=16\n"
        f"print time[{k}] v(out)[{k}] i(d1)[{k}]\nwrdata {table} v(out) i(v1)\n.endc\n.end\n")
    result = subprocess.run([ngspice(), "-b", str(control)], capture_output=True, text=True,
                            timeout=60)
    output = result.stdout + result.stderr
    # ngspice lists the vectors with the types we gave them
    assert re.search(rf"v\(out\)\s*:\s*voltage, real, {waves.time.size} long", output)
    assert re.search(r"i\(v1\)\s*:\s*current, real", output)
    assert re.search(r"time\s*:\s*time, real.*\[default scale\]", output)
    printed = dict(re.findall(rf"^(\S+\[{k}\]) = (\S+)$", output, re.MULTILINE))
    assert float(printed[f"time[{k}]"]) == pytest.approx(waves.time[k], rel=1e-14)
    assert float(printed[f"v(out)[{k}]"]) == pytest.approx(waves["v(out)"][k], rel=1e-14)
    assert float(printed[f"i(d1)[{k}]"]) == pytest.approx(waves["i(d1)"][k], rel=1e-14)
    data = np.loadtxt(table)  # wrdata: time, v(out), time, i(v1)
    np.testing.assert_allclose(data[:, 0], waves.time, rtol=1e-14)
    np.testing.assert_allclose(data[:, 1], waves["v(out)"], rtol=1e-14, atol=1e-300)
    np.testing.assert_allclose(data[:, 3], waves["i(v1)"], rtol=1e-14, atol=1e-300)


@pytest.mark.parametrize("binary", [True, False])
def test_spicelib_reads_our_file(tmp_path, waves, binary):
    spicelib = pytest.importorskip("spicelib")
    path = tmp_path / "hw.raw"
    waves.to_raw(path, binary=binary)
    raw = spicelib.RawRead(str(path), dialect="ngspice", verbose=False)
    assert raw.get_trace_names() == ["time", *waves.names]
    # (get_trace, not get_axis: spicelib loads binary files lazily, ngspice's own as well)
    np.testing.assert_allclose(raw.get_trace("time").get_wave(), waves.time, rtol=1e-15)
    np.testing.assert_allclose(raw.get_trace("v(out)").get_wave(), waves["v(out)"],
                               rtol=1e-15, atol=1e-300)


def test_cli_writes_raw(tmp_path):
    raw = tmp_path / "out.raw"
    status = main(["run", str(NETLISTS / "half_wave_rectifier.cir"), "-o", str(tmp_path / "o.csv"),
                   "-r", str(raw), "--ascii", "--signals", "v(out)", "--stop", "10m", "-q"])
    assert status == 0
    text = raw.read_text()
    assert "Values:\n" in text and "\t1\tv(out)\tvoltage\n" in text and "No. Variables: 2\n" in text
    back = read_raw(raw)
    assert back.names == ["v(out)"] and back.time[-1] == pytest.approx(10e-3)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"hello\n", "no 'Values:' or 'Binary:' section"),
        (b"Title: x\nFlags: complex\nNo. Variables: 1\nNo. Points: 1\nVariables:\n\t0\tfrequency\t"
         b"frequency\nValues:\n 0\t1,0\n", "complex data"),
        (b"Title: x\nFlags: real\nNo. Variables: 2\nNo. Points: 3\nVariables:\n\t0\ttime\ttime\n"
         b"\t1\tv(a)\tvoltage\nBinary:\n" + bytes(16), "file holds fewer"),
    ],
)
def test_bad_files_give_clear_errors(tmp_path, content, message):
    path = tmp_path / "bad.raw"
    path.write_bytes(content)
    with pytest.raises(RawFileError, match=re.escape(message)):
        read_raw(path)
