"""Type tests against classes whose module may not be imported.

Some element and card families (behavioural sources, XSPICE blocks, MOSFETs) are imported
only when a netlist uses them, so that a run of a plain netlist does not build their
classes. Code that every run passes through still asks "is this one of them?":
:func:`is_loaded_instance` answers without importing the module.
"""

from __future__ import annotations

import sys


def is_loaded_instance(value: object, module: str, *names: str) -> bool:
    """``isinstance(value, (module.name, ...))`` without importing ``module``: if it was
    never imported, none of its classes can have an instance, and the answer is False."""
    loaded = sys.modules.get(module)
    return loaded is not None and isinstance(value, tuple(getattr(loaded, name) for name in names))
