"""The progress bar: its line, and silence off a terminal, with --quiet, and for short runs."""

import io

import pytest

from circuitnsds.cli.main import main
from circuitnsds.cli.progress import ProgressBar, format_progress
from tests.conftest import NETLISTS


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


class Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_format_progress_with_and_without_step_counts():
    line = format_progress(0.042, 0.1, 2.0, width=10)
    assert line.startswith("[████░░░░░░]  42%")
    assert "t = 42 ms / 100 ms" in line
    assert "21 ms/s" in line  # 42 ms simulated in 2 s of wall time
    assert "steps" not in line
    assert line.endswith("3 s left")  # 58 ms to go at 21 ms/s
    line = format_progress(0.05, 0.1, 4.0, step=2500, steps=10000, width=8)
    assert line.startswith("[██░░░░░░]  25%")  # fraction from the step counts when known
    assert "2500/10000 steps" in line and "625 steps/s" in line


def test_nothing_is_drawn_when_the_stream_is_not_a_terminal():
    stream, clock = io.StringIO(), Clock()
    bar = ProgressBar(stream, clock=clock)
    clock.now += 5
    bar(0.5, 1.0)
    bar.close()
    assert not bar.enabled and stream.getvalue() == ""


def test_terminal_draws_after_the_delay_and_ends_the_line():
    stream, clock = FakeTerminal(), Clock()
    bar = ProgressBar(stream, clock=clock)
    clock.now += 0.6
    bar(0.1, 1.0)
    assert stream.getvalue() == ""  # runs shorter than about a second stay silent
    clock.now += 0.6
    bar(0.3, 1.0)
    bar(1.0, 1.0)
    bar.close()
    text = stream.getvalue()
    assert text.count("\r") == 2 and text.endswith("\n")
    assert "t = 300 ms / 1 s" in text and "100%" in text


def test_quiet_disables_even_on_a_terminal():
    stream, clock = FakeTerminal(), Clock()
    bar = ProgressBar(stream, enabled=False, clock=clock)
    clock.now += 5
    bar(0.5, 1.0)
    assert stream.getvalue() == ""


@pytest.mark.parametrize("quiet", [True, False])
def test_cli_progress_stays_off_a_captured_stderr(tmp_path, capsys, monkeypatch, quiet):
    calls = []
    original = ProgressBar.__call__

    def spy(self, *args):
        calls.append(self.enabled)
        original(self, *args)

    monkeypatch.setattr(ProgressBar, "__call__", spy)
    monkeypatch.setattr(ProgressBar, "__init__", _slow_start(ProgressBar.__init__))
    args = ["run", str(NETLISTS / "half_wave_rectifier.cir"), "-o", str(tmp_path / "o.csv"),
            "--step", "2u"] + (["-q"] if quiet else [])
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "\r" not in err and "█" not in err
    assert not any(calls)


def _slow_start(init):
    """Make the bar's delay zero, so that only the terminal test keeps it silent."""
    def wrapped(self, *args, **kwargs):
        kwargs["delay"] = 0.0
        init(self, *args, **kwargs)
    return wrapped
