"""The time-stepping engine: the θ-method step system, mode maps, compiled loops, grids.

It takes an :class:`~circuitnsds.system.mlcs.MLCS`, a time grid and a state, and returns a
trajectory. It imports only :mod:`circuitnsds.system`, :mod:`circuitnsds.solvers` and the
package's foundation modules (errors, units): never the netlist, the front end, the
elements or :class:`~circuitnsds.circuit.circuit.Circuit`.
"""
