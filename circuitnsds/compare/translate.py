"""A circuitnsds netlist rewritten for ngspice (text level, everything else verbatim).

The same file is meant to run in both simulators (docs/compare.md), but a few things
in it are for circuitnsds only or get in the way of a batch comparison:

* diode-model parameters of the idealised diode (``Vfwd Ron Roff Vrev Rrev`` and
  LTspice's ``Ilimit Revilimit Epsilon Revepsilon``): ngspice's own diode does not know
  them. With ``ltspice=True`` (what :func:`~circuitnsds.compare.compare` chooses when the
  netlist has such models) they are kept, for ngspice run with ``set ngbehavior=lta``,
  which turns those models into its ``sidiode`` code model (``inpcom.c``,
  ``ltspice_compat``); the LTspice defaults that ``sidiode`` lacks are written out
  (``Roff`` = 1/gmin, where ``sidiode`` would take 1 Ω) and Shockley parameters, which
  ``sidiode`` rejects, are dropped. Otherwise they are dropped and ``Vrev`` becomes ``BV``
  when the model has no ``BV``;
* the smooth-model overrides of a comparison (``N``, ``IS``, ``RS``, ``CJO``) replace
  the value of every ``D`` model, so one netlist is compared at several emission
  coefficients without editing it;
* ``.control ... .endc`` blocks, ``.save`` (the comparison chooses what to save),
  other analyses (``.op .ac .dc ...``) and output commands (``.print .plot .four
  ...``) are removed; a script's ``tran`` and ``meas``, which circuitnsds's reader takes
  as ``.tran`` and ``.meas``, reach ngspice as those dot commands, and ``.meas`` lines
  stay when the comparison compares measurements (``measures=True``);
* a ``Z`` line (circuitnsds's IGBT or thyristor) is refused: ngspice reads ``Z`` as a
  MESFET and has no IGBT or thyristor device;
* ``.tran`` TSTEP and TSTOP are replaced when the comparison overrides them;
* a diode whose current is compared gets a 0 V source in series (an ammeter:
  ``D1 a k m`` becomes ``D1 a cnsds_d1_k m`` and ``v_cnsds_d1 cnsds_d1_k k 0``),
  because ngspice's own ``@d1[id]`` is the current of the last linearisation,
  which at a sharp knee can be far from the current the circuit carries (kA
  spikes were seen on a Zener whose series inductor carried 0.6 A); the ammeter's
  branch current is the terminal current, junction-capacitance current included;
* the deck is rebuilt from the statements circuitnsds's own reader parsed as circuit
  (:func:`circuitnsds.netlist.parser.parse_netlist` and
  :func:`~circuitnsds.netlist.includes.expand_includes`), one line per statement, with
  ``.include``/``.lib`` files inlined. ngspice therefore never opens a file circuitnsds
  did not read, and nothing that is not circuit reaches it: comment lines go (ngspice
  runs ``*#`` comment lines as commands), ``.control`` blocks of the netlist and of
  every included file go, the title becomes ``circuitnsds compare: TITLE`` (a title
  ``*ng_script`` would make ngspice read the whole deck as a script), and a dot command
  that is not in :data:`CIRCUIT_COMMANDS` is removed with a note.

Inlining rather than translating each included file (and pointing ngspice at the
copy) means one reader decides what every ``.include``/``.lib`` line means
(``~``, quotes, relative paths, library sections), so both simulators read the same
models, and no file path in the netlist reaches ngspice.

Everything else (elements, ``.subckt``, ``.param``, ``.options``, ``.ic``) is passed
through as circuitnsds read it: each statement's text with its comments removed
and its ``+`` continuations joined.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from circuitnsds.compare.errors import CompareError
from circuitnsds.errors import NetlistError
from circuitnsds.netlist.includes import expand_includes
from circuitnsds.netlist.parser import Netlist, Statement, parse_netlist, read_netlist_file

#: Diode-model parameters of the idealised (circuitnsds / LTspice) diode that ngspice lacks.
IDEAL_ONLY_PARAMETERS = frozenset(
    {"vfwd", "ron", "roff", "vrev", "rrev", "ilimit", "revilimit", "epsilon", "revepsilon"}
)
#: Spellings ngspice accepts for the same parameter (an override replaces all of them).
ALIASES = {"is": ("is", "js"), "cjo": ("cjo", "cj0", "cj"), "n": ("n",), "rs": ("rs",)}
#: Commands removed from the ngspice netlist (analyses other than .tran, output, saving).
DROPPED_COMMANDS = frozenset(
    {".save", ".op", ".ac", ".dc", ".noise", ".tf", ".sens", ".pz", ".disto", ".four", ".meas",
     ".measure", ".print", ".plot", ".probe", ".width", ".backanno"}
)

_PAIR = re.compile(r"([A-Za-z_][\w.]*)\s*=\s*(\{[^}]*\}|'[^']*'|\"[^\"]*\"|[^\s,()=]+)")
_MODEL = re.compile(r"^\.model\s+(\S+)\s+([A-Za-z]+)\b\s*(.*)$", re.IGNORECASE | re.DOTALL)


@dataclass(frozen=True)
class DiodeOverrides:
    """Smooth-model parameters forced on every ``D`` model of the ngspice run.

    ``None`` keeps the netlist's value (or ngspice's default: ``N = 1``,
    ``IS = 1e-14 A``, ``RS = 0 Ω``, ``CJO = 0 F``).

    Attributes:
        n: emission coefficient (dimensionless, > 0).
        is_: saturation current [A] (> 0).
        rs: series resistance [Ω] (>= 0).
        cjo: zero-bias junction capacitance [F] (>= 0).
    """

    n: float | None = None
    is_: float | None = None
    rs: float | None = None
    cjo: float | None = None

    def __post_init__(self) -> None:
        for name, value, positive in (("N", self.n, True), ("IS", self.is_, True),
                                      ("RS", self.rs, False), ("CJO", self.cjo, False)):
            if value is None:
                continue
            if not value == value or value < 0 or (positive and value == 0):  # NaN or out of range
                raise CompareError(f"diode override {name}={value:g} must be "
                                   + ("positive" if positive else "non-negative"),
                                   where=f"--{name.lower()}")

    def items(self) -> dict[str, float]:
        """The overridden SPICE parameters, ``{"n": 0.1, "is": 1e-14, ...}``."""
        values = {"n": self.n, "is": self.is_, "rs": self.rs, "cjo": self.cjo}
        return {key: value for key, value in values.items() if value is not None}

    def label(self) -> str:
        """``"N=0.1 RS=0.01"``, or ``"netlist models"`` when nothing is overridden."""
        return " ".join(f"{key.upper()}={value:g}" for key, value in self.items().items()) \
            or "netlist models"


@dataclass
class Translation:
    """The ngspice netlist and what was changed to get it.

    Attributes:
        text: netlist text for ngspice (title line first, ``.end`` last).
        notes: one line per change (dropped parameters and commands), for reports.
    """

    text: str
    notes: list[str] = field(default_factory=list)
    has_tran: bool = False
    ammeters: set[str] = field(default_factory=set)
    ltspice: bool = False
    off_resistance: float = 1e12
    measures: bool = False


def translate_netlist(
    source: str | Path,
    *,
    overrides: DiodeOverrides | None = None,
    step: float | None = None,
    stop: float | None = None,
    saves: Iterable[str] = (),
    ammeters: Iterable[str] = (),
    options: str = "",
    ltspice: bool = False,
    off_resistance: float = 1e12,
    measures: bool = False,
) -> Translation:
    """Rewrite a netlist for ngspice (see the module docstring for what changes).

    Args:
        source: a netlist file (``Path``, or a string without a newline) or netlist text
            (its relative include paths start from the current directory).
        overrides: diode parameters forced on every ``D`` model.
        step, stop: replace ``.tran`` TSTEP and TSTOP [s] (TSTART, TMAX and UIC kept).
        saves: vectors for a ``.save`` line (``all`` is always saved as well), e.g. ``@r1[i]``.
        ammeters: local names of the diodes (``d1``, also inside subcircuits) that get a
            0 V source in series; see :func:`ngspice_vector` for its current's name.
        options: text of an ``.options`` line added for ngspice (e.g. ``"method=gear"``).
        ltspice: keep LTspice PWL diode models for ngspice's LTspice mode (see above).
        off_resistance: ``Roff`` [Ω] written into LTspice PWL models that give none
            (circuitnsds's 1/gmin).
        measures: keep the ``.meas``/``.measure`` lines (ngspice prints their results).

    Raises:
        NetlistError: what circuitnsds's reader refuses (an included file that cannot be
            read, an unclosed quote, ...), at file:line.
    """
    overrides = overrides or DiodeOverrides()
    netlist = _circuit_statements(source)
    translation = Translation("", ammeters={name.lower() for name in ammeters}, ltspice=ltspice,
                              off_resistance=off_resistance, measures=measures)
    context = _Context(overrides, step, stop, translation)
    body: list[str] = []
    for statement in netlist.statements:
        body.extend(_translate_statement(statement, context))
    if netlist.control_blocks:
        passed = {"tran", "meas", "measure"} if measures else {"tran"}  # (the others are removed)
        taken = list(dict.fromkeys(word for block in netlist.control_blocks for word in block.taken
                                   if word in passed))
        kept = (f" (its {', '.join(taken)} kept as {', '.join('.' + word for word in taken)})"
                if taken else "")
        translation.notes.append(f"{len(netlist.control_blocks)} .control block(s) removed{kept}")
    if netlist.included:
        translation.notes.append(f"{len(netlist.included)} included file(s) inlined")
    if not translation.has_tran:
        if step is None or stop is None:
            raise NetlistError("no .tran line", where=netlist.file,
                               hint="add .tran TSTEP TSTOP, or give the step and the stop time")
        body.append(f".tran {step:.12g} {stop:.12g}")
        translation.notes.append(f"added .tran {step:g} {stop:g}")
    if options.strip():
        body.append(f".options {_one_line(options.strip())}")
    body.append(".save all" + "".join(f" {_one_line(vector)}" for vector in saves))
    body.append(".end")
    translation.text = "\n".join([safe_title(netlist.title)] + body) + "\n"
    return translation


def safe_title(title: str) -> str:
    """The title line of the ngspice deck: ``circuitnsds compare: TITLE``, which cannot start
    ngspice's script mode (``*ng_script``) or hold a line break."""
    return _one_line(f"circuitnsds compare: {title}".strip())


