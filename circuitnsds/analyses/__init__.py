"""Analyses: each takes a Circuit and its settings and returns a result object.

The only layer that combines the circuit, its checks and the engine: the operating point
(:mod:`~circuitnsds.analyses.operating_point`) and the transient
(:mod:`~circuitnsds.analyses.transient`).
"""
