"""The ngspice comparison without ngspice: error measures, netlist translation, name mapping,
and the message a user gets when PySpice or ngspice is missing."""

import math
import os
import subprocess
import sys

import numpy as np
import pytest

from circuitnsds.compare import CompareError, DiodeOverrides, resample, signal_metrics, translate_netlist
from circuitnsds.compare.metrics import flag_negligible
from circuitnsds.compare.translate import ngspice_vector
from tests.conftest import NETLISTS

# --- error measures -------------------------------------------------------------------------


def test_shifted_sine_gives_the_analytic_errors():
    # sin(wt + phi) - sin(wt) = 2 sin(phi/2) cos(wt + phi/2): over whole periods its RMS is
    # sqrt(2)|sin(phi/2)| and its peak 2|sin(phi/2)|; the range of sin is 2.
    phi = 0.3
    t = np.linspace(0.0, 3.0, 30001)
    ref = np.sin(2 * np.pi * t)
    other = np.sin(2 * np.pi * t + phi)
    m = signal_metrics(t, ref, other, signal="v(x)")
    assert m.scale == pytest.approx(2.0, rel=1e-6)
    assert m.nrms == pytest.approx(math.sqrt(2) * abs(math.sin(phi / 2)) / 2, rel=1e-6)
    assert m.nmax == pytest.approx(abs(math.sin(phi / 2)), rel=1e-6)
    assert m.mean_diff == pytest.approx(0.0, abs=1e-9)
    assert m.ripple_diff == pytest.approx(0.0, abs=1e-6)


def test_offset_and_gain_show_in_mean_and_ripple():
    t = np.linspace(0.0, 1.0, 1001)
    ref = 5 + np.sin(2 * np.pi * t)                       # mean 5, ripple 2
    other = 5.5 + 1.5 * np.sin(2 * np.pi * t)             # mean 5.5, ripple 3
    m = signal_metrics(t, ref, other)
    assert m.mean_diff == pytest.approx(0.5, rel=1e-9)
    assert m.ripple_diff == pytest.approx(1.0, rel=1e-6)
    assert m.mean_ref == pytest.approx(5.0, rel=1e-9)
    # difference 0.5 + 0.5 sin: mean square 0.25 + 0.125
    assert m.nrms == pytest.approx(math.sqrt(0.375) / 2, rel=1e-6)


def test_window_restricts_every_measure():
    t = np.linspace(0.0, 2.0, 2001)
    ref = np.where(t < 1.0, 0.0, t - 1.0)
    other = ref + np.where(t < 1.0, 10.0, 0.1)            # big error only before t = 1
    m = signal_metrics(t, ref, other, window=(1.0, 2.0))
    assert m.nmax == pytest.approx(0.1, rel=1e-9)          # range of ref on [1, 2] is 1
    assert m.points == 1001


def test_time_weighting_on_a_non_uniform_grid():
    # ten points crowd into the first 1 % of the span: a plain average of the samples would
    # give a mean difference near 0.09; the time average of the linear difference t is 1/2
    t = np.concatenate([np.linspace(0.0, 0.01, 11), [1.0]])
    m = signal_metrics(t, np.zeros_like(t), t)
    assert m.mean_diff == pytest.approx(0.5, rel=1e-12)
    assert m.scale == 1.0                                  # the reference is zero: absolute errors
    assert m.nmax == pytest.approx(1.0)


def test_constant_reference_is_measured_against_its_magnitude():
    t = np.linspace(0.0, 1.0, 11)
    m = signal_metrics(t, np.full(11, 2.0) + 1e-13 * t, np.full(11, 2.02))
    assert m.scale == pytest.approx(2.0)
    assert m.nmax == pytest.approx(0.01, rel=1e-6)
    zero = signal_metrics(t, np.zeros(11), np.full(11, 1e-3))
    assert zero.scale == 1.0 and zero.nmax == pytest.approx(1e-3)