def _one_line(text: str) -> str:
    """``text`` with any line break (or other control character) made a blank."""
    return "".join(" " if ord(char) < 32 or ord(char) == 127 else char for char in text)


def _circuit_statements(source: str | Path) -> Netlist:
    """The netlist as circuitnsds's reader sees it: statements outside ``.control`` blocks,
    comments removed, includes inlined."""
    if isinstance(source, Path) or "\n" not in source:
        return expand_includes(read_netlist_file(source))
    return expand_includes(parse_netlist(source), Path.cwd())


#: Dot commands of a circuit that reach ngspice; any other is removed (with a note).
CIRCUIT_COMMANDS = frozenset(
    {".model", ".subckt", ".ends", ".param", ".func", ".global", ".ic", ".nodeset", ".options",
     ".option", ".opt", ".temp", ".tran", ".meas", ".measure"}
)


@dataclass(frozen=True)
class _Context:
    """The settings of the whole translation and the :class:`Translation` being filled in."""

    overrides: DiodeOverrides
    step: float | None
    stop: float | None
    translation: Translation


def _measured_level(text: str) -> str | None:
    """The WHEN/TRIG/TARG level of a ``.meas`` line that is a bare name (an earlier
    measurement's, as a script writes ``WHEN v(2)=ymax``), or ``None``."""
    from circuitnsds.frontend.cards.meas import parse_meas

    try:
        spec = parse_meas(text)
    except NetlistError:
        return None
    for crossing in (spec.when, spec.trig, spec.targ) if spec is not None else ():
        level = getattr(crossing, "level", None)
        if isinstance(level, str) and re.fullmatch(r"[a-z_]\w*", level):
            return level
    return None


