"""The README's two commands in sequence, in one environment, from outside the checkout (issue 19).

1. ``pip install .`` then ``circuitnsds run netlists/bridge_rectifier.cir -o bridge.csv
   --plot bridge.png`` (a long enough run to load compiled code: the buck converter too);
2. ``pip install -e .`` (the test extras are already installed here);
3. from another folder: ``import circuitnsds`` must be the editable package (not a namespace
   package left behind in ``site-packages``), ``circuitnsds.read_netlist`` must exist, and
   no file of circuitnsds may remain in ``site-packages`` but pip's editable hook.

The environment is a fresh ``venv`` with the system's site packages (numpy, scipy, numba,
... are not reinstalled: ``--no-deps``; pip fetches the build backend), ``HOME`` in a
temporary folder (so the per-user cache starts empty). Prints each step and ``OK`` or the
failure; exit status 0 when all hold. Takes ~1 minute (two pip installs).

Usage: ``python benchmarks/install_sequence.py``
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

CHECKOUT = Path(__file__).resolve().parents[1]


def run(command: list[str], cwd: Path, env: dict) -> subprocess.CompletedProcess:
    started = time.perf_counter()
    done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    print(f"  $ {' '.join(command[-6:])}  ({time.perf_counter() - started:.1f} s, exit {done.returncode})")
    if done.returncode != 0:
        print(done.stdout[-2000:], done.stderr[-2000:])
    return done


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        venv, home, work = root / "venv", root / "home", root / "elsewhere"
        home.mkdir()
        work.mkdir()
        # the system's pip and setuptools (and every dependency) through --system-site-packages
        subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", str(venv)],
                       check=True)
        python = venv / "bin" / "python"
        env = {k: v for k, v in os.environ.items() if k not in {"PYTHONPATH", "CIRCUITNSDS_CACHE_DIR",
                                                               "NUMBA_CACHE_DIR", "XDG_CACHE_HOME"}}
        env.update(HOME=str(home), PATH=f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}")
        site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()"
                                    "['purelib'])"], capture_output=True, text=True, env=env,
                                   check=True).stdout.strip())
        print(f"venv {venv}, site-packages {site} (host: {sysconfig.get_paths()['purelib']})")
        pip = [str(python), "-m", "pip", "install", "-q", "--no-deps"]  # pip fetches the build backend
        print("1. pip install . ; circuitnsds run (the bridge, then a long buck run)")
        if run([*pip, str(CHECKOUT)], work, env).returncode:
            return 1
        for netlist, extra in (("bridge_rectifier.cir", ["--plot", "bridge.png"]),
                               ("buck_converter.cir", ["--stop", "50m", "--signals", "v(out)"])):
            if run(["circuitnsds", "run", str(CHECKOUT / "netlists" / netlist), "-o", "out.csv", "-q",
                    *extra], work, env).returncode:
                return 1
        time.sleep(0.5)
        inside = sorted(str(p.relative_to(site)) for p in (site / "circuitnsds").rglob("*")
                        if p.is_file() and p.suffix in {".nbi", ".nbc"})
        print(f"   compiled-code files inside the installed package: {inside or 'none'}")
        print("2. pip install -e .")
        if run([*pip, "-e", str(CHECKOUT)], work, env).returncode:
            return 1
        left = sorted(str(p.relative_to(site)) for p in (site / "circuitnsds").rglob("*")) \
            if (site / "circuitnsds").exists() else []
        print(f"   left in site-packages/circuitnsds: {left or 'nothing (the folder is gone)'}")
        print("3. from another folder: import circuitnsds; read_netlist; circuitnsds compare --help")
        check = run([str(python), "-c", "import circuitnsds; print(circuitnsds.__file__); "
                     "circuitnsds.read_netlist"], work, env)
        helped = run(["circuitnsds", "compare", "--help"], work, env)
        ok = (not inside and not left and check.returncode == 0 and helped.returncode == 0
              and check.stdout.strip().startswith(str(CHECKOUT)))
        print(f"   imported from: {check.stdout.strip()}")
        print("OK" if ok else "FAILED")
        return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
