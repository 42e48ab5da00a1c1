"""Identify a holder from tap recordings, and predict it with other tools and stick-outs.

The scikit-learn-like contract of taptune::

    result = identify(analyses, assemblies, IdentifyOptions(seed=0))   # fit
    predictions = predict(result.param_sets, assembly.with_stickout(0.0635))

``identify`` runs several independent genetic-algorithm "islands" (seeded from one
master seed, in parallel processes when allowed), polishes each best by least squares (Gauss–Newton), and
keeps every candidate whose objective is close to the best: the parameters of this
model are not all identifiable from three frequencies and one peak shape (docs/physics.md §5),
but the predictions are, and their spread over the near-optimal set is the honest
uncertainty that ``predict`` reports.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, is_dataclass, replace
from typing import Callable, Sequence

import numpy as np

from taptune.errors import InputError
from taptune.io.assembly import Tolerances
from taptune.identify.objective import Objective, ObjectiveOptions, Target, make_target, model_shape, objective_terms
from taptune.identify import bands
from taptune.identify.bands import Band
from taptune.identify.optimize import Cancelled, GAOptions
from taptune.model.params import NAMES, HolderParams, from_p, p_to_unit, to_p, unit_to_p

ProgressCallback = Callable[[float, str], "bool | None"]


@dataclass(frozen=True)
class IdentifyOptions:
    """How to identify. ``seed`` fixes the result; ``jobs`` only changes the speed."""

    seed: int = 0
    islands: int = 2  # independent GA runs, each polished; their union is the archive
    jobs: int | None = None  # processes; None = min(islands, CPU count)
    ga: GAOptions = GAOptions()
    polish_evaluations: int = 120  # least-squares polish: ≈ 8 Jacobians (beat BOBYQA's 250)
    polish_starts: int = 4  # polishes from diverse good points (island bests first)
    polish_band: float = 2.0  # archive points this far above J_min may start a polish
    objective: ObjectiveOptions = ObjectiveOptions()
    model: object | None = None  # taptune.model.ModelOptions; None = defaults
    # Near-optimal set (the uncertainty, docs/physics.md §5), term by term against the best fit:
    # the frequency term may exceed the best's by near_frequency per measured mode (≈ the
    # 0.05 % the peaks are measured to); the shape term, dominated by the systematic
    # difference between the sound and the tip receptance (radiation, microphone), may
    # reach near_shape_factor × the best's + near_shape_abs.
    near_frequency: float = 0.01
    near_shape_factor: float = 3.0
    near_shape_abs: float = 0.02
    near_candidates: int = 300  # archive points checked term by term (their terms are remembered)
    # The set's extent: each parameter pushed low and high inside it (a long valley runs
    # far beyond what the optimisers' archives visit). Each push starts from the member
    # already farthest that way, so far fewer evaluations reach the valley's end (with the
    # 0.01 first step below, 150 reach as far as 200 did with 0.05: 7.50 vs 7.53 unit
    # lengths over 80 pushes of 8 validation holders).
    # k_tt, k_rr, alpha and the two factors set the frequencies; the loss intensities
    # hardly move them and are left to the archive members.
    extreme_axes: tuple[int, ...] = (0, 1, 4, 5, 6)
    extreme_evaluations: int = 150
    # COBYLA's first step in the unit cube: the set is a thin, curved valley and the
    # push starts on its edge; 0.05 left 40 % of the pushes stuck where they began.
    extreme_step: float = 0.01
    near_count: int = 24  # how many diverse members the set keeps (best included)


@dataclass(frozen=True)
class Identification:
    """Result of :func:`identify` (SI inside, library units for the parameters)."""

    params: HolderParams
    param_sets: tuple[HolderParams, ...]  # near-optimal set, best first
    bending_measured_hz: tuple[tuple[float | None, ...], ...]  # per recording, modes 1–3
    bending_model_hz: tuple[tuple[float, ...], ...]  # full model at the best params
    damping_model: tuple[tuple[float, ...], ...]
    objective: float
    objective_terms: tuple[tuple[float, float], ...]  # (frequency, shape) per recording
    evaluations: int
    seconds: float
    seed: int
    warnings: tuple[str, ...]
    window_hz: tuple[np.ndarray, ...] = field(repr=False, compare=False)
    measured_shape: tuple[np.ndarray, ...] = field(repr=False, compare=False)
    model_shape: tuple[np.ndarray, ...] = field(repr=False, compare=False)

    @property
    def relative_floor(self) -> float:
        """The smallest relative spread a prediction may claim: the fit's misfit (≥ 0.05 %)."""
        return max(fit_misfit(m, f) for m, f in zip(self.bending_measured_hz, self.bending_model_hz))

    @property
    def param_spread(self) -> dict[str, float]:
        """± half-range of each parameter over the near-optimal set."""
        values = np.array([[getattr(p, n) for n in NAMES] for p in self.param_sets])
        return {n: float((values[:, i].max() - values[:, i].min()) / 2) for i, n in enumerate(NAMES)}

    def to_dict(self) -> dict:
        """JSON-ready dictionary (docs/cli.md keys for one recording; lists per recording for joint fits)."""
        single = len(self.bending_measured_hz) == 1

        def pick(x):
            return list(x[0]) if single else [list(v) for v in x]

        return {
            "bending_measured_hz": pick(self.bending_measured_hz),
            "bending_model_hz": pick([[round(f, 2) for f in v] for v in self.bending_model_hz]),
            "damping_ratio_model": pick([[round(z, 6) for z in v] for v in self.damping_model]),
            "params": self.params.to_dict(),
            "params_spread": self.param_spread,
            "near_optimal_sets": len(self.param_sets),
            "objective": round(self.objective, 6),
            "objective_terms": [{"frequency": round(f, 6), "shape": round(s, 6)} for f, s in self.objective_terms],
            "evaluations": self.evaluations,
            "seconds": round(self.seconds, 3),
            "seed": self.seed,
            "warnings": list(self.warnings),
        }