def _translate_statement(statement: Statement, context: _Context) -> list[str]:
    """The ngspice line(s) for one statement circuitnsds read (none for a removed command)."""
    translation, keyword, text = context.translation, statement.keyword, _one_line(statement.text)
    where = str(statement.location)
    if keyword in {".meas", ".measure"} and translation.measures:
        named = _measured_level(text)
        if named:
            translation.notes.append(
                f"{where}: {keyword} removed for ngspice: its level {named!r} names an earlier "
                "measurement, which ngspice 39 reads in a .control script but not as a dot command "
                "(it stops the run: 'Undefined parameter')")
            return []
        return [text]
    if keyword in DROPPED_COMMANDS:
        translation.notes.append(f"{where}: {keyword} removed")
        return []
    if keyword == ".model":
        return [_model(text, context.overrides, translation, where) or text]
    if keyword == ".tran":
        translation.has_tran = True
        return [_tran(text, context.step, context.stop)]
    if keyword.startswith(".") and keyword not in CIRCUIT_COMMANDS:
        translation.notes.append(f"{where}: {keyword} removed (not a circuit line for ngspice)")
        return []
    if not keyword.startswith(".") and not keyword[:1].isalpha():
        translation.notes.append(f"{where}: {keyword} removed (not an element)")
        return []
    if keyword[:1] == "z":  # circuitnsds's IGBT/SCR line; ngspice reads Z as a MESFET
        raise NetlistError(f"{keyword}: ngspice 39 has no IGBT or thyristor device (its Z line is "
                           "a MESFET), so this netlist cannot be compared", where=statement.location,
                           hint="compare a copy in which the device is written in ngspice's "
                           "terms (e.g. an S switch in series with a diode)")
    if keyword[:1] == "d" and keyword in translation.ammeters:
        translation.notes.append(f"{where}: {keyword}: a 0 V ammeter ({AMMETER_PREFIX}{keyword}) "
                                 "added in series, whose current is the diode's")
        return _ammeter(text)
    return [text]


