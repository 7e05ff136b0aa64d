"""Reading netlists: text -> statements (parser), then includes, parameters and subcircuits
expanded into a flat list of statements (includes, params, subcircuits, loader)."""

from circuitnsds.netlist.includes import expand_includes
from circuitnsds.netlist.loader import load_netlist, load_netlist_text, preprocess
from circuitnsds.netlist.parser import Netlist, Statement, parse_netlist, read_netlist_file
from circuitnsds.netlist.subcircuits import flatten

__all__ = [
    "Netlist", "Statement", "expand_includes", "flatten", "load_netlist", "load_netlist_text",
    "parse_netlist", "preprocess", "read_netlist_file",
]
