"""The ``circuitnsds`` command: ``run`` a netlist's transient, find its periodic steady state
(``pss``), its small-signal response (``ac``), or print ``info`` about it.

Errors in the input print one message (file:line, what, hint) on stderr and
exit with status 1; no traceback. ``--debug`` shows tracebacks.

Exit status (:data:`EXIT_STATUS`): 0 success; 1 the netlist, the circuit or the
simulation is at fault (any :class:`~circuitnsds.errors.CircuitnsdsError`, and any
warning under ``--strict``); 2 bad command-line arguments, or an internal error of
circuitnsds (a bug: please report it); 130 interrupted (Ctrl-C), 143 (SIGTERM) and
129 (SIGHUP), which stop a command as Ctrl-C does (:mod:`circuitnsds.cli.interrupts`).
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import warnings
from pathlib import Path

from circuitnsds.cli.interrupts import described, exit_status, terminations_interrupt
from circuitnsds.cli.joined import Joined
from circuitnsds.cli.progress import ProgressBar
from circuitnsds.errors import (
    CircuitnsdsError,
    NetlistWarning,
    RunNote,
    SimulationError,
    as_error,
    for_terminal,
)
from circuitnsds.output.files import OutputError, check_outputs
from circuitnsds.output.files import writing as _writing
from circuitnsds.values import parse_value

EXIT_STATUS = {0: "success", 1: "error in the netlist, the circuit or the simulation (or a warning "
               "under --strict)", 2: "bad command-line arguments, or an internal error (a bug)",
               129: "stopped by SIGHUP (as by Ctrl-C)", 130: "interrupted (Ctrl-C)",
               143: "stopped by SIGTERM (as by Ctrl-C)"}
"""The exit statuses of the command and their meaning (docs/usage.md lists them)."""
STRICT_HELP = "treat every warning (ignored constructs, suspicious circuits) as an error"


def _signal_names(text: str) -> list[str]:
    """``"v(a,b), i(l1)"`` -> ``["v(a,b)", "i(l1)"]`` (commas inside parentheses kept)."""
    import re

    return [re.sub(r"\s+", "", name).lower()
            for name in re.findall(r"[a-z]+\s*\([^)]*\)|[^,\s]+", text, re.IGNORECASE)]


def _seconds(text: str) -> float:
    try:
        return parse_value(text)
    except ValueError as exc:
        if "not a number" not in str(exc):  # too large, or so small it would be 0
            raise argparse.ArgumentTypeError(str(exc)) from None
        raise argparse.ArgumentTypeError(f"{text!r} is not a time (e.g. 1u, 10ms, 2e-3)") from None


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="circuitnsds",
        description="Transient simulation of SPICE netlists with ideal diodes and Zeners.",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    from circuitnsds import __version__  # (the package is imported already: no cost)

    parser.add_argument("--version", action="version", version=f"circuitnsds {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)

    run = commands.add_parser("run", help="run the transient of a netlist, write CSV (and PNG)")
    _add_output_arguments(run)
    run.add_argument("--tstart", type=_seconds, metavar="T0",
                     help="write (and plot) only from T0 on [s]; measurements use the whole run")
    run.add_argument("--tstop", type=_seconds, metavar="T1", help="write (and plot) only up to T1 [s]")
    run.add_argument("--every", type=int, metavar="N", default=1,
                     help="write every N-th time point (and the last)")
    run.add_argument("--step", type=_seconds, help="time step [s] (default: .tran TSTEP)")
    run.add_argument("--stop", type=_seconds, help="end time [s] (default: .tran TSTOP)")
    run.add_argument("--theta", type=float, default=None,
                     help="θ of the θ-method in [0.5, 1] (default: .options theta, else 1: implicit Euler); "
                     "under the default method=auto it applies where θ runs: a circuit the exact "
                     "integrator cannot run, and its hand-offs")
    run.add_argument("--uic", action="store_true",
                     help="start from initial conditions (as .tran ... UIC)")
    from circuitnsds.cli.sweep import add_execution_arguments

    add_execution_arguments(run)  # a netlist with .step lines makes `run` a sweep

    pss = commands.add_parser("pss", help="find the periodic steady state (one settled period), "
                              "write it as run does")
    _add_output_arguments(pss)
    pss.add_argument("--period", type=_seconds,
                     help="period [s] (default: .pss GFREQ, else the common period of the sources)")
    pss.add_argument("--step", type=_seconds,
                     help="time step [s] (default: period/.pss PSSPOINTS, else .tran TSTEP, else "
                     "period/1000)")
    pss.add_argument("--warmup", type=int, default=0, metavar="PERIODS",
                     help="periods of transient before the shooting (default: .pss TSTAB, else 0)")
    pss.add_argument("--tol", type=float, default=None,
                     help="relative periodicity tolerance (default: .pss STEADYCOEFF, else 1e-9)")
    pss.add_argument("--max-iterations", type=int, default=None, metavar="N",
                     help="Newton steps before a fallback of transient periods (default: .pss "
                     "SCITER, else 10; on the exact period map 30)")
    pss.add_argument("--uic", action="store_true",
                     help="start from initial conditions instead of the operating point")

    ac = commands.add_parser("ac", help="small-signal AC (Bode) at the operating point or around "
                             "the periodic steady state")
    ac.add_argument("netlist", type=Path, help="SPICE netlist (ngspice dialect); - reads it from "
                    "standard input (the Bode table then goes to standard output)")
    ac.add_argument("--input", metavar="SOURCE",
                    help="the source whose value is perturbed, as named in the netlist: a supply "
                    "(line-to-output), a current source at the output (output impedance), the "
                    "control voltage of a PWM comparator switch (control-to-output) (default: "
                    "every source with an AC magnitude, as SPICE's .ac)")
    ac.add_argument("--output", action="append", metavar="SIGNAL",
                    help="signal to report, e.g. v(out); repeatable (default: every signal)")
    ac.add_argument("--sweep", choices=("dec", "oct", "lin"), default=None,
                    help="frequency spacing (default: the .ac line's, else dec)")
    ac.add_argument("--points", type=int, help="points per decade/octave, or in all for lin "
                    "(default: the .ac line's, else 20)")
    ac.add_argument("--fstart", type=_seconds, help="first frequency [Hz] (default: .ac FSTART)")
    ac.add_argument("--fstop", type=_seconds, help="last frequency [Hz] (default: .ac FSTOP)")
    ac.add_argument("--around", choices=("auto", "op", "pss"), default="auto",
                    help="linearise at the operating point or around the periodic steady state "
                    "(default: pss when a source varies in time)")
    ac.add_argument("--loop-gain", metavar="RETURN,INJECTED",
                    help='loop gain by voltage injection with --input a source in series with the '
                    'loop, e.g. "v(a),v(b)" for Vinj b a: T = -v(a)/v(b), written as "loop" with its '
                    "crossover and phase margin")
    ac.add_argument("-o", "--csv", type=Path, metavar="CSV",
                    help="Bode table to write: frequency [Hz], then mag [dB] and phase [deg] per "
                    "output (default: NETLIST name with _ac.csv)")
    ac.add_argument("--plot", type=Path, metavar="PNG", help="also write a Bode plot")
    _add_quiet_and_strict(ac, "no summary on stderr")

    info = commands.add_parser("info", help="print elements, nodes, MLCS size, breakpoints "
                               "and the circuit checks")
    info.add_argument("netlist", type=Path, help="SPICE netlist; - reads it from standard input")
    info.add_argument("--matrices", type=Path, metavar="NPZ",
                      help="also save the MLCS matrices to this .npz file")
    info.add_argument("--strict", action="store_true", help=STRICT_HELP + " (after the report)")

    from circuitnsds.compare.cli import add_compare_parser

    add_compare_parser(commands)
    from circuitnsds.cli.sweep import add_sweep_parser

    add_sweep_parser(commands)
    return parser


def _add_quiet_and_strict(command: argparse.ArgumentParser, quiet: str) -> None:
    """``-q`` (its help says what it silences) and ``--strict``, as every analysis takes them."""
    command.add_argument("-q", "--quiet", action="store_true", help=quiet)
    command.add_argument("--strict", action="store_true", help=STRICT_HELP)


def _add_output_arguments(command: argparse.ArgumentParser) -> None:
    """The arguments ``run`` and ``pss`` share: the netlist, the files written, measurements."""
    command.add_argument("netlist", type=Path, help="SPICE netlist (ngspice dialect); - reads it "
                         "from standard input")
    command.add_argument("-o", "--output", type=Path,
                         help="CSV file to write, - for standard output (default: NETLIST name with "
                         ".csv, in the current directory, unless only -r is given; standard output "
                         "for a netlist read from standard input)")
    command.add_argument("-r", "--raw", type=Path, metavar="RAW",
                         help="also write a SPICE raw file (binary, as ngspice's write) for ngspice, "
                         "LTspice's viewer, spicelib")
    command.add_argument("--ascii", action="store_true", help="write the raw file in ASCII")
    command.add_argument("--plot", type=Path, metavar="PNG",
                         help="also write a figure to this PNG (PDF, SVG by the extension)")
    command.add_argument("--events", type=Path, metavar="CSV",
                         help="write every switching (time, element, state) of the S, W and M "
                         "switches to this CSV file")
    command.add_argument("--mark-events", action="store_true",
                         help="draw each switching as a thin vertical line on --plot and --show")
    command.add_argument("--show", action="store_true",
                         help="open the figure in a window (needs a display)")
    command.add_argument("--measure", action="append", default=[], metavar="EXPR",
                         help='measure on the results, e.g. "mean(v(out))", "ripple(v(out), 80m, '
                         '100m)", "power(rload, period=20m)", "thd(v(in), 50)", or ngspice\'s .meas '
                         'syntax "tran vavg AVG v(out) from=1m to=2m"; repeatable; printed as a table')
    command.add_argument("--signals", action=Joined,
                         help='comma-separated signals to write, e.g. "v(out),i(l1)" (repeatable; '
                         "default: all)")
    command.add_argument("--losses", nargs="?", const="", metavar="LOADS",
                         help="print the power balance of every element (sources, switches, diodes "
                         "with their conduction and switching parts, resistors, stored energy, what "
                         "is unaccounted) over the run, or --tstart..--tstop; LOADS: comma-separated "
                         "load elements counted as output, e.g. rload (then the efficiency)")
    command.add_argument("--losses-csv", type=Path, metavar="CSV",
                         help="write the loss table as CSV: element,kind,power_W,conduction_W,"
                         "turn_on_W,turn_off_W,recovery_W (LOADS from --losses)")
    _add_quiet_and_strict(command, "no progress or summary on stderr")


def program() -> int:
    """The ``circuitnsds`` command as its process runs it (the console script and
    ``python -m circuitnsds``): :func:`main`, then the garbage collector told to leave
    alone every object alive (:func:`gc.freeze`), so that the interpreter's exit does not
    traverse them all once more. Every file is written and closed by then; what the exit
    skips is collecting reference cycles, whose finalisers Python does not promise to run
    at exit anyway. The bridge's ``run -o ... --plot ...`` spent 30-60 ms in that exit,
    ~10 ms after the freeze. (Tests call :func:`main`: frozen objects would stay for the
    rest of their process.)

    Before that, the collector's first threshold goes from 700 allocations to 20,000: the
    command imports most of its modules as it goes, and each young-generation pass walks
    the classes and functions just made. At most 20,000 more objects wait for their pass.
    The bridge's ``run -o ... --plot ...`` spent 18-20 ms in 54 collector passes, 7-10 ms
    in 9 after (timed by :data:`gc.callbacks`)."""
    gc.set_threshold(20_000, *gc.get_threshold()[1:])
    status = main()
    gc.freeze()
    return status


def main(argv: list[str] | None = None) -> int:
    """The command line: parse ``argv`` (default: the process's), run the command, print
    errors as one line each; returns the exit status (0 success, 1 bad input or a failed
    run, 2 an internal error, 130 interrupted)."""
    args = build_parser().parse_args(argv)
    with warnings.catch_warnings(record=True) as caught, terminations_interrupt():
        warnings.simplefilter("always")
        strict = getattr(args, "strict", False)
        if strict and args.command in ("run", "pss", "ac"):  # stop at the first warning, before any output
            warnings.filterwarnings("error", category=NetlistWarning)
        try:
            if args.command in ("compare", "sweep") and str(args.netlist) == "-":
                raise CircuitnsdsError(f"{args.command} reads a netlist file, not standard input",
                                       where="-", hint="save the netlist to a file (run, pss, ac "
                                       "and info read standard input)")
            if args.command == "compare":
                from circuitnsds.compare.cli import run_compare

                status = run_compare(args)
            elif args.command == "sweep":
                from circuitnsds.cli.sweep import run_sweep

                status = run_sweep(args)
            else:
                status = {"run": _run, "pss": _pss, "ac": _ac, "info": _info}[args.command](args)
        except CircuitnsdsError as exc:
            _print_warnings(caught)
            if args.debug:
                raise
            print(f"circuitnsds: error: {exc}", file=sys.stderr)
            return 1
        except NetlistWarning as warning:  # --strict
            _print_warnings(caught)
            if args.debug:
                raise
            print(f"circuitnsds: error: {as_error(warning)}", file=sys.stderr)
            return 1
        except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP
            _print_warnings(caught)
            print(f"circuitnsds: {described(exc)}", file=sys.stderr)
            return exit_status(exc)
        except BrokenPipeError:  # output piped into `head` and the like: not an error
            sys.stdout = open(os.devnull, "w")  # noqa: SIM115 (interpreter exit flushes it)
            return 0
        except MemoryError as exc:  # a limit met past the checks (ulimit -v, a cgroup): not a bug
            _print_warnings(caught)
            if args.debug:
                raise
            print(f"circuitnsds: error: out of memory{f' ({exc})' if str(exc) else ''}\n  hint: a "
                  "longer step, a shorter .tran, fewer signals kept (--signals), or more memory for "
                  "the process (ulimit -v, the container's limit)", file=sys.stderr)
            return 1
        except Exception as exc:  # a bug in circuitnsds, not bad input
            if args.debug:
                raise
            print(f"circuitnsds: internal error: {type(exc).__name__}: {exc}\n"
                  "  this is a bug; please report it with the netlist "
                  "(run with --debug for the traceback)", file=sys.stderr)
            return 2
    _print_warnings(caught)
    if strict and status == 0 and any(issubclass(w.category, NetlistWarning) for w in caught):
        print("circuitnsds: error: the warnings above are errors under --strict", file=sys.stderr)
        return 1
    return status


def _print_warnings(caught: list[warnings.WarningMessage]) -> None:
    """circuitnsds's own warnings and notes, one line each; a warning of a library (numpy's
    overflow in some intermediate) once per message with its count and origin, not as one of
    ours (a 1000-diode chain printed 178 lines of numpy overflow as circuitnsds warnings).
    Each of ours once: a run refitted and run again makes its checks twice."""
    foreign: dict[tuple[str, str], list] = {}
    said: set[tuple[str, str]] = set()
    for warning in caught:
        key = (warning.category.__name__, str(warning.message))
        if not issubclass(warning.category, (NetlistWarning, RunNote)):
            foreign.setdefault(key, [0, f"{Path(warning.filename).name}:{warning.lineno}"])[0] += 1
            continue
        if key in said:
            continue
        said.add(key)
        kind = "note" if issubclass(warning.category, RunNote) else "warning"
        print(f"circuitnsds: {kind}: {for_terminal(str(warning.message))}", file=sys.stderr)
    for (category, message), (count, origin) in foreign.items():
        times = f", {count} times" if count > 1 else ""
        print(f"circuitnsds: library {category} ({origin}{times}): {for_terminal(message)} "
              "(from a library the run uses, not a finding about the circuit)", file=sys.stderr)


def _read(path: Path):
    """The circuit of netlist file ``path``, or of standard input for ``-``."""
    if str(path) == "-":
        from circuitnsds.frontend.elaborate import elaborate
        from circuitnsds.netlist import load_netlist_text

        return elaborate(load_netlist_text(sys.stdin.read(), file="<stdin>"))
    from circuitnsds import read_netlist

    return read_netlist(path)


def _outputs(args: argparse.Namespace) -> dict[str, Path]:
    """Option -> file of every output asked for (``-``: standard output)."""
    from circuitnsds.output.writers import WRITERS

    outputs = {}
    if args.output or not args.raw:  # a raw file alone replaces the default CSV
        stdin = str(args.netlist) == "-"
        outputs["-o"] = args.output or Path("-" if stdin else args.netlist.stem + ".csv")
    for writer in WRITERS:
        if getattr(args, writer.attribute, None):
            outputs[writer.option] = getattr(args, writer.attribute)
    if getattr(args, "losses_csv", None):
        outputs["--losses-csv"] = args.losses_csv
    return outputs


def _stdin(args: argparse.Namespace) -> list[str]:
    """``["-"]`` when the netlist is read from standard input (its file is an input too)."""
    return ["-"] if str(args.netlist) == "-" else []


def _shown(written: list[Path]) -> str:
    return ", ".join("standard output" if str(path) == "-" else str(path) for path in written)


def _prepare(args: argparse.Namespace, builder=None):
    """Read the netlist (unless ``builder`` has read it) and check what can be checked before
    a long run (``run``, ``pss``)."""
    if args.ascii and not args.raw:  # an option that qualifies an output not asked for
        raise OutputError("--ascii is the format of the raw file, and no -r is given",
                          where="--ascii", hint="add -r out.raw, or leave --ascii out")
    if args.signals is not None and not _signal_names(args.signals):
        raise OutputError(f"--signals {args.signals!r} names no signal", where="--signals",
                          hint='list them, e.g. --signals "v(out),i(l1)"; leave --signals out for all')
    if args.mark_events and not (args.plot or args.show):
        raise OutputError("--mark-events draws on the figure, and neither --plot nor --show is given",
                          where="--mark-events", hint="add --plot out.png, or use --events out.csv "
                          "for the switching instants")
    circuit = builder.build() if builder is not None else _read(args.netlist)
    outputs = _outputs(args)
    thermal_files = sorted({element.model.thermal for element in circuit.elements
                            if getattr(getattr(element, "model", None), "thermal", None)})
    # before a long run: never over the netlist, a file it includes, or another output
    check_outputs(outputs, [circuit.file, *circuit.included, *thermal_files, *_stdin(args)],
                  stdout=("-o",))
    args.thermal_devices = []
    if thermal_files:  # the datasheets read (and their errors shown) before the run
        from circuitnsds.thermal.junction import devices_of

        args.thermal_devices = devices_of(circuit)
    if not args.signals and circuit.saved_signals:  # .save chooses the columns unless --signals does
        args.signals = ",".join(circuit.saved_signals)
    meas_lines = [e for e in args.measure if e.split()[:1] and e.split()[0].lower() == "tran"]
    args.measure = [e for e in args.measure if e not in meas_lines]
    if args.measure:  # syntax errors before a long run, not after it
        from circuitnsds.output.measure import parse_measurement

        for expression in args.measure:
            parse_measurement(expression)
    if args.plot:  # an unknown figure format before a long run, not after it
        from circuitnsds.output.plot import plot_format

        plot_format(args.plot)
    if meas_lines:  # ngspice's syntax: --measure "tran vavg AVG v(out) from=1m to=2m"
        from circuitnsds.frontend.cards.meas import parse_meas

        circuit.measurements.extend(parse_meas(f".meas {line}") for line in meas_lines)
    if args.show:
        from circuitnsds.output.plot import check_display

        check_display()
    return circuit


def _run(args: argparse.Namespace) -> int:
    from circuitnsds.cli.sweep import run_steps
    from circuitnsds.frontend.build import CircuitBuilder

    source = args.netlist if str(args.netlist) != "-" else sys.stdin.read() + "\n"  # - : stdin
    builder = CircuitBuilder.load(source)  # read once
    if builder.steps:  # .step lines: the run is a sweep
        return run_steps(args, builder)
    circuit = _prepare(args, builder)
    progress = ProgressBar(sys.stderr, enabled=False if args.quiet else None)
    # only the signals written are kept (memory bounded by them), unless measurements may
    # need others
    names = [name for name in _signal_names(args.signals or "") if name != "time"]
    plain = names and all("," not in name for name in names)  # v(a,b) is computed from two
    needs_all = args.measure or getattr(args, "losses", None) is not None or circuit.measurements \
        or circuit.fourier or args.losses_csv or args.thermal_devices
    kept = names if plain and not needs_all else None
    stream = _csv_stream(args, kept)  # the CSV written as the run goes
    try:
        waves = circuit.transient(args.step, args.stop, theta=args.theta, uic=True if args.uic else None,
                                  progress=progress, signals=kept, sink=stream)
    except SimulationError as exc:
        progress.close()
        _write_partial(args, exc.partial, "before the failure", stream)
        raise
    except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP: keep what was computed
        progress.close()
        _write_partial(args, getattr(exc, "partial", None), f"when {described(exc)}", stream)
        raise
    except BaseException:
        if stream is not None:
            stream.abort()
        raise
    finally:
        progress.close()
    stats = waves.stats
    residual = stream.max_residual if stream is not None else waves.residual.max()
    if stream is not None:
        waves = stream.waveforms(waves)  # the rows kept for the raw file and figure, if any
    thermal = None
    if args.thermal_devices:
        waves, thermal = _junctions(args, circuit, waves, steady=False)
    kind = "Newton-stepper" if stats.get("newton_iterations") else "θ-method"
    done = (f"{stats['steps']} {kind} steps" if "exact_segments" not in stats else
            f"{stats['steps']} rows from {int(stats['exact_segments'])} exact segments "
            f"({int(stats['events'])} events located)"
            + (f" and {int(stats['theta_steps'])} θ steps" if stats.get("theta_steps") else ""))
    return _finish(args, circuit, waves, f"{done} in {stats['seconds']:.3g} s "
                   f"({stats['unknowns']} unknowns, {stats['pairs']} complementarity pairs); "
                   f"max residual {residual:.1e}{newton_summary(stats)}"
                   f"{'; ' + stats['method'] if stats.get('method') else ''}", stream, thermal)


def _csv_stream(args: argparse.Namespace, kept: list[str] | None):
    """A :class:`~circuitnsds.output.csvfile.CsvStream` for ``-o`` when the CSV's rows are
    exactly the kept signals' (no ``--tstart``/``--tstop``/``--every``), else ``None``. It
    also holds the rows when the raw file or the figure needs them."""
    output = _outputs(args).get("-o")
    if kept is None or output is None or getattr(args, "every", 1) != 1 \
            or getattr(args, "tstart", None) is not None or getattr(args, "tstop", None) is not None:
        return None
    from circuitnsds.output.csvfile import CsvStream

    with _writing(output):
        return CsvStream(sys.stdout if str(output) == "-" else output, kept,
                         keep=bool(args.raw or args.plot or args.show))


def _pss(args: argparse.Namespace) -> int:
    import time

    circuit = _prepare(args)
    started = time.perf_counter()
    result = circuit.pss(args.period, step=args.step, periods_warmup=args.warmup, tol=args.tol,
                         max_iterations=args.max_iterations, uic=True if args.uic else None)
    waves, thermal = result.waveforms, None
    if args.thermal_devices:
        waves, thermal = _junctions(args, circuit, waves, steady=True, period=result.period)
    return _finish(args, circuit, waves,
                   f"{result.summary()}; {time.perf_counter() - started:.3g} s", thermal=thermal)


def _ac(args: argparse.Namespace) -> int:
    import time

    import numpy as np

    from circuitnsds.errors import CircuitError
    from circuitnsds.output.bode import plot_bode, write_bode_csv
    from circuitnsds.specs import AcSpec

    circuit = _read(args.netlist)
    spec = circuit.analyses.get("ac")
    start = args.fstart if args.fstart is not None else (spec.start if spec else None)
    stop = args.fstop if args.fstop is not None else (spec.stop if spec else None)
    if start is None or stop is None:
        raise CircuitError("no frequency range: no .ac line and no --fstart/--fstop",
                           where=str(args.netlist), hint="add --fstart 10 --fstop 1meg, or an .ac line")
    if not 0 < start <= stop or (args.points is not None and args.points < 1):
        raise CircuitError(f"need 0 < --fstart <= --fstop and --points >= 1 (got {start:g}, {stop:g})",
                           where=str(args.netlist))
    sweep = AcSpec(args.sweep or (spec.sweep if spec else "dec"),
                   args.points or (spec.points if spec else 20), start, stop)
    outputs, loop = args.output, None
    if args.loop_gain:
        loop = [name.strip().lower() for name in args.loop_gain.split(",")]
        if len(loop) != 2 or not args.input:
            raise CircuitError("--loop-gain takes RETURN,INJECTED (two signals) and needs --input "
                               "(the injection source)", where="--loop-gain")
        outputs = list(dict.fromkeys([*(outputs or []), *loop]))
    default_csv = "-" if str(args.netlist) == "-" else args.netlist.stem + "_ac.csv"
    bode_outputs = {"-o": args.csv or Path(default_csv)}
    to_stdout = str(bode_outputs["-o"]) == "-"  # the Bode table; what is printed goes to stderr
    if args.plot:
        bode_outputs["--plot"] = args.plot
    check_outputs(bode_outputs, [circuit.file, *circuit.included, *_stdin(args)],  # not over the netlist
                  stdout=("-o",))
    if args.plot:  # an unknown figure format before the analysis, not after it
        from circuitnsds.output.plot import plot_format

        plot_format(args.plot)
    started = time.perf_counter()
    result = circuit.ac(args.input, outputs, sweep.frequencies(), around=args.around)
    seconds = time.perf_counter() - started
    marks = {}
    if loop:
        from circuitnsds.analyses.ac import margins

        result.transfer["loop"] = result.loop_gain(*loop)
        crossover, margin = margins(result.frequencies, result.transfer["loop"])
        marks["loop"] = (crossover, margin)
        print(f"loop gain -{loop[0]}/{loop[1]}: crossover {crossover:.6g} Hz, phase margin "
              f"{margin:.4g} deg" if np.isfinite(crossover) else
              f"loop gain -{loop[0]}/{loop[1]}: |T| does not cross 1 in the sweep",
              file=sys.stderr if to_stdout else sys.stdout, flush=True)
    written = [bode_outputs["-o"]]
    from circuitnsds.output.files import replaced_together

    with replaced_together() as temporary:  # the table and the figure: both or neither
        if args.plot:
            with _writing(args.plot):
                plot_bode(result, temporary(args.plot), marks)
            written.append(args.plot)
        with _writing(written[0]):
            write_bode_csv(result, sys.stdout if to_stdout else temporary(written[0]))
    if not args.quiet:
        around = "periodic steady state" if result.around == "pss" else "operating point"
        print(f"circuitnsds: AC of {len(result.transfer)} signal(s) at {result.frequencies.size} "
              f"frequencies around the {around} in {seconds:.3g} s; wrote "
              f"{', '.join(map(str, written))}", file=sys.stderr)
    return 0


def _junctions(args: argparse.Namespace, circuit, waves, *, steady: bool, period=None):
    """The devices' losses and junction temperatures (:mod:`circuitnsds.thermal.junction`):
    ``waves`` with a ``tj(DEVICE)`` signal [°C] per device whose file has a thermal network,
    and the :class:`~circuitnsds.thermal.junction.ThermalResult`. A transient drives the
    networks with the average loss of each switching period (the shortest period of the
    sources; the instantaneous loss without one); a periodic steady state gives the thermal
    steady state."""
    from circuitnsds.thermal import junction

    start = 0.0
    if period is None:
        period, start = junction.switching_period(circuit)
    result = junction.analyse(circuit, waves, steady=steady, period=period, start=start,
                              devices=args.thermal_devices)
    waves = junction.with_junction_temperatures(waves, result)
    if steady and not args.quiet:
        for name, values in result.junction.items():
            print(f"circuitnsds: thermal steady state: tj({name}) = {values[0]:.4g} °C",
                  file=sys.stderr)
    return waves, result


def newton_summary(stats: dict) -> str:
    """The Newton stepper's cost for the run summary (``""`` for another stepper): iterations
    per step and time per iteration (each a linearisation and a dense solve of the step)."""
    iterations = stats.get("newton_iterations")
    if not iterations or not stats.get("steps"):
        return ""
    return (f"; Newton: {iterations / stats['steps']:.2f} iterations per step, "
            f"{1e6 * stats['newton_seconds'] / iterations:.0f} µs per iteration")


def _finish(args: argparse.Namespace, circuit, waves, summary: str, stream=None,
            thermal=None) -> int:
    """Write the files asked for (``stream``: the CSV written during the run, put in place
    here), print the measurements, the loss table (``thermal``: the devices' datasheet
    losses) and the summary, show the figure."""
    names, written = _write_outputs(args, waves if stream is not None else _selected(args, waves),
                                    stream)
    report = sys.stderr if "-" in map(str, written) else sys.stdout  # stdout holds the CSV alone
    if args.measure:
        from circuitnsds.output.measure import evaluate, format_table

        table = format_table([evaluate(expression, waves, circuit) for expression in args.measure])
        print(table, file=report, flush=True)
    if getattr(args, "losses", None) is not None or getattr(args, "losses_csv", None):
        from circuitnsds.output.measure import losses

        loads = tuple(name.strip() for name in (args.losses or "").split(",") if name.strip())
        parts = None
        if thermal is not None:
            def parts(t0, t1):
                return {name: result.average(t0, t1) for name, result in thermal.losses.items()}
        table = losses(waves, circuit, getattr(args, "tstart", None), getattr(args, "tstop", None),
                       outputs=loads, devices=parts)
        if args.losses is not None:
            print(table.format(), file=report, flush=True)
        if args.losses_csv:
            with _writing(args.losses_csv):
                table.to_csv(args.losses_csv)
            written.append(args.losses_csv)
    if circuit.measurements or circuit.fourier:  # printed as ngspice prints them
        from circuitnsds.output.meas import fourier, run_measurements

        for result in run_measurements(circuit.measurements, waves):
            print(result.line, file=report, flush=True)
        for spec in circuit.fourier:
            print(fourier(spec, waves), file=report, flush=True)
    if not args.quiet:
        print(f"circuitnsds: {summary}; wrote {_shown(written)}", file=sys.stderr)
    if args.show:
        from circuitnsds.output.plot import show_waveforms

        show_waveforms(waves, names, events=args.mark_events)
    return 0


def _write_partial(args: argparse.Namespace, partial, when: str, stream=None) -> None:
    """Write the waveforms computed before a failed step or an interruption (``partial``,
    ``None`` if nothing was computed; ``stream``: the CSV written so far) to the files asked
    for (the error itself is reported by the caller); a failure to write them is only
    mentioned."""
    if stream is not None and stream.rows:
        partial, last = stream.waveforms(partial or _no_rows(stream.names)), stream.last_time
    elif partial is None or partial.time.size == 0:
        if stream is not None:
            stream.abort()
        print("circuitnsds: no results to write (the run stopped before its first step)",
              file=sys.stderr)
        return
    else:
        last = partial.time[-1]
    note = f"partial: the run stopped at t = {last:.6g} s ({when}); the rows end there"
    try:
        _, written = _write_outputs(args, partial, stream, partial=note)
    except CircuitnsdsError as exc:
        print(f"circuitnsds: the results {when} were not written: {exc.message}", file=sys.stderr)
        return
    print(f"circuitnsds: wrote the results up to t = {last:.6g} s "
          f"({when}) to {_shown(written)}", file=sys.stderr)


def _no_rows(names: list[str]):
    """Waveforms of ``names`` without a row (what a streamed run leaves in memory)."""
    import numpy as np

    from circuitnsds.output.waveforms import Waveforms

    return Waveforms(time=np.zeros(0), signals={name: np.zeros(0) for name in names})


def _selected(args: argparse.Namespace, waves):
    """The waveforms to write: differential ``v(a,b)`` signals of ``--signals`` added, the
    ``--tstart``/``--tstop`` window and ``--every`` decimation applied."""
    import numpy as np

    from circuitnsds.arrays import sorted_unique
    from circuitnsds.errors import CircuitError
    from circuitnsds.output.waveforms import Waveforms

    extra = {}
    for name in _signal_names(args.signals or ""):
        if name.startswith("v(") and "," in name and name not in waves:
            from circuitnsds.output.measure import MeasurementError, series

            try:
                extra[name] = series(waves, name)[1]
            except MeasurementError as exc:
                raise CircuitError(exc.message, where="--signals", hint=exc.hint) from None
    every = getattr(args, "every", 1)
    tstart, tstop = getattr(args, "tstart", None), getattr(args, "tstop", None)
    if every < 1:
        raise CircuitError(f"--every {every} must be at least 1", where="--every")
    time = waves.time
    keep = np.ones(time.size, dtype=bool)
    if tstart is not None:
        keep &= time >= tstart
    if tstop is not None:
        keep &= time <= tstop
    index = np.flatnonzero(keep)
    if index.size == 0:
        raise CircuitError(f"no time point in the window --tstart/--tstop "
                           f"(the run spans {time[0]:g} .. {time[-1]:g} s)", where="--tstart")
    if every > 1:
        index = sorted_unique(np.append(index[::every], index[-1]))
    if not extra and index.size == time.size:
        return waves
    signals = {name: np.asarray(waves[name])[index] for name in waves.names}
    signals.update({name: values[index] for name, values in extra.items()})
    first, last = time[index[0]], time[index[-1]]  # the switchings in the window, all of them
    return Waveforms(time[index], signals, title=waves.title, stats=waves.stats,
                     residual=None if waves.residual is None else waves.residual[index],
                     events=[event for event in waves.events if first <= event[0] <= last])


def _write_outputs(args: argparse.Namespace, waves, stream=None,
                   partial: str | None = None) -> tuple[list[str] | None, list[Path]]:
    """Write the CSV (``stream``: put in place the one written during the run) and the files
    of :data:`~circuitnsds.output.writers.WRITERS` asked for (raw file, figure, events), as
    one set: all replaced or none
    (:func:`~circuitnsds.output.files.replaced_together`). ``partial``: the note that marks a
    partial result (a first line ``# partial: ...`` in the CSV files, the same words in the
    raw file's and the figure's title). Returns the signal names chosen with ``--signals``
    (``None``: all) and the files written."""
    from circuitnsds.errors import CircuitError
    from circuitnsds.output.files import replaced_together
    from circuitnsds.output.writers import WRITERS, WriterSettings

    names = None
    if args.signals:
        names = [name for name in _signal_names(args.signals) if name != "time"]
        unknown = [name for name in names if name not in waves]
        if unknown:
            if stream is not None:
                stream.abort()
            raise CircuitError(f"unknown signal(s) {', '.join(unknown)}",
                               where="--signals (or .save)", hint=f"available: {', '.join(waves.names)}")
    if partial is not None:
        from dataclasses import replace

        waves = replace(waves, title=f"{waves.title or 'circuitnsds transient'} [{partial}]")
    written = []
    output = _outputs(args).get("-o")
    try:
        with replaced_together() as temporary:
            if stream is None and output is not None and str(output) != "-":
                with _writing(output), open(temporary(output), "wb") as handle:
                    if partial is not None:
                        handle.write(f"# {partial}\n".encode())
                    waves.to_csv(handle, names)
            settings = WriterSettings(binary=not args.ascii, mark_events=args.mark_events, partial=partial)
            for writer in WRITERS:  # -r, --plot, --events (output/writers.py)
                path = getattr(args, writer.attribute, None)
                if path:
                    with _writing(path):
                        writer.write(waves, temporary(path), names, settings)
                    written.append(path)
            if stream is not None:  # last: its rename comes just before the others'
                stream.commit(partial)
            elif output is not None and str(output) == "-":
                if partial is not None:
                    print(f"# {partial}", flush=True)
                waves.to_csv(sys.stdout, names)
                sys.stdout.flush()
    except BaseException:
        if stream is not None:
            stream.abort()
        raise
    return names, ([output] if output is not None else []) + written


def _info(args: argparse.Namespace) -> int:
    from circuitnsds.cli.info import circuit_report

    circuit = _read(args.netlist)
    report, ok = circuit_report(circuit)
    print(report)
    if not ok:
        print("circuitnsds: error: the circuit fails the checks above", file=sys.stderr)
        return 1
    if args.matrices:
        check_outputs({"--matrices": args.matrices}, [circuit.file, *circuit.included, *_stdin(args)])
        from circuitnsds.output.files import atomic_path

        with _writing(args.matrices), atomic_path(args.matrices) as temporary:
            circuit.mlcs().save(temporary)
        print(f"matrices saved to {args.matrices}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
