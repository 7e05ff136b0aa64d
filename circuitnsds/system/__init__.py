"""The mathematical system the engine integrates: the MLCS and its source functions.

Layer 2 of the pipeline (netlist -> frontend -> circuit -> **system** -> engine): an
:class:`~circuitnsds.system.mlcs.MLCS` holds ``E, A, B, C, D`` and the sources as plain
arrays and :mod:`~circuitnsds.system.stimuli` functions of time. It knows nothing about
netlists or elements, so the engine and the solvers can take it without importing them.
"""
