"""The holder-library file format: entries, provenance records and their validation.

A library file is one JSON document::

    {"schema": "taptune-holder-library", "version": 1, 2, 3 or 4 (see VERSION),
     "holders": {NAME: ENTRY, ...}}

with ``ENTRY`` as written by :meth:`HolderEntry.to_dict` (lengths in mm, moduli in GPa,
holder parameters in library units, see :mod:`taptune.model.params`)::

    {"name": "ER32 collet chuck HSK-A63 x 100", "interface": "HSK-A63",
     "holder": {"name", "interface", "clamp_length", "material": {"density",
                "youngs_modulus", "poisson", "loss_factor"}, "segments": [{"length", "od", "id"}]},
     "params": {"k_tt", "k_rr", "eta_tt", "eta_rr", "alpha", "density_factor", "modulus_factor"},
     "param_sets": [PARAMS, ...],                       # near-optimal sets (docs/physics.md §5)
     "model_options": {"h_max_mm": 2.0, ...},           # ModelOptions.to_dict()
     "identifications": [{"recording": "tap.wav", "sha256": "<64 hex>",
                          "tool": {"name", "total_length", "material", "segments",
                                   optional "shank_diameter", "flute_length",
                                   "flute_diameter", "flute_ratio"},
                          "stickout_mm", "date": "2026-11-22T12:38:49Z", "objective",
                          "seed": int | null, "evaluations",
                          "bending_measured_hz": [f1, null, f3], "bending_model_hz": [...],
                          "taptune_version",
                          optional "stickout_tolerance_mm"}, ...],  # as the assembly file stated it
     "checks": [{"date", "recording", "sha256", "tool": "<tool name>", "stickout_mm",  # optional
                 "verdict": "consistent" | "differs" | "inconclusive",
                 "modes": [{"mode", "measured_hz" | null, "predicted_hz", "band_hz"}, ...],
                 "taptune_version"}, ...],
     "observations": [CUT, ...]}                         # optional: taptune.library.observations

Every read is
validated here by hand-written checks on plain JSON data: nothing is ever executed,
imported or unpickled, and every message names the file, the holder and the key.
Unknown keys are rejected rather than ignored, so a typo or a foreign document cannot
pass as a library; a newer format gets a new ``version`` (:data:`VERSION`), and a file is
written with the oldest version that holds what it has, so an older taptune refuses only
the files it could not read, and clearly.
"""

from __future__ import annotations

import hashlib
import json
import itertools
import math
import operator
import re
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path

from taptune.errors import InputError, LibraryError
from taptune.io.assembly import (
    GPA,
    MAX_STICKOUT_TOLERANCE_MM,
    MM,
    NAME_MAX_LEN,
    Assembly,
    Holder,
    Material,
    Segment,
    Tool,
    holder_from_dict,
    material_to_dict,
    segments_to_list,
    validate,
    validate_holder,
)
from taptune.library.observations import CutObservation, ObservationError
from taptune.model.params import _PLAUSIBLE, NAMES, HolderParams

SCHEMA = "taptune-holder-library"
#: The newest format this build reads and writes. Version 2 added the ``checks`` history,
#: version 3 the stick-out tolerance stated at each identification, version 4 the cuts
#: observed with the holder (``observations``). A library is written
#: with the oldest version that holds what it has (1 without either), so older taptunes
#: keep reading it, and refuse a file they cannot read with "written by a newer taptune"
#: instead of tripping over an unknown key.
VERSION = 4
#: The format of a library without ``checks`` (what every taptune before checks reads).
VERSION_WITHOUT_CHECKS = 1
#: The format of a library with checks but no stated tolerances.
VERSION_WITH_CHECKS = 2
#: The format of a library without cut observations (version 4 added them).
VERSION_WITHOUT_OBSERVATIONS = 3

# Units of the holder parameters in tables and CSV headers (ASCII so spreadsheets agree).
PARAM_UNITS = {
    "k_tt": "N/m/mm",
    "k_rr": "N*m/rad/mm",
    "eta_tt": "1/mm",
    "eta_rr": "1/mm",
    "alpha": "%",
    "density_factor": "-",
    "modulus_factor": "-",
}

_PLAUSIBLE_PARAMS = {k: (lo, hi) for k, lo, hi in _PLAUSIBLE}
_SHA256 = re.compile(r"^[0-9a-f]{64}$")
_CONTROL = re.compile(r"[\x00-\x1f]")
_MAX_NAME = NAME_MAX_LEN  # what an assembly file may name


class LibraryFormatError(LibraryError, InputError):
    """A library or import file that cannot be used: unreadable, not JSON, not this schema.

    It is both a :class:`LibraryError` (what went wrong) and an :class:`InputError`
    (whose fault: a file the user points at), so every command exits 2 on it.
    """


class UnknownHolderError(LibraryError, InputError):
    """No holder of that name in the library; the message lists close matches."""

    def __init__(self, message: str, name: str, close_matches: tuple[str, ...]):
        super().__init__(message)
        self.name = name
        self.close_matches = close_matches


# --------------------------------------------------------------------------- checks


def _fail(src: str, key: str, problem: str):
    raise LibraryFormatError(f"{src}: {key} {problem}")


_KEY_SETS: dict[tuple, tuple[frozenset, frozenset]] = {}


