"""Every bundled netlist runs, and every step obeys the device laws (checked independently)."""

import numpy as np
import pytest

import circuitnsds
from tests.conftest import NETLISTS
from tests.device_checks import assert_device_laws

ALL = sorted(NETLISTS.glob("*.cir"))


@pytest.mark.parametrize("path", ALL, ids=[p.stem for p in ALL])
def test_bundled_netlist_obeys_device_laws(path):
    circuit = circuitnsds.read_netlist(path)
    waves = circuit.transient()
    assert waves.residual.max() <= 1e-9
    for name in waves.names:
        assert np.all(np.isfinite(waves[name])), name
    assert_device_laws(circuit, waves)
