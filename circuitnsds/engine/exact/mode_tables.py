"""The known modes of a run as the arrays the compiled loop reads (:mod:`.loop`).

A mode joins when Python has met it (:func:`.run.choose_mode` builds it); its solution
map for the run's source structure (:class:`~.solution_map.SolutionMap`, ``z`` widened to
every pair: an inactive pair's multiplier is 0) and the magnitudes of its event functions'
round-off are packed into arrays indexed by mode, which grow (capacity doubled, terms
padded with zero coefficients) as modes join.
"""

from __future__ import annotations

import numpy as np

from circuitnsds.engine.exact.source_table import SourceTable

INITIAL_CAPACITY = 8
"""Modes the arrays hold at least before they first grow (then doubled). Growing copies
every known mode's maps: from 8, the three-phase inverter's 116 modes copied them four
times, and each mode that brought one more term copied them all again (terms grow by half
at least, padded with zeros the loop does not read: it reads ``terms`` of each mode).
``np.zeros`` leaves the pages of unused rows unallocated, so the first mode sizes the
arrays for up to :data:`INITIAL_BYTES` of maps (the inverter's 200 KB a mode: 338 modes;
a circuit whose maps take more than 8 MB a mode starts at 8, as before), and for the terms
a mode can have without a resonance (``1 + r + 2 J``: the constant, the state's modes, each
source term and its ramp's partner)."""
INITIAL_BYTES = 1 << 26
"""[bytes] The maps the arrays are first sized for (64 MiB, of address space until used)."""
MAXIMUM_INITIAL_CAPACITY = 512