def _object(value, src: str, key: str, required: tuple[str, ...], optional: tuple[str, ...] = ()) -> dict:
    """``value`` as a JSON object with exactly the allowed keys (all ``required`` present)."""
    # The usual case in one set test (a library has tens of objects per holder), then the reason.
    sets = _KEY_SETS.get((required, optional))
    if sets is None:
        sets = _KEY_SETS[(required, optional)] = (frozenset(required), frozenset(required + optional))
    if type(value) is dict and value.keys() >= sets[0] and sets[1].issuperset(value):
        return value
    if not isinstance(value, dict):
        _fail(src, key, f"must be a JSON object, got {_kind(value)}")
    unknown = [k for k in value if k not in required and k not in optional]
    if unknown:
        _fail(src, f"{key}.{unknown[0]}" if key else unknown[0], f"is not a known key (allowed: {', '.join(required + optional)})")
    missing = [k for k in required if k not in value]
    if missing:
        _fail(src, f"{key}.{missing[0]}" if key else missing[0], "is missing")
    return value


def _is_finite(value) -> bool:
    # JSON integers are unbounded: one with 400 digits overflows a float.
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def _number(value, src: str, key: str, lo: float | None = None, lo_open: bool = True) -> float:
    """A finite JSON number, optionally above ``lo`` (strictly when ``lo_open``)."""
    if type(value) is float and math.isfinite(value) and (lo is None or (value > lo if lo_open else value >= lo)):
        return value  # the usual case without the checks below
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not _is_finite(value):
        shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:37] + "..."
        _fail(src, key, f"must be a finite number, got {shown}")
    if lo is not None and (value <= lo if lo_open else value < lo):
        _fail(src, key, f"must be {'>' if lo_open else '>='} {lo:g}, got {value!r}")
    return float(value)


def _integer(value, src: str, key: str, lo: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < lo:
        _fail(src, key, f"must be an integer >= {lo}, got {value!r}")
    return value


def _text(value, src: str, key: str, max_len: int = 1000) -> str:
    if not isinstance(value, str) or not value.strip():
        _fail(src, key, f"must be a non-empty string, got {value!r}")
    if len(value) > max_len or _CONTROL.search(value):
        _fail(src, key, f"must be one line of at most {max_len} characters, got {value[:60]!r}")
    return value


def _list(value, src: str, key: str, of: str = "") -> list:
    """``value`` as a JSON list; ``of`` says of what, for the message (" of frequencies")."""
    if not isinstance(value, list):
        _fail(src, key, f"must be a list{of}, got {_kind(value)}")
    return value


def _sha256(value, src: str, key: str) -> str:
    if not isinstance(value, str) or not _SHA256.match(value):
        _fail(src, key, f"must be 64 lower-case hex digits, got {value!r}")
    return value


def _frequencies(value, src: str, key: str) -> tuple[float | None, ...]:
    """Bending frequencies f1, f2, … [Hz]: numbers > 0, or null for a mode not measured."""
    values = _list(value, src, key, " of frequencies (numbers or null)")
    return tuple(None if v is None else _number(v, src, f"{key}[{i}]", 0.0) for i, v in enumerate(values))


def _as_frequencies(values) -> tuple[float | None, ...]:
    return tuple(None if f is None else float(f) for f in values)


def _plain(value, src: str, key: str, depth: int = 0):
    """JSON scalars, lists and string-keyed objects only (what model options may hold)."""
    if depth > 8:
        _fail(src, key, "is nested too deeply")
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, float)):
        return _number(value, src, key) if isinstance(value, float) else value
    if isinstance(value, list):
        return [_plain(v, src, f"{key}[{i}]", depth + 1) for i, v in enumerate(value)]
    if isinstance(value, dict):
        return {k: _plain(v, src, f"{key}.{k}", depth + 1) for k, v in value.items()}
    _fail(src, key, f"must be plain JSON data, got {_kind(value)}")


def _kind(value) -> str:
    names = {dict: "an object", list: "a list", str: "a string", bool: "a boolean", type(None): "null"}
    return names.get(type(value), f"a number ({value!r})" if isinstance(value, (int, float)) else type(value).__name__)


def _material(value, src: str, key: str) -> dict:
    m = _object(value, src, key, ("density", "youngs_modulus", "poisson", "loss_factor"))
    out = {
        "density": _number(m["density"], src, f"{key}.density", 0.0),
        "youngs_modulus": _number(m["youngs_modulus"], src, f"{key}.youngs_modulus", 0.0),
        "poisson": _number(m["poisson"], src, f"{key}.poisson", -1.0),
        "loss_factor": _number(m["loss_factor"], src, f"{key}.loss_factor", 0.0, lo_open=False),
    }
    if out["poisson"] >= 0.5:
        _fail(src, f"{key}.poisson", f"must be < 0.5, got {out['poisson']!r}")
    if out["loss_factor"] >= 1:
        _fail(src, f"{key}.loss_factor", f"must be < 1, got {out['loss_factor']!r}")
    return out


def _segments(value, src: str, key: str) -> list[dict]:
    if not isinstance(value, list) or not value:
        _fail(src, key, "must be a non-empty list of {length, od, id} objects")
    out = []
    for i, s in enumerate(value, 1):
        k = f"{key}[{i}]"
        s = _object(s, src, k, ("length", "od", "id"))
        seg = {
            "length": _number(s["length"], src, f"{k}.length", 0.0),
            "od": _number(s["od"], src, f"{k}.od", 0.0),
            "id": _number(s["id"], src, f"{k}.id", 0.0, lo_open=False),
        }
        if seg["id"] >= seg["od"]:
            _fail(src, f"{k}.id", f"must be smaller than od ({seg['od']:g} mm), got {seg['id']:g}")
        out.append(seg)
    return out


