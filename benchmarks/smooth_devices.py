"""Issue 33 benchmark: the cost of one evaluation of each smooth device's relation
(``SmoothRelation.evaluate``: currents, charges and both Jacobians at one iterate), the unit
a Newton step of the smooth stepper pays per device and iteration.

Each device is stamped from a one-device netlist with its series resistances and charges (a
vendor card where there is one) and evaluated at a fixed iterate; the table gives the best
of five repeats of N calls, in µs per call. Usage: ``python benchmarks/smooth_devices.py``.
"""

from __future__ import annotations

import sys
import timeit
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import circuitnsds  # noqa: E402

CALLS = 2000
DEVICES = {
    "Q 2N2222 (RB, RC, charges)": (
        "vc c 0 5\nvb b 0 0.7\nq1 c b 0 qx\n.model qx npn(is=14.34f vaf=74.03 bf=255.9 "
        "ne=1.307 ise=14.34f ikf=.2847 br=6.092 rc=1 cjc=7.306p cje=22.01p tr=46.91n "
        "tf=411.1p itf=.6 vtf=1.7 xtf=3 rb=10)", "q1"),
    "J (RD, RS, charges)": ("vd d 0 5\nj1 d 0 0 jx\n.model jx njf(rd=1 rs=1 cgs=2p cgd=1p)", "j1"),
    "M level 1 (body effect, CBD)": (
        "vd d 0 5\nvg g 0 2\nm1 d g 0 0 mx\n.model mx nmos(vto=1 kp=50u gamma=0.4 cbd=1p "
        "smooth=1)", "m1"),
    "M VDMOS IRF530": (
        "vd d 0 5\nvg g 0 5\nm1 d g 0 mx\n.model mx vdmos(rg=3 vto=4 rd=50m rs=12m rb=60m "
        "kp=5 lambda=.01 cgdmax=1n cgdmin=.26n cgs=.2n cjo=.4n is=52p ksubthres=.1 smooth=1)",
        "m1"),
    "D (RS, BV, charges)": (
        "va a 0 0.6\nd1 a 0 dx\n.model dx d(is=1e-14 rs=1 bv=10 cjo=1p tt=1n smooth=1)", "d1"),
}


def main() -> None:
    print(f"{'device':32s} {'inputs':>6s} {'µs per evaluate':>16s}")
    for name, (body, element) in DEVICES.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mlcs = circuitnsds.read_netlist(f"bench\n{body}\n.end\n").mlcs()
        relation = next(r for r in mlcs.smooth if r.name == element)
        x = np.linspace(0.1, 0.7, len(relation.inputs))
        best = min(timeit.repeat(lambda relation=relation, x=x: relation.evaluate(x, 0.0),
                                 number=CALLS, repeat=5)) / CALLS
        print(f"{name:32s} {len(relation.inputs):6d} {best * 1e6:16.1f}")


if __name__ == "__main__":
    main()
