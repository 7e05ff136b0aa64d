"""Fuzzing: mutated netlists must only ever raise circuitnsds's own errors.

Run from the repository root::

    python benchmarks/fuzz.py [--cases 10000] [--seed 0] [--workers 4] [--cli-every 5]

Each case takes a netlist of ``netlists/`` (or an empty or binary file), applies one
to three random mutations (:func:`mutate`: deleted tokens and lines, swapped letters,
garbage bytes, huge numbers, NaN/inf literals, truncation, duplicated lines, very long
lines and tokens, stray parentheses/braces/quotes; deep nesting: parentheses, function
calls and unary signs hundreds to twenty thousand deep, chains of ``.param`` dependencies
written in order or backwards, subcircuits instantiating several of the level below up to
101 levels deep; extreme values: numbers at the edges of the doubles and of physics,
``.options gmin`` from 0 to 1e300), writes it to a file and runs
:func:`run_case`: ``read_netlist`` → ``circuit.mlcs()`` → a ten-step transient, and
for every ``--cli-every``-th case also ``circuitnsds info`` in-process.

The allowed outcomes are success and a :class:`~circuitnsds.CircuitnsdsError`
subclass; the command line must exit with 0 or 1, print no traceback and no
"internal error", and at most two error lines. Anything else is a *finding*: it is
printed with the input that triggered it (saved under ``--findings``) and the script
exits with status 1. Cases run in worker processes with a memory limit and a time
limit, so that a runaway case is reported (``MemoryError`` / ``timeout``) instead of
stopping the machine. The table at the end counts outcomes by exception type.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import io
import multiprocessing
import random
import resource
import signal
import sys
import tempfile
import time
import traceback
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
NETLISTS = ROOT / "netlists"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

CASE_SECONDS = 120
"""Time limit of one case (parse, stamp, ten steps, info) in a worker [s]."""
MEMORY_BYTES = 3 * 1024**3
"""Address-space limit of a worker process [bytes]."""
TRANSIENT_STEPS = 10
MESSAGE_CHARS = 2000
"""Longest acceptable error message (a netlist line of a megabyte must not be echoed whole)."""

HUGE = ["1e308", "-1e308", "1e999", "9" * 400, "1e-320", "0", "-0", "1e-300", "1meg" * 3,
        "1e308meg", "123456789012345678901234567890", "0.0000000000000000000000000001"]
NON_FINITE = ["nan", "NaN", "inf", "-inf", "Infinity", "{1/0}", "{0*1e999}", "{1e300*1e300}",
              "{sqrt(-1)}", "{log(0)}", "'1/0'", "{nan}", "{inf}", "1e", "e5", "--1", "1..2"]
STRAY = ["(", ")", "=", "{", "}", "'", '"', "+", ",", ".end", ".ends", ".subckt x a b",
         ".include", ".lib", ".param", ".param a={a}", ".model", ".tran", "x1", "0", "gnd",
         "*", ";", "$", "\\", "\t", "\r", "\x0c", "\u00b5", "\u2212", "\ufeff"]


EXTREME = ["1e-15", "1e-300", "1e300", "1e-320", "5e-324", "1.7e308", "1e-30", "1e30", "1e-400",
           "1e400", "1f", "1t", "1e-12", "1e12", "2.2250738585072014e-308"]
"""Values at the edges of the doubles and of physics, for any number of the netlist."""
OPTIONS = [".options gmin=1e300", ".options gmin=1e-300", ".options gmin=0", ".options theta=0.5",
           ".options theta=1e-300", ".options gmin=1e-15"]
DEPTHS = (2, 50, 99, 100, 101, 300, 5000)
"""Nesting depths of the deep-nesting generators (the parser's limit is 100)."""


def nested_expression(rng: random.Random) -> str:
    """An expression nested deeply: parentheses, function calls, unary signs, powers."""
    depth = rng.choice(DEPTHS)
    value = rng.choice(["1", "2", "1k", "0.5"])
    shape = rng.choice(["parens", "calls", "unary", "power", "mixed"])
    if shape == "parens":
        text = "(" * depth + value + ")" * depth
    elif shape == "calls":
        call = rng.choice(["abs(", "sqrt(", "max(1,", "exp(", "sgn("])
        text = call * depth + value + ")" * depth
    elif shape == "unary":
        text = "".join(rng.choice("+-") for _ in range(rng.choice((1, 2, 1000, 20000, 20001)))) + value
    elif shape == "power":
        text = value + "^" + "-" * depth + "1"
    else:
        text = "(-" * depth + value + ")" * depth
    return "{" + text + "}"


def param_chain(rng: random.Random) -> tuple[list[bytes], str]:
    """``.param`` lines of a chain of dependencies (written in order or backwards) and the
    name of its last parameter."""
    length = rng.choice((3, 49, 50, 51, 300, 3000))
    lines = [f".param fz{k}={{fz{k - 1}+1}}".encode() for k in range(1, length)]
    lines.insert(0, b".param fz0=1")
    if rng.random() < 0.5:
        lines.reverse()
    return lines, f"{{fz{length - 1}}}"


def fan_out(rng: random.Random) -> list[bytes]:
    """Subcircuits each instantiating ``fan`` of the level below, ``depth`` levels: fan^depth
    resistors from a few lines, tied to ground by ``Rfz``."""
    depth, fan = rng.choice([(2, 2), (8, 2), (12, 3), (20, 2), (30, 2), (40, 4), (101, 1)])
    lines = [b".subckt fzl0 a b", b"Rfz a b 1k", b".ends"]
    for level in range(1, depth + 1):
        lines.append(f".subckt fzl{level} a b".encode())
        lines += [f"Xfz{k} a b fzl{level - 1}".encode() for k in range(fan)]
        lines.append(b".ends")
    return lines + [f"Xfztop fza 0 fzl{depth}".encode(), b"Rfzt fza 0 1k"]


def corpus() -> dict[str, bytes]:
    """The seeds: every bundled netlist (``.cir`` and the ``.lib`` it includes)."""
    return {path.name: path.read_bytes() for path in sorted(NETLISTS.glob("*.cir"))}


def _tokens(text: bytes) -> list[tuple[int, int]]:
    """``(start, end)`` of every whitespace-separated token."""
    spans, start = [], None
    for index, byte in enumerate(text + b" "):
        if chr(byte).isspace():
            if start is not None:
                spans.append((start, index))
                start = None
        elif start is None:
            start = index
    return spans


def _numbers(text: bytes) -> list[tuple[int, int]]:
    return [(a, b) for a, b in _tokens(text) if text[a:a + 1].isdigit()
            or (text[a:a + 1] in b"-+." and text[a + 1:a + 2].isdigit())]


MAX_BYTES = 4_000_000
"""A very long line or token is cut to about this many bytes (mutations may stack)."""
LONG_REPEATS = (1000, 30_000, 200_000)
"""How many times a long line repeats its unit (a 200 000-fold line is a few megabytes)."""


def mutate(data: bytes, rng: random.Random, long_repeats: tuple[int, ...] = LONG_REPEATS) -> bytes:
    """One random mutation of ``data`` (see the module docstring); ``long_repeats``: the
    lengths (in repeats of a unit) of the very long lines and tokens it may insert."""
    kind = rng.choice(["delete_token", "swap_letters", "garbage", "huge", "non_finite",
                       "truncate", "duplicate_line", "delete_line", "long_line", "long_token",
                       "stray", "case", "swap_lines", "empty", "binary", "deep_nesting",
                       "param_chain", "fan_out", "extreme", "extreme_option"])
    tokens = _tokens(data)
    if kind == "empty":
        return rng.choice([b"", b"\n", b" ", b"title only\n", b"\n\n.end\n"])
    if kind == "binary":
        return bytes(rng.randrange(256) for _ in range(rng.randrange(1, 300))) + b"\0"
    if kind == "delete_token" and tokens:
        a, b = rng.choice(tokens)
        return data[:a] + data[b:]
    if kind == "swap_letters" and len(data) > 2:
        i = rng.randrange(len(data) - 1)
        return data[:i] + data[i + 1:i + 2] + data[i:i + 1] + data[i + 2:]
    if kind == "garbage":
        i = rng.randrange(len(data) + 1)
        junk = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 12)))
        return data[:i] + junk + data[i:]
    if kind in {"huge", "non_finite"}:
        spans = _numbers(data) or tokens
        if spans:
            a, b = rng.choice(spans)
            value = rng.choice(HUGE if kind == "huge" else NON_FINITE)
            return data[:a] + value.encode() + data[b:]
        return data
    if kind == "deep_nesting" and tokens:
        a, b = rng.choice(_numbers(data) or tokens)
        return data[:a] + nested_expression(rng).encode() + data[b:]
    if kind == "extreme":
        spans = _numbers(data)
        if spans:
            a, b = rng.choice(spans)
            return data[:a] + rng.choice(EXTREME).encode() + data[b:]
        return data
    if kind == "truncate":
        return data[:rng.randrange(len(data) + 1)]
    lines = data.split(b"\n")
    if kind == "duplicate_line":
        i = rng.randrange(len(lines))
        return b"\n".join(lines[:i + 1] + [lines[i]] + lines[i + 1:])
    if kind == "delete_line":
        i = rng.randrange(len(lines))
        return b"\n".join(lines[:i] + lines[i + 1:])
    if kind == "param_chain":
        chain, last = param_chain(rng)
        spans = _numbers(data)
        if spans:
            a, b = rng.choice(spans)
            data = data[:a] + last.encode() + data[b:]
        lines = data.split(b"\n")
        return b"\n".join(lines[:1] + chain + lines[1:])
    if kind == "fan_out":
        return b"\n".join(lines[:1] + fan_out(rng) + lines[1:])
    if kind == "extreme_option":
        return b"\n".join(lines[:1] + [rng.choice(OPTIONS).encode()] + lines[1:])
    if kind == "swap_lines" and len(lines) > 1:
        i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
        lines[i], lines[j] = lines[j], lines[i]
        return b"\n".join(lines)
    if kind == "long_line":
        i = rng.randrange(len(lines))
        unit = rng.choice([b"x", b" 1k", b"R1 a 0 1k ", b"(", b"{", b"+ 1 ", lines[i] + b" "])
        lines.insert(i, unit * min(rng.choice(long_repeats), MAX_BYTES // len(unit)))
        return b"\n".join(lines)
    if kind == "long_token" and tokens:
        a, b = rng.choice(tokens)
        repeats = min(rng.choice([100, min(5000, max(long_repeats))]), MAX_BYTES // (b - a))
        return data[:b] + data[a:b] * repeats + data[b:]
    if kind == "stray":
        i = rng.randrange(len(data) + 1)
        return data[:i] + b" " + rng.choice(STRAY).encode() + b" " + data[i:]
    if kind == "case" and tokens:
        a, b = rng.choice(tokens)
        return data[:a] + data[a:b].swapcase() + data[b:]
    return data


def make_case(rng: random.Random, seeds: dict[str, bytes],
              long_repeats: tuple[int, ...] = LONG_REPEATS) -> tuple[str, bytes]:
    """``(seed name, mutated bytes)`` with one to three mutations."""
    name = rng.choice(sorted(seeds))
    data = seeds[name]
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        data = mutate(data, rng, long_repeats)
    return name, data


def _shown(data: bytes, limit: int = 800) -> bytes:
    """The lines of ``data`` that are not ``*`` comments, at most ``limit`` bytes of them."""
    lines = [line[:200] for line in data.split(b"\n") if not line.lstrip().startswith(b"*")]
    return b"\n".join(lines)[:limit]


def run_case(data: bytes, directory: Path, cli: bool = False) -> str:
    """Run one mutated netlist; returns the outcome (``ok`` or an exception class name).

    Raises:
        AssertionError: a finding (a non-project exception, a traceback or an internal
            error from the command line, an error message of more than two lines).
    """
    import circuitnsds
    from circuitnsds.errors import CircuitnsdsError

    path = directory / "case.cir"
    path.write_bytes(data)
    outcome = "ok"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            circuit = circuitnsds.read_netlist(path)
            circuit.mlcs()
            tran = circuit.analyses.get("tran")
            step = tran.step if tran is not None else 1e-6
            circuit.transient(step, TRANSIENT_STEPS * step)
        except CircuitnsdsError as exc:
            outcome = type(exc).__name__
            text = str(exc)
            assert len(text.splitlines()) <= 2, f"error of {len(text.splitlines())} lines: {text!r}"
            assert len(text) <= MESSAGE_CHARS, (f"error message of {len(text)} characters: "
                                                f"{text[:300]!r}...")
        except Exception as exc:  # noqa: BLE001 - this is what the fuzzer looks for
            raise AssertionError(f"non-project exception {type(exc).__name__}: {exc}\n"
                                 f"input (without comment lines): {_shown(data)!r}\n"
                                 + traceback.format_exc()) from None
    if cli:
        from circuitnsds.cli.main import main

        stdout, stderr = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            status = main(["info", str(path)])
        err = stderr.getvalue()
        assert status in (0, 1), f"circuitnsds info exited with {status}:\n{err}"
        assert "Traceback" not in err and "internal error" not in err, err
        errors = [line for line in err.splitlines() if not line.startswith("circuitnsds: warning:")]
        assert len(errors) <= 2, f"error of {len(errors)} lines:\n{err}"
    return outcome


# ---------------------------------------------------------------- worker processes

_SEEDS: dict[str, bytes] = {}
_DIRECTORY: Path | None = None


def _init_worker(seeds: dict[str, bytes], directory: str) -> None:
    global _SEEDS, _DIRECTORY
    _SEEDS = seeds
    _DIRECTORY = Path(tempfile.mkdtemp(dir=directory))
    for lib in NETLISTS.glob("*.lib"):  # so that .include of a bundled library resolves
        (_DIRECTORY / lib.name).write_bytes(lib.read_bytes())
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_BYTES, MEMORY_BYTES))
    import circuitnsds  # noqa: F401 - imported once per worker, not timed per case
    import circuitnsds.checks.wellposed  # noqa: F401
    import circuitnsds.cli.main  # noqa: F401


class _Timeout(BaseException):  # not caught by the "except Exception" of run_case
    pass


def _alarm(signum, frame):
    raise _Timeout


def _work(job: tuple[int, int, bool]) -> tuple[int, str, str, float, str | None, bytes | None]:
    """``(index, seed name, outcome, seconds, finding text, input of a finding)``."""
    index, seed, cli = job
    name, data = make_case(random.Random(seed), _SEEDS)
    started = time.perf_counter()
    signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(CASE_SECONDS)
    try:
        outcome = run_case(data, _DIRECTORY, cli)
        finding = None
    except AssertionError as exc:
        outcome, finding = "FINDING", str(exc)
    except _Timeout:
        outcome, finding = "TIMEOUT", f"case did not finish in {CASE_SECONDS} s"
    except MemoryError:
        outcome, finding = "FINDING", "MemoryError (above the worker's memory limit)"
    finally:
        signal.alarm(0)
    seconds = time.perf_counter() - started
    return index, name, outcome, seconds, finding, data if finding else None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=min(4, multiprocessing.cpu_count()))
    parser.add_argument("--cli-every", type=int, default=5,
                        help="also run 'circuitnsds info' on every N-th case (0: never)")
    parser.add_argument("--findings", type=Path, default=Path("fuzz-findings"),
                        help="folder for the inputs of findings")
    args = parser.parse_args(argv)

    seeds = corpus()
    master = random.Random(args.seed)
    jobs = [(k, master.randrange(2**63), bool(args.cli_every) and k % args.cli_every == 0)
            for k in range(args.cases)]
    outcomes: collections.Counter[str] = collections.Counter()
    per_seed: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)
    findings: list[tuple[int, str, str, bytes]] = []
    slowest = (0.0, -1)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as directory, multiprocessing.get_context("fork").Pool(
            args.workers, _init_worker, (seeds, directory), maxtasksperchild=500) as pool:
        for done, (index, name, outcome, seconds, finding, data) in enumerate(
                pool.imap_unordered(_work, jobs, chunksize=8), start=1):
            outcomes[outcome] += 1
            per_seed[name][outcome] += 1
            slowest = max(slowest, (seconds, index))
            if finding:
                findings.append((index, name, finding, data))
                print(f"FINDING in case {index} (from {name}): {finding.splitlines()[0]}",
                      file=sys.stderr, flush=True)
            if done % 1000 == 0:
                print(f"  {done} cases, {time.perf_counter() - started:.0f} s", file=sys.stderr,
                      flush=True)
    wall = time.perf_counter() - started

    print(f"\n{args.cases} mutated netlists (seed {args.seed}, {args.workers} workers, "
          f"'circuitnsds info' on every {args.cli_every}-th): {wall:.1f} s wall, "
          f"{wall / max(args.cases, 1) * 1e3 * args.workers:.1f} ms per case and worker; "
          f"slowest case {slowest[1]}: {slowest[0]:.2f} s\n")
    width = max(len(k) for k in outcomes)
    print(f"{'outcome':<{width}}  {'cases':>6}  share")
    for outcome, count in outcomes.most_common():
        print(f"{outcome:<{width}}  {count:>6}  {100 * count / args.cases:5.1f} %")
    print("\nby seed netlist: " + "; ".join(
        f"{name} {sum(c.values())} ({c['ok']} ran)" for name, c in sorted(per_seed.items())))
    if findings:
        args.findings.mkdir(parents=True, exist_ok=True)
        print(f"\n{len(findings)} FINDINGS (inputs saved in {args.findings}/):")
        for index, name, finding, data in findings:
            (args.findings / f"case{index}.cir").write_bytes(data)
            print(f"--- case {index} (from {name}):\n{finding}")
        return 1
    print("\nno findings: every failure was a circuitnsds error")
    return 0


if __name__ == "__main__":
    sys.exit(main())
