"""Reading netlist text into plain statements (no interpretation of elements)."""

from circuitnsds.netlist.parser import Netlist, Statement, parse_netlist, read_netlist_file

__all__ = ["Netlist", "Statement", "parse_netlist", "read_netlist_file"]