def test_resample_interpolates_and_leaves_nan_outside():
    t_from = np.array([0.1, 0.2, 0.2, 0.4])               # a repeated point, as ngspice writes
    values = np.array([1.0, 2.0, 3.0, 5.0])
    out = resample(t_from, values, np.array([0.0, 0.15, 0.3, 0.4, 0.5]))
    assert np.isnan(out[0]) and np.isnan(out[-1])
    np.testing.assert_allclose(out[1:4], [1.5, 4.0, 5.0])


def test_points_without_ngspice_values_are_left_out():
    t = np.linspace(0.0, 1.0, 11)
    other = t.copy()
    other[0] = np.nan                                      # ngspice writes no t = 0 under UIC
    m = signal_metrics(t, t, other)
    assert m.points == 10 and m.nmax == 0.0
    with pytest.raises(ValueError, match="no value"):
        signal_metrics(t, t, np.full(11, np.nan))


def test_negligible_signals_are_flagged():
    t = np.linspace(0.0, 1.0, 101)
    big = signal_metrics(t, np.sin(6 * t), np.sin(6 * t) * 1.01, signal="i(d1)")
    leak = signal_metrics(t, 1e-12 * t, 1e-9 * t, signal="i(d2)")      # pA against A
    volt = signal_metrics(t, 1e-3 * t, 0.0 * t, signal="v(a)")          # the only voltage
    flagged = flag_negligible({"i(d1)": big, "i(d2)": leak, "v(a)": volt})
    assert flagged["i(d2)"].negligible
    assert not flagged["i(d1)"].negligible and not flagged["v(a)"].negligible


# --- translation for ngspice ---------------------------------------------------------------


def test_ideal_only_parameters_are_dropped_and_overrides_applied():
    text = ("t\nD1 a k dz\nR1 a 0 1\n"
            ".model dz D(Is=1e-12 Vfwd=0.7 Ron=0.1 Roff=1e9 Vrev=5.1 Rrev=2 CJ0=1p)\n"
            ".model sw1 SW(VT=1)\n.tran 1u 1m\n.end\n")
    plain = translate_netlist(text).text
    assert ".model dz D(is=1e-12 cj0=1p bv=5.1)" in plain
    assert ".model sw1 SW(VT=1)" in plain                  # other model types verbatim
    forced = translate_netlist(text, overrides=DiodeOverrides(n=0.05, is_=1e-14, cjo=0)).text
    assert ".model dz D(bv=5.1 n=0.05 is=1e-14 cjo=0)" in forced   # CJ0 alias replaced too


def test_bv_wins_over_vrev_and_continuation_lines_are_joined():
    text = "t\nD1 a 0 dz\n.model dz D(BV=6\n* comment inside\n+ Vrev=6 N=2)\n.tran 1u 1m\n.end\n"
    out = translate_netlist(text, overrides=DiodeOverrides(n=0.1)).text
    assert ".model dz D(bv=6 n=0.1)" in out
    assert "Vrev" not in out


def test_control_blocks_saves_and_other_analyses_are_removed():
    text = ("t\nR1 a 0 1\nV1 a 0 1\n.op\n.save v(a)\n.control\nrun\nplot v(a)\n.endc\n"
            ".tran 1u 1m uic\n.end\nR9 after end 1\n")
    translation = translate_netlist(text, saves=["@r1[i]"])
    lines = translation.text.splitlines()
    assert lines[0] == "circuitnsds compare: t"
    assert [line for line in lines if line.startswith(".")] == [".tran 1u 1m uic", ".save all @r1[i]", ".end"]
    assert "R9" not in translation.text
    assert any(".control" in note for note in translation.notes)