def _model(logical: str, overrides: DiodeOverrides, translation: Translation, name: str) -> str | None:
    """The rewritten ``.model`` line of a diode model; ``None`` for other model types."""
    match = _MODEL.match(logical)
    if match is None or match.group(2).lower() != "d":
        return None
    model, rest = match.group(1), match.group(3).strip()
    if rest.startswith("(") and rest.endswith(")"):
        rest = rest[1:-1]
    params = {key.lower(): value for key, value in _PAIR.findall(rest)}
    text = [key for key in ("mfg", "type") if key in params]
    for key in text:
        del params[key]
    if text:
        translation.notes.append(f"{name}: .model {model}: {', '.join(text)} removed (text "
                                 "values, which ngspice cannot read)")
    if translation.ltspice and IDEAL_ONLY_PARAMETERS & params.keys():
        return _ltspice_model(model, params, translation, name)
    dropped = [key for key in params if key in IDEAL_ONLY_PARAMETERS]
    if "vrev" in params and "bv" not in params:
        params["bv"] = params["vrev"]
        translation.notes.append(f"{name}: .model {model}: Vrev={params['vrev']} used as BV")
    for key in dropped:
        del params[key]
    if dropped:
        translation.notes.append(f"{name}: .model {model}: {', '.join(dropped)} removed "
                                 "(idealised-diode parameters)")
    for key, value in overrides.items().items():
        for alias in ALIASES[key]:
            params.pop(alias, None)
        params[key] = f"{value:.12g}"
    if not params:
        return f".model {model} D"
    return f".model {model} D(" + " ".join(f"{key}={value}" for key, value in params.items()) + ")"


