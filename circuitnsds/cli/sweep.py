"""``circuitnsds sweep``: a netlist at many parameter values, a table (and a figure).

``circuitnsds run`` on a netlist with ``.step`` lines comes here too. The table goes to
stdout (and to ``-o`` as CSV); the exit status is 0 when every point ran, 1 when some
failed or were lost by a Dask cluster (their rows say why, the error message names the
lost rows; the table is written all the same).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from circuitnsds.cli.joined import Joined
from circuitnsds.cli.progress import CountBar
from circuitnsds.errors import CircuitError
from circuitnsds.values import parse_value

LOST_SHOWN = 20
"""Lost rows named in the error message (the table has them all)."""

PARAM_HELP = ('NAME=START:STOP:COUNT (COUNT values, both ends included), NAME=V1,V2,... or NAME=V; '
              'repeatable: the points are the outer product (first --param outermost, after the '
              "netlist's .step lines)")


def _seconds(text: str) -> float:
    try:
        return parse_value(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a time (e.g. 1u, 10ms, 2e-3)") from None


def _positive_seconds(text: str) -> float:
    value = _seconds(text)
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: give a positive number of seconds")
    return value


def _param(text: str):
    from circuitnsds.netlist.steps import StepSyntaxError, parse_param_option

    try:
        return parse_param_option(text)
    except StepSyntaxError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_sweep_parser(commands) -> None:
    """The ``sweep`` subcommand's arguments."""
    sweep = commands.add_parser("sweep", help="run a netlist at many parameter values (or Monte "
                                "Carlo runs), locally or on a Dask cluster; write a table")
    sweep.add_argument("netlist", type=Path, help="SPICE netlist with .param definitions")
    sweep.add_argument("--param", action="append", default=[], type=_param, metavar="NAME=VALUES",
                       help=PARAM_HELP)
    sweep.add_argument("--samples", type=int, metavar="N",
                       help="N Monte Carlo runs (parameter run = 1..N, innermost), as "
                       ".step param run 1 N 1")
    sweep.add_argument("--measure", action="append", default=[], metavar="EXPR",
                       help='measurement per point, e.g. "mean(v(out), 1m, 2m)"; repeatable; '
                       "a column each")
    sweep.add_argument("--losses", nargs="?", const="", metavar="LOADS",
                       help="add each point's loss figures as columns: efficiency (with LOADS, "
                       "comma-separated load elements), losses_W, each datasheet device's "
                       "conduction/turn-on/turn-off/recovery power and max(tj(DEVICE))")
    sweep.add_argument("-o", "--output", type=Path, metavar="CSV", help="write the table as CSV")
    sweep.add_argument("--plot", type=Path, metavar="PNG",
                       help="figure: each measurement against the first swept parameter (a line per "
                       "value of the next), or histograms for Monte Carlo runs")
    sweep.add_argument("--waveforms", type=Path, metavar="DIR",
                       help="also write each point's waveforms to DIR/point_NNNN.csv")
    sweep.add_argument("--signals", action=Joined,
                       help='signals written with --waveforms, e.g. "v(out),i(l1)" (repeatable)')
    add_execution_arguments(sweep)
    sweep.add_argument("--step", type=_seconds, help="time step [s] (default: .tran TSTEP)")
    sweep.add_argument("--stop", type=_seconds, help="end time [s] (default: .tran TSTOP)")
    sweep.add_argument("--theta", type=float, default=None, help="θ of the θ-method in [0.5, 1]")
    sweep.add_argument("-q", "--quiet", action="store_true", help="no progress or summary on stderr")


def add_execution_arguments(parser: argparse.ArgumentParser) -> None:
    """``--workers``, ``--scheduler``, ``--seed``: for ``sweep``, and for ``run`` on a netlist
    with ``.step`` lines."""
    parser.add_argument("--workers", type=int, metavar="N",
                        help="sweeps: local worker processes (default: one per core); 0: every "
                        "point in this process, without Dask")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="sweeps: a running Dask scheduler, e.g. tcp://host:8786 (its workers "
                        "need circuitnsds, not the netlist's files)")
    parser.add_argument("--seed", type=int,
                        help="Monte Carlo seed (default: .options seed, else 1)")
    parser.add_argument("--connect-timeout", type=_positive_seconds, metavar="S",
                        help="sweeps: seconds to reach --scheduler and to wait for one answer from "
                        "it (default 10)")
    parser.add_argument("--worker-timeout", type=_positive_seconds, metavar="S",
                        help="sweeps: seconds to wait while the cluster has no worker or its scheduler "
                        "does not answer; then the points not finished are marked lost (default 60)")