def test_a_control_scripts_tran_and_meas_reach_ngspice_and_the_note_says_so():
    # Qucs-S writes the analysis only in .control: the note said only "1 .control block(s)
    # removed" after the merge of dialect32 (its own note said the tran and meas were kept)
    import warnings

    text = "t\nR1 a 0 1\nV1 a 0 1\n.control\ntran 10n 30m\nrun\nmeas tran top MAX v(a)\n.endc\n.end\n"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (the script's other lines are reported as warnings)
        translation = translate_netlist(text, measures=True)
    lines = translation.text.splitlines()
    assert ".tran 10n 30m" in lines and ".meas tran top MAX v(a)" in lines
    assert "1 .control block(s) removed (its tran, meas kept as .tran, .meas)" in translation.notes
    saved = translate_netlist(text.replace("run\n", "save v(a)\n"))  # .save and .meas go
    assert "1 .control block(s) removed (its tran kept as .tran)" in saved.notes, saved.notes


def test_tran_override_keeps_tstart_tmax_uic_and_expressions():
    text = "t\nR1 a 0 1\nV1 a 0 1\n.tran {tstep} { 3 / freq } 1m 2u uic\n.end\n"
    assert ".tran 1e-06 0.002 1m 2u uic" in translate_netlist(text, step=1e-6, stop=2e-3).text
    assert ".tran {tstep} { 3 / freq } 1m 2u uic" in translate_netlist(text).text
    with pytest.raises(Exception, match="no .tran"):
        translate_netlist("t\nR1 a 0 1\n.end\n")
    assert ".tran 1e-06 0.001" in translate_netlist("t\nR1 a 0 1\n.end\n", step=1e-6, stop=1e-3).text


def test_included_files_are_inlined_and_translated(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "models.lib").write_text("* models\n.model dx D(Vfwd=0.7 N=1.5)\n")
    top = tmp_path / "top.cir"
    top.write_text("t\n.include lib/models.lib\nD1 a 0 dx\nV1 a 0 1\n.tran 1u 1m\n.end\n")
    translation = translate_netlist(top, overrides=DiodeOverrides(n=0.2))
    assert ".include" not in translation.text and "models.lib" not in translation.text
    assert translation.text.splitlines()[1] == ".model dx D(n=0.2)"  # in place of the .include
    with pytest.raises(Exception, match="nowhere.lib. not found"):
        bad = tmp_path / "bad.cir"
        bad.write_text("t\n.include nowhere.lib\n.tran 1u 1m\n.end\n")
        translate_netlist(bad)


def test_bundled_vendor_library_translates():
    # the .lib of the vendor Zener has continuation lines with comments inside a .model
    text = translate_netlist(NETLISTS / "vendor_zener_regulator.cir", overrides=DiodeOverrides(n=0.1)).text
    assert ".model DFWD D(is=2.61E-15 cjo=180P vj=0.75 m=0.33 tt=50.1N rs=0.7 n=0.1)" in text
    assert ".MODEL RMOD RES(TC1=1e-3)" in text


def test_diodes_get_a_series_ammeter_when_their_current_is_compared():
    text = ("t\nV1 a 0 1\nD1 a k dm 2\nR1 k 0 1\n.subckt half p q\nD1 p q dm\n.ends\n.model dm D\n"
            ".tran 1u 1m\n.end\n")
    out = translate_netlist(text, ammeters=["d1"]).text.splitlines()
    assert "D1 a cnsds_d1_k dm 2" in out and "v_cnsds_d1 cnsds_d1_k k 0" in out
    assert "D1 p cnsds_d1_k dm" in out and "v_cnsds_d1 cnsds_d1_k q 0" in out


@pytest.mark.parametrize(("signal", "vector", "save"), [
    ("v(out)", "out", None),
    ("v(x1.mid)", "x1.mid", None),
    ("i(v1)", "v1#branch", None),
    ("i(L1)", "l1#branch", None),
    ("i(x1.vs)", "v.x1.vs#branch", None),
    ("i(d1)", "v_cnsds_d1#branch", None),
    ("i(x1.x2.d3)", "v.x1.x2.v_cnsds_d3#branch", None),
    ("i(r1)", "@r1[i]", "@r1[i]"),
    ("i(x1.c2)", "@c.x1.c2[i]", "@c.x1.c2[i]"),
    ("i(i1)", "@i1[c]", "@i1[c]"),
])
def test_signal_names_map_to_ngspice_vectors(signal, vector, save):
    assert ngspice_vector(signal) == (vector, save)


def test_bad_overrides_are_refused():
    with pytest.raises(CompareError, match="N=0 must be positive"):
        DiodeOverrides(n=0.0)
    with pytest.raises(CompareError, match="RS=-1 must be non-negative"):
        DiodeOverrides(rs=-1.0)
    assert DiodeOverrides(n=0.1, rs=0.0).label() == "N=0.1 RS=0"


# --- without PySpice ------------------------------------------------------------------------


def test_missing_pyspice_is_one_message_with_the_install_command(tmp_path):
    code = ("import sys; sys.modules['PySpice'] = None; from circuitnsds.cli.main import main; "
            f"sys.exit(main(['compare', {str(NETLISTS / 'half_wave_rectifier.cir')!r}]))")
    env = {**os.environ, "PYTHONPATH": str(NETLISTS.parent)}
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                            env=env)
    assert result.returncode == 1
    assert "PySpice is not installed" in result.stderr
    assert "apt-get install ngspice libngspice0-dev" in result.stderr
    assert "pip install 'circuitnsds[ngspice]'" in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize(("args", "message"), [
    (["--window", "30m"], "write the window as t0:t1"),
    (["--n", "abc"], "is not a number"),
])
def test_malformed_options_are_usage_errors(args, message, capsys):
    from circuitnsds.cli.main import main

    with pytest.raises(SystemExit) as exit_info:
        main(["compare", str(NETLISTS / "half_wave_rectifier.cir"), *args])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err


