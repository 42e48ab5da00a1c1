"""The next speed to try after a cut, from the holder's stability lobes; and what a cut says of the lobes.

After a chatter (or to confirm a clean cut) the machinist wants a speed at which the
same depth is stable, near the present one, and not on a knife edge: the lobes'
boundary at the cut's depth leaves *windows* of speed where the limit is above the
depth by a margin; the speed suggested in each is its middle (a 1 % error of the
tool-point frequency moves a pocket by 1 % of its speed). Windows narrower than
:data:`MIN_WINDOW` of their speed come last. When no window lies in the speed range,
the depth to come down to is the best limit near the present speed, less the margin.

The chatter frequency heard is matched against the predicted tool-point modes: a
chatter far from every tool mode is a workpiece, fixture or spindle vibration that the
holder's data cannot help with.

Signatures::

    lobe_advice(rpm, a_lim, depth, rpm_now, *, margin=1.15, min_rpm=None, max_rpm=None, count=5) -> LobeAdvice
    match_mode(chatter_hz, modes) -> (FRFMode | None, bool)
    observation_warnings(observations, rpm, a_lim, a_safe=None) -> list[str]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The limit must stand this much above the cut's depth to call a speed stable.
MARGIN = 1.15
#: A window narrower than this fraction of its speed is a knife edge.
MIN_WINDOW = 0.05
#: A chatter frequency within this fraction (or the mode's half-power bandwidth, if wider) of a tool-point mode is that mode's.
MODE_TOLERANCE = 0.05
#: A chatter below the safe limit (with a band), or below CENTRAL_FRACTION × the central limit
#: (without one), is a chatter the lobes called safe; a clean cut above FAR_ABOVE × the central
#: limit, one they called chatter.
CENTRAL_FRACTION = 0.8
FAR_ABOVE = 1.5


@dataclass(frozen=True)
class LobeAdvice:
    """Speeds to try at the cut's depth, best first.

    Attributes
    ----------
    suggested_rpm : tuple of float
        Window middles, best first (or the best speed near the present one when there is no window).
    windows : tuple of (rpm_low, rpm_high, a_min [m])
        Speed windows where the limit is at least ``margin`` × depth, ordered as the suggestions.
    depth_to : float or None
        Depth [m] to come down to when no window lies in the range (None otherwise).
    limit_now : float
        The limit [m] at the present speed.
    """

    suggested_rpm: tuple
    windows: tuple
    depth_to: float | None
    limit_now: float

    def to_dict(self) -> dict:
        return {"suggested_rpm": [round(r) for r in self.suggested_rpm],
                "windows": [{"rpm_low": lo, "rpm_high": hi, "a_min_mm": a * 1e3} for lo, hi, a in self.windows],
                "depth_to_mm": None if self.depth_to is None else self.depth_to * 1e3,
                "a_lim_now_mm": self.limit_now * 1e3 if np.isfinite(self.limit_now) else None}


def lobe_advice(rpm, a_lim, depth: float, rpm_now: float, *, margin: float = MARGIN, min_rpm: float | None = None,
                max_rpm: float | None = None, count: int = 5) -> LobeAdvice:
    """Where the lobes allow ``depth`` [m] near ``rpm_now`` [rpm].

    Parameters
    ----------
    rpm, a_lim : array_like, shape (n,)
        The boundary (a safe one when there is: the depth stable with the wanted
        confidence) on an ascending speed grid [rpm], [m] (inf where no lobe reaches).
    depth : float
        The cut's axial depth [m].
    rpm_now : float
        The present speed [rpm].
    margin : float
        The limit must be ≥ margin × depth.
    min_rpm, max_rpm : float, optional
        The machine's speed range.
    """
    n = np.asarray(rpm, float)
    a = np.asarray(a_lim, float)
    keep = np.ones(len(n), bool)
    if min_rpm is not None:
        keep &= n >= min_rpm
    if max_rpm is not None:
        keep &= n <= max_rpm
    n, a = n[keep], a[keep]
    limit_now = float(np.interp(rpm_now, n, np.where(np.isfinite(a), a, 1e3))) if len(n) else float("nan")
    ok = a >= margin * depth
    edges = np.diff(np.concatenate([[0], ok.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    windows = []
    for s, e in zip(starts, ends):
        lo, hi = float(n[s]), float(n[e - 1])
        mid = 0.5 * (lo + hi)
        width = (hi - lo) / mid
        # Near first, knife edges last; a window at the end of the range is cut by the
        # range, not by a lobe, so its middle is not the safest point: keep the middle anyway.
        windows.append((width < MIN_WINDOW, abs(np.log(mid / rpm_now)), mid, (lo, hi, float(np.min(a[s:e])))))
    windows.sort(key=lambda w: (w[0], w[1]))
    if windows:
        return LobeAdvice(tuple(w[2] for w in windows[:count]), tuple(w[3] for w in windows[:count]), None, limit_now)
    # No window: the best limit within ±25 % of the present speed, and the depth to come down to.
    near = np.abs(np.log(n / rpm_now)) <= np.log(1.25)
    if not near.any():
        near = np.ones(len(n), bool)
    i = np.flatnonzero(near)[np.argmax(np.where(np.isfinite(a[near]), a[near], 0.0))]
    return LobeAdvice((float(n[i]),), (), float(a[i] / margin), limit_now)


def match_mode(chatter_hz: float, modes) -> tuple[object | None, bool]:
    """The tool-point mode nearest ``chatter_hz`` and whether the chatter is plausibly it.

    A chatter frequency lies a little above the natural frequency it grows on; within
    the larger of :data:`MODE_TOLERANCE` and the mode's half-power bandwidth 2ζf it is that mode's.
    """
    if not modes:
        return None, False
    m = min(modes, key=lambda m: abs(np.log(chatter_hz / m.hz)))
    tol = max(MODE_TOLERANCE * m.hz, 2 * m.damping_ratio * m.hz)
    return m, bool(abs(chatter_hz - m.hz) <= tol)


def limit_at(rpm, a_lim, speed: float) -> float:
    """The boundary [m] at ``speed`` [rpm] (linear between grid speeds; NaN outside the grid)."""
    n = np.asarray(rpm, float)
    a = np.asarray(a_lim, float)
    if not (n[0] <= speed <= n[-1]):
        return float("nan")
    return float(np.interp(speed, n, np.where(np.isfinite(a), a, 1e3)))


def observation_warnings(observations, rpm, a_lim, a_safe=None, confidence: float | None = None) -> list[str]:
    """Cuts that contradict the lobes: a chatter below the safe limit, a clean cut far above the central one.

    ``observations`` are :class:`taptune.library.observations.CutObservation`-like
    records (rpm, depth_mm, verdict); ``a_lim``/``a_safe`` [m] on the speed grid ``rpm``.
    """
    out = []
    safe = CENTRAL_FRACTION * np.asarray(a_lim, float) if a_safe is None else a_safe
    what = (f"stable with {100 * (1 - CENTRAL_FRACTION):.0f} % to spare" if a_safe is None or confidence is None
            else f"stable with {100 * confidence:.0f} % confidence")
    for o in observations:
        depth = o.depth_mm * 1e-3
        lim, lim_safe = limit_at(rpm, a_lim, o.rpm), limit_at(rpm, safe, o.rpm)
        if not np.isfinite(lim):
            continue
        if o.verdict == "chatter" and depth < lim_safe:
            out.append(f"chatter observed at {o.rpm:.0f} rpm and {o.depth_mm:g} mm where the lobes say {what} "
                       f"(up to {lim_safe * 1e3:.3g} mm): the model is off there")
        elif o.verdict == "stable" and depth > FAR_ABOVE * lim:
            out.append(f"a clean cut at {o.rpm:.0f} rpm and {o.depth_mm:g} mm, {depth / lim:.1f}× the predicted "
                       f"limit {lim * 1e3:.3g} mm: the model is off there")
    return out


#: Members of the chatter's family this close [dB] to its strongest line may be the tool's chatter.
FAMILY_DB = 10.0


@dataclass(frozen=True)
class CutAdvice:
    """What to do after a listened cut: speeds to try and why.

    Attributes
    ----------
    suggested_rpm : tuple of float
        Best first.
    basis : {"lobes", "rule"}
        From the holder's lobes at the cut's depth, or by the tooth-passing rule.
    lobes : LobeAdvice or None
    chatter_hz : float or None
        The chatter frequency the advice is for: with the lobes, the member of the
        chatter's family on a tool-point mode, when one is.
    tool_mode_hz : float or None
        The tool-point mode nearest the chatter.
    matches_tool : bool or None
        Whether the chatter is that mode's (None without a chatter or without modes).
    warnings : tuple of str
    """

    suggested_rpm: tuple
    basis: str
    lobes: LobeAdvice | None = None
    chatter_hz: float | None = None
    tool_mode_hz: float | None = None
    matches_tool: bool | None = None
    warnings: tuple = ()


def advise(analysis, *, min_rpm: float, max_rpm: float | None, depth: float | None = None, rpm=None, a_lim=None,
           modes=(), holder: str = "the holder") -> CutAdvice:
    """The next speeds after the cut ``analysis`` (a :class:`taptune.signal.cut.CutAnalysis`).

    Without lobes (``rpm``/``a_lim`` None): the Smith–Tlusty speeds of the chatter
    (none for a stable cut). With the holder's boundary ``a_lim`` [m] on the speed grid
    ``rpm`` (a safe boundary when there is one) and the cut's ``depth`` [m]: the windows
    of :func:`lobe_advice`, and the chatter matched against the tool-point ``modes``.
    """
    from taptune.signal.cut import smith_tlusty_speeds

    chatter = analysis.chatter_hz if analysis.verdict != "stable" else None
    if rpm is None or a_lim is None or depth is None:
        speeds = () if chatter is None else tuple(smith_tlusty_speeds(
            chatter, analysis.teeth, analysis.spindle_rpm, min_rpm=min_rpm, max_rpm=max_rpm))
        return CutAdvice(speeds, "rule", chatter_hz=chatter)
    warnings = []
    advice = lobe_advice(rpm, a_lim, depth, analysis.spindle_rpm, min_rpm=min_rpm, max_rpm=max_rpm)
    mode, matches = None, None
    if chatter is not None and modes:
        # The tooth passing aliases the chatter into f_c + k f_tp: a member of the family
        # within FAMILY_DB of the strongest line that lies on a tool-point mode is the tool's chatter.
        family = [f for f, db in zip(analysis.family_hz, analysis.family_level_db) if db >= -FAMILY_DB]
        for f in [chatter] + family:
            m, ok = match_mode(f, modes)
            if ok:
                mode, matches, chatter = m, True, f
                break
        else:
            mode, matches = match_mode(chatter, modes)
            warnings.append(f"the chatter at {chatter:.0f} Hz matches no tool-point mode of {holder} (nearest "
                            f"{mode.hz:.0f} Hz): likely the workpiece, the fixture or the spindle; the holder's "
                            "lobes cannot help with it")
    if advice.depth_to is not None:
        warnings.append(f"no speed within {max(min_rpm, float(rpm[0])):.0f}–{float(rpm[-1]):.0f} rpm is stable at "
                        f"{depth * 1e3:g} mm by the lobes: come down to {advice.depth_to * 1e3:.2g} mm at "
                        f"{advice.suggested_rpm[0]:.0f} rpm")
    return CutAdvice(advice.suggested_rpm, "lobes", advice, chatter, None if mode is None else mode.hz, matches,
                     tuple(warnings))