def check_holder_dict(value, src: str, key: str = "holder") -> dict:
    """Validate holder geometry as written by :func:`taptune.io.assembly.holder_to_dict` (mm, GPa)."""
    h = _object(value, src, key, ("name", "interface", "clamp_length", "material", "segments"), ("gauge_length",))
    out = {
        "name": _text(h["name"], src, f"{key}.name", _MAX_NAME),
        "interface": _text(h["interface"], src, f"{key}.interface", _MAX_NAME),
        "clamp_length": _number(h["clamp_length"], src, f"{key}.clamp_length", 0.0),
        "material": _material(h["material"], src, f"{key}.material"),
        "segments": _segments(h["segments"], src, f"{key}.segments"),
    }
    length = sum(s["length"] for s in out["segments"])
    if out["clamp_length"] > length * (1 + 1e-9):
        _fail(src, f"{key}.clamp_length", f"({out['clamp_length']:g} mm) exceeds the holder length ({length:g} mm)")
    if "gauge_length" in h:
        out["gauge_length"] = _number(h["gauge_length"], src, f"{key}.gauge_length", 0.0)
        if out["gauge_length"] > length * (1 + 1e-9):
            _fail(src, f"{key}.gauge_length", f"({out['gauge_length']:g} mm) exceeds the holder length ({length:g} mm)")
    return out


def holder_range_problem(holder: dict, src: str) -> str | None:
    """What makes checked holder geometry (:func:`check_holder_dict`) implausible, or None.

    The assembly file's ranges (lengths, diameters, materials: :func:`validate_holder`),
    so a holder is never saved that an assembly file could not describe. They are
    checked when a holder is written or imported (refused) and only warned about when a
    library is read: one holder an older taptune saved with, say, a 1e9 mm segment must
    not make every other holder of the file unusable. The message names ``src``.
    """
    try:
        validate_holder(holder_from_dict(holder, src), src)
    except InputError as err:
        return str(err)
    return None


_TOOL_OPTIONAL = ("shank_diameter", "flute_length", "flute_diameter", "flute_ratio")


def check_tool_dict(value, src: str, key: str = "tool") -> dict:
    """Validate tool geometry as written by :func:`tool_to_dict` (mm, GPa)."""
    t = _object(value, src, key, ("name", "total_length", "material", "segments"), _TOOL_OPTIONAL)
    out = {
        "name": _text(t["name"], src, f"{key}.name", _MAX_NAME),
        "total_length": _number(t["total_length"], src, f"{key}.total_length", 0.0),
        "material": _material(t["material"], src, f"{key}.material"),
        "segments": _segments(t["segments"], src, f"{key}.segments"),
    }
    for k in _TOOL_OPTIONAL:
        if k in t and t[k] is not None:
            out[k] = _number(t[k], src, f"{key}.{k}", 0.0)
    length = sum(s["length"] for s in out["segments"])
    if abs(length - out["total_length"]) > 0.01:
        _fail(src, f"{key}.total_length", f"is {out['total_length']:g} mm but the segments add up to {length:g} mm")
    return out


_PARAM_VALUES = operator.itemgetter(*NAMES)
#: Per parameter of :data:`NAMES`, a closed range inside which :meth:`HolderParams.from_dict`
#: accepts a float (its plausible ranges; alpha strictly inside ±100 %, the factors > 0).
_PARAM_LOW, _PARAM_HIGH = zip(*(_PLAUSIBLE_PARAMS.get(k, (-math.nextafter(100.0, 0.0), math.nextafter(100.0, 0.0)))
                                for k in NAMES))
_FLOAT = frozenset({float})
_DICT = frozenset({dict})
_SEVEN = frozenset({len(NAMES)})


def check_params(value, src: str, key: str) -> HolderParams:
    """Validate the seven holder parameters (exactly the keys of :data:`NAMES`)."""
    # A library holds tens of sets per holder: the usual case (seven plausible floats,
    # no other key) in one pass; anything else goes the long way, which says what is wrong.
    if type(value) is dict and len(value) == len(NAMES):
        try:
            values = _PARAM_VALUES(value)
        except KeyError:
            values = None
        # map() over C functions: no Python frame per value.
        if (values is not None and _FLOAT.issuperset(map(type, values)) and all(map(operator.le, _PARAM_LOW, values))
                and all(map(operator.le, values, _PARAM_HIGH))):
            return HolderParams(*values)
    _object(value, src, key, NAMES)
    for k in NAMES:
        v = value[k]
        if type(v) is not float or not math.isfinite(v):  # the usual case passes without a call
            _number(v, src, f"{key}.{k}")
    try:
        return HolderParams.from_dict(value, f"{src}: {key}")
    except InputError as err:
        raise LibraryFormatError(str(err)) from None


def check_param_sets(values: list, src: str, key: str) -> tuple[HolderParams, ...]:
    """:func:`check_params` of each item of the list ``values`` (named ``key[i]``).

    The usual case (every item seven plausible floats and no other key) is tested for
    all sets at once; any other list goes set by set, so a message names the set.
    """
    if _DICT.issuperset(map(type, values)) and _SEVEN.issuperset(map(len, values)):
        try:
            rows = list(map(_PARAM_VALUES, values))
        except KeyError:
            rows = None
        if rows is not None:
            flat = list(itertools.chain.from_iterable(rows))
            if (_FLOAT.issuperset(map(type, flat)) and all(map(operator.le, itertools.cycle(_PARAM_LOW), flat))
                    and all(map(operator.le, flat, itertools.cycle(_PARAM_HIGH)))):
                return tuple(itertools.starmap(HolderParams, rows))
    return tuple(check_params(p, src, f"{key}[{i}]") for i, p in enumerate(values))


