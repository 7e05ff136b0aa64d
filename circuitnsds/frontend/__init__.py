"""From netlist statements to a Circuit: one reader per card (``frontend.cards``) and
:func:`~circuitnsds.frontend.elaborate.elaborate`, which applies them in netlist order."""
