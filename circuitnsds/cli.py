"""The ``circuitnsds`` command: ``run`` a netlist's transient, or print ``info`` about it.

Errors in the input print one message (file:line, what, hint) on stderr and
exit with status 1; no traceback. ``--debug`` shows tracebacks.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from circuitnsds.errors import CircuitnsdsError
from circuitnsds.values import parse_value


class OutputError(CircuitnsdsError):
    """An output file cannot be written."""


def _seconds(text: str) -> float:
    try:
        return parse_value(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a time (e.g. 1u, 10ms, 2e-3)") from None


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="circuitnsds",
        description="Transient simulation of SPICE netlists with ideal diodes and Zeners.",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    commands = parser.add_subparsers(dest="command", required=True)

    run = commands.add_parser("run", help="run the transient of a netlist, write CSV (and PNG)")
    run.add_argument("netlist", type=Path, help="SPICE netlist (ngspice dialect)")
    run.add_argument("-o", "--output", type=Path,
                     help="CSV file to write (default: NETLIST name with .csv, in the "
                     "current directory)")
    run.add_argument("--plot", type=Path, metavar="PNG", help="also write a plot to this PNG")
    run.add_argument("--signals", help='comma-separated signals to write, e.g. "v(out),i(l1)" '
                     "(default: all)")
    run.add_argument("--step", type=_seconds, help="time step [s] (default: .tran TSTEP)")
    run.add_argument("--stop", type=_seconds, help="end time [s] (default: .tran TSTOP)")
    run.add_argument("--theta", type=float, default=1.0,
                     help="θ of the θ-method in [0.5, 1] (default 1: implicit Euler)")
    run.add_argument("--uic", action="store_true",
                     help="start from initial conditions (as .tran ... UIC)")
    run.add_argument("-q", "--quiet", action="store_true", help="no progress or summary on stderr")

    info = commands.add_parser("info", help="print nodes, elements and MLCS sizes of a netlist")
    info.add_argument("netlist", type=Path)
    info.add_argument("--matrices", type=Path, metavar="NPZ",
                      help="also save the MLCS matrices to this .npz file")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            status = _run(args) if args.command == "run" else _info(args)
        except CircuitnsdsError as exc:
            _print_warnings(caught)
            if args.debug:
                raise
            print(f"circuitnsds: error: {exc}", file=sys.stderr)
            return 1
        except KeyboardInterrupt:
            print("circuitnsds: interrupted", file=sys.stderr)
            return 130
        except Exception as exc:  # a bug in circuitnsds, not bad input
            if args.debug:
                raise
            print(f"circuitnsds: internal error: {type(exc).__name__}: {exc}\n"
                  "  this is a bug; please report it with the netlist "
                  "(run with --debug for the traceback)", file=sys.stderr)
            return 2
    _print_warnings(caught)
    return status


def _print_warnings(caught: list[warnings.WarningMessage]) -> None:
    for warning in caught:
        print(f"circuitnsds: warning: {warning.message}", file=sys.stderr)


class _Progress:
    """Writes ``t = ... (xx%)`` on stderr, overwriting the line, for runs over a second."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.shown = False

    def __call__(self, t: float, stop: float) -> None:
        if not self.enabled:
            return
        self.shown = True
        print(f"\r  t = {t:.4g} s ({100 * t / stop:5.1f} %)", end="", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.shown:
            print(file=sys.stderr)


@contextmanager
def _writing(path: Path) -> Iterator[None]:
    """Turn a failure to write ``path`` into a clean error."""
    try:
        yield
    except OSError as exc:
        raise OutputError(f"cannot write {path}: {exc.strerror or exc}", where=str(path),
                          hint="check that the folder exists and is writable") from None


def _run(args: argparse.Namespace) -> int:
    from circuitnsds import read_netlist
    from circuitnsds.errors import CircuitError

    circuit = read_netlist(args.netlist)
    progress = _Progress(enabled=not args.quiet)
    try:
        waves = circuit.transient(args.step, args.stop, theta=args.theta,
                                  uic=True if args.uic else None, progress=progress)
    finally:
        progress.close()
    names = None
    if args.signals:
        names = [name.strip() for name in args.signals.split(",")
                 if name.strip() and name.strip().lower() != "time"]
        unknown = [name for name in names if name not in waves]
        if unknown:
            raise CircuitError(f"unknown signal(s) {', '.join(unknown)}",
                               where="--signals", hint=f"available: {', '.join(waves.names)}")
    output = args.output or Path(args.netlist.stem + ".csv")
    with _writing(output):
        waves.to_csv(output, names)
    if args.plot:
        from circuitnsds.plot import plot_waveforms

        with _writing(args.plot):
            plot_waveforms(waves, args.plot, names)
    if not args.quiet:
        stats = waves.stats
        print(f"circuitnsds: {stats['steps']} steps in {stats['seconds']:.3g} s "
              f"({stats['unknowns']} unknowns, {stats['pairs']} complementarity pairs); "
              f"max residual {waves.residual.max():.1e}; wrote {output}"
              + (f" and {args.plot}" if args.plot else ""), file=sys.stderr)
    return 0


def _info(args: argparse.Namespace) -> int:
    from circuitnsds import read_netlist
    from circuitnsds.elements import Diode

    circuit = read_netlist(args.netlist)
    mlcs = circuit.mlcs()
    print(f"title:    {circuit.title}")
    print(f"nodes:    {', '.join(circuit.nodes)} (+ ground 0)")
    print(f"elements: {len(circuit.elements)}")
    for element in circuit.elements:
        if isinstance(element, Diode):
            m = element.model
            detail = f"{m.kind} diode, Vfwd={m.forward_drop:g} V, Ron={m.on_resistance:g} Ω, " \
                     f"Roff={m.off_resistance:g} Ω"
            if m.kind == "zener":
                detail += f", BV={m.breakdown_voltage:g} V, Rrev={m.breakdown_resistance:g} Ω"
            print(f"  {element.name} {' '.join(element.nodes)}: model {m.name}: {detail}")
    if circuit.tran:
        t = circuit.tran
        print(f"tran:     step {t.step:g} s, stop {t.stop:g} s"
              + (f", start {t.start:g} s" if t.start else "")
              + (f", max step {t.max_step:g} s" if t.max_step else "")
              + (", UIC" if t.uic else ""))
    print(mlcs)
    if args.matrices:
        with _writing(args.matrices):
            mlcs.save(args.matrices)
        print(f"matrices saved to {args.matrices}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
