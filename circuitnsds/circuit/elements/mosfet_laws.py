"""What an ideal MOSFET's two linear values depend on in the circuit: the channel's
on-resistance at a gate drive (:class:`ChannelLaw`) and the output capacitance over the
voltage the device switches (:class:`OutputCapacitance`), both from the model card's
equations as ngspice 39 has them. The card reader evaluates them at a first guess; a run's
observer (:mod:`~circuitnsds.circuit.elements.mosfet_notes`) measures the gate drive the
circuit applies and the voltage the drain swings, and the analysis re-evaluates them there
(:func:`circuitnsds.analyses.refits.refit_mosfets`).

**The output capacitance is charge-equivalent** (a datasheet's ``Co(tr)``): the linear
capacitor that takes the same charge as the device's nonlinear ``Coss(v)`` from 0 to the
switched voltage ``V``, ``Ceq = Q(V)/V``. A zero-voltage transition is the swing of the
drain between the rails by an (about constant) inductor current ``I``: it lasts ``Q(V)/I``
and it completes when the current lasts that long, so the charge is what decides ZVS and the
dead time it needs. The energy-equivalent value (``Co(er)``, the same ``∫v·C(v)dv``) is
smaller (the charge at low voltage, where ``C(v)`` is largest, counts less in the energy)
and belongs to hard-switching loss, which the ideal switch leaves to the datasheet tables
(:mod:`circuitnsds.thermal`). The zero-bias value (a junction's ``CJO``, its largest) is
several times either: 0.7 nF for an SPA11N60C3 whose datasheet gives ``Co(tr)`` ≈ 85 pF.

Sign conventions: ``V`` [V] is the blocking drain–source voltage, positive (``v(d) − v(s)``
for an n-channel device, ``v(s) − v(d)`` for a p-channel one); the gate drive ``Vgs`` [V]
is ``|v(g) − v(s)|``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class ChannelLaw:
    """The on-resistance ``Ron(Vgs) = (Rd + Rs + Rch(Vgs))/m`` of a conducting channel at a
    small ``Vds``, ngspice's equations:

    * VDMOS: ``Rch = (1 + θ·Vgs)/(Kp·mtriode·Vov)``, ``Vov = ksubthres·ln(1 + e^((Vgs − Vto
      − subshift)/ksubthres))``;
    * level 1–3: ``Rch = (1 + θ·(Vgs − Vto))/(β·(Vgs − Vto))``, ``β = Kp·W/(L − 2·LD)``,
      ``θ`` level 3's mobility modulation ``THETA`` (0 for levels 1 and 2).

    Attributes:
        device: ``vdmos`` or ``level`` (1–3).
        threshold: ``|Vto|`` [V], the drive at which the channel opens.
        gain: ``Kp·mtriode`` (VDMOS) or ``β`` (level 1–3) [A/V²].
        theta: mobility reduction ``θ`` [1/V] (VDMOS: of ``Vgs``; level 3: of the overdrive).
        slope: VDMOS ``ksubthres`` [V]; shift: ``subshift`` [V].
        drain, source: ``Rd``, ``Rs`` [Ω].
        count: the instance multiplier ``m``.
    """

    device: str
    threshold: float
    gain: float
    theta: float = 0.0
    slope: float = 0.1
    shift: float = 0.0
    drain: float = 0.0
    source: float = 0.0
    count: float = 1.0

    def channel(self, drive: float) -> float:
        """``Rch`` [Ω] of one device at ``|Vgs| = drive`` [V] (``inf`` at or below the
        threshold of a level 1–3 model)."""
        overdrive = drive - self.threshold
        if self.device == "vdmos":
            argument = (overdrive - self.shift) / self.slope
            smoothed = self.slope * (argument if argument > 30 else math.log1p(math.exp(argument)))
            return (1.0 + self.theta * drive) / (self.gain * smoothed)
        if overdrive <= 0:
            return math.inf
        return (1.0 + self.theta * overdrive) / (self.gain * overdrive)

    def saturation_current(self, drive: float) -> float:
        """The channel's saturation current [A] of the instance at ``|Vgs| = drive`` [V]:
        ``gain·Vov²/2/(1 + θ·Vgs)`` (the square law; a VDMOS's ``mtriode`` is in ``gain``, so
        with ``mtriode`` > 1 this is that much above ngspice's: the larger the figure, the fewer
        channels it finds current-limited)."""
        overdrive = drive - self.threshold
        if self.device == "vdmos":
            argument = (overdrive - self.shift) / self.slope
            overdrive = self.slope * (argument if argument > 30 else math.log1p(math.exp(argument)))
            damping = 1.0 + self.theta * drive
        else:
            damping = 1.0 + self.theta * max(overdrive, 0.0)
        return self.count * self.gain * max(overdrive, 0.0) ** 2 / (2.0 * damping)

    def resistance(self, drive: float) -> float:
        """``Ron`` [Ω] of the instance at ``|Vgs| = drive`` [V]."""
        return (self.drain + self.source + self.channel(drive)) / self.count

    def rule(self, drive: float) -> str:
        """``Ron`` at ``drive`` [V] written out: ``Rd + Rs + Rch = ... Ω``."""
        return (f"Rd + Rs + Rch = {self.drain:g} + {self.source:g} + {self.channel(drive):.4g} Ω"
                + (f", / m={self.count:g}" if self.count != 1 else ""))


@dataclass(frozen=True)
class OutputCapacitance:
    """A blocking MOSFET's drain–source capacitance ``Coss(v)`` as ngspice has it, and its
    charge-equivalent linear value (module docstring).

    * the junction (VDMOS body diode ``CJO``, ``VJ`` = 0.8, ``M`` = 0.5; level 1–3 ``CBD``,
      ``PB`` = 0.8, ``MJ`` = 0.5) reverse-biased by ``v``: ``Cj(v) = CJO/(1 + v/VJ)^M``
      (``FC`` only shapes forward bias, which a blocking device does not see);
    * VDMOS gate–drain ``Cgd(Vgd)`` with the gate held at the source (``Vgd = −v``):
      ``Cgd = y + s·atan(a·Vgd)`` for ``Vgd ≤ 0``, ``s = (Cgdmax − Cgdmin)/(1 + π/2)``,
      ``y = Cgdmax − s`` (ngspice's ``DevCapVDMOS``, from Cgdmax at large ``Vgd`` to Cgdmin
      at large ``−Vgd``); level 1–3 the overlap ``CGDO·W``, constant.

    Attributes:
        junction: zero-bias junction capacitance [F] (0: none).
        potential: the junction's built-in potential [V]; grading: its exponent.
        gate_drain_min, gate_drain_max: VDMOS ``Cgdmin``, ``Cgdmax`` [F]; slope: ``a`` [1/V].
        overlap: constant gate–drain capacitance [F] (level 1–3 ``CGDO·W``).
        count: the instance multiplier ``m``.
    """

    junction: float = 0.0
    potential: float = 0.8
    grading: float = 0.5
    gate_drain_min: float = 0.0
    gate_drain_max: float = 0.0
    slope: float = 1.0
    overlap: float = 0.0
    count: float = 1.0

    def capacitance(self, voltage: float) -> float:
        """``Coss(v)`` [F] of the instance at the blocking voltage ``voltage`` [V] ≥ 0."""
        junction = self.junction / (1.0 + voltage / self.potential) ** self.grading
        spread = (self.gate_drain_max - self.gate_drain_min) / (1.0 + math.pi / 2)
        gate_drain = self.gate_drain_max - spread - spread * math.atan(self.slope * voltage)
        return (junction + gate_drain + self.overlap) * self.count

    def charge(self, voltage: float) -> float:
        """``Q(V) = ∫₀^V Coss(v) dv`` [C] of the instance, ``V = voltage`` [V] ≥ 0 (closed
        forms of the two integrals)."""
        ratio = 1.0 + voltage / self.potential
        if abs(1.0 - self.grading) < 1e-12:
            junction = self.junction * self.potential * math.log(ratio)
        else:
            junction = (self.junction * self.potential / (1.0 - self.grading)
                        * (ratio ** (1.0 - self.grading) - 1.0))
        spread = (self.gate_drain_max - self.gate_drain_min) / (1.0 + math.pi / 2)
        a = self.slope
        atan_integral = (voltage * math.atan(a * voltage) - math.log1p((a * voltage) ** 2) / (2 * a)
                         if a > 0 else 0.0)
        gate_drain = (self.gate_drain_max - spread) * voltage - spread * atan_integral
        return (junction + gate_drain + self.overlap * voltage) * self.count

    def equivalent(self, voltage: float) -> float:
        """The charge-equivalent capacitance ``Q(V)/V`` [F] over ``0..V``, ``V = voltage``
        [V] (``Coss(0)`` at ``V = 0``)."""
        return self.capacitance(0.0) if voltage <= 0 else self.charge(voltage) / voltage

    @property
    def present(self) -> bool:
        """Whether the model has any output capacitance."""
        return self.capacitance(0.0) > 0
