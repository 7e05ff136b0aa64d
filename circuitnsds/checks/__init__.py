"""Checks of a circuit before and during simulation.

:mod:`~circuitnsds.checks.topology` (graph primitives: floating nodes, voltage-source
loops, current-source cut-sets), :mod:`~circuitnsds.checks.rules` (element values and
source timing) and :mod:`~circuitnsds.checks.wellposed` (is each step's complementarity
problem uniquely solvable, built on the engine's step system).
"""