def run_sweep(args: argparse.Namespace, builder=None) -> int:
    """Run ``circuitnsds sweep`` (or ``run`` on a netlist with ``.step`` lines; ``builder``:
    the netlist already read)."""
    from circuitnsds.frontend.build import CircuitBuilder
    from circuitnsds.sweeps.api import sweep

    builder = builder if builder is not None else CircuitBuilder.load(args.netlist)
    params = {}
    for step in getattr(args, "param", []):
        if step.name.lower() in {name.lower() for name in params}:
            raise CircuitError(f"--param {step.name} is given twice", where="--param")
        params[step.name] = list(step.values)
    signals = [s.strip() for s in args.signals.split(",") if s.strip()] if args.signals else None
    from circuitnsds.output.files import check_outputs

    netlist = builder.netlist
    check_outputs({option: path for option, path in (("-o", args.output), ("--plot", args.plot),
                                                     ("--waveforms", getattr(args, "waveforms", None)))
                   if path}, [netlist.file, *netlist.included], stdout=("-o",),  # not over the netlist
                  folders=("--waveforms",))
    if args.plot:  # matplotlib present and the figure format known, before the run
        from circuitnsds.output import sweep_plot  # noqa: F401
        from circuitnsds.output.plot import plot_format

        plot_format(args.plot)
    progress = CountBar(sys.stderr, enabled=False if args.quiet else None)
    try:
        table = sweep(builder, params, samples=getattr(args, "samples", None), measure=args.measure,
                      signals=signals, workers=getattr(args, "workers", None),
                      scheduler=getattr(args, "scheduler", None), seed=getattr(args, "seed", None),
                      keep_waveforms=getattr(args, "waveforms", None) or False, step=args.step,
                      stop=args.stop, theta=args.theta, progress=progress,
                      losses=None if getattr(args, "losses", None) is None else
                      [name.strip() for name in args.losses.split(",") if name.strip()],
                      connect_timeout=getattr(args, "connect_timeout", None),
                      worker_timeout=getattr(args, "worker_timeout", None))
    finally:
        progress.close()
    figures = [*args.measure, *table.attrs["loss_columns"]]
    parameters = [c for c in table.columns if c not in (*figures, "status", "error", "warnings",
                                                        "file")]
    warned = list(dict.fromkeys(m for text in table["warnings"] if text for m in text.split("\n")))
    if getattr(args, "strict", False) and warned:  # run --strict: nothing written
        for message in warned:
            print(f"circuitnsds: warning (in some points): {message}", file=sys.stderr)
        print("circuitnsds: error: the warnings above are errors under --strict", file=sys.stderr)
        return 1
    written = []
    to_stdout = str(args.output) == "-"  # the CSV alone on stdout, the table for people on stderr
    if to_stdout:
        table.to_csv(sys.stdout, index=False, float_format="%.10g")
        sys.stdout.flush()
    elif args.output:
        from circuitnsds.output.files import atomic_path, writing

        with writing(args.output), atomic_path(args.output) as temporary:
            table.to_csv(temporary, index=False, float_format="%.10g")
        written.append(args.output)
    shown = table.drop(columns=[c for c in ("warnings", "file") if c in table.columns])
    if not (table["error"] != "").any():
        shown = shown.drop(columns=["status", "error"])
    print(shown.to_string(index=False, float_format=lambda v: f"{v:.6g}"),
          file=sys.stderr if to_stdout else sys.stdout, flush=True)
    for message in warned:
        print(f"circuitnsds: warning (in some points): {message}", file=sys.stderr)
    if args.plot:
        from circuitnsds.output.files import writing
        from circuitnsds.output.sweep_plot import plot_sweep

        with writing(args.plot):
            plot_sweep(table, parameters, figures, args.plot)
        written.append(args.plot)
    from circuitnsds.sweeps.execute import LOST

    lost = [k for k, status in enumerate(table["status"]) if status == LOST]
    failed = int((table["status"] != "ok").sum()) - len(lost)
    if not args.quiet:
        where = f"; wrote {', '.join(map(str, written))}" if written else ""
        print(f"circuitnsds: {len(table)} points in {table.attrs['seconds']:.3g} s, "
              f"{failed} failed, {len(lost)} lost{where}", file=sys.stderr)
    if lost:
        shown_rows = ", ".join(map(str, lost[:LOST_SHOWN])) + (", ..." if len(lost) > LOST_SHOWN else "")
        reasons = "; ".join(dict.fromkeys(table["error"][k].removeprefix("lost: ") for k in lost))
        print(f"circuitnsds: error: {len(lost)} of {len(table)} points lost by the cluster (rows "
              f"{shown_rows}, counted from 0; status 'lost' in the table): {reasons}", file=sys.stderr)
    if failed:
        print(f"circuitnsds: error: {failed} of {len(table)} points failed (see the error column)",
              file=sys.stderr)
    return 1 if failed or lost else 0


def run_steps(args: argparse.Namespace, builder=None) -> int:
    """``circuitnsds run`` on a netlist with ``.step`` lines: the sweep they describe, the
    ``run`` options that make sense for a table (``-o`` is the table's CSV)."""
    used = [name for name, on in (("-r", args.raw), ("--ascii", args.ascii), ("--show", args.show),
                                  ("--uic", args.uic), ("--events", args.events),
                                  ("--mark-events", args.mark_events), ("--losses-csv", args.losses_csv),
                                  ("--tstart", args.tstart is not None),
                                  ("--tstop", args.tstop is not None), ("--every", args.every != 1))
            if on]
    if used:  # options about one run's waveforms: a sweep writes a table
        raise CircuitError(f"{', '.join(used)}: not available when .step lines make `run` a sweep",
                           where=str(args.netlist), hint="the sweep writes one row per point (-o, "
                           "--plot, --measure); for one point's waveforms use circuitnsds sweep "
                           "--waveforms DIR; for UIC add it to the .tran line")
    return run_sweep(args, builder)
