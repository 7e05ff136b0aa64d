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
  .meas ...``) are removed;
* ``.tran`` TSTEP and TSTOP are replaced when the comparison overrides them;
* a diode whose current is compared gets a 0 V source in series (an ammeter:
  ``D1 a k m`` becomes ``D1 a cnsds_d1_k m`` and ``v_cnsds_d1 cnsds_d1_k k 0``),
  because ngspice's own ``@d1[id]`` is the current of the last linearisation,
  which at a sharp knee can be far from the current the circuit carries (kA
  spikes were seen on a Zener whose series inductor carried 0.6 A); the ammeter's
  branch current is the terminal current, junction-capacitance current included;
* ``.include`` and ``.lib`` files are translated the same way into a scratch folder
  and referenced by absolute path, so that relative paths keep meaning "relative
  to the including file" wherever ngspice runs.

Everything else (elements, ``.subckt``, ``.param``, ``.options``, ``.ic``,
comments) is passed through unchanged.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

from circuitnsds.compare.errors import CompareError
from circuitnsds.errors import NetlistError
from circuitnsds.netlist.parser import logical_lines, physical_lines

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
        includes: translated included files written to the scratch folder.
        notes: one line per change (dropped parameters and commands), for reports.
    """

    text: str
    includes: list[Path] = field(default_factory=list)
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
    scratch: Path | None = None,
    ltspice: bool = False,
    off_resistance: float = 1e12,
    measures: bool = False,
) -> Translation:
    """Rewrite a netlist for ngspice (see the module docstring for what changes).

    Args:
        source: a netlist file (``Path``, or a string without a newline) or netlist text.
        overrides: diode parameters forced on every ``D`` model.
        step, stop: replace ``.tran`` TSTEP and TSTOP [s] (TSTART, TMAX and UIC kept).
        saves: vectors for a ``.save`` line (``all`` is always saved as well), e.g. ``@r1[i]``.
        ammeters: local names of the diodes (``d1``, also inside subcircuits) that get a
            0 V source in series; see :func:`ngspice_vector` for its current's name.
        options: text of an ``.options`` line added for ngspice (e.g. ``"method=gear"``).
        scratch: folder for translated ``.include``/``.lib`` files (required when the
            netlist includes files).
        ltspice: keep LTspice PWL diode models for ngspice's LTspice mode (see above).
        off_resistance: ``Roff`` [Ω] written into LTspice PWL models that give none
            (circuitnsds's 1/gmin).
        measures: keep the ``.meas``/``.measure`` lines (ngspice prints their results).

    Raises:
        NetlistError: an included file cannot be read, or ``.include`` is used without
            a scratch folder.
    """
    overrides = overrides or DiodeOverrides()
    if isinstance(source, Path) or "\n" not in source:
        path = Path(source)
        text, base, name = _read(path, None), path.resolve().parent, str(path)
    else:
        text, base, name = source, Path.cwd(), "<text>"
    translation = Translation("", ammeters={name.lower() for name in ammeters}, ltspice=ltspice,
                              off_resistance=off_resistance, measures=measures)
    lines = physical_lines(text)
    if not lines:
        raise NetlistError("the netlist is empty", where=name)
    body = _translate_lines(lines[1:], _Context(base, name, overrides, step, stop, scratch, translation))
    if not translation.has_tran:
        if step is None or stop is None:
            raise NetlistError("no .tran line", where=name,
                               hint="add .tran TSTEP TSTOP, or give the step and the stop time")
        body.append(f".tran {step:.12g} {stop:.12g}")
        translation.notes.append(f"added .tran {step:g} {stop:g}")
    if options.strip():
        body.append(f".options {options.strip()}")
    body.append(".save all" + "".join(f" {vector}" for vector in saves))
    body.append(".end")
    translation.text = "\n".join([lines[0]] + body) + "\n"
    return translation


def _read(path: Path, where: str | None) -> str:
    try:
        return path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise NetlistError(f"cannot read {path}: {exc.strerror or exc}", where=where or str(path),
                           hint="check the path (relative paths are relative to the including "
                           "file)") from None


@dataclass(frozen=True)
class _Context:
    """What translating one file needs: where it is (``base`` folder, ``name`` for messages),
    the settings of the whole translation, and the :class:`Translation` being filled in."""

    base: Path
    name: str
    overrides: DiodeOverrides
    step: float | None
    stop: float | None
    scratch: Path | None
    translation: Translation


def _translate_lines(lines: list[str], context: _Context) -> list[str]:
    name, overrides, translation = context.name, context.overrides, context.translation
    step, stop = context.step, context.stop
    out: list[str] = []
    in_control = False
    for line in logical_lines(lines):
        physical, logical = list(line.physical), line.text
        if not logical:
            if not in_control:
                out.extend(physical)
            continue
        keyword = logical.split()[0].lower() if logical.split() else ""
        if in_control:
            in_control = keyword != ".endc"
            if keyword == "tran":  # the script's analysis, which circuitnsds runs too
                translation.has_tran = True
                out.append(_tran("." + logical, step, stop))
            elif keyword in {"meas", "measure"} and translation.measures:
                out.append("." + logical)
            continue
        if keyword == ".control":
            in_control = True
            translation.notes.append(f"{name}: .control block removed (its tran and meas lines "
                                     "kept as .tran and .meas)")
            continue
        if keyword == ".end":
            break
        if keyword in {".meas", ".measure"} and translation.measures:
            out.extend(physical)
            continue
        if keyword in DROPPED_COMMANDS:
            translation.notes.append(f"{name}: {keyword} removed")
            continue
        if keyword == ".model":
            out.append(_model(logical, overrides, translation, name) or "\n".join(physical))
            continue
        if keyword == ".tran":
            translation.has_tran = True
            out.append(_tran(logical, step, stop))
            continue
        if keyword[:1] == "d" and keyword in translation.ammeters:
            out.extend(_ammeter(logical))
            translation.notes.append(f"{name}: {keyword}: a 0 V ammeter ({AMMETER_PREFIX}{keyword}) "
                                     "added in series, whose current is the diode's")
            continue
        if keyword in {".include", ".inc", ".lib"}:
            out.append(_include(logical, context))
            continue
        out.extend(physical)
    return out


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


def _include(logical: str, context: _Context) -> str:
    """Translate an included file into ``context.scratch`` and point the line at it."""
    base, name, scratch, translation = context.base, context.name, context.scratch, context.translation
    parts = logical.split(None, 1)
    keyword, argument = parts[0], parts[1].strip() if len(parts) > 1 else ""
    if keyword.lower() == ".lib" and len(argument.split()) < 2 and not argument.startswith(("'", '"')):
        return logical  # `.lib SECTION` opens a section inside a library file
    quoted = re.match(r"""^(['"])(.*?)\1\s*(.*)$""", argument)
    if quoted:
        target, section = quoted.group(2), quoted.group(3)
    else:
        target, _, section = argument.partition(" ")
    path = Path(target).expanduser()
    if not path.is_absolute():
        path = base / path
    if scratch is None:
        raise NetlistError(f"{keyword} needs a scratch folder for the translated file",
                           where=name, hint="pass scratch=Path(...) to translate_netlist")
    text = _read(path, f"{name}: {keyword} {target}")
    body = _translate_lines(physical_lines(text), replace(context, base=path.resolve().parent,
                                                          name=str(path)))
    copy = scratch / f"{len(translation.includes) + 1}_{path.name}"
    copy.write_text("\n".join(body) + "\n", encoding="utf-8")
    translation.includes.append(copy)
    return f'{keyword} "{copy}"' + (f" {section.strip()}" if section.strip() else "")


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