@dataclass(frozen=True)
class Prediction:
    """Predicted free-free bending modes of a holder with one tool at one stick-out."""

    stickout_mm: float
    bending_hz: tuple[float, ...]
    bending_hz_spread: tuple[float, ...]  # the honest ± half-width (band.half_width_hz)
    damping_ratio: tuple[float, ...]
    damping_ratio_spread: tuple[float, ...]
    band: Band | None = field(default=None, compare=False)  # how the ± was made

    def to_dict(self) -> dict:
        out = {
            "stickout": round(self.stickout_mm, 4),
            "bending_hz": [round(f, 2) for f in self.bending_hz],
            "bending_hz_spread": [round(f, 2) for f in self.bending_hz_spread],
            "damping_ratio": [round(z, 6) for z in self.damping_ratio],
            "damping_ratio_spread": [round(z, 6) for z in self.damping_ratio_spread],
        }
        if self.band is not None:
            out["band"] = self.band.to_dict()
        return out

    def band_text(self) -> str:
        """How sure the frequencies are, in plain words ('' without a band)."""
        return self.band.text(self.bending_hz) if self.band is not None else ""


# ----------------------------------------------------------------------------- helpers


def _model_options(options: IdentifyOptions):
    from taptune.model import ModelOptions

    return options.model if options.model is not None else ModelOptions()


def bending_peaks(analysis) -> dict[int, float]:
    """Bending frequencies by mode number from a :class:`SpectrumAnalysis`."""
    out: dict[int, float] = {}
    for peak in analysis.peaks:
        if peak.kind == "bending" and peak.mode is not None:
            out[int(peak.mode)] = float(peak.hz)
    return out


# ----------------------------------------------------------------------------- identify