class ModeTables:
    """Arrays of :mod:`.loop` for the modes of ``system`` (an :class:`.run.ExactSystem`)."""

    def __init__(self, system, sources: SourceTable):
        self.system = system
        self.sources = sources
        self.n, self.m = system.n, system.m
        self.columns = system.m + len(system.mlcs.switches)
        self.inputs = system.coordinates.rank + sources.powers.size * len(system.mlcs.stimuli) + 1
        self.known = 0
        self.built_seen = 0
        """How many of the system's built modes :meth:`add_all_built` has gone through."""
        self.index: dict[tuple, int] = {}
        self._sized = False
        self.entries = np.zeros(0, np.int32)
        """The nonzero columns of every known mode's lines, as :attr:`first` indexes them."""
        self.entries_used = 0
        self._allocate(INITIAL_CAPACITY, 1)

    def _allocate(self, capacity: int, terms: int) -> None:
        old = getattr(self, "bits", None)
        n, m, c, r = self.n, self.m, self.columns, self.system.coordinates.rank
        fresh = {
            "bits": np.zeros((capacity, c), np.bool_),
            "z_map": np.zeros((capacity, terms * (n + m), self.inputs), complex),
            "table_map": np.zeros((capacity, terms * c, self.inputs), complex),
            "powers": np.zeros((capacity, terms), np.int64),
            "exponents": np.zeros((capacity, terms), complex),
            "terms": np.zeros(capacity, np.int64),
            "slope_weights": np.zeros((capacity, terms), complex),
            "rows_p": np.zeros((capacity, c, r)),
            "rows_q": np.zeros((capacity, c, n)),
            "rows_y": np.zeros((capacity, c, n)),
            "rows_c": np.zeros((capacity, c)),
            "fast_rows": np.zeros((capacity, c, r)),
            "gap_rows": np.zeros((capacity, c, r)),
        }
        if old is not None:
            for name, array in fresh.items():
                current = getattr(self, name)
                if name in ("z_map", "table_map"):
                    array[:self.known, :current.shape[1]] = current[:self.known]
                elif name in ("powers", "exponents", "slope_weights"):
                    array[:self.known, :current.shape[1]] = current[:self.known]
                else:
                    array[:self.known] = current[:self.known]
        for name, array in fresh.items():
            setattr(self, name, array)
        listed = getattr(self, "first", None)
        self.first = np.zeros((capacity, self.lines_per_mode(terms)), np.int64)
        """Each mode's lines (:meth:`_list`): the offsets in :attr:`entries` where they start."""
        if listed is not None and listed.shape[1] == self.first.shape[1]:
            self.first[:self.known] = listed[:self.known]  # (more modes, the same lines)
        elif self.known:  # (more terms: a mode's lines are laid out again)
            self.entries_used = 0
            for i in range(self.known):
                self._list(i)

    def lines_per_mode(self, terms: int) -> int:
        """The lines of a mode's lists (:meth:`_list`) with arrays of ``terms`` terms."""
        return terms * self.columns + 2 * self.columns + terms * (self.n + self.m) + 1

    def _list(self, i: int) -> None:
        """Mode ``i``'s nonzero entries, line by line, into :attr:`first` and :attr:`entries`
        (what the C loop sums over: a zero entry adds ±0 to a sum that is never -0, so the
        sums are the dense ones bit for bit): the event table map's lines (``terms ·
        columns`` over the inputs), ``rows_q``'s and ``rows_y``'s (``columns`` over ``n``),
        the z map's (``terms · (n + m)`` over the inputs), then the end. The lines of terms
        the mode does not have are empty (the loop reads a mode's ``terms`` only). Listed
        once, when the mode joins: the C loop listed each mode it met in every call, 3 % of
        the inverter's instructions."""
        held, terms, c, width = self.powers.shape[1], int(self.terms[i]), self.columns, self.n + self.m
        blocks = ((self.table_map[i, :terms * c], c * (held - terms)), (self.rows_q[i], 0),
                  (self.rows_y[i], 0), (self.z_map[i, :terms * width], width * (held - terms)))
        counts = np.zeros(self.lines_per_mode(held) - 1, np.int64)
        listed, line = [], 0
        for block, empty in blocks:  # (flat indices of each block: 2x faster than masks in place)
            lines, columns = np.divmod(np.flatnonzero(block != 0), block.shape[1])
            counts[line:line + block.shape[0]] = np.bincount(lines, minlength=block.shape[0])
            listed.append(columns)
            line += block.shape[0] + empty
        columns = np.concatenate(listed).astype(np.int32)
        start = self.entries_used
        if start + columns.size > self.entries.size:
            grown = np.zeros(max(2 * self.entries.size, start + columns.size, 4096), np.int32)
            grown[:start] = self.entries[:start]
            self.entries = grown
        self.entries[start:start + columns.size] = columns
        self.first[i, 0] = start
        np.cumsum(counts, out=self.first[i, 1:])
        self.first[i, 1:] += start
        self.entries_used = start + columns.size

    def mode_of(self, index: int) -> tuple[np.ndarray, tuple[bool, ...]]:
        """``(active, closed)`` of mode ``index``."""
        bits = self.bits[index]
        return bits[:self.m].copy(), tuple(bool(b) for b in bits[self.m:])

    def add(self, active: np.ndarray, closed: tuple[bool, ...]) -> int:
        """The index of the mode (added when new)."""
        key = (tuple(np.asarray(active, bool).tolist()), tuple(closed))
        if key in self.index:
            return self.index[key]
        system, sources = self.system, self.sources
        mode = system.mode(np.asarray(active, bool), tuple(closed))
        rows, constants, rows_P, rows_Q, rows_Y = system.event_row_data(mode, tuple(closed))
        linear = system.solution_map(mode, rows, constants, sources.powers, sources.exponents,
                                     len(system.mlcs.stimuli))
        terms = linear.powers.size
        n, m, c = self.n, self.m, self.columns
        held = self.powers.shape[1]
        if not self.known and not self._sized:  # (the first mode: sized as INITIAL_CAPACITY says)
            self._sized = True
            held = max(terms, 1 + system.coordinates.rank + 2 * sources.powers.size)
            per_mode = 16 * held * (n + m + c) * self.inputs
            capacity = max(INITIAL_CAPACITY, min(MAXIMUM_INITIAL_CAPACITY, INITIAL_BYTES // per_mode))
            self._allocate(capacity, held)
        if self.known == self.bits.shape[0] or terms > held:
            self._allocate(2 * self.bits.shape[0] if self.known == self.bits.shape[0] else self.bits.shape[0],
                           held if terms <= held else max(terms, held + held // 2))
        i = self.known
        self.bits[i, :m] = key[0]
        self.bits[i, m:] = key[1]
        z = linear.z_map.reshape(terms, linear.size, self.inputs)
        wide = self.z_map[i, :terms * (n + m)].reshape(terms, n + m, self.inputs)  # (a view, written)
        wide[:, :n] = z[:, :n]
        wide[:, n + mode.active_index] = z[:, n:]
        self.table_map[i, :terms * c] = linear.table_map
        self.powers[i, :terms] = linear.powers
        self.exponents[i, :terms] = linear.exponents
        self.slope_weights[i, :terms] = linear.slope_weights
        self.terms[i] = terms
        self.rows_p[i] = rows_P
        self.rows_q[i] = rows_Q[:, :n]
        self.rows_y[i] = rows_Y
        self.rows_c[i] = rows_Q[:, n:] @ np.abs(mode.e_active) + np.abs(constants)
        if mode.fast_P is not None:  # (else zeros: nothing along a fast mode to count)
            self.fast_rows[i] = system.fast_rows(mode, tuple(closed))
        if mode.vector_gap is not None:  # (else zeros: the modal sum is P x)
            self.gap_rows[i] = system.gap_rows(mode, tuple(closed))
        self._list(i)
        self.index[key] = i
        self.known += 1
        return i

    def add_all_built(self) -> None:
        """Every mode the system has built (the flips Python went through) joins: those built
        since the last call (the system's list only grows)."""
        built = self.system.built_modes()
        for active, closed in built[self.built_seen:]:
            self.add(np.array(active, bool), closed)
        self.built_seen = len(built)
