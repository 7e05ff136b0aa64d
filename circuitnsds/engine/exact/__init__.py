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
  :mod:`.first_event`: the same search, compiled, over every event function of a segment;
* :mod:`.solution_map`: a mode's solution and event functions as one linear map of the
  segment's state and source coefficients; :mod:`.source_table`: every source's piece on
  every interval of the run; :mod:`.mode_tables`: the modes met, as arrays;
* :mod:`.loop`: the event loop, compiled; :mod:`.run`: the run (Python chooses a mode the
  loop has not met; :func:`.run.run_python` is the whole loop in Python).
"""
