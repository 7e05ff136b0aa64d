"""Meaning of each kind of netlist line ("card"): one module per family.

:mod:`circuitnsds.frontend.elaborate` walks a flat netlist and hands each statement to
the function here that reads it; every function turns mistakes into
:class:`~circuitnsds.errors.NetlistError` naming ``file:line``.
"""
