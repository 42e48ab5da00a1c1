"""Cuts observed with a holder (``taptune cut``), kept in its history to test its lobes.

Each record is one analysed cut: where it was on the lobe diagram (speed, axial and
radial depth, direction, teeth, the cutting coefficients) and what the sound said
(stable / chatter / unclear, the chatter frequency). In the library file, under the
holder's optional ``"observations"`` key::

    {"date", "recording", "sha256", "rpm", "depth_mm", "ae_mm", "milling": "up" | "down",
     "teeth", "material": NAME | null, "ktc_mpa", "krc_mpa",
     "verdict": "stable" | "chatter" | "unclear", "chatter_hz": Hz | null,
     "chatter_level_db": dB | null, "taptune_version"}

Validation is by hand on plain JSON, in the style of :mod:`taptune.library.schema`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from datetime import datetime, timezone

from taptune.errors import InputError

VERDICTS = ("stable", "chatter", "unclear")
MILLING = ("up", "down")


class ObservationError(InputError):
    """A cut observation in a library file that does not validate."""


@dataclass(frozen=True)
class CutObservation:
    """One analysed cut with a holder (lengths in mm, coefficients in MPa, as in the file).

    Attributes
    ----------
    date : str
        ISO 8601 UTC time of the analysis.
    recording, sha256 : str
        The recording's file name and its SHA-256.
    rpm : float
        The spindle speed heard [rpm].
    depth_mm, ae_mm : float
        Axial and radial depth of cut [mm].
    milling : {"up", "down"}
    teeth : int
    material : str or None
        The named work material, when one was given.
    ktc_mpa, krc_mpa : float
        The cutting coefficients used [MPa].
    verdict : {"stable", "chatter", "unclear"}
    chatter_hz, chatter_level_db : float or None
        The chatter frequency [Hz] and its level above the forced vibration [dB].
    taptune_version : str
    """

    date: str
    recording: str
    sha256: str
    rpm: float
    depth_mm: float
    ae_mm: float
    milling: str
    teeth: int
    material: str | None
    ktc_mpa: float
    krc_mpa: float
    verdict: str
    chatter_hz: float | None
    chatter_level_db: float | None
    taptune_version: str

    def to_dict(self) -> dict:
        return {name: getattr(self, name) for name in self.__dataclass_fields__}

    @classmethod
    def from_analysis(cls, analysis, *, depth_mm: float, ae_mm: float, milling: str, ktc_mpa: float,
                      krc_mpa: float, material: str | None = None, recording: str = "", sha256: str | None = None,
                      date: str | None = None) -> "CutObservation":
        """The record of a :class:`taptune.signal.cut.CutAnalysis` (the speed heard, the verdict) at this cut.

        ``sha256`` None (a live recording, never a file) is stored as 64 zeros.
        """
        from taptune import __version__

        def rounded(v, digits):
            return None if v is None else round(float(v), digits)

        when = date or datetime.now(timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z")
        return cls(date=when, recording=recording.replace("\\", "/").rsplit("/", 1)[-1] or "recorded cut",
                   sha256=sha256 or "0" * 64, rpm=round(analysis.spindle_rpm, 1), depth_mm=float(depth_mm),
                   ae_mm=float(ae_mm), milling=milling, teeth=int(analysis.teeth), material=material,
                   ktc_mpa=float(ktc_mpa), krc_mpa=float(krc_mpa), verdict=analysis.verdict,
                   chatter_hz=rounded(analysis.chatter_hz, 2), chatter_level_db=rounded(analysis.chatter_level_db, 1),
                   taptune_version=__version__)

    @classmethod
    def from_dict(cls, data, source: str = "<library>", key: str = "observation") -> "CutObservation":
        """Validated record from JSON data; :class:`ObservationError` names ``source`` and ``key``.

        (This module stays below :mod:`taptune.library.schema`, which turns the error into
        its LibraryFormatError, so the checks are its own.)
        """
        def fail(name, problem):
            raise ObservationError(f"{source}: {key}{'.' + name if name else ''} {problem}")

        if not isinstance(data, dict):
            fail("", f"must be a JSON object, got {type(data).__name__}")
        fields = tuple(cls.__dataclass_fields__)
        for k in data:
            if k not in fields:
                fail(k, f"is not a known key (allowed: {', '.join(fields)})")
        for k in fields:
            if k not in data:
                fail(k, "is missing")
        d = dict(data)

        def number(name, lo=None, closed=False, optional=False):
            v = d[name]
            if v is None and optional:
                return None
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                fail(name, f"must be a finite number, got {v!r}")
            if lo is not None and (v < lo if closed else v <= lo):
                fail(name, f"must be {'>=' if closed else '>'} {lo:g}, got {v!r}")
            return float(v)

        def text(name, max_len=1000, optional=False):
            v = d[name]
            if v is None and optional:
                return None
            if not isinstance(v, str) or not v.strip() or len(v) > max_len or any(ord(c) < 32 for c in v):
                fail(name, f"must be one non-empty line of at most {max_len} characters, got {v!r}")
            return v

        if d["verdict"] not in VERDICTS:
            fail("verdict", f"must be one of {', '.join(VERDICTS)}, got {d['verdict']!r}")
        if d["milling"] not in MILLING:
            fail("milling", f"must be 'up' or 'down', got {d['milling']!r}")
        if not (isinstance(d["sha256"], str) and re.fullmatch(r"[0-9a-f]{64}", d["sha256"])):
            fail("sha256", f"must be 64 lower-case hex digits, got {d['sha256']!r}")
        teeth = d["teeth"]
        if isinstance(teeth, bool) or not isinstance(teeth, int) or teeth < 1:
            fail("teeth", f"must be an integer >= 1, got {teeth!r}")
        date = text("date", 64)
        try:
            when = datetime.fromisoformat(date)
        except ValueError:
            when = None
        if when is None or when.tzinfo is None or when.utcoffset().total_seconds() != 0:
            fail("date", f"must be an ISO-8601 date and time in UTC, got {date!r}")
        return cls(
            date=date, recording=text("recording"), sha256=d["sha256"], rpm=number("rpm", 0.0),
            depth_mm=number("depth_mm", 0.0), ae_mm=number("ae_mm", 0.0), milling=d["milling"], teeth=teeth,
            material=text("material", 100, optional=True), ktc_mpa=number("ktc_mpa", 0.0),
            krc_mpa=number("krc_mpa", 0.0, closed=True), verdict=d["verdict"],
            chatter_hz=number("chatter_hz", 0.0, optional=True),
            chatter_level_db=number("chatter_level_db", optional=True),
            taptune_version=text("taptune_version", 64),
        )
