"""What the exact integrator's Python spends building modes (issue 31): the thread CPU time of
the mode-building functions, per run and per mode built, and the numpy calls per mode.

Each case runs in this process through the command line's :func:`~circuitnsds.cli.main.main`
(``run NETLIST -o out.csv --signals S`` on the netlist with ``.options method=exact`` added),
with the functions below wrapped to add up their own thread CPU time (``time.thread_time``,
inclusive: a function's time holds its callees'; a function called inside itself counts once).
``building`` is the time inside ``run.choose_mode`` and ``ModeTables.add`` (outermost calls):
everything Python does when the compiled loop meets a mode it does not know. The table gives
the median of ``--repeats`` runs (each in a fresh :class:`ExactSystem`: nothing is cached
across runs but imports; the least too: on a shared machine the least is the steadier), and
ms per mode built.

``--count`` runs once more with :func:`sys.setprofile` counting the calls into numpy's C
functions and numpy's Python functions made inside the building (per mode built).

Usage: ``PYTHONPATH=$PWD python benchmarks/mode_building.py [--repeats 3] [--only WORD] [--count]``
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import io
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
CASES = [
    ("inverter 400 ms", ROOT / "benchmarks" / "netlists" / "inverter_three_phase.cir", "i(lab)"),
    ("RF multiplier", ROOT / "benchmarks" / "netlists" / "rf_multiplier.cir", "v(out)"),
    ("flyback Coss", ROOT / "benchmarks" / "netlists" / "flyback_coss.cir", "v(out)"),
    ("boost DCM 60 ms", ROOT / "benchmarks" / "netlists" / "boost_dcm_60ms.cir", "v(out)"),
    ("bridge 200 ms", ROOT / "benchmarks" / "netlists" / "bridge_200ms.cir", "v(out)"),
]


def with_exact(text: str) -> str:
    """The netlist with ``.options method=exact`` before its ``.end``."""
    lines = text.splitlines()
    end = max((k for k, line in enumerate(lines) if line.strip().lower() == ".end"), default=len(lines))
    return "\n".join([*lines[:end], ".options method=exact", *lines[end:]]) + "\n"


def targets() -> list[tuple[str, object, str]]:
    """``(label, owner, attribute)`` of the functions timed."""
    from circuitnsds.engine.exact import mode, mode_tables, run, solution_map

    return [
        ("choose_mode", run, "choose_mode"),
        ("ModeTables.add", mode_tables.ModeTables, "add"),
        ("ExactSystem.mode", run.ExactSystem, "mode"),
        ("ModeDynamics.__init__", mode.ModeDynamics, "__init__"),
        ("_pencil_eigen", mode, "_pencil_eigen"),
        ("event_functions", run.ExactSystem, "event_functions"),
        ("_event_rows", run.ExactSystem, "_event_rows"),
        ("solution_map", run.ExactSystem, "solution_map"),
        ("SolutionMap.__init__", solution_map.SolutionMap, "__init__"),
        ("_violations", run, "_violations"),
    ]


BUILDING = ("choose_mode", "ModeTables.add")


class Timers:
    """Inclusive thread CPU seconds and calls per wrapped function; ``outer`` the building's."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self.depth: dict[str, int] = {}
        self.building_depth = 0
        self.building = 0.0

    def wrap(self, label: str, function):
        @functools.wraps(function)
        def timed(*args, **kwargs):
            depth = self.depth.get(label, 0)
            outer = label in BUILDING and self.building_depth == 0
            self.depth[label] = depth + 1
            self.building_depth += label in BUILDING
            start = time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                spent = time.thread_time() - start
                self.depth[label] = depth
                self.building_depth -= label in BUILDING
                if depth == 0:
                    self.seconds[label] = self.seconds.get(label, 0.0) + spent
                    self.calls[label] = self.calls.get(label, 0) + 1
                if outer:
                    self.building += spent
        return timed


@contextlib.contextmanager
def wrapped(timers: Timers):
    originals = []
    for label, owner, attribute in targets():
        original = owner.__dict__[attribute]
        originals.append((owner, attribute, original))
        setattr(owner, attribute, timers.wrap(label, original))
    try:
        yield
    finally:
        for owner, attribute, original in originals:
            setattr(owner, attribute, original)