def check_date(value, src: str, key: str) -> str:
    """An ISO-8601 date-time in UTC (``Z`` or ``+00:00``)."""
    text = _text(value, src, key, 64)
    try:
        when = datetime.fromisoformat(text)
    except ValueError:
        _fail(src, key, f"must be an ISO-8601 date and time in UTC, got {text!r}")
    if when.tzinfo is None or when.utcoffset().total_seconds() != 0:
        _fail(src, key, f"must be in UTC (end with Z or +00:00), got {text!r}")
    return text


# --------------------------------------------------------------------------- geometry


def tool_to_dict(tool: Tool) -> dict:
    """Tool geometry as plain JSON-able data (mm, GPa); kept with each identification."""
    out = {
        "name": tool.name,
        "total_length": tool.total_length / MM,
        "material": material_to_dict(tool.material),
        "segments": segments_to_list(tool.segments),
    }
    for k in ("shank_diameter", "flute_length", "flute_diameter"):
        if getattr(tool, k) is not None:
            out[k] = getattr(tool, k) / MM
    if tool.flute_ratio is not None:
        out["flute_ratio"] = tool.flute_ratio
    return out


def tool_from_dict(data: dict, source: str = "<library>") -> Tool:
    """Inverse of :func:`tool_to_dict` (SI inside); raises LibraryFormatError naming ``source``."""
    t = check_tool_dict(data, source)
    m = t["material"]

    def mm(key):
        return t[key] * MM if key in t else None

    return Tool(
        name=t["name"],
        total_length=t["total_length"] * MM,
        segments=tuple(Segment(s["length"] * MM, s["od"] * MM, s["id"] * MM) for s in t["segments"]),
        material=Material(m["density"], m["youngs_modulus"] * GPA, m["poisson"], m["loss_factor"]),
        shank_diameter=mm("shank_diameter"),
        flute_length=mm("flute_length"),
        flute_diameter=mm("flute_diameter"),
        flute_ratio=t.get("flute_ratio"),
    )


# --------------------------------------------------------------------------- records


