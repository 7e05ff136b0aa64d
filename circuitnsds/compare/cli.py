"""``circuitnsds compare NETLIST``: the ngspice comparison on the command line.

Prints the table on stdout; ``--json`` and ``--plot`` write files. An ngspice run
that stops early is part of the report (exit status 0); bad options, a netlist
circuitnsds cannot read and a missing ngspice/PySpice are errors (status 1, one
message with a hint, no traceback).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from circuitnsds.compare.errors import CompareError
from circuitnsds.output.files import replaced_together, writing
from circuitnsds.values import parse_value


def _number(text: str) -> float:
    try:
        return parse_value(text.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (e.g. 0.1, 10m, 1e-14)") from None


def _numbers(text: str) -> list[float]:
    values = [_number(part) for part in text.split(",") if part.strip()]
    if not values:
        raise argparse.ArgumentTypeError("give one or more numbers separated by commas, e.g. 1,0.3,0.1")
    return values


def _window(text: str) -> tuple[float, float]:
    start, colon, stop = text.partition(":")
    if not colon:
        raise argparse.ArgumentTypeError(f"{text!r}: write the window as t0:t1, e.g. 20m:40m")
    return _number(start), _number(stop)


def add_compare_parser(commands: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``compare`` subcommand to the ``circuitnsds`` parser."""
    parser = commands.add_parser(
        "compare", help="run a netlist in circuitnsds and in ngspice and report the differences",
        description="Run NETLIST with ideal devices (circuitnsds) and with Shockley diodes (ngspice, "
        "through PySpice), interpolate ngspice onto circuitnsds's time grid and report, per signal, "
        "the RMS and largest difference normalised by the signal's range and the differences of "
        "the mean value and of the peak-to-peak ripple. Several --n values make a convergence "
        "study. Needs ngspice's shared library and PySpice: sudo apt-get install ngspice "
        "libngspice0-dev && python -m pip install 'circuitnsds[ngspice]'.")
    parser.add_argument("netlist", type=Path, help="SPICE netlist (ngspice dialect)")
    parser.add_argument("--signals", help='comma-separated signals, e.g. "v(out),i(d1)" (default: node '
                        "voltages and the currents of voltage sources, inductors and diodes)")
    parser.add_argument("--window", type=_window, metavar="T0:T1",
                        help="measure over this time window [s], e.g. 20m:40m (default: the whole run)")
    parser.add_argument("--n", type=_numbers, metavar="N[,N...]",
                        help="emission coefficient(s) forced on every diode model in ngspice; several "
                        "values make a convergence study, e.g. 1,0.3,0.1,0.03")
    parser.add_argument("--is", dest="is_", type=_number, metavar="IS",
                        help="saturation current [A] forced on every diode model in ngspice")
    parser.add_argument("--rs", type=_number, help="series resistance [Ω] forced on every diode model")
    parser.add_argument("--cjo", type=_number, help="junction capacitance [F] forced on every diode model")
    parser.add_argument("--step", type=_number, help="time step [s] for both (default: .tran TSTEP)")
    parser.add_argument("--stop", type=_number, help="end time [s] for both (default: .tran TSTOP)")
    parser.add_argument("--theta", type=float, default=None,
                        help="θ of circuitnsds's θ-method (default: .options theta, else 1)")
    parser.add_argument("--ngspice-options", default="", metavar="TEXT",
                        help='an .options line for ngspice only, e.g. "method=gear reltol=1e-4"')
    parser.add_argument("--plot", type=Path, metavar="PNG",
                        help="write both waveforms and their difference to this PNG; with several "
                        "--n also PNG-stem-convergence.png")
    parser.add_argument("--json", type=Path, metavar="FILE", help="write the report as JSON")
    return parser


def convergence_path(plot: Path) -> Path:
    """``cmp.png`` -> ``cmp-convergence.png``."""
    return plot.with_name(f"{plot.stem}-convergence{plot.suffix or '.png'}")


def _check_outputs(args: argparse.Namespace) -> None:
    """Before both runs: no output over the netlist, a file it includes or another output,
    and a figure format that exists."""
    from circuitnsds.frontend.build import CircuitBuilder
    from circuitnsds.output.files import check_outputs

    outputs = {option: path for option, path in (("--json", args.json), ("--plot", args.plot)) if path}
    if args.plot and args.n and len(args.n) > 1:
        outputs["--plot (convergence)"] = convergence_path(args.plot)
    if not outputs:
        return
    netlist = CircuitBuilder.load(args.netlist).netlist
    check_outputs(outputs, [netlist.file, *netlist.included])
    if args.plot:
        from circuitnsds.output.plot import plot_format

        plot_format(args.plot)


def run_compare(args: argparse.Namespace) -> int:
    """Run the comparison described by the parsed arguments; print the table."""
    from circuitnsds.compare.api import compare

    signals = None
    if args.signals:  # (commas inside parentheses kept: "v(a,b), i(l1)")
        import re

        signals = [re.sub(r"\s+", "", name) for name in
                   re.findall(r"[a-z]+\s*\([^)]*\)|[^,\s]+", args.signals, re.IGNORECASE)]
    _check_outputs(args)
    comparison = compare(args.netlist, signals=signals, window=args.window, n=args.n, is_=args.is_,
                         rs=args.rs, cjo=args.cjo, step=args.step, stop=args.stop,
                         theta=args.theta, ngspice_options=args.ngspice_options)
    print(comparison.table(), flush=True)
    written = []
    with replaced_together() as temporary:  # all the files, or none (as every command's outputs)
        if args.json:
            with writing(args.json, CompareError):
                comparison.to_json(temporary(args.json))
            written.append(args.json)
        if args.plot:
            with writing(args.plot, CompareError):
                comparison.plot(temporary(args.plot))
            written.append(args.plot)
            if len(comparison.runs) > 1 and all(run.overrides.n is not None for run in comparison.runs):
                path = convergence_path(args.plot)
                with writing(path, CompareError):
                    comparison.plot_convergence(temporary(path))
                written.append(path)
    if written:
        print(f"circuitnsds: wrote {', '.join(map(str, written))}", file=sys.stderr)
    return 0
