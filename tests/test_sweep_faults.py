"""Sweeps on a Dask cluster that fails: a real scheduler and real workers on 127.0.0.1,
killed while the sweep runs. The finished points are kept, the others are marked lost,
the sweep ends within its timeouts, and bad addresses are refused before connecting."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import circuitnsds
from circuitnsds.sweeps.execute import ExecutorError, scheduler_address

ROOT = Path(__file__).resolve().parent.parent

# A diode rectifier on an RC: ten thousand steps per millisecond of T; T = 3 is a point of
# a few tenths of a second, T = 100 keeps a gigabyte of waveforms (a worker's memory limit).
SLOW_POINT = """RC and diode, run for T milliseconds
.param T=1
V1 a 0 PULSE(0 1 0 0 0 5u 10u)
R1 a b 1k
C1 b 0 1n
D1 b c dmod
R2 c 0 1k
.model dmod D(Ron=1m)
.tran 10n {T*1m}
.end
"""
MEAN = "mean(v(b))"
POINTS = 24


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _start(arguments: list[str], log: Path, **environment: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT), **environment}
    return subprocess.Popen([sys.executable, "-m", *arguments], stdout=log.open("w"),
                            stderr=subprocess.STDOUT, env=env, start_new_session=True)


class Cluster:
    """A scheduler and ``workers`` worker processes on 127.0.0.1 (ended by :meth:`close`)."""

    def __init__(self, folder: Path, workers: int, worker_options: tuple[str, ...] = ("--no-nanny",),
                 **environment: str):
        port = _free_port()
        self.address = f"tcp://127.0.0.1:{port}"
        self.scheduler = _start(["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port",
                                 str(port), "--no-dashboard"], folder / "scheduler.log", **environment)
        self.workers = [_start(["distributed.cli.dask_worker", self.address, "--nthreads", "1",
                                "--no-dashboard", "--host", "127.0.0.1", *worker_options],
                               folder / f"worker{k}.log", **environment) for k in range(workers)]
        from distributed import Client

        with Client(self.address, timeout="30s") as client:
            client.wait_for_workers(workers, timeout=60)

    def kill(self, processes) -> None:
        for process in processes:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)  # the worker and its nanny's children

    def close(self) -> None:
        self.kill([self.scheduler, *self.workers])
        for process in (self.scheduler, *self.workers):
            process.wait(timeout=15)


def _sweep_killing(cluster: Cluster, victims, after: int, **options):
    """The sweep of ``POINTS`` slow points; ``victims`` killed once ``after`` points finished."""
    killed = threading.Event()

    def progress(done: int, total: int) -> None:
        if done >= after and not killed.is_set():
            killed.set()
            cluster.kill(victims)

    started = time.monotonic()
    table = circuitnsds.sweep(SLOW_POINT, {"T": [3.0] * POINTS}, measure=[MEAN],
                              scheduler=cluster.address, progress=progress, **options)
    return table, time.monotonic() - started


def _check_kept_and_lost(table) -> None:
    assert len(table) == POINTS and set(table["status"]) <= {"ok", "lost"}
    ok, lost = table[table["status"] == "ok"], table[table["status"] == "lost"]
    assert len(ok) >= 3 and len(lost) >= 1, list(table["status"])
    # the kept rows are the points' true values: the diode's mean over whole periods is 1/4 V
    assert ok[MEAN].between(0.2499, 0.2501).all(), list(ok[MEAN])
    assert lost[MEAN].isna().all() and lost["error"].str.startswith("lost: ").all()
    assert (ok["error"] == "").all()


def test_a_killed_scheduler_keeps_the_finished_points_and_marks_the_rest_lost(tmp_path):
    cluster = Cluster(tmp_path, workers=2)
    try:
        table, seconds = _sweep_killing(cluster, [cluster.scheduler], after=3, worker_timeout=5)
    finally:
        cluster.close()
    _check_kept_and_lost(table)
    assert table[table["status"] == "lost"]["error"].str.contains("scheduler").all()
    assert seconds < 60


def test_all_workers_killed_ends_after_the_worker_timeout(tmp_path):
    cluster = Cluster(tmp_path, workers=2)
    try:
        table, seconds = _sweep_killing(cluster, cluster.workers, after=3, worker_timeout=2,
                                        connect_timeout=2)
    finally:
        cluster.close()
    _check_kept_and_lost(table)
    errors = table[table["status"] == "lost"]["error"]
    assert errors.str.contains("no worker for 2 s").any()  # the points never run
    assert (errors.str.contains("no worker for 2 s") | errors.str.contains("worker holding it")).all()
    assert seconds < 60


def test_a_worker_killed_by_its_memory_limit_loses_only_its_point(tmp_path):
    # one point keeps a gigabyte; its worker's nanny kills it at 95 % of 600 MB, and with no
    # retries allowed the scheduler gives up on that point at once (KilledWorker); one task
    # at a time on the worker, so that no other point is on the worker when it dies
    cluster = Cluster(tmp_path, workers=1, worker_options=("--memory-limit", "600MB"),
                      DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES="0",
                      DASK_DISTRIBUTED__SCHEDULER__WORKER_SATURATION="1.0")
    try:
        started = time.monotonic()
        table = circuitnsds.sweep(SLOW_POINT, {"T": [3.0, 100.0, 3.0]}, measure=[MEAN],
                                  scheduler=cluster.address, worker_timeout=30)
        seconds = time.monotonic() - started
    finally:
        cluster.close()
    assert list(table["status"]) == ["ok", "lost", "ok"], list(table["error"])
    assert "KilledWorker" in table["error"][1] and "memory limit" in table["error"][1]
    assert seconds < 90


@pytest.mark.parametrize("address, message", [
    ("garbage", "not HOST:PORT"), ("", "not HOST:PORT"), ("   ", "not HOST:PORT"),
    ("inproc://x", "inproc:// scheme"), ("ucx://127.0.0.1:1", "ucx:// scheme"),
    ("tcp://127.0.0.1:99999", "port 99999"), ("tcp://:8786", "not HOST:PORT"),
    ("tcp://127.0.0.1", "not HOST:PORT"),
    ("tcp://127.0.0.1:8786/path", "not HOST:PORT"), ("tls://127.0.0.1:8786", "tls:// needs certificates"),
])
def test_malformed_scheduler_addresses_are_refused_before_connecting(address, message, monkeypatch):
    import distributed

    def no_client(*args, **kwargs):
        raise AssertionError("connected")

    monkeypatch.setattr(distributed, "Client", no_client)
    with pytest.raises(ExecutorError, match=message):
        circuitnsds.sweep(SLOW_POINT, {"T": [1]}, scheduler=address)


def test_an_address_is_written_out_with_its_scheme_and_port():
    assert scheduler_address("127.0.0.1:9") == "tcp://127.0.0.1:9"
    assert scheduler_address(" tcp://localhost:8786 ") == "tcp://localhost:8786"
    assert scheduler_address("tcp://[::1]:8786") == "tcp://[::1]:8786"


def test_cli_refuses_a_malformed_address_without_a_traceback(capsys):
    from circuitnsds.cli.main import main

    status = main(["sweep", str(ROOT / "netlists" / "sweeps" / "buck_param.cir"), "--param", "D=0.5",
                   "--scheduler", "garbage"])
    err = capsys.readouterr().err
    assert status == 1 and "scheduler address 'garbage'" in err
    assert "Traceback" not in err and "internal error" not in err


def test_a_port_that_accepts_and_never_answers_is_an_error_within_the_connect_timeout():
    with socket.socket() as mute:  # the kernel accepts connections; nothing ever answers
        mute.bind(("127.0.0.1", 0))
        mute.listen(8)
        started = time.monotonic()
        with pytest.raises(ExecutorError, match="cannot reach the Dask scheduler"):
            circuitnsds.sweep(SLOW_POINT, {"T": [1]}, scheduler=f"tcp://127.0.0.1:{mute.getsockname()[1]}",
                              connect_timeout=1)
        assert time.monotonic() - started < 10


def test_cli_writes_the_finished_rows_and_names_the_lost_ones(tmp_path, capsys):
    from circuitnsds.cli.main import main

    cluster = Cluster(tmp_path, workers=1)
    netlist, table = tmp_path / "slow.cir", tmp_path / "table.csv"
    netlist.write_text(SLOW_POINT)
    killed = threading.Event()
    from circuitnsds.cli import sweep as cli_sweep

    real = cli_sweep.CountBar

    class KillingBar(real):  # kills the only worker once two points are in
        def __call__(self, done, total):
            if done >= 2 and not killed.is_set():
                killed.set()
                cluster.kill(cluster.workers)
            return super().__call__(done, total)

    try:
        cli_sweep.CountBar = KillingBar
        status = main(["sweep", str(netlist), "--param", "T=3,3,3,3,3,3,3,3", "--measure", MEAN,
                       "--scheduler", cluster.address, "--worker-timeout", "2", "--connect-timeout", "2",
                       "-o", str(table)])
    finally:
        cli_sweep.CountBar = real
        cluster.close()
    err = capsys.readouterr().err
    assert status == 1 and "Traceback" not in err
    lines = table.read_text().splitlines()
    statuses = [line.split(",")[2] for line in lines[1:]]
    assert len(statuses) == 8 and statuses.count("ok") >= 2 and "lost" in statuses
    lost_rows = ", ".join(str(k) for k, s in enumerate(statuses) if s == "lost")
    assert f"points lost by the cluster (rows {lost_rows}," in err


def test_a_point_out_of_memory_is_a_failed_row_not_an_internal_error(monkeypatch):
    from circuitnsds.circuit.circuit import Circuit

    def exhausted(self, *args, **kwargs):
        raise MemoryError("Unable to allocate 2 GiB")

    monkeypatch.setattr(Circuit, "transient", exhausted)
    table = circuitnsds.sweep(SLOW_POINT, {"T": [1]}, measure=[MEAN], workers=0)
    assert list(table["status"]) == ["failed"]
    assert table["error"][0] == "out of memory (Unable to allocate 2 GiB)"