def identify(
    analyses: Sequence,
    assemblies: Sequence,
    options: IdentifyOptions = IdentifyOptions(),
    progress: ProgressCallback | None = None,
    evaluator_factory: Callable | None = None,
) -> Identification:
    """Fit the seven holder parameters to one or several tap recordings of one holder.

    Parameters
    ----------
    analyses : sequence of SpectrumAnalysis
        One per recording (``taptune.signal.analyse_recording``), with labelled bending peaks.
    assemblies : sequence of Assembly
        The assembly of each recording (same holder, any tool and stick-out).
    options : IdentifyOptions
        Seed, optimiser budget, objective and model options.
    progress : callable, optional
        ``progress(fraction, message)``; returning False cancels (raises ``Cancelled``).
    evaluator_factory : callable, optional
        ``factory(assembly, model_options)`` returning an evaluator; default the fast
        reduced model (:class:`taptune.model.reduced.FastEvaluator`).

    Returns
    -------
    Identification
    """
    from taptune.identify import search  # the optimisers' processes: not loaded by predict
    from taptune.model import build_model, solve_modes, tip_receptance

    t0 = time.perf_counter()
    if len(analyses) != len(assemblies) or not analyses:
        raise InputError("identify: give one assembly per recording")
    names = {a.holder.name for a in assemblies}
    if len(names) > 1:
        raise InputError(f"identify: a joint fit needs one holder, got {sorted(names)}")
    model_options = _model_options(options)

    def say(fraction, message):
        if progress is not None and progress(fraction, message) is False:
            raise Cancelled()

    targets: list[Target] = []
    warnings: list[str] = []
    for analysis, asm in zip(analyses, assemblies):
        label = getattr(analysis, "file", None) or getattr(analysis, "path", "") or asm.source
        target = make_target(analysis.freq_hz, analysis.magnitude, bending_peaks(analysis), options.objective, label)
        targets.append(target)
        warnings.extend(target.warnings)

    say(0.0, "building the model")
    if evaluator_factory is None:
        from taptune.model.reduced import cached_evaluator

        evaluator_factory = cached_evaluator  # the app identifies one assembly again and again
    evaluators = [evaluator_factory(asm, model_options) for asm in assemblies]
    objective = Objective(targets, evaluators, options.objective)

    say(0.05, "fitting the model")
    with search.Workers(objective, options, progress) as workers:
        islands = workers.map(search.ga_task, range(options.islands))
        starts = search.polish_starts(islands, options, search.n_modes(objective))
        polished = workers.map(search.polish_task, starts, phase=(0.8, 0.0, "polishing the best fits"))
        best = min(polished, key=lambda r: r.value)
        members, extra = search.near_optimal_set(objective, workers, islands + polished, best, options)
    evaluations = sum(r.evaluations for r in islands + polished) + extra
    param_sets = tuple(from_p(unit_to_p(u)) for u in members)
    params = param_sets[0]

    say(0.97, "checking on the full model")
    measured, model_hz, model_zeta, window, meas_shape, mod_shape, terms = [], [], [], [], [], [], []
    for target, asm, evaluator in zip(targets, assemblies, evaluators):
        # The evaluators hold the full model they were reduced from; build it only if not.
        fe = getattr(evaluator, "fe", None) or build_model(asm, model_options)
        modes = solve_modes(fe, params, n_modes=3)
        h = tip_receptance(fe, params, target.window_hz)
        fm = np.asarray(modes.frequency_hz[:3], dtype=float)
        meas = {m: f for m, f in zip(target.modes, target.measured_hz)}
        measured.append(tuple(float(meas[m]) if m in meas else None for m in (1, 2, 3)))
        model_hz.append(tuple(float(f) for f in fm))
        model_zeta.append(tuple(float(z) for z in modes.damping_ratio[:3]))
        window.append(target.window_hz)
        meas_shape.append(target.shape)
        mod_shape.append(model_shape(target.window_hz, h, options.objective))
        terms.append(objective_terms(target, fm, h, options.objective))
        misfit = np.abs(fm[np.asarray(target.modes) - 1] / target.measured_hz - 1)
        if misfit.max() > 0.001:
            warnings.append(
                f"{target.label}: the fitted model misses a measured bending frequency by {100 * misfit.max():.2f} % "
                "(check the peak labels and the assembly dimensions)"
            )
    at_bound = [n for n, u in zip(NAMES, p_to_unit(to_p(params))) if (u < 1e-3 or u > 1 - 1e-3) and n not in ("eta_tt", "eta_rr")]
    if at_bound:
        warnings.append(
            f"identified {', '.join(at_bound)} at the edge of the search space: the tap cannot tell values beyond it "
            "apart (e.g. an effectively rigid contact), or the assembly description is off"
        )
    say(1.0, "done")
    return Identification(
        params=params,
        param_sets=param_sets,
        bending_measured_hz=tuple(measured),
        bending_model_hz=tuple(model_hz),
        damping_model=tuple(model_zeta),
        objective=float(sum(f + s for f, s in terms)),
        objective_terms=tuple(terms),
        evaluations=int(evaluations),
        seconds=time.perf_counter() - t0,
        seed=options.seed,
        warnings=tuple(dict.fromkeys(warnings)),
        window_hz=tuple(window),
        measured_shape=tuple(meas_shape),
        model_shape=tuple(mod_shape),
    )


# ----------------------------------------------------------------------------- predict


