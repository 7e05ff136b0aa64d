"""Shared helpers for the engine tests."""

from pathlib import Path

import pytest

import circuitnsds

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"


def circuit_from(body: str, title: str = "test circuit"):
    """A Circuit from netlist lines (title and .end added)."""
    return circuitnsds.read_netlist(f"{title}\n{body}\n.end\n")


@pytest.fixture
def netlists() -> Path:
    return NETLISTS
