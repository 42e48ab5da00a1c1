"""Verify a holder by one tap: does a new recording agree with the library's prediction?

A holder identified once predicts every tool and stick-out within an honest band (its
near-optimal parameter sets, the geometry tolerances and the model form,
:func:`~taptune.identify.core.predict`). A new tap of
the same holder must land inside that band; a worn, dirty or badly seated collet has a
softer contact, and every bending mode drops. :func:`check_tap` compares the measured
bending peaks with the prediction mode by mode and gives one of three verdicts.

The rules, per mode n with measured f_m, predicted f_p and band ±b. The band is the
prediction's own ``bending_hz_spread`` (:mod:`taptune.identify.bands`): the
near-optimal parameter sets, the stated geometry tolerances — the stick-out read off a
ruler at this tap and at the identification among them — and the calibrated model-form
term that grows with the stick-out change. It holds the truth in 90 % of predictions
(``bands.COVERAGE``), so it is read as ±1.645 standard deviations of the prediction's
error, s_p = b/1.645. Nothing is added to it but the one thing it does not contain, the
measurement uncertainty of this tap's peak σ = max(tap-to-tap scatter, 0.05 % of f_m):

* ``z`` = (f_m − f_p)/s with s = √(s_p² + σ²): the deviation in standard deviations;
* **inside** |z| ≤ 1.645 (the band, widened by σ), **beyond** up to 3, **outside** above
  3 (about twice the band: one good mode in several hundred);
* **differs** when a mode is outside. Modes merely beyond their bands, even several in
  the same direction, are not enough: a stick-out read 0.5 mm off moves every mode the
  same way a softer contact does, so they are one piece of evidence, not several;
* **consistent** when at least one mode was measured, all are inside, and the tap
  rules out a worn holder: for some measured mode it lies outside the same band around
  the prediction with the contact stiffnesses halved (|f_m − f_worn| > 1.645 s;
  ``worn_hz``, the smallest such shift over the near-optimal parameter sets), and that
  worn prediction lies outside the good holder's band (|f_pred − f_worn| > 1.645 s);
* **inconclusive** otherwise: no bending peak measured (or only above what the
  recording carries), a mode beyond its band but not outside, or a tap inside both the
  good holder's band and the worn holder's.

A mode measured inside the spindle interface's local-mode band (``excluded_bands_hz`` of
the analysis: known only as a band, not marked by a tap on the interface) may be an
interface mode or the bending mode beside it — the sound cannot tell them apart — so it
decides nothing on its own: outside its band it makes the check ``inconclusive``, not
``differs``, and it cannot be the mode that rules out wear.

The verdict therefore depends on the band: a band twice as wide needs twice the shift to
read ``differs``, and a band too wide to tell the good holder from a worn one turns
``consistent`` into ``inconclusive`` rather than pretending the holder is fine.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Modes closer than EDGE_MARGIN (relative) below the recording's bandwidth are not
# trusted: a codec's transition band bends their peaks (the analysis' own rule).
from taptune.signal.bandwidth import EDGE_MARGIN

#: The measured peaks are known to 0.05 % at best (the fit's floor, docs/physics.md §5), whatever their scatter.
MEASUREMENT_FLOOR = 5e-4
#: The band's half-width in standard deviations of the prediction error: it holds the
#: truth in 90 % of predictions (bands.COVERAGE), the two-sided normal 90 % point.
Z_BAND = 1.645
#: |z| above this: clearly outside (about twice the band when σ is small).
Z_OUTSIDE = 3.0

VERDICTS = ("consistent", "differs", "inconclusive")


@dataclass(frozen=True)
class ModeCheck:
    """One bending mode of a check (frequencies in Hz).

    ``z``: the deviation in standard deviations (band and measurement); ``status``:
    ``"inside"`` the band, ``"beyond"`` it (|z| up to 3), ``"outside"`` (more),
    ``"not measured"``, or ``"hidden"`` (measured above what the recording carries).
    """

    mode: int
    measured_hz: float | None
    predicted_hz: float
    band_hz: float  # the prediction's ± half-width
    sigma_hz: float | None
    deviation_pct: float | None
    z: float | None
    status: str

    def to_dict(self) -> dict:
        def r(v, nd):
            return None if v is None else round(float(v), nd)

        return {"mode": self.mode, "measured_hz": r(self.measured_hz, 2), "predicted_hz": r(self.predicted_hz, 2),
                "band_hz": r(self.band_hz, 2), "sigma_hz": r(self.sigma_hz, 3),
                "deviation_pct": r(self.deviation_pct, 4), "z": r(self.z, 2), "status": self.status}


@dataclass(frozen=True)
class CheckResult:
    """Verdict of :func:`check_tap` with the per-mode comparison and the reasons in words."""

    verdict: str
    modes: tuple[ModeCheck, ...]
    reasons: tuple[str, ...]

    @property
    def measured(self) -> list[ModeCheck]:
        """Modes that entered the verdict."""
        return [m for m in self.modes if m.z is not None]

    def to_dict(self) -> dict:
        return {"verdict": self.verdict, "modes": [m.to_dict() for m in self.modes], "reasons": list(self.reasons)}


def check_tap(analysis, prediction, worn_hz=None, measurement_floor: float = MEASUREMENT_FLOOR,
              z_outside: float = Z_OUTSIDE) -> CheckResult:
    """Compare the bending peaks of a new tap with a holder's prediction for that assembly.

    Parameters
    ----------
    analysis : SpectrumAnalysis
        The new tap, labelled with the model's guidance (library parameters).
    prediction : Prediction
        The holder's prediction for the tap's assembly (values and ± bands [Hz]).
    worn_hz : array_like, optional
        The same prediction with both contact stiffnesses halved [Hz]: what a worn
        holder would sound like (:func:`taptune.library.checks.worn_prediction_hz`
        takes the smallest shift over the near-optimal parameter sets). Without it the
        check cannot tell whether the tap rules out wear, and never says more than the
        band allows.
    measurement_floor : float
        Smallest relative 1σ of a measured peak.
    z_outside : float
        |z| (standard deviations of band and measurement) that is "clearly outside".

    Returns
    -------
    CheckResult
        Verdict per the module's rules.
    """
    peaks = {p.mode: p for p in analysis.bending_peaks if p.mode is not None}
    bandwidth = getattr(analysis, "bandwidth_hz", None)
    interface = tuple(getattr(analysis, "excluded_bands_hz", None) or ())
    worn = None if worn_hz is None else np.asarray(worn_hz, dtype=float)
    modes, reasons, sensitive, ambiguous = [], [], [], set()
    for n, (fp, spread) in enumerate(zip(prediction.bending_hz, prediction.bending_hz_spread), 1):
        band = float(spread)
        peak = peaks.get(n)
        if peak is None:
            modes.append(ModeCheck(n, None, fp, band, None, None, None, "not measured"))
            continue
        fm = float(peak.hz)
        if bandwidth is not None and max(fm, fp) > (1 - EDGE_MARGIN) * bandwidth:
            modes.append(ModeCheck(n, fm, fp, band, None, 100 * (fm / fp - 1), None, "hidden"))
            reasons.append(f"mode {n} lies at or above the {bandwidth / 1000:.1f} kHz the recording carries: not used")
            continue
        sigma = max(float(peak.scatter_hz), measurement_floor * fm)
        d = fm - fp
        s = float(np.hypot(band / Z_BAND, sigma))
        z = d / s
        status = "inside" if abs(z) <= Z_BAND else ("outside" if abs(z) > z_outside else "beyond")
        modes.append(ModeCheck(n, fm, fp, band, sigma, 100 * (fm / fp - 1), z, status))
        if any(lo <= fm <= hi for lo, hi in interface):
            ambiguous.add(n)
            continue
        if worn is not None and n <= worn.size:
            # The worn holder's prediction carries the same band: the tap rules it out
            # when it lies outside that band too, and wear moves the mode out of the good
            # holder's band. Otherwise the model's own error (the same for the good and
            # the worn prediction) can put a worn holder's tap on the far side of the worn
            # band (realism check pair iche001: a 3 % wear shift in a ±4 % band read
            # consistent).
            sensitive.append(abs(fm - worn[n - 1]) > Z_BAND * s and abs(fp - worn[n - 1]) > Z_BAND * s)
    verdict = _verdict(modes, sensitive, worn is not None, reasons, ambiguous)
    return CheckResult(verdict, tuple(modes), tuple(reasons))


def _verdict(modes: list[ModeCheck], sensitive: list[bool], knows_wear: bool, reasons: list[str],
             ambiguous=frozenset()) -> str:
    used = [m for m in modes if m.z is not None]
    if not used:
        reasons.append("no bending mode of the prediction was measured: tap again (closer microphone, harder tap)")
        return "inconclusive"
    unsure = [m for m in used if m.mode in ambiguous and m.status != "inside"]
    if unsure and all(m.mode in ambiguous for m in used if m.status == "outside"):
        reasons += [f"mode {m.mode} ({m.measured_hz:.0f} Hz) is {abs(m.z):.1f} σ {'below' if m.z < 0 else 'above'} "
                    f"its prediction, but it lies among the spindle interface's own modes, which the sound cannot "
                    f"tell from a bending mode: tap the interface too, or check at another stick-out" for m in unsure]
        return "inconclusive"
    outside = [m for m in used if m.status == "outside"]
    beyond = [m for m in used if m.status == "beyond"]
    if outside:
        reasons += [f"mode {m.mode} is {abs(m.z):.1f} σ {'below' if m.z < 0 else 'above'} its prediction, "
                    f"outside its band" for m in outside]
        if all(m.z > 0 for m in outside):
            # A softer contact lowers every mode: higher ones point at the description.
            reasons.append("higher than predicted, which wear does not do: check the stick-out and the tool in the "
                           "assembly file")
        return "differs"
    if beyond:
        reasons += [f"mode {m.mode} lies beyond its band ({abs(m.z):.1f} σ {'below' if m.z < 0 else 'above'}), "
                    f"not clearly outside: borderline" for m in beyond]
        if len(beyond) > 1:
            reasons.append("a stick-out read slightly off moves every mode the same way: tap again, or measure "
                           "the stick-out more carefully")
        return "inconclusive"
    if knows_wear and not any(sensitive):
        reasons.append("inside the bands, but a contact worn to half its stiffness could sound like this too: the "
                       "bands are too wide to tell (a stick-out measured more closely, stated as "
                       "[setup] stickout_tolerance, or a holder identified at two stick-outs narrows them)")
        return "inconclusive"
    if not knows_wear:
        reasons.append("inside the bands (the sensitivity to wear was not assessed)")
    if len(used) == 1:
        reasons.append(f"only mode {used[0].mode} was measured")
    return "consistent"