def predict(param_sets: Sequence[HolderParams], assembly, model_options=None, n_modes: int = 3,
            relative_floor: float = 5e-4, *, identified: Sequence | None = None, tolerances=None,
            model_form=None, measured_modes=None, agreed: bool = False) -> Prediction:
    """Predict the bending modes of ``assembly`` with the holder's near-optimal parameter sets.

    The first set is the best fit and gives the values. The ± half-width
    (``bending_hz_spread``) is the honest band of :mod:`taptune.identify.bands`:
    the near-optimal sets' spread (every set explains the measurement as well, docs/physics.md
    §5; never less than ``relative_floor`` × f, the fit's misfit, see
    :func:`fit_misfit`), the stated geometry tolerances propagated through the model,
    and the calibrated model-form term, combined in quadrature.

    Parameters
    ----------
    identified : sequence of Assembly, optional
        The assemblies the holder was identified on (their stick-outs set the model-form
        term's Δ and the identification side of the geometry term; unknown: Δ = 20 mm).
    tolerances : Tolerances, optional
        Default: ``assembly.tolerances`` (the assembly file's keys, or their defaults).
    model_form : dict or sequence of float, optional
        Model-form coefficients per evidence group, or per mode (default
        :func:`bands.model_form_for` the number of ``identified`` assemblies: one tap or
        several; zeros give the parameter and geometry band alone).
    measured_modes : sequence of bool, optional
        Which modes the tap(s) measured (sets the evidence groups, :func:`bands.evidence_groups`).
    agreed : bool
        The sets come from one joint fit of the ``identified`` recordings that agree
        (:func:`bands.taps_agree`): the narrower model-form term of agreeing taps.
    """
    from taptune.model import ModelOptions, build_model, solve_modes

    if not param_sets:
        raise InputError("predict: the holder has no identified parameters")
    options = model_options or ModelOptions()
    fe = build_model(assembly, options)
    f, z = [], []
    for params in param_sets:
        modes = solve_modes(fe, params, n_modes=n_modes)
        f.append(np.asarray(modes.frequency_hz[:n_modes], dtype=float))
        z.append(np.asarray(modes.damping_ratio[:n_modes], dtype=float))
    f, z = np.array(f), np.array(z)
    tol = tolerances if tolerances is not None else getattr(assembly, "tolerances", Tolerances())
    # An identification of this very setup (holder, tool and stick-out) differs from the
    # predicted assembly only in its name: named alike, it shares the band's cached
    # sensitivities of the prediction instead of solving the same models again.
    identified = [_named_as(a, assembly) for a in identified or ()]
    set_hz = np.maximum(np.abs(f - f[0]).max(0), relative_floor * f[0])
    geometry_hz, parts = bands.geometry_term(assembly, param_sets[0], identified, tol, options, f[0])
    delta = bands.delta_stickout_mm(assembly, identified)
    groups = bands.evidence_groups(f, measured_modes)
    coefficients = bands.model_form_for(len(identified), agreed) if model_form is None else model_form
    model_hz = bands.model_form_term(f[0], delta, coefficients, groups)
    half = bands.compose(set_hz, geometry_hz, model_hz)
    band = Band(
        half_width_hz=tuple(map(float, half)), set_hz=tuple(map(float, set_hz)),
        geometry_hz=tuple(map(float, geometry_hz)), model_form_hz=tuple(map(float, model_hz)),
        geometry_parts_hz={k: tuple(map(float, v)) for k, v in parts.items()},
        delta_stickout_mm=delta, recordings=len(identified), tolerances=tol, model_form_groups=groups,
        taps_agree=bool(agreed and len(identified) >= 2 and model_form is None),
    )
    return Prediction(
        stickout_mm=assembly.stickout * 1e3,
        bending_hz=tuple(map(float, f[0])),
        bending_hz_spread=band.half_width_hz,
        damping_ratio=tuple(map(float, z[0])),
        damping_ratio_spread=tuple(map(float, np.abs(z - z[0]).max(0))),
        band=band,
    )


def _named_as(identified, assembly):
    """``identified`` with the name (``source``) of ``assembly`` when that is all they differ in."""
    if not (is_dataclass(identified) and is_dataclass(assembly)) or identified.source == assembly.source:
        return identified
    renamed = replace(identified, source=assembly.source)
    return renamed if renamed == assembly else identified


def fit_misfit(measured_hz, model_hz, floor: float = 5e-4) -> float:
    """Largest relative miss of the fitted model on the measured frequencies, at least ``floor``.

    Works on the pairs stored in an identification or a library provenance record (None
    entries, modes not measured, are skipped).
    """
    pairs = [(m, f) for m, f in zip(measured_hz, model_hz) if m is not None and f is not None]
    return max([floor] + [abs(f / m - 1) for m, f in pairs])
