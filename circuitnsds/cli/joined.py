"""An argparse action for options that name a list and may be given more than once."""

from __future__ import annotations

import argparse


class Joined(argparse.Action):
    """An option whose every use adds to a comma-separated list: ``--signals v(a) --signals
    v(b)`` is ``"v(a),v(b)"`` (with the default ``store`` the last one alone was kept and the
    others dropped unsaid)."""

    def __call__(self, parser, namespace, values, option_string=None):
        before = getattr(namespace, self.dest, None)
        setattr(namespace, self.dest, f"{before},{values}" if before else values)
