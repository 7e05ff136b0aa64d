"""Independent physical checks of simulated waveforms (not using the solver's own residual)."""

from __future__ import annotations

import numpy as np

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import Diode
from circuitnsds.output.waveforms import Waveforms


def voltage(waves: Waveforms, node: str) -> np.ndarray:
    return np.zeros_like(waves.time) if node == "0" else waves[f"v({node})"]


def assert_device_laws(circuit: Circuit, waves: Waveforms, rel: float = 1e-6) -> None:
    """Every diode obeys its piecewise-linear characteristic at every step after t = 0.

    The pair current is the reported current minus the off-conductance current;
    tolerances are ``rel`` times the largest voltage and current seen in the run.
    """
    voltages = np.array([waves[n] for n in waves.names if n.startswith("v(")])
    scale_v = float(np.abs(voltages).max()) if voltages.size else 1.0
    eps_v = rel * max(scale_v, 1e-3)
    for element in circuit.elements:
        if not isinstance(element, Diode):
            continue
        model = element.model
        v = (voltage(waves, element.nodes[0]) - voltage(waves, element.nodes[1]))[1:]
        i = waves[f"i({element.name})"][1:] - v * element.area / model.off_resistance
        eps_i = rel * max(float(np.abs(i).max()), 1e-6)
        ron = model.on_resistance / element.area
        forward = i > eps_i
        np.testing.assert_allclose(v[forward], model.forward_drop + ron * i[forward],
                                   atol=eps_v, err_msg=f"{element.name} conducting")
        upper = model.forward_drop + ron * np.maximum(i, 0)
        assert np.all(v <= upper + eps_v), f"{element.name} above its forward characteristic"
        if model.kind == "zener":
            rrev = model.breakdown_resistance / element.area
            reverse = i < -eps_i
            np.testing.assert_allclose(v[reverse], -model.breakdown_voltage + rrev * i[reverse],
                                       atol=eps_v, err_msg=f"{element.name} in breakdown")
            lower = -model.breakdown_voltage + rrev * np.minimum(i, 0)
            assert np.all(v >= lower - eps_v), f"{element.name} below its breakdown"
        else:
            assert np.all(i >= -eps_i), f"{element.name} conducts backwards: min {i.min():g} A"