def utc_now() -> str:
    """The current time as ISO-8601 UTC to the second, e.g. ``2026-11-22T12:38:49Z``."""
    return datetime.now(timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z")


def date_label(iso: str | None) -> str:
    """``2026-11-22 12:38`` (UTC) from an ISO-8601 UTC date: how every list and view shows dates ('' for None)."""
    return datetime.fromisoformat(iso).strftime("%Y-%m-%d %H:%M") if iso else ""


def sha256_file(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes (identifies a recording whatever its name)."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


@dataclass(frozen=True)
class ProvenanceRecord:
    """One identification that produced (or refined) a library entry.

    Parameters
    ----------
    recording : str
        File name of the recording (no folder).
    sha256 : str
        Hex SHA-256 of the recording's bytes.
    tool : dict
        Tool geometry (:func:`tool_to_dict`, mm), enough to rebuild the assembly.
    stickout_mm : float
        Stick-out of the tool during the recording [mm].
    date : str
        When the identification ran, ISO-8601 UTC.
    objective : float
        Final objective value J (docs/physics.md §4).
    seed : int or None
        Optimiser seed (None if the run was not seeded).
    evaluations : int
        Model evaluations the optimiser used.
    bending_measured_hz, bending_model_hz : tuple of float or None
        Measured and fitted bending frequencies f1, f2, … [Hz]; position n is mode n + 1,
        None where that mode was not measured.
    taptune_version : str
        Version of taptune that ran the identification.
    stickout_tolerance_mm : float or None
        ± stick-out [mm] the assembly file stated (``stickout_tolerance``); None for the
        default, a ruler's (and in records from before it was kept). A later prediction's
        band takes the stick-out error of this identification from it.
    """

    recording: str
    sha256: str
    tool: dict
    stickout_mm: float
    date: str
    objective: float
    seed: int | None
    evaluations: int
    bending_measured_hz: tuple[float | None, ...]
    bending_model_hz: tuple[float | None, ...]
    taptune_version: str
    stickout_tolerance_mm: float | None = None

    def __post_init__(self):
        # Lists from callers become tuples so records compare and hash like values.
        object.__setattr__(self, "bending_measured_hz", _as_frequencies(self.bending_measured_hz))
        object.__setattr__(self, "bending_model_hz", _as_frequencies(self.bending_model_hz))

    @property
    def tool_name(self) -> str:
        """Name of the tool used in this identification."""
        return self.tool["name"]

    @classmethod
    def from_recording(
        cls,
        path: str | Path,
        tool: Tool,
        stickout_mm: float,
        objective: float,
        seed: int | None,
        evaluations: int,
        bending_measured_hz,
        bending_model_hz,
        date: str | None = None,
        stickout_tolerance_mm: float | None = None,
    ) -> "ProvenanceRecord":
        """A record for the recording at ``path`` (name and SHA-256 taken from the file)."""
        from taptune import __version__

        return cls(
            recording=Path(path).name,
            sha256=sha256_file(path),
            tool=tool_to_dict(tool),
            stickout_mm=float(stickout_mm),
            date=date or utc_now(),
            objective=float(objective),
            seed=None if seed is None else int(seed),
            evaluations=int(evaluations),
            bending_measured_hz=tuple(bending_measured_hz),
            bending_model_hz=tuple(bending_model_hz),
            taptune_version=__version__,
            stickout_tolerance_mm=None if stickout_tolerance_mm is None else float(stickout_tolerance_mm),
        )

    def to_dict(self) -> dict:
        stated = {} if self.stickout_tolerance_mm is None else {"stickout_tolerance_mm": self.stickout_tolerance_mm}
        return {
            "recording": self.recording,
            "sha256": self.sha256,
            "tool": self.tool,
            "stickout_mm": self.stickout_mm,
            "date": self.date,
            "objective": self.objective,
            "seed": self.seed,
            "evaluations": self.evaluations,
            "bending_measured_hz": list(self.bending_measured_hz),
            "bending_model_hz": list(self.bending_model_hz),
            "taptune_version": self.taptune_version,
        } | stated

    @classmethod
    def from_dict(cls, data, source: str = "<library>", key: str = "identification") -> "ProvenanceRecord":
        """Validated record from JSON data; errors name ``source`` and ``key``."""
        optional = ("stickout_tolerance_mm",)
        d = _object(data, source, key, tuple(f for f in cls.__dataclass_fields__ if f not in optional), optional)
        tolerance = d.get("stickout_tolerance_mm")
        sha = _sha256(d["sha256"], source, f"{key}.sha256")
        seed = d["seed"]
        return cls(
            recording=_text(d["recording"], source, f"{key}.recording"),
            sha256=sha,
            tool=check_tool_dict(d["tool"], source, f"{key}.tool"),
            stickout_mm=_number(d["stickout_mm"], source, f"{key}.stickout_mm", 0.0),
            date=check_date(d["date"], source, f"{key}.date"),
            objective=_number(d["objective"], source, f"{key}.objective", 0.0, lo_open=False),
            seed=None if seed is None else _integer(seed, source, f"{key}.seed"),
            evaluations=_integer(d["evaluations"], source, f"{key}.evaluations"),
            bending_measured_hz=_frequencies(d["bending_measured_hz"], source, f"{key}.bending_measured_hz"),
            bending_model_hz=_frequencies(d["bending_model_hz"], source, f"{key}.bending_model_hz"),
            taptune_version=_text(d["taptune_version"], source, f"{key}.taptune_version", 64),
            stickout_tolerance_mm=None if tolerance is None else _stickout_tolerance(
                tolerance, source, f"{key}.stickout_tolerance_mm"),
        )


def _stickout_tolerance(value, source: str, key: str) -> float:
    """A stated stick-out tolerance [mm], in the range an assembly file may state."""
    v = _number(value, source, key, 0.0, lo_open=False)
    if v > MAX_STICKOUT_TOLERANCE_MM:
        _fail(source, key, f"must be <= {MAX_STICKOUT_TOLERANCE_MM:g} mm, got {v!r}")
    return v


@dataclass(frozen=True)
class CheckRecord:
    """One check of the holder by a single tap (``taptune check``), kept in its history.

    ``modes`` holds per bending mode ``{"mode", "measured_hz" (null if not measured),
    "predicted_hz", "band_hz"}`` [Hz], ``band_hz`` the half-width the verdict used (the
    prediction's band plus the stick-out term); ``verdict`` is ``consistent``, ``differs``
    or ``inconclusive`` (taptune.identify.check).
    """

    date: str
    recording: str
    sha256: str
    tool: str
    stickout_mm: float
    verdict: str
    modes: tuple[dict, ...]
    taptune_version: str

    VERDICTS = ("consistent", "differs", "inconclusive")

    def __post_init__(self):
        object.__setattr__(self, "modes", tuple(self.modes))

    def to_dict(self) -> dict:
        return {"date": self.date, "recording": self.recording, "sha256": self.sha256, "tool": self.tool,
                "stickout_mm": self.stickout_mm, "verdict": self.verdict, "modes": [dict(m) for m in self.modes],
                "taptune_version": self.taptune_version}

    @classmethod
    def from_dict(cls, data, source: str = "<library>", key: str = "check") -> "CheckRecord":
        """Validated record from JSON data; errors name ``source`` and ``key``."""
        d = _object(data, source, key, tuple(f for f in cls.__dataclass_fields__))
        sha = _sha256(d["sha256"], source, f"{key}.sha256")
        if d["verdict"] not in cls.VERDICTS:
            _fail(source, f"{key}.verdict", f"must be one of {', '.join(cls.VERDICTS)}, got {d['verdict']!r}")
        modes = []
        for i, m in enumerate(_list(d["modes"], source, f"{key}.modes")):
            k = f"{key}.modes[{i}]"
            m = _object(m, source, k, ("mode", "measured_hz", "predicted_hz", "band_hz"))
            measured = m["measured_hz"]
            modes.append({"mode": _integer(m["mode"], source, f"{k}.mode", 1),
                          "measured_hz": None if measured is None else _number(measured, source, f"{k}.measured_hz", 0.0),
                          "predicted_hz": _number(m["predicted_hz"], source, f"{k}.predicted_hz", 0.0),
                          "band_hz": _number(m["band_hz"], source, f"{k}.band_hz", 0.0, lo_open=False)})
        return cls(
            date=check_date(d["date"], source, f"{key}.date"),
            recording=_text(d["recording"], source, f"{key}.recording"),
            sha256=sha,
            tool=_text(d["tool"], source, f"{key}.tool", _MAX_NAME),
            stickout_mm=_number(d["stickout_mm"], source, f"{key}.stickout_mm", 0.0),
            verdict=d["verdict"],
            modes=tuple(modes),
            taptune_version=_text(d["taptune_version"], source, f"{key}.taptune_version", 64),
        )


# --------------------------------------------------------------------------- entries


@dataclass(frozen=True)
class HolderEntry:
    """A holder in the library: geometry, identified parameters, uncertainty set, history.

    Parameters
    ----------
    name : str
        Library key (the assembly file's holder name).
    holder : dict
        Holder geometry (:func:`taptune.io.assembly.holder_to_dict`, mm, GPa).
    interface : str
        Spindle interface, e.g. ``"HSK-A63"`` (equal to ``holder["interface"]``).
    params : HolderParams
        The best parameters.
    param_sets : tuple of HolderParams
        Near-optimal parameter sets (docs/physics.md §5); their spread is the uncertainty.
    model_options : dict
        The model options the parameters were identified with (docs/physics.md §1).
    identifications : tuple of ProvenanceRecord
        Every identification of this holder, oldest first.
    checks : tuple of CheckRecord
        Every check by one tap (``taptune check``), oldest first; the key is optional in
        the file (libraries from before checks existed) and left out while empty.
    warnings : tuple of str
        What reading found implausible but kept (:func:`holder_range_problem`: geometry an
        older taptune saved); never written to the file, ignored by comparisons.
    """

    name: str
    holder: dict
    interface: str
    params: HolderParams
    param_sets: tuple[HolderParams, ...] = ()
    model_options: dict = field(default_factory=dict)
    identifications: tuple[ProvenanceRecord, ...] = ()
    checks: tuple[CheckRecord, ...] = ()
    observations: tuple[CutObservation, ...] = ()
    warnings: tuple[str, ...] = field(default=(), compare=False)

    def __post_init__(self):
        object.__setattr__(self, "warnings", tuple(self.warnings))
        object.__setattr__(self, "param_sets", tuple(self.param_sets))
        object.__setattr__(self, "identifications", tuple(self.identifications))
        object.__setattr__(self, "checks", tuple(self.checks))
        object.__setattr__(self, "observations", tuple(self.observations))

    @classmethod
    def create(
        cls,
        holder: Holder,
        params: HolderParams,
        param_sets=(),
        model_options: dict | None = None,
        identifications=(),
        name: str | None = None,
    ) -> "HolderEntry":
        """An entry for an io ``Holder`` (named after it unless ``name`` is given)."""
        from taptune.io.assembly import holder_to_dict

        return cls(
            name=name or holder.name,
            holder=holder_to_dict(holder),
            interface=holder.interface,
            params=params,
            param_sets=tuple(param_sets),
            model_options=dict(model_options or {}),
            identifications=tuple(identifications),
        )

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "interface": self.interface,
            "holder": self.holder,
            "params": self.params.to_dict(),
            "param_sets": [p.to_dict() for p in self.param_sets],
            "model_options": self.model_options,
            "identifications": [r.to_dict() for r in self.identifications],
        } | ({"checks": [c.to_dict() for c in self.checks]} if self.checks else {}) | (
            {"observations": [o.to_dict() for o in self.observations]} if self.observations else {})

    @classmethod
    def from_dict(cls, data, source: str = "<library>") -> "HolderEntry":
        """Validated entry from JSON data; errors name ``source`` (file and holder) and the key.

        Wrong types and missing or unknown keys raise LibraryFormatError; geometry that is
        well-formed but implausible (:func:`holder_range_problem`) is kept, with a warning
        in ``warnings`` (writing such an entry is refused: :func:`checked_entry`).
        """
        optional = ("checks", "observations")
        d = _object(data, source, "", tuple(f for f in cls.__dataclass_fields__ if f not in optional + ("warnings",)),
                    optional)
        checks = _list(d.get("checks", []), source, "checks")
        try:
            observations = tuple(CutObservation.from_dict(o, source, f"observations[{i}]")
                                 for i, o in enumerate(_list(d.get("observations", []), source, "observations")))
        except ObservationError as err:
            raise LibraryFormatError(str(err)) from None
        holder = check_holder_dict(d["holder"], source)
        interface = _text(d["interface"], source, "interface", _MAX_NAME)
        if interface != holder["interface"]:
            _fail(source, "interface", f"{interface!r} differs from holder.interface {holder['interface']!r}")
        sets = _list(d["param_sets"], source, "param_sets", " of parameter objects")
        options = d["model_options"]
        if not isinstance(options, dict):
            _fail(source, "model_options", f"must be a JSON object, got {_kind(options)}")
        records = _list(d["identifications"], source, "identifications")
        name = _text(d["name"], source, "name", _MAX_NAME)
        problem = holder_range_problem(holder, source)
        warnings = () if problem is None else (
            f"{problem}; the holder is kept as it is and listed, but its stored geometry cannot be used: "
            f"identify it again with a corrected assembly file, or remove it (taptune library remove {name!r})",)
        return cls(
            name=name,
            holder=holder,
            interface=interface,
            params=check_params(d["params"], source, "params"),
            param_sets=check_param_sets(sets, source, "param_sets"),
            model_options=_plain(options, source, "model_options"),
            identifications=tuple(
                ProvenanceRecord.from_dict(r, source, f"identifications[{i}]") for i, r in enumerate(records)
            ),
            checks=tuple(CheckRecord.from_dict(c, source, f"checks[{i}]") for i, c in enumerate(checks)),
            observations=observations,
            warnings=warnings,
        )

    def holder_geometry(self) -> Holder:
        """The holder as an io :class:`~taptune.io.assembly.Holder` (SI)."""
        return holder_from_dict(self.holder, f"holder {self.name!r}")

    def assembly(self, tool: dict | Tool, stickout_mm: float) -> Assembly:
        """This holder with ``tool`` (a :func:`tool_to_dict` dict or a Tool) at ``stickout_mm``, validated."""
        if isinstance(tool, dict):
            tool = tool_from_dict(tool, f"holder {self.name!r}: tool")
        source = f"holder {self.name!r} with tool {tool.name!r} at {stickout_mm:g} mm"
        return validate(Assembly(self.holder_geometry(), tool, stickout_mm * MM, source=source))

    def options(self):
        """The stored model options as a :class:`~taptune.model.options.ModelOptions`.

        Keys a newer taptune added are ignored; values the model rejects raise
        LibraryFormatError, since predictions must use the identification's options.
        """
        from taptune.model.options import ModelOptions

        try:
            return ModelOptions.from_dict(self.model_options, f"holder {self.name!r}: model_options")
        except InputError as err:
            raise LibraryFormatError(f"{err} (the predictions must use the identification's options)") from None

    def prediction_sets(self) -> list[HolderParams]:
        """The best parameters first, then the other near-optimal sets (no repeats)."""
        return [self.params] + [p for p in self.param_sets if p != self.params]

    def relative_floor(self) -> float:
        """The smallest relative spread a prediction may claim: the worst misfit of any
        identification of this holder (at least the 0.05 % the peaks are measured to)."""
        from taptune.identify.core import fit_misfit

        return max([fit_misfit(r.bending_measured_hz, r.bending_model_hz) for r in self.identifications] or [5e-4])

    def identified_assemblies(self) -> list[Assembly]:
        """The assemblies of this holder's identifications (the band's Δ stick-out and
        the identification side of its geometry part), with the stick-out tolerance each
        identification stated; records that no longer form a valid assembly are left out."""
        out = []
        for r in self.identifications:
            try:
                assembly = self.assembly(r.tool, r.stickout_mm)
            except InputError:
                continue
            if r.stickout_tolerance_mm is not None:
                assembly = replace(assembly, tolerances=replace(assembly.tolerances, stickout=r.stickout_tolerance_mm * MM))
            out.append(assembly)
        return out

    def predict(self, assembly):
        """Bending modes with the honest ± band of this holder in ``assembly`` (an identify
        Prediction; ``bending_hz_spread`` is the band's half-width, ``band`` its make-up):
        the one way the CLI, the library commands and the GUI predict from the library."""
        from taptune.identify import predict

        return predict(self.prediction_sets(), assembly, self.options(), relative_floor=self.relative_floor(),
                       identified=self.identified_assemblies(), measured_modes=self.measured_modes())

    def measured_modes(self) -> tuple[bool, ...] | None:
        """Which bending modes any identification measured (the band's evidence groups);
        None without identification records."""
        from taptune.identify.bands import measured_modes

        measured = [r.bending_measured_hz for r in self.identifications]
        return measured_modes(measured) if measured else None

    def spread(self) -> dict[str, float]:
        """± half-width of each parameter over the best and the near-optimal sets (library units)."""
        sets = (self.params,) + self.param_sets
        out = {}
        for k in NAMES:
            values = [getattr(p, k) for p in sets]
            out[k] = (max(values) - min(values)) / 2
        return out

    @property
    def last_identified(self) -> str | None:
        """Date of the latest identification (ISO-8601 UTC), None if there is none."""
        dates = [r.date for r in self.identifications]
        return max(dates, key=lambda d: datetime.fromisoformat(d)) if dates else None

    def differences(self, other: "HolderEntry") -> list[str]:
        """What differs between two entries apart from their identification history."""
        out = []
        for k in NAMES:
            a, b = getattr(self.params, k), getattr(other.params, k)
            if a != b:
                out.append(f"{k} {a:.6g} vs {b:.6g}")
        if self.param_sets != other.param_sets:
            out.append(f"param_sets ({len(self.param_sets)} vs {len(other.param_sets)} sets)")
        if self.holder != other.holder or self.interface != other.interface:
            out.append("holder geometry")
        if self.model_options != other.model_options:
            out.append("model_options")
        return out

    def superseding(self, older: "HolderEntry") -> "HolderEntry":
        """This entry's parameters and geometry with ``older``'s history (identifications, checks) kept in front.

        Records already in ``older`` are not repeated, so putting back an entry that was
        read, extended and written is the same as appending its new records.
        """
        history = list(older.identifications)
        history += [r for r in self.identifications if r not in older.identifications]
        checks = older.checks + tuple(c for c in self.checks if c not in older.checks)
        observed = older.observations + tuple(o for o in self.observations if o not in older.observations)
        return replace(self, identifications=tuple(history), checks=checks, observations=observed)


def checked_entry(entry: HolderEntry, source: str) -> HolderEntry:
    """``entry`` as it will read back from a file: validated, with plain JSON values.

    Raises LibraryFormatError naming ``source`` and the key before anything is written,
    so a bad entry from a caller is reported as such, not as a broken library; implausible
    geometry (:func:`holder_range_problem`), which a read only warns about, is refused here.
    """
    if not isinstance(entry, HolderEntry):
        raise TypeError(f"{source}: expected a HolderEntry, got {type(entry).__name__}")
    try:
        text = json.dumps(entry.to_dict(), allow_nan=False)
    except (TypeError, ValueError) as err:
        raise LibraryFormatError(f"{source}: cannot be written as JSON ({err})") from None
    checked = HolderEntry.from_dict(json.loads(text), source)
    refuse_implausible(checked, source, "not saved")
    return checked


def refuse_implausible(entry: HolderEntry, source: str, outcome: str) -> None:
    """Raise LibraryFormatError naming ``source`` when ``entry``'s geometry is implausible.

    ``outcome`` says what happened instead (``"not saved"``, ``"nothing was imported"``).
    """
    problem = holder_range_problem(entry.holder, source)
    if problem is not None:
        raise LibraryFormatError(f"{problem}; {outcome}")


# --------------------------------------------------------------------------- documents


def _reject_constant(name: str):
    # JSON has no NaN or Infinity; Python's json would otherwise accept them.
    raise ValueError(f"{name} is not a JSON number")


def _unique_keys(pairs):
    out = dict(pairs)
    if len(out) != len(pairs):
        keys = [k for k, _ in pairs]
        dup = next(k for k in keys if keys.count(k) > 1)
        raise ValueError(f"duplicate key {dup!r}")
    return out


def decode(raw: bytes, source: str) -> object:
    """Parse JSON bytes strictly (UTF-8, no NaN, no duplicate keys); plain data only."""
    if not raw.strip():
        raise LibraryFormatError(f"{source}: is empty (truncated?), not a holder library")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise LibraryFormatError(f"{source}: is not UTF-8 text, so not a holder library (JSON)") from None
    try:
        return json.loads(text, object_pairs_hook=_unique_keys, parse_constant=_reject_constant)
    except json.JSONDecodeError as err:
        raise LibraryFormatError(
            f"{source}: is not valid JSON (line {err.lineno} column {err.colno}: {err.msg}); truncated or not a holder library"
        ) from None
    except ValueError as err:
        raise LibraryFormatError(f"{source}: is not valid JSON ({err})") from None
    except RecursionError:
        raise LibraryFormatError(f"{source}: JSON is nested too deeply to be a holder library") from None


def parse_library(data, source: str) -> dict[str, HolderEntry]:
    """Validate a decoded library document; return its entries by name."""
    if not isinstance(data, dict) or data.get("schema") != SCHEMA:
        found = data.get("schema") if isinstance(data, dict) else None
        what = f"schema {found!r}" if found is not None else "no \"schema\": \"taptune-holder-library\" key"
        raise LibraryFormatError(f"{source}: is not a taptune holder library ({what})")
    if "version" not in data:
        _fail(source, "version", "is missing")
    version = data["version"]
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        _fail(source, "version", f"must be a positive integer, got {version!r}")
    # Before any other key: a newer format may have keys this build does not know.
    if version > VERSION:
        _fail(source, "version", f"is {version}: written by a newer taptune (this one reads versions 1–{VERSION}); "
              "update taptune to use it (the file is left as it is)")
    _object(data, source, "", ("schema", "version", "holders"))
    holders = data["holders"]
    if not isinstance(holders, dict):
        _fail(source, "holders", f"must be a JSON object of holders by name, got {_kind(holders)}")
    out = {}
    for name, value in holders.items():
        where = f"{source}: holder {name!r}"
        entry = HolderEntry.from_dict(value, where)
        if entry.name != name:
            _fail(where, "name", f"{entry.name!r} differs from its key in \"holders\"")
        out[name] = entry
    return out


def library_version(entries) -> int:
    """The oldest library format version that holds these entries (see :data:`VERSION`)."""
    entries = list(entries)
    stated = any(r.stickout_tolerance_mm is not None for entry in entries for r in entry.identifications)
    with_checks = any(entry.checks for entry in entries)
    if any(entry.observations for entry in entries):
        return VERSION
    if stated:
        return VERSION_WITHOUT_OBSERVATIONS
    return VERSION_WITH_CHECKS if with_checks else VERSION_WITHOUT_CHECKS


def library_document(entries: dict[str, HolderEntry]) -> dict:
    """The JSON document of a library (holders sorted by name, for stable diffs)."""
    return {
        "schema": SCHEMA,
        "version": library_version(entries.values()),
        "holders": {name: entries[name].to_dict() for name in sorted(entries)},
    }


def encode(entries: dict[str, HolderEntry], source: str) -> bytes:
    """Library bytes, checked by reading them back: nothing is written that cannot be read."""
    for name, entry in entries.items():
        if not isinstance(entry, HolderEntry) or entry.name != name:
            raise LibraryError(f"{source}: holder {name!r} must be a HolderEntry named {name!r}")
    try:
        text = json.dumps(library_document(entries), indent=2, ensure_ascii=False, allow_nan=False)
    except (TypeError, ValueError) as err:
        raise LibraryFormatError(f"{source}: cannot be written as JSON ({err})") from None
    raw = (text + "\n").encode("utf-8")
    parse_library(decode(raw, source), source)
    return raw
