"""Verify a holder by one tap: does a new recording agree with the library's prediction?

A holder identified once predicts every tool and stick-out within an honest band (its
near-optimal parameter sets, the geometry tolerances and the model form,
:func:`~taptune.identify.core.predict`). A new tap of
the same holder must land inside that band; a worn, dirty or badly seated collet has a
softer contact, and every bending mode drops. :func:`check_tap` compares the measured
bending peaks with the prediction mode by mode and gives one of three verdicts.

The rules, per mode n with measured f_m, predicted f_p, band ±b and measurement
uncertainty σ = max(tap-to-tap scatter of the peak, 0.05 % of f_m). The band is the
prediction's own ``bending_hz_spread`` (:mod:`taptune.identify.bands`): the
near-optimal parameter sets, the stated geometry tolerances — the stick-out read off a
ruler at this tap and at the identification among them — and the calibrated model-form
term that grows with the stick-out change. Nothing is added to it but σ, the one thing
it does not contain (how well this tap's peaks are measured):

* the deviation d = f_m − f_p; ``z`` = sign(d)·max(|d| − b, 0)/σ counts the
  measurement's standard deviations *beyond* the band (0 inside it);
* **differs** when a mode is clearly outside (|z| > 3), or when two or more modes lie
  beyond their bands in the same direction (a softer contact lowers them all);
* **consistent** when at least one mode was measured, none lies beyond its band, and the
  check could have seen a worn holder: for some measured mode, halving the contact
  stiffnesses would move the prediction by more than b + 3σ (``worn_hz``);
* **inconclusive** otherwise: no bending peak measured (or only above what the
  recording carries), a single mode just beyond its band (0 < |z| ≤ 3), modes beyond
  in opposite directions, or bands so wide that a worn holder would still read inside.

The verdict therefore depends on the band: a band twice as wide needs twice the shift to
read ``differs``, and a band wider than the worn-holder shift turns ``consistent`` into
``inconclusive`` rather than pretending the holder is fine.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The measured peaks are known to 0.05 % at best (MODEL.md §8.3), whatever their scatter.
MEASUREMENT_FLOOR = 5e-4
#: |z| above this: clearly outside the band.
Z_OUTSIDE = 3.0
#: Modes closer than this (relative) below the recording's bandwidth are not trusted
#: (a codec's transition band bends their peaks; signal.bandwidth.EDGE_MARGIN).
EDGE_MARGIN = 0.03

VERDICTS = ("consistent", "differs", "inconclusive")


@dataclass(frozen=True)
class ModeCheck:
    """One bending mode of a check (frequencies in Hz).

    ``status``: ``"inside"`` the band, ``"beyond"`` it by up to 3σ, ``"outside"`` (more),
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
        holder would sound like. Without it the check cannot tell whether it could
        have seen wear, and never says more than the band allows.
    measurement_floor : float
        Smallest relative 1σ of a measured peak.
    z_outside : float
        Standard deviations beyond the band that are "clearly outside".

    Returns
    -------
    CheckResult
        Verdict per the module's rules.
    """
    peaks = {p.mode: p for p in analysis.bending_peaks if p.mode is not None}
    bandwidth = getattr(analysis, "bandwidth_hz", None)
    worn = None if worn_hz is None else np.asarray(worn_hz, dtype=float)
    modes, reasons, sensitive = [], [], []
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
        z = float(np.sign(d) * max(abs(d) - band, 0.0) / sigma)
        status = "inside" if z == 0 else ("outside" if abs(z) > z_outside else "beyond")
        modes.append(ModeCheck(n, fm, fp, band, sigma, 100 * (fm / fp - 1), z, status))
        if worn is not None and n <= worn.size:
            sensitive.append(abs(worn[n - 1] - fp) > band + z_outside * sigma)
    verdict = _verdict(modes, sensitive, worn is not None, reasons)
    return CheckResult(verdict, tuple(modes), tuple(reasons))


def _verdict(modes: list[ModeCheck], sensitive: list[bool], knows_wear: bool, reasons: list[str]) -> str:
    used = [m for m in modes if m.z is not None]
    if not used:
        reasons.append("no bending mode of the prediction was measured: tap again (closer microphone, harder tap)")
        return "inconclusive"
    outside = [m for m in used if m.status == "outside"]
    beyond = [m for m in used if m.status != "inside"]
    lower = [m for m in beyond if m.z < 0]
    higher = [m for m in beyond if m.z > 0]
    if outside or len(lower) >= 2 or len(higher) >= 2:
        if outside:
            reasons += [f"mode {m.mode} is {abs(m.z):.1f} σ {'below' if m.z < 0 else 'above'} its band" for m in outside]
        else:
            side = lower if len(lower) >= 2 else higher
            reasons.append(f"modes {', '.join(str(m.mode) for m in side)} all lie "
                           f"{'below' if side is lower else 'above'} their bands")
        if not lower:
            # A softer contact lowers every mode: higher ones point at the description.
            reasons.append("higher than predicted, which wear does not do: check the stick-out and the tool in the "
                           "assembly file")
        return "differs"
    if beyond:
        reasons += [f"mode {m.mode} lies just beyond its band ({abs(m.z):.1f} σ): borderline" for m in beyond]
        return "inconclusive"
    if knows_wear and not any(sensitive):
        reasons.append("every measured mode's band is wider than the shift of a contact worn to half its stiffness: "
                       "inside the band, yet a worn holder would be too")
        return "inconclusive"
    if not knows_wear:
        reasons.append("inside the bands (the sensitivity to wear was not assessed)")
    if len(used) == 1:
        reasons.append(f"only mode {used[0].mode} was measured")
    return "consistent"
