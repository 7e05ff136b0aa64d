"""Figures: panels per quantity, engineering units, legends; --show without a display."""

import numpy as np
import pytest
from matplotlib.figure import Figure

import circuitnsds
from circuitnsds import units
from circuitnsds.cli.main import main
from circuitnsds.output.plot import PlotError, draw, plot_waveforms, show_waveforms
from circuitnsds.output.waveforms import Waveforms
from tests.conftest import NETLISTS


@pytest.fixture(scope="module")
def zener() -> Waveforms:
    return circuitnsds.read_netlist(NETLISTS / "zener_regulator.cir").transient()


def test_panels_units_and_legends(zener):
    figure = Figure()
    draw(figure, zener, ["v(in)", "v(out)", "i(dz1)", "i(v1)"])
    top, bottom = figure.axes
    assert top.get_ylabel() == "voltage [V]"
    assert bottom.get_ylabel() == "current [mA]"  # up to 149 mA
    assert bottom.get_xlabel() == "time [ms]"  # a 10 ms run
    assert [t.get_text() for t in top.get_legend().get_texts()] == ["v(in)", "v(out)"]
    assert [t.get_text() for t in bottom.get_legend().get_texts()] == ["i(dz1)", "i(v1)"]
    assert top.get_title() == zener.title
    x, y = bottom.lines[0].get_data()
    assert x[-1] == pytest.approx(10.0)  # ms
    np.testing.assert_allclose(y, zener["i(dz1)"] * 1e3)
    assert top.get_xlim() == pytest.approx((0, 10))


def test_default_signals_and_unknown_names(zener):
    figure = Figure()
    draw(figure, zener)
    assert len(figure.axes) == 2  # voltages, then currents of non-resistors
    labels = [t.get_text() for t in figure.axes[1].get_legend().get_texts()]
    assert labels == ["i(v1)", "i(dz1)"]
    with pytest.raises(KeyError, match="v\\(nope\\)"):
        draw(Figure(), zener, ["v(nope)"])


def test_writes_png(tmp_path, zener):
    path = tmp_path / "z.png"
    plot_waveforms(zener, path, ["v(out)"])
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    plot_waveforms(zener, tmp_path / "z.pdf", ["v(out)"])  # other formats: matplotlib's
    assert (tmp_path / "z.pdf").read_bytes()[:5] == b"%PDF-"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["z.pdf", "z.png"]  # no temporary left


@pytest.mark.parametrize(("span", "factor", "unit"), [(2.0, 1.0, "s"), (0.1, 1e3, "ms"),
                                                      (20e-6, 1e6, "µs"), (5e-9, 1e9, "ns")])
def test_time_units(span, factor, unit):
    assert units.time_unit(span) == (factor, unit)


def test_format_si():
    assert units.format_si(0.0125, "A") == "12.5 mA"
    assert units.format_si(-372.6, "W") == "-372.6 W"
    assert units.format_si(999.96, "V") == "1 kV"
    assert units.format_si(0.0, "V") == "0 V"
    assert units.format_si(2.2e6, "Ω") == "2.2 MΩ"


def test_show_without_a_display_is_a_clean_error(tmp_path, monkeypatch, capsys, zener):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    with pytest.raises(PlotError, match="needs a display"):
        show_waveforms(zener)
    csv = tmp_path / "o.csv"
    status = main(["run", str(NETLISTS / "zener_regulator.cir"), "-o", str(csv), "--show"])
    err = capsys.readouterr().err
    assert status == 1 and "--show needs a display" in err and "--plot out.png" in err
    assert "Traceback" not in err
    assert not csv.exists()  # refused before simulating


def test_show_without_an_interactive_backend_is_a_clean_error(monkeypatch, zener):
    import matplotlib.pyplot as plt

    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(plt, "get_backend", lambda: "agg")
    with pytest.raises(PlotError, match="no interactive backend"):
        show_waveforms(zener)


def test_show_opens_a_window_when_it_can(monkeypatch, zener):
    import matplotlib.pyplot as plt

    shown = []
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(plt, "get_backend", lambda: "tkagg")
    monkeypatch.setattr(plt, "show", lambda: shown.append(plt.gcf()))
    show_waveforms(zener, ["v(out)"])
    assert len(shown) == 1 and shown[0].axes[0].get_ylabel() == "voltage [V]"
    plt.close(shown[0])


# the formats matplotlib 3.7-3.10 write, as its own error lists them (matplotlib PR #30363,
# "ValueError: Format 'avif' is not supported (supported formats: eps, jpeg, ...)"):
# .gif came back in 3.11 and .avif is newer still
MATPLOTLIB_3_10_FORMATS = ("eps", "jpeg", "jpg", "pdf", "pgf", "png", "ps", "raw", "rgba", "svg",
                           "svgz", "tif", "tiff", "webp")


@pytest.mark.parametrize("suffix", ["gif", "avif"])
def test_plot_format_asks_the_installed_matplotlib_for_newer_formats(monkeypatch, suffix):
    """``--plot`` is checked before the run; with a matplotlib the package accepts
    (>= 3.7) that cannot write .gif or .avif the check must say so then, not after the run
    (where savefig raises a ValueError)."""
    from matplotlib.backend_bases import FigureCanvasBase

    from circuitnsds.output.plot import plot_format

    monkeypatch.setattr(FigureCanvasBase, "get_supported_filetypes",
                        classmethod(lambda cls: {k: k.upper() for k in MATPLOTLIB_3_10_FORMATS}))
    with pytest.raises(PlotError, match="not a figure format"):
        plot_format(f"x.{suffix}")
    assert [plot_format(f"x.{k}") for k in MATPLOTLIB_3_10_FORMATS] == list(MATPLOTLIB_3_10_FORMATS)
