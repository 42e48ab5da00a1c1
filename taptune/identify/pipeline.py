"""The steps every front end runs in the same order: recording → labelled spectrum → fit.

The signal layer never imports the model, so the model's expectations (bending
frequencies with nominal or library parameters, and the physical bounds from
``bending_bounds``) are computed here and handed to ``analyse_recording`` as plain arrays.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from taptune.identify.labelfit import PARAMETER_SPREAD
from taptune.model.params import NOMINAL, HolderParams


def model_expectation(assembly, params: HolderParams | None = None, model_options=None):
    """What the model expects of a recording of ``assembly``, for the peak labels.

    Returns
    -------
    expected : ndarray, shape (3,)
        Bending frequencies [Hz] with ``params`` (nominal by default).
    bounds : ndarray, shape (3, 2)
        Their physical bounds [Hz] (``bending_bounds``).
    spread : ndarray, shape (3, len(PARAMETER_SPREAD))
        How far each mode moves [Hz] per plausible parameter change.
    """
    from taptune.model import ModelOptions, analyse, bending_bounds, build_model

    options = model_options or ModelOptions()
    params = params or NOMINAL
    fe = build_model(assembly, options)
    expected = np.asarray(analyse(assembly, params, options, fe=fe).bending_hz[:3], dtype=float)
    bounds = np.asarray(bending_bounds(assembly, options, fe=fe), dtype=float)
    spread = np.zeros((expected.size, len(PARAMETER_SPREAD)))
    for k, (name, step) in enumerate(PARAMETER_SPREAD):
        value = getattr(params, name)
        moved = value * 10**step if name in ("k_tt", "k_rr") else value + step
        f = np.asarray(analyse(assembly, replace(params, **{name: moved}), options, fe=fe).bending_hz[:3])
        spread[:, k] = f[: expected.size] - expected
    return expected, bounds, spread


def analyse_for_assembly(recording, assembly=None, params: HolderParams | None = None, model_options=None,
                         guidance=None, decide_labels: bool = True, **kwargs):
    """Analyse a recording; with an assembly, the model guides the bending labels.

    ``guidance`` is a :func:`model_expectation` result the caller already has (computed
    here otherwise). When the labels are ambiguous (several plausible assignments, or a
    loud peak the guidance left out), each is fitted on the fast model and the one the
    model explains best is kept (:mod:`taptune.identify.labelfit`; ``decide_labels``
    False keeps the guidance's choice). Extra keyword arguments go to
    :func:`taptune.signal.analysis.analyse_recording`.
    """
    from taptune.identify.labelfit import choose_labeling, labelled_modes, relabelled
    from taptune.signal.analysis import SpectrumOptions, analyse_recording, find_spectral_peaks

    if assembly is None:
        return analyse_recording(recording, **kwargs)
    guidance = guidance or model_expectation(assembly, params, model_options)
    expected, bounds, spread = guidance
    kwargs.setdefault("interface", assembly.holder.interface)
    spectrum_options = kwargs.get("options") or SpectrumOptions()
    # The spectra and picked peaks serve the analysis and, after a relabelling, the
    # full refinement of the new bending peaks (with the pole fits' spectra cached).
    found = find_spectral_peaks(recording, spectrum_options)
    analysis = analyse_recording(recording, expected_hz=expected, bounds_hz=bounds, spread_hz=spread, found=found,
                                 **kwargs)
    if not decide_labels:
        return analysis

    def evaluator():
        from taptune.model import ModelOptions
        from taptune.model.reduced import cached_evaluator

        # The one the identification then fits with (built once for both).
        return cached_evaluator(assembly, model_options or ModelOptions())

    modes, warnings = choose_labeling(analysis, evaluator, guidance, analysis.excluded_bands_hz,
                                      spectrum_options.labels)
    if modes is None:
        return analysis
    if modes == labelled_modes(analysis.peaks, len(modes)):
        return replace(analysis, warnings=list(analysis.warnings) + warnings) if warnings else analysis
    return relabelled(analysis, modes, warnings, analysis.excluded_bands_hz, refine=_full_refinement(found))


def _full_refinement(r):
    """``refine(peaks, indices)``: the full pole-fit frequency of the given peaks (the
    analysis refined non-bending peaks only roughly); ``r`` is the recording's
    :func:`~taptune.signal.analysis.find_spectral_peaks`."""

    def refine(peaks, indices):
        base = r["peaks"]
        if not base:
            return peaks
        hz = np.array([q.hz for q in base])
        match = {i: int(np.argmin(np.abs(hz - peaks[i].hz))) for i in indices}
        effort = [0] * len(base)
        for j in match.values():
            effort[j] = 2
        fine = r["refine"](base, effort)
        return [replace(q, hz=fine[match[i]].hz, damping_ratio=fine[match[i]].damping_ratio) if i in match else q
                for i, q in enumerate(peaks)]

    return refine


def check_distinct(recordings) -> None:
    """Refuse a joint fit given the same recording twice (a file and its copy): it would
    count one tap as two and narrow the bands for nothing."""
    from taptune.errors import InputError

    for i, a in enumerate(recordings):
        for b in recordings[:i]:
            if a.sample_rate == b.sample_rate and np.array_equal(a.samples, b.samples):
                raise InputError(f"{a.path}: holds the same recording as {b.path}; a joint fit needs different taps "
                                 f"(the holder at another stick-out, or tapped again)")


def identify_recordings(recordings, assemblies, options=None, progress=None, library_params=None):
    """Analyse each recording (model-guided labels) and fit the holder jointly.

    Parameters
    ----------
    recordings : sequence of Recording
    assemblies : sequence of Assembly
        One per recording, same holder.
    options : IdentifyOptions, optional
    progress : callable, optional
        ``progress(fraction, message)``; returning False cancels.
    library_params : HolderParams, optional
        Parameters of this holder from the library, used instead of the nominal ones to
        guide the peak labels.

    Returns
    -------
    (list of SpectrumAnalysis, Identification)
    """
    from taptune.identify.core import IdentifyOptions, identify

    options = options or IdentifyOptions()
    check_distinct(recordings)
    analyses = [
        analyse_for_assembly(r, a, library_params, options.model) for r, a in zip(recordings, assemblies)
    ]
    return analyses, identify(analyses, assemblies, options, progress=progress)


def identification_record(recordings, assemblies, analyses, result) -> dict:
    """The JSON record of an identification (docs/cli.md keys; lists per recording for a joint fit).

    What ``taptune identify --json`` prints and ``taptune batch`` writes per recording.
    """
    per_file = []
    for rec, analysis in zip(recordings, analyses):
        d = analysis.to_dict()
        per_file.append({
            "file": rec.path,
            "sample_rate": rec.sample_rate,
            "taps": d["taps"],
            "peaks": d["peaks"],
            "warnings": d["warnings"],
        })
    out = {"holder": assemblies[0].holder.name}
    if len(per_file) == 1:
        out.update({k: v for k, v in per_file[0].items() if k != "warnings"})
    else:
        out["file"] = [f["file"] for f in per_file]
        out["recordings"] = [{k: v for k, v in f.items() if k != "warnings"} for f in per_file]
    out.update(result.to_dict())
    out["warnings"] = [w for f in per_file for w in f["warnings"]] + out["warnings"]
    outlook = transfer_outlook(result, assemblies)
    if outlook is not None:
        from taptune.identify.bands import second_tap_advice

        out["transfer_outlook"] = outlook.to_dict()
        advice = second_tap_advice([outlook])
        if advice:
            out["warnings"].append(advice)
    # The assembly files' own warnings (a misspelt key, an implied collet) first, once each.
    out["warnings"] = list(dict.fromkeys([w for a in assemblies for w in a.warnings] + out["warnings"]))
    return out


def transfer_outlook(result, assemblies, offset_mm: float = 20.0):
    """How well this identification transfers: the prediction (with its band) at the first
    recording's stick-out + ``offset_mm`` (or − ``offset_mm`` / 2 when the tool cannot come
    out that far); None when neither stick-out is valid."""
    from taptune.errors import InputError
    from taptune.identify.bands import measured_modes, taps_agree
    from taptune.identify.core import predict

    base = assemblies[0]
    for delta in (offset_mm, -offset_mm / 2):
        try:
            target = base.with_stickout(base.stickout + delta * 1e-3)
        except InputError:
            continue
        measured = getattr(result, "bending_measured_hz", None)
        return predict(result.param_sets, target, relative_floor=result.relative_floor, identified=list(assemblies),
                       measured_modes=None if measured is None else measured_modes(measured),
                       agreed=measured is not None and taps_agree(measured, result.relative_floor,
                                                                  [a.stickout for a in assemblies],
                                                                  [a.tolerances.stickout for a in assemblies]))
    return None