def run_case(netlist: Path, signal: str, workdir: Path) -> tuple[Timers, int, float, str]:
    """One in-process run: the timers, the modes built, the process's thread CPU of the
    command [s], and its stderr."""
    from circuitnsds.cli.main import main
    from circuitnsds.engine.exact import mode

    path = workdir / netlist.name
    path.write_text(with_exact(netlist.read_text()))
    timers = Timers()
    built = [0]
    original = mode.ModeDynamics.__init__

    def counting(self, *args, **kwargs):
        built[0] += 1
        original(self, *args, **kwargs)

    mode.ModeDynamics.__init__ = counting
    err = io.StringIO()
    try:
        with wrapped(timers), contextlib.redirect_stderr(err):
            start = time.thread_time()
            main(["run", str(path), "-o", str(workdir / "out.csv"), "--signals", signal])
            total = time.thread_time() - start
    finally:
        mode.ModeDynamics.__init__ = original
    return timers, built[0], total, err.getvalue()


def count_numpy(netlist: Path, signal: str, workdir: Path) -> tuple[int, int, int]:
    """``(numpy C calls, numpy Python calls, modes built)`` inside the building."""
    from circuitnsds.cli.main import main
    from circuitnsds.engine.exact import mode, mode_tables, run

    path = workdir / netlist.name
    path.write_text(with_exact(netlist.read_text()))
    counts = [0, 0, 0]
    inside = [0]

    def profiler(frame, event, arg):
        if not inside[0]:
            return
        if event == "c_call":
            module = getattr(arg, "__module__", None) or ""
            owner = type(getattr(arg, "__self__", None)).__module__ or ""
            if module.startswith("numpy") or owner.startswith("numpy"):
                counts[0] += 1
        elif event == "call" and "/numpy/" in frame.f_code.co_filename:
            counts[1] += 1

    def entering(function):
        @functools.wraps(function)
        def inner(*args, **kwargs):
            inside[0] += 1
            try:
                return function(*args, **kwargs)
            finally:
                inside[0] -= 1
        return inner

    originals = [(run, "choose_mode", run.choose_mode),
                 (mode_tables.ModeTables, "add", mode_tables.ModeTables.add)]
    init = mode.ModeDynamics.__init__

    def counting(self, *args, **kwargs):
        counts[2] += 1
        init(self, *args, **kwargs)

    mode.ModeDynamics.__init__ = counting
    for owner, attribute, function in originals:
        setattr(owner, attribute, entering(function))
    sys.setprofile(profiler)
    try:
        with contextlib.redirect_stderr(io.StringIO()):
            main(["run", str(path), "-o", str(workdir / "out.csv"), "--signals", signal])
    finally:
        sys.setprofile(None)
        for owner, attribute, function in originals:
            setattr(owner, attribute, function)
        mode.ModeDynamics.__init__ = init
    return counts[0], counts[1], counts[2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--only", help="the cases whose label contains this")
    parser.add_argument("--count", action="store_true", help="count numpy calls per mode too")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        workdir = Path(scratch)
        for label, netlist, signal in CASES:
            if args.only and args.only.lower() not in label.lower():
                continue
            runs = [run_case(netlist, signal, workdir) for _ in range(args.repeats)]
            built = runs[0][1]
            building = statistics.median(r[0].building for r in runs)
            total = statistics.median(r[2] for r in runs)
            summary = next((line for line in runs[0][3].splitlines() if "exact segments" in line), "")
            least = min(r[0].building for r in runs)
            print(f"== {label}: {built} modes built; building {building:.3f} s "
                  f"({1e3 * building / max(built, 1):.2f} ms/mode; least {least:.3f} s) of the command's "
                  f"{total:.3f} s thread CPU (medians of {args.repeats})")
            print(f"   {summary.strip()}")
            for name in [t[0] for t in targets()]:
                seconds = statistics.median(r[0].seconds.get(name, 0.0) for r in runs)
                calls = runs[0][0].calls.get(name, 0)
                per_mode = 1e3 * seconds / max(built, 1)
                print(f"   {name:<24} {calls:>6} calls {seconds:8.4f} s {per_mode:7.3f} ms/mode")
            if args.count:
                c_calls, py_calls, modes = count_numpy(netlist, signal, workdir)
                print(f"   numpy calls in the building: {c_calls / max(modes, 1):.0f} C and "
                      f"{py_calls / max(modes, 1):.0f} Python functions per mode built ({modes} modes)")


if __name__ == "__main__":
    main()
