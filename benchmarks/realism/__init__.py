"""The realism corpus: synthetic holders OUTSIDE taptune's model family, with their truth.

Use it to measure, never to tune one case (issue 9). Public API::

    from benchmarks.realism.corpus import make_corpus, make_case, check_pairs, worn, elsewhere, KINDS
    from benchmarks.realism.audio import record, write_case, audible_modes, clean_recording
    from benchmarks.realism.truth import TruthHolder, Profile, ExtraMass, truth_modes, truth_receptance
    from benchmarks.realism.run import run_case, summarise

    cases = make_corpus("validation", 24)      # or "calibration", "infamily" (disjoint seeds)
    case = cases[0]
    case.described                             # Assembly: what the user's TOML says (recorded stick-out)
    case.described_at(q.stickout_mm)           # ... at a query stick-out (what predict gets)
    case.true_assembly, case.holder            # the hidden truth (geometry; TruthHolder)
    case.truth.bending_hz                      # true f1-f3 at the recording [Hz] (doublet centres)
    for q in case.queries:                     # Query(stickout_mm, true_stickout_mm, truth: TruthModes)
        q.truth.bending_hz
    case.kinds                                 # deviations present, subset of KINDS
    rec = record(case)                         # taptune.io.audio.Recording (deterministic)
    write_case(case, folder)                   # <name>.wav, <name>.toml, <name>_so<mm>.toml, <name>.truth.json
    pairs = check_pairs(n)                     # [(reference Case, other Case, "consistent" | "differs")]
    worn(case, 0.5)                            # same holder, contact stiffness intensities x 0.5

Command line (one identification ≈ 5 CPU-s; results JSON keeps every param_set, so
band methods can be re-evaluated offline with ``summarise``)::

    python -m benchmarks.realism.run --split validation --n 24 --out results.json [--jobs 2]

Baselines: ``benchmarks/realism/baseline_<split>.json``.
"""
