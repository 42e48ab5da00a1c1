"""Labels the model decides: when the peak labels are ambiguous, fit each plausible labeling.

The signal layer ranks joint assignments of peaks to bending modes by how well the
model *guidance* (nominal or library parameters, linearised spreads) explains them
(:func:`taptune.signal.labels.ranked_labelings`). Far from the nominal holder — a
contact pressure that is not linear along the grip, parameters at an edge of the
published range, a roughly measured geometry — the linearised explanation can favour
leaving a mode out over taking a loud peak where the nominal model did not expect it.
So the few plausible labelings are each fitted, frequency only, on the fast reduced
model: a maximum-a-posteriori fit of the frequency-setting parameters (k_tt, k_rr, alpha,
holder density and modulus) with a prior spread per parameter and a model-form
tolerance per frequency. The labeling whose fit costs least (fit + missing modes +
band and weak-peak costs) wins, and the warnings say so when it was a close call or
overrode the guidance.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from taptune.model.params import NAMES, NOMINAL, P_LOWER, P_UPPER, to_p
from taptune.signal.analysis import FAINT_MARK, faint_warning
from taptune.signal.labels import (LabelOptions, Labeling, apply_labels, label_candidates,
                                   loud_peaks, missing_warnings, ranked_labelings)

#: Plausible spread of each frequency-setting holder parameter around the nominal
#: values (docs/physics.md §2): (name, step); k_tt and k_rr in decades, alpha in %, the
#: factors absolute. The published holders lie within about one spread. The labels'
#: guidance uses how far each bending mode moves per spread
#: (:func:`taptune.identify.pipeline.model_expectation`); the fit here, as its prior.
#: The loss intensities hardly move the frequencies and stay nominal.
PARAMETER_SPREAD = (("k_tt", 0.5), ("k_rr", 1.0), ("modulus_factor", 0.05),
                    ("density_factor", 0.03), ("alpha", 15.0))
#: The same as (index into p, spread), in the order of p.
PRIOR_SPREAD = tuple(sorted((NAMES.index(name), step) for name, step in PARAMETER_SPREAD))


@dataclass(frozen=True)
class LabelFitOptions:
    """How the plausible labelings are compared.

    sigma_model : float
        Relative frequency tolerance of the fit: holders outside the model family
        (contact pressure not linear along the grip, a nut the file leaves out) are off
        by about 1 % in ways the five parameters cannot absorb.
    faint_sigma_factor : float
        A faint peak (``Peak.reliability == "faint"``, found only by the guided search)
        weighs less in the fit: its tolerance is this many times ``sigma_model``, so a
        noise bump that happens to pass cannot pull the parameters far.
    sigma_level_db, radiation_exponent : float
        Tolerance of a mode's relative loudness and the sound's tilt f^p
        (:func:`level_cost`; radiation, microphone and tap force make ~±6 dB).
    keep : int
        Labelings taken from the guidance ranking (plus the best one using each loud
        peak the best left out).
    max_extra_cost : float
        Labelings costing this much more than the best under the guidance are not fitted.
    close : float
        Fit-score difference below which the choice is reported as a close call.
    explained_misfit, missed_misfit, dropped_misfit : float
        A labeling whose quick fit meets every peak within ``explained_misfit``
        (relative: the peaks' precision, plus the pull of the fit's prior) beats one that
        explains every loud peak but misses a peak by ``missed_misfit`` or more, when the
        fit prefers it: the loud peak it leaves out is then not a bending mode of this
        holder (an axial, table or fixture resonance). When it assigns fewer modes the
        miss must reach ``dropped_misfit``: holders outside the model family are fitted
        about 1 % off, and their loud true mode must not be dropped for that.
    dropped_misfit_max : float
        ... but not when the miss reaches this (the library's limit for storing a fit):
        a loud peak that far off says the assembly file more likely describes another
        holder or tool than the peak is a resonance of the table; the loud labeling stays
        and the fit is refused as poor, naming the miss and the file (a hydraulic chuck's
        tap identified with an ER32 file kept mode 1 alone, 10.5 % off with modes 2 and 3,
        and was stored without a word otherwise).
    """

    sigma_model: float = 0.01
    faint_sigma_factor: float = 2.0
    sigma_level_db: float = 6.0
    radiation_exponent: float = 1.75
    keep: int = 4
    max_extra_cost: float = 8.0
    close: float = 1.0
    explained_misfit: float = 0.003
    missed_misfit: float = 0.01
    dropped_misfit: float = 0.03
    dropped_misfit_max: float = 0.05


@dataclass(frozen=True)
class LabelChoice:
    """The fitted score of one labeling (lower is better)."""

    labeling: Labeling
    score: float
    model_hz: tuple[float, ...]
    misfit: float = 0.0  # largest relative miss of the fitted model on the assigned peaks

    @property
    def assigned(self) -> int:
        return sum(i is not None for i in self.labeling.modes)


class RememberedEvaluator:
    """An evaluator that solves each (parameter vector, window) once.

    The quick fits of the plausible labelings all start from the same points (the
    nominal holder, a soft and a stiff contact) with the same finite-difference steps,
    and each fit's optimum is evaluated again for its model frequencies and its levels:
    the same candidates, solved once. The evaluation is a pure function of p and the
    window, so a remembered one is the very result a new solve would give.

    Parameters
    ----------
    evaluator : FastEvaluator-like
        ``evaluate(p, window_hz)``.
    """

    def __init__(self, evaluator):
        self.evaluator = evaluator
        self._seen = {}

    def evaluate(self, p, window_hz):
        """``evaluator.evaluate(p, window_hz)``, solved only the first time."""
        p = np.asarray(p, dtype=float)
        window_hz = np.asarray(window_hz, dtype=float)
        key = (p.tobytes(), window_hz.tobytes())
        found = self._seen.get(key)
        if found is None:
            found = self._seen[key] = self.evaluator.evaluate(p, window_hz)
        return found

    def evaluate_many(self, P, window_hz):
        """``evaluator.evaluate_many(P, window_hz)``, solved only the first time (a batch is
        remembered whole: the finite-difference batches at the common starts recur)."""
        P = np.asarray(P, dtype=float)
        window_hz = np.asarray(window_hz, dtype=float)
        key = ("many", P.shape, P.tobytes(), window_hz.tobytes())
        found = self._seen.get(key)
        if found is None:
            found = self._seen[key] = self.evaluator.evaluate_many(P, window_hz)
        return found


def quick_fit(evaluator, measured: dict[int, float], sigma=0.01) -> tuple[float, np.ndarray, np.ndarray]:
    """MAP fit of the frequency-setting parameters to measured bending frequencies.

    Parameters
    ----------
    evaluator : FastEvaluator-like
        ``evaluate(p, window_hz).bending_hz`` gives f1–f3 [Hz].
    measured : dict
        {mode (1-based): frequency [Hz]}.
    sigma : float or dict
        Relative frequency tolerance, or {mode: tolerance} (faint peaks weigh less).

    Returns
    -------
    cost : float
        Σ((f_model/f_meas − 1)/σ)² + Σ((p − p_nominal)/spread)² at the optimum.
    model_hz : ndarray, shape (3,)
        The fitted model's f1–f3 [Hz].
    p : ndarray, shape (7,)
        The fitted parameter vector.
    """
    from scipy.optimize import least_squares

    p0 = to_p(NOMINAL)
    idx = np.array([i for i, _ in PRIOR_SPREAD])
    scale = np.array([s for _, s in PRIOR_SPREAD])
    modes = np.array(sorted(measured)) - 1
    f_meas = np.array([measured[m + 1] for m in modes])
    sig = np.array([sigma[m + 1] if isinstance(sigma, dict) else sigma for m in modes], dtype=float)
    window = np.array([1000.0])

    def p_of(x):
        p = p0.copy()
        p[idx] = p0[idx] + x * scale
        return p

    def residuals_of(f, x):
        return np.concatenate([(np.asarray(f, dtype=float)[..., modes] / f_meas - 1) / sig, x], axis=-1)

    seen = {}

    def residuals(x):
        r = residuals_of(evaluator.evaluate(p_of(x), window).bending_hz, x)
        seen.clear()
        seen[x.tobytes()] = r
        return r

    lo = (P_LOWER[idx] - p0[idx]) / scale
    hi = (P_UPPER[idx] - p0[idx]) / scale
    diff_step = 1e-3

    def jacobian(x):
        # least_squares' own '2-point' differences (scipy.optimize._numdiff: the relative
        # step, √eps·max(1, |x|) where it vanishes, turned back where it leaves the bounds),
        # with the moved candidates solved in one batch instead of one by one.
        r0 = seen.get(x.tobytes())
        if r0 is None:
            r0 = residuals(x)
        sign = np.where(x >= 0, 1.0, -1.0)
        h = diff_step * sign * np.abs(x)
        h = np.where((x + h) - x == 0, np.sqrt(np.finfo(float).eps) * sign * np.maximum(1.0, np.abs(x)), h)
        h = np.where(((x + h < lo) | (x + h > hi)) & (np.abs(h) <= np.maximum(x - lo, hi - x)), -h, h)
        X = x + np.diag(h)
        h = np.diag(X) - x
        batch = evaluator.evaluate_many(np.array([p_of(row) for row in X]), window).bending_hz
        return ((residuals_of(batch, X) - r0) / h[:, None]).T

    jac = jacobian if hasattr(evaluator, "evaluate_many") else "2-point"
    best = None
    # Nominal, a soft and a stiff contact: the frequencies saturate in the contact
    # stiffness, so one start can stall on a plateau.
    for start in (0.0, -1.0, 1.0):
        x0 = np.clip(np.full(idx.size, 0.0) + np.where(idx < 2, start, 0.0), lo + 1e-6, hi - 1e-6)
        try:
            r = least_squares(residuals, x0, jac=jac, bounds=(lo, hi), x_scale=1.0, diff_step=diff_step, max_nfev=60)
        except (ValueError, np.linalg.LinAlgError):
            continue
        cost = float(r.fun @ r.fun)
        if best is None or cost < best[0]:
            best = (cost, r.x)
    if best is None:
        return np.inf, np.full(3, np.nan), p0
    f = np.asarray(evaluator.evaluate(p_of(best[1]), window).bending_hz, dtype=float)
    return best[0], f, p_of(best[1])


def level_cost(evaluator, p, peaks_by_mode: dict, options: "LabelFitOptions") -> float:
    """How well the fitted model explains the peaks' relative loudness.

    A mode's peak in the tip receptance is |φ_tip|²/(ω²·2ζ); the sound tilts it by about
    f^radiation_exponent, and the peak's own decay (the measured ζ, when the pole fit gave
    one) replaces the model's damping, which the frequency-only fit does not know. The
    levels are compared up to a common offset (unknown tap force and microphone gain):
    Σ((ΔL_measured − ΔL_model)/σ_level)² over the assigned modes, mean removed.
    """
    modes = sorted(peaks_by_mode)
    if len(modes) < 2:
        return 0.0
    e = evaluator.evaluate(p, np.array([1000.0]))
    f_model = np.asarray(e.bending_hz, dtype=float)
    h = np.abs(np.asarray(evaluator.evaluate(p, f_model).tip_receptance))
    resid = []
    for m in modes:
        pk = peaks_by_mode[m]
        zeta_model = float(e.damping_ratio[m - 1])
        # A pole fit of a faint or crowded peak can return an absurd decay: the measured
        # damping may correct the model's by at most a factor 3 either way.
        zeta = pk.damping_ratio if pk.damping_ratio and pk.damping_ratio > 0 else zeta_model
        ratio = float(np.clip(zeta_model / zeta, 1 / 3, 3))
        model_db = 20 * np.log10(h[m - 1] * ratio * f_model[m - 1] ** options.radiation_exponent)
        resid.append(pk.level_db - model_db)
    r = np.asarray(resid) - np.mean(resid)
    return float(np.sum((r / options.sigma_level_db) ** 2))


def labelled_modes(peaks, n: int) -> list:
    """Index of the peak labelled bending mode 1..n (None where no peak is)."""
    return [next((i for i, p in enumerate(peaks) if p.kind == "bending" and p.mode == m + 1), None)
            for m in range(n)]


def _describe(lab: Labeling, peaks) -> str:
    parts = [f"mode {m + 1} = {peaks[i].hz:.0f} Hz" if i is not None else f"mode {m + 1} unassigned"
             for m, i in enumerate(lab.modes)]
    return ", ".join(parts)


def choose_labeling(analysis, evaluator_of, guidance, bands=(), label_options: LabelOptions = LabelOptions(),
                    options: LabelFitOptions = LabelFitOptions()):
    """Re-decide an analysis' bending labels by fitting each plausible labeling.

    Parameters
    ----------
    analysis : SpectrumAnalysis
        Labelled by the guidance.
    evaluator_of : callable
        ``evaluator_of()`` returns the assembly's fast evaluator (built only when needed).
    guidance : (expected, bounds, spread)
        :func:`taptune.identify.pipeline.model_expectation`.
    bands : sequence of (lo, hi)
        The interface bands used for the labels.

    Returns
    -------
    modes : list of (int or None) or None
        Peak index per mode of the chosen labeling; None when there was nothing to decide.
    warnings : list of str
    """
    expected, bounds, spread = guidance
    peaks = analysis.peaks
    stat, grown = label_candidates(peaks)
    cand = [not s and not g for s, g in zip(stat, grown)]
    current = tuple(labelled_modes(peaks, len(expected)))
    ranked = ranked_labelings(peaks, expected, bounds, bands, candidates=cand, spread_hz=spread,
                              options=label_options, keep=options.keep)
    # Loud peaks inside the interface bands too (no bands given): the fit judges them.
    loud = [i for i, is_loud in enumerate(loud_peaks(peaks, cand, (), label_options)) if is_loud]
    extra = ranked_labelings(peaks, expected, bounds, bands, candidates=cand, spread_hz=spread,
                             options=label_options, keep=1, must_try=loud)[1:]
    if not ranked:
        return None, []
    best_cost = ranked[0].cost
    pool = [lab for lab in ranked if lab.cost - best_cost <= options.max_extra_cost]
    pool += [lab for lab in extra if lab.modes not in {q.modes for q in pool}]
    # A fit always improves when a mode is left out; it may add or swap peaks, never
    # drop one the guidance took.
    n_current = sum(i is not None for i in current)
    pool = [lab for lab in pool if sum(i is not None for i in lab.modes) >= n_current]
    if len(pool) < 2:
        return None, []
    evaluator = RememberedEvaluator(evaluator_of())
    choices = []
    for lab in pool:
        chosen = {m + 1: peaks[i] for m, i in enumerate(lab.modes) if i is not None}
        if not chosen:
            # Nothing to fit: the parameters stay at the prior's centre (fit cost 0), so
            # leaving every mode out costs its missing modes. Skipping it would hand a
            # tap that rings only the interface to the one labeling that takes its peaks.
            choices.append(LabelChoice(lab, lab.label_cost, tuple(map(float, expected))))
            continue
        sigma = {m: options.sigma_model * (options.faint_sigma_factor if pk.reliability == "faint" else 1.0)
                 for m, pk in chosen.items()}
        fit, model_hz, p = quick_fit(evaluator, {m: pk.hz for m, pk in chosen.items()}, sigma)
        score = fit + level_cost(evaluator, p, chosen, options) + lab.label_cost
        misfit = max(abs(model_hz[m - 1] / pk.hz - 1) for m, pk in chosen.items())
        choices.append(LabelChoice(lab, score, tuple(map(float, model_hz)), float(misfit)))
    choices.sort(key=lambda c: c.score)
    # A prominent peak outside the interface bands, where a mode is missing, is not
    # dropped because the nominal guidance expected the mode elsewhere (docs/physics.md §4):
    # when some plausible labeling explains every such peak, the choice is among those.
    allowed = [c for c in choices if c.labeling.unexplained == 0] or choices
    best = allowed[0]
    warnings = []
    name = analysis.file or "recording"
    # ... unless taking it leaves the fitted model percent off while a labeling the fit
    # prefers is explained within the peaks' precision: then the loud peak is not a
    # bending mode of this holder (a holder the model describes exactly, its mode 3 beside
    # a louder axial mode, was fitted 2-3 % off; another, tapped again 10 mm out, took a
    # table resonance and an interface mode for modes 2 and 3, 22 % off).
    explained = [c for c in choices if c.misfit <= options.explained_misfit and c.score < best.score and c.assigned
                 and (options.missed_misfit <= best.misfit if c.assigned >= best.assigned
                      else options.dropped_misfit <= best.misfit < options.dropped_misfit_max)]
    if explained:
        loud = [f"{peaks[i].hz:.0f} Hz" for i in best.labeling.modes
                if i is not None and i not in explained[0].labeling.modes]
        what, it = ("peak at", "it") if len(loud) == 1 else ("peaks at", "them")
        said = (f"the prominent {what} {', '.join(loud)} left as other, not bending" if loud
                else f"labels were ambiguous: chose {_describe(explained[0].labeling, peaks)}")
        warnings.append(
            f"{name}: {said}: the fitted model explains {_describe(explained[0].labeling, peaks)} within "
            f"{100 * explained[0].misfit:.2f} % and would miss by {100 * best.misfit:.1f} % with "
            f"{it if loud else _describe(best.labeling, peaks)} (an axial, table or fixture resonance? if a bending "
            f"mode, check the assembly dimensions)")
        best = explained[0]
    others = [c for c in choices if c is not best]
    runner = others[0] if others else None
    overrode = best.labeling.modes != current
    if warnings:
        pass  # the choice is said above
    elif runner is not None and runner.score < best.score:
        kept = [peaks[i] for i in best.labeling.modes if i is not None and i not in runner.labeling.modes]
        warnings.append(
            f"{name}: labels were ambiguous: chose {_describe(best.labeling, peaks)}: a prominent peak "
            f"({', '.join(f'{q.hz:.0f} Hz' for q in kept) or 'loud'}) is not left unexplained, although the "
            f"fitted model alone prefers {_describe(runner.labeling, peaks)} (check the assembly dimensions)")
    elif runner is not None and (overrode or runner.score - best.score < options.close):
        better = 100 * (1 - best.score / runner.score) if runner.score > 0 else 0.0
        warnings.append(
            f"{name}: labels were ambiguous: chose {_describe(best.labeling, peaks)} "
            f"(the fitted model explains it {better:.0f} % better than {_describe(runner.labeling, peaks)})")
    return list(best.labeling.modes), warnings


def relabelled(analysis, modes, warnings, bands=(), refine=None):
    """``analysis`` with the bending labels ``modes`` and the choice's warnings.

    ``refine(peaks, new_bending) -> peaks`` re-measures peaks that became bending with
    the full pole-fit effort (they were refined only roughly as non-bending peaks).
    """
    peaks = analysis.peaks
    stat, grown = label_candidates(peaks)
    old = {i for i, p in enumerate(peaks) if p.kind == "bending"}
    old_modes = labelled_modes(peaks, len(modes))
    out = apply_labels(peaks, modes, bands, stationary=stat, grown=grown, source="fit")
    # Faint peaks were refined fully by the analysis (and the picking the refinement
    # redoes does not hold them).
    new = [i for i in modes if i is not None and i not in old and peaks[i].reliability != "faint"]
    if new and refine is not None:
        out = refine(out, new)
    # The old labels' missing-mode warning, exactly as the labels wrote it, gives way to the new one's.
    stale = set(missing_warnings(old_modes, len(modes)))
    kept = [w for w in analysis.warnings if w not in stale and FAINT_MARK not in w]
    faint = faint_warning(getattr(analysis, "file", "") or "<recording>",
                          [p for p in out if p.kind == "bending" and p.reliability == "faint"])
    return replace(analysis, peaks=out, warnings=kept + missing_warnings(modes, len(modes))
                   + ([faint] if faint else []) + list(warnings))
