"""The steps every front end runs in the same order: recording → labelled spectrum → fit.

The signal layer never imports the model, so the model's expectations (bending
frequencies with nominal or library parameters, and the physical bounds of MODEL.md
§7.6) are computed here and handed to ``analyse_recording`` as plain arrays.
"""

from __future__ import annotations

import numpy as np

from taptune.model.params import NOMINAL, HolderParams


#: Plausible spread of each holder parameter around the nominal values (MODEL.md §8.1):
#: (name, step); k_tt and k_rr in decades. The labels use how far each bending mode
#: moves per spread.
PARAMETER_SPREAD = (("k_tt", 0.5), ("k_rr", 1.0), ("modulus_factor", 0.05),
                    ("density_factor", 0.03), ("alpha", 15.0))


def model_expectation(assembly, params: HolderParams | None = None, model_options=None):
    """What the model expects of a recording of ``assembly``, for the peak labels.

    Returns
    -------
    expected : ndarray, shape (3,)
        Bending frequencies [Hz] with ``params`` (nominal by default).
    bounds : ndarray, shape (3, 2)
        Their physical bounds [Hz] (MODEL.md §7.6).
    spread : ndarray, shape (3, len(PARAMETER_SPREAD))
        How far each mode moves [Hz] per plausible parameter change.
    """
    from dataclasses import replace

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
                         guidance=None, **kwargs):
    """Analyse a recording; with an assembly, the model guides the bending labels.

    ``guidance`` is a :func:`model_expectation` result the caller already has (computed
    here otherwise). Extra keyword arguments go to
    :func:`taptune.signal.analysis.analyse_recording`.
    """
    from taptune.signal.analysis import analyse_recording

    if assembly is None:
        return analyse_recording(recording, **kwargs)
    expected, bounds, spread = guidance or model_expectation(assembly, params, model_options)
    kwargs.setdefault("interface", assembly.holder.interface)
    return analyse_recording(recording, expected_hz=expected, bounds_hz=bounds, spread_hz=spread, **kwargs)


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
    analyses = [
        analyse_for_assembly(r, a, library_params, options.model) for r, a in zip(recordings, assemblies)
    ]
    return analyses, identify(analyses, assemblies, options, progress=progress)


def identification_record(recordings, assemblies, analyses, result) -> dict:
    """The JSON record of an identification (CLI-CONTRACT.md keys; lists per recording for a joint fit).

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
    return out
