"""Event-driven exact integration of an MLCS (DESIGN.md "Event-driven exact integration").

Between two events the mode (active pairs, switch states) is fixed and the circuit is a
linear time-invariant system driven by known source pieces, so its solution is an
exponential polynomial in the time since the segment's start, computed in closed form:

* :mod:`.exppoly`: vector exponential polynomials ``Σ c_j τ^p_j e^{ν_j τ}``;
* :mod:`.sources`: each source's current piece (PULSE/PWL/DC affine, SIN a damped
  rotation, EXP a decay) as an exponential polynomial, and where the piece ends;
* :mod:`.mode`: one mode's reduced state equations ``x' = F x + H φ(t)`` and the map back
  to every unknown, with ``F``'s eigen-decomposition cached;
* :mod:`.roots`: the first root of an event function, certified root-free elsewhere;
* :mod:`.run`: the event loop.
"""
