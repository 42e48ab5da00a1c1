"""The coupling plane and the holder cut there (docs/machine.md).

The coupling plane is where the holder leaves the spindle: the spindle-side face of the
flange (for HSK, the face contact). It lies ``gauge_length`` behind the holder's front
face when the holder gives one; otherwise the interface decides through
:data:`INTERFACE_SHANK_MM`, the length of the taper shank in front of the segments'
spindle-side end. For coupling only the part z ≥ z_cp of the holder is kept: the taper
belongs to the spindle side, whose measured receptance already contains it.

Signatures::

    coupling_plane(holder, source="") -> float                   # z_cp [m]
    plane_warning(holder, source="") -> str | None               # a gauge_length off the taper's end
    interface_warning(machine_interface, holder) -> str | None   # the machine's interface is another
    cut_holder(holder, source="") -> Holder                      # part z >= z_cp, z from the plane
    cut_assembly(assembly) -> Assembly                           # the same for holder and tool
"""

from __future__ import annotations

import re
from dataclasses import replace

from taptune.errors import InputError
from taptune.io.assembly import TOL_M, Assembly, Holder, Segment, validate

MM = 1e-3

#: Length of the taper shank [mm] behind the coupling plane, per spindle interface:
#: the hollow taper shank l1 of DIN 69893-1 / ISO 12164-1 (HSK form A; forms C, E, F share
#: the shank of the same size). The coupling plane is the flange's face contact.
INTERFACE_SHANK_MM = {
    "HSK-A32": 16.0,
    "HSK-A40": 20.0,
    "HSK-A50": 25.0,
    "HSK-A63": 32.0,
    "HSK-A80": 40.0,
    "HSK-A100": 50.0,
    "HSK-A125": 63.0,
    "HSK-A160": 80.0,
}


def _interface_key(name: str) -> str | None:
    """``"HSK-A63"`` for spellings like ``HSK A63``, ``hsk-a 63``, ``HSK63A``, ``HSK-C63``."""
    s = re.sub(r"[\s_\-]", "", name.upper())
    m = re.fullmatch(r"HSK([ACEF])?(\d+)([ACEF])?", s)
    if not m or (m.group(1) and m.group(3)):
        return None
    return f"HSK-A{int(m.group(2))}"


def same_interface(a: str, b: str) -> bool:
    """Whether two interface names agree ignoring case, spaces and punctuation
    (the machine file's and the holder's; a mismatch is only warned about)."""
    def plain(name: str) -> str:
        return "".join(ch for ch in name.upper() if ch.isalnum())

    return plain(a) == plain(b)


def interface_warning(machine_interface: str, holder: Holder) -> str | None:
    """A warning when the machine's interface is not the holder's (:func:`same_interface`), else None."""
    if same_interface(machine_interface, holder.interface):
        return None
    return f"the machine's interface {machine_interface!r} differs from the holder's {holder.interface!r}"


def shank_length(interface: str) -> float | None:
    """Taper shank length of a known interface [m], or None."""
    key = _interface_key(interface)
    mm = INTERFACE_SHANK_MM.get(key) if key else None
    return None if mm is None else mm * MM


def coupling_plane(holder: Holder, source: str = "") -> float:
    """z of the coupling plane [m], measured from the holder's spindle-side end.

    Parameters
    ----------
    holder : Holder
        Validated holder (``gauge_length`` ≤ its length).
    source : str
        File name for messages.

    Raises
    ------
    InputError
        When the holder gives no ``gauge_length`` and its interface is not in
        :data:`INTERFACE_SHANK_MM`.
    """
    if holder.gauge_length is not None:
        return max(0.0, holder.length - holder.gauge_length)
    shank = shank_length(holder.interface)
    if shank is None:
        known = ", ".join(INTERFACE_SHANK_MM)
        raise InputError(
            f"{source or holder.name}: [holder] gauge_length is missing and interface {holder.interface!r} "
            f"has no known coupling plane (known: {known}); give gauge_length in mm (front face to the plane)"
        )
    if shank >= holder.length - TOL_M:
        raise InputError(
            f"{source or holder.name}: the {holder.interface} taper shank ({shank / MM:g} mm) is as long as the "
            f"holder ({holder.length / MM:g} mm): give [holder] gauge_length"
        )
    return shank


#: A stated gauge length that moves the plane farther than this from the interface's own
#: (the end of its taper shank) is questioned [m].
PLANE_MISMATCH_M = 2e-3


def plane_warning(holder: Holder, source: str = "") -> str | None:
    """A warning when ``gauge_length`` puts the coupling plane away from the end of the
    interface's taper shank, else None.

    On a holder whose segments include the taper, the two agree; a catalogue gauge length
    copied for segments that describe another (longer) body does not, and moves the plane
    without an error (e.g. to the holder's back end, inside the taper).
    """
    shank = shank_length(holder.interface)
    if holder.gauge_length is None or shank is None or shank >= holder.length - TOL_M:
        return None
    stated = max(0.0, holder.length - holder.gauge_length)
    if abs(stated - shank) <= PLANE_MISMATCH_M:
        return None
    return (f"{source or holder.name}: [holder] gauge_length = {holder.gauge_length / MM:g} mm puts the coupling "
            f"plane {stated / MM:g} mm from the holder's spindle-side end, but the {holder.interface} taper shank "
            f"ends at {shank / MM:g} mm (gauge length {(holder.length - shank) / MM:g} mm on these segments): "
            f"gauge_length is measured on the described segments, front face to the flange's face contact")


def cut_holder(holder: Holder, source: str = "") -> Holder:
    """The holder in front of the coupling plane, its z = 0 at the plane.

    A plane inside a segment splits it. ``clamp_length`` is capped at the cut length
    (the contact zone, measured from the front face, never reaches behind a tool's end
    that lies in front of the plane); ``gauge_length`` becomes the cut length.
    """
    z_cp = coupling_plane(holder, source)
    segs, z = [], 0.0
    for s in holder.segments:
        a, b = z, z + s.length
        z = b
        if b <= z_cp + TOL_M:
            continue
        segs.append(Segment(b - max(a, z_cp), s.od, s.id))
    length = sum(s.length for s in segs)
    return replace(holder, segments=tuple(segs), clamp_length=min(holder.clamp_length, length), gauge_length=length)


def cut_assembly(assembly: Assembly) -> Assembly:
    """The assembly with its holder cut at the coupling plane (docs/machine.md).

    Raises
    ------
    InputError
        When the tool reaches behind the coupling plane (it would be cut too).
    """
    src = assembly.source
    z_cp = coupling_plane(assembly.holder, src)
    if assembly.z_tool_start < z_cp - TOL_M:
        raise InputError(
            f"{src}: the tool reaches {(z_cp - assembly.z_tool_start) / MM:g} mm behind the coupling plane "
            f"({z_cp / MM:g} mm from the holder's spindle-side end): shorten the inserted length or check gauge_length"
        )
    return validate(replace(assembly, holder=cut_holder(assembly.holder, src), warnings=()))