def test_outputs_over_the_netlist_its_includes_or_each_other_are_refused_before_the_run(tmp_path, capsys):
    # before: `compare NETLIST --json NETLIST` replaced the netlist by the JSON report, exit 0
    # ("wrote NETLIST"); an unknown --plot extension failed only after both simulations
    from circuitnsds.cli.main import main

    netlist = tmp_path / "top.cir"
    (tmp_path / "models.lib").write_text(".model dideal D\n")
    text = (NETLISTS / "half_wave_rectifier.cir").read_text().replace(".model dideal D",
                                                                       ".include models.lib")
    netlist.write_text(text)
    for args, message in [(["--json", str(netlist)], f"--json {netlist} would overwrite the netlist"),
                          (["--plot", str(tmp_path / "models.lib")], "would overwrite the netlist "
                           f"input {tmp_path / 'models.lib'}"),
                          (["--json", str(tmp_path / "a.x"), "--plot", str(tmp_path / "a.x")],
                           "--json and --plot name the same file"),
                          (["--plot", str(tmp_path / "c.xyz")], "'.xyz' is not a figure format")]:
        assert main(["compare", str(netlist), *args]) == 1
        assert message in capsys.readouterr().err
    assert netlist.read_text() == text and (tmp_path / "models.lib").read_text() == ".model dideal D\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["models.lib", "top.cir"]


def test_a_meas_level_naming_a_measurement_is_kept_from_ngspice_with_a_note():
    # ngspice's simple-meas-tran.sp, in its script: meas tran tmax WHEN v(2)=YMAX; as the dot
    # command compare gives ngspice, its numparam stops the whole run ("Undefined parameter [ymax]")
    text = ("m\nV1 a 0 SIN(0 1 1k)\nR1 a 0 1k\n.tran 10u 2m\n.meas tran ymax MAX v(a)\n"
            ".meas tran tmax WHEN v(a)=ymax\n.meas tran thalf WHEN v(a)=0.5\n.end\n")
    translation = translate_netlist(text, measures=True)
    assert ".meas tran ymax MAX v(a)" in translation.text
    assert ".meas tran thalf WHEN v(a)=0.5" in translation.text
    assert "tmax" not in translation.text
    assert any("<text>:6: .meas removed for ngspice: its level 'ymax'" in note for note in translation.notes)
