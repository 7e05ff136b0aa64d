"""The circuit: elements, nodes, models and initial conditions (no analysis).

Elements own their MNA stamps (:mod:`circuitnsds.circuit.elements`); a
:class:`~circuitnsds.circuit.circuit.Circuit` is what the front end builds from a netlist
and what every analysis takes.
"""
