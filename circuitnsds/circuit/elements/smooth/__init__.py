"""Smooth semiconductor devices with ngspice's equations (issue 33): each a
:class:`~circuitnsds.circuit.elements.base.Element` whose stamp adds the internal nodes its
series resistances need and one :class:`~circuitnsds.system.smooth.SmoothRelation`.

One module per device (``bjt``: Gummel–Poon, ngspice's level 1; ``jfet``: ngspice's level 1),
their equations in pure functions; ``junctions`` holds what they share (the pn-junction
current and depletion charge, SPICE's limiting functions); ``terminals`` maps a device's
terminals onto the unknowns of the MLCS.
"""