def _ltspice_model(model: str, params: dict[str, str], translation: Translation, name: str) -> str:
    """An LTspice PWL diode model for ngspice's ``sidiode``: idealised parameters only,
    ``Roff`` written out when absent."""
    kept = {key: value for key, value in params.items() if key in IDEAL_ONLY_PARAMETERS}
    dropped = sorted(set(params) - set(kept))
    if "roff" not in kept:
        kept["roff"] = f"{translation.off_resistance:.12g}"
        translation.notes.append(f"{name}: .model {model}: Roff={kept['roff']} written out "
                                 "(LTspice's default 1/gmin; ngspice's sidiode would take 1 ohm)")
    if dropped:
        translation.notes.append(f"{name}: .model {model}: {', '.join(dropped)} removed (not "
                                 "parameters of LTspice's PWL diode)")
    return f".model {model} D(" + " ".join(f"{key}={value}" for key, value in kept.items()) + ")"


AMMETER_PREFIX = "v_cnsds_"


def _ammeter(logical: str) -> list[str]:
    """``D1 a k m ...`` -> the diode to an inner node, and a 0 V source from it to ``k``."""
    tokens = logical.split()
    if len(tokens) < 4:
        return [logical]  # malformed: let ngspice report it
    name, cathode = tokens[0], tokens[2]
    inner = f"cnsds_{name.lower()}_k"
    tokens[2] = inner
    return [" ".join(tokens), f"{AMMETER_PREFIX}{name.lower()} {inner} {cathode} 0"]


_FIELD = re.compile(r"\{[^}]*\}|'[^']*'|\S+")


def _tran(logical: str, step: float | None, stop: float | None) -> str:
    if step is None and stop is None:
        return logical
    tokens = _FIELD.findall(logical)  # an expression {...} or '...' is one field
    numbers = [token for token in tokens[1:] if not token.lower().startswith("uic")]
    if len(numbers) == 1 and step is not None:  # LTspice's .tran TSTOP: ngspice needs TSTEP
        tokens.insert(tokens.index(numbers[0]), f"{step:.12g}")
        numbers.insert(0, tokens[tokens.index(numbers[0]) - 1])
    if step is not None and numbers:
        tokens[tokens.index(numbers[0])] = f"{step:.12g}"
    if stop is not None and len(numbers) > 1:
        tokens[tokens.index(numbers[1], 2)] = f"{stop:.12g}"
    return " ".join(tokens)


def ngspice_vector(signal: str, ammeter: bool = True) -> tuple[str, str | None]:
    """ngspice's vector for a circuitnsds signal name, and the ``.save`` entry it needs.

    ``v(node)`` → ``node``; ``i(v1)``, ``i(l1)``, ``i(e1)``, ``i(h1)`` → ``v1#branch``;
    diodes ``i(d1)`` → ``v_cnsds_d1#branch``, the current (anode → cathode) of the
    series ammeter that :func:`translate_netlist` adds (``ammeters=["d1"]``); other
    currents → a device parameter that must be saved explicitly: resistors,
    capacitors, switches and G/F sources ``@r1[i]`` (first → second node), current
    sources ``@i1[c]``. Elements inside subcircuit instances (``x1.d1`` in
    circuitnsds) are ``d.x1.d1`` in ngspice (``v.x1.v_cnsds_d1#branch`` for the
    ammeter); their nodes (``x1.n1``) have the same name in both. With ``ammeter=False``
    (the netlist as written, no ammeter added) a diode's current is ``@d1[id]``: its
    junction current at ngspice's last linearisation, capacitance current excluded.
    """
    key = signal.strip().lower()
    kind, inner = key[:2], key[2:-1]
    if kind == "v(" and key.endswith(")"):
        return inner, None
    if kind != "i(" or not key.endswith(")") or not inner:
        raise ValueError(f"{signal!r} is not a v(...) or i(...) signal")
    *path, element = inner.split(".")
    letter = element[0]
    if letter == "d" and ammeter:
        element, letter = f"{AMMETER_PREFIX}{element}", "v"
    device = ".".join([letter, *path, element]) if path else element
    if letter in "vleh":
        return f"{device}#branch", None
    parameter = {"i": "c", "d": "id"}.get(letter, "i")
    vector = f"@{device}[{parameter}]"
    return vector, vector
