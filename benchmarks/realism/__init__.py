"""The realism corpus: synthetic holders OUTSIDE taptune's model family, with their truth.

Use it to measure, never to tune one case (issue 9). Public API::

    from benchmarks.realism.corpus import make_corpus, make_case, check_pairs, worn, elsewhere, KINDS
    from benchmarks.realism.audio import record, write_case, audible_modes, audibility_margins, write_check_pairs
    from benchmarks.realism.corpus import without, case_of
    from benchmarks.realism.truth import TruthHolder, Profile, ExtraMass, truth_modes, truth_receptance
    from benchmarks.realism.run import run_case, summarise, print_summary, reevaluate

    cases = make_corpus("validation", 24)      # or "calibration", "infamily" (disjoint seeds)
    cases = make_corpus("validation", 24, tier="issue")  # the holders issue 9 describes (names i*)
    case_of(record)                            # the case of a stored results record (split, index, tier)
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
    worn(case, 0.5[, stickout_mm])             # same holder, contact stiffness intensities x 0.5
    elsewhere(case, stickout_mm)               # same holder and tool clamped again (fresh ruler error)
    without(case, "flute")                     # one deviation removed (attribution)
    audibility_margins(case, analysis)         # dB of each truth mode over the noise floor (audible: >= 6)
    write_check_pairs(n, folder)               # pair<k>/{reference,other}.{wav,toml}, expected.json

    records = json.load(open("benchmarks/realism/baseline_validation.json"))["cases"]
    new = reevaluate(records, lambda sets, asm, rec: my_predict(sets, asm))   # no re-identification
    print_summary(summarise(new), "my bands")

Each record: the case (described/truth, kinds, recording settings), ``labels`` (per truth
mode: audible, margin_db, labelled_hz, right), ``peaks``, ``identification`` (param_sets,
measured and model frequencies, warnings), ``predictions`` (per query and mode: truth_hz,
predicted_hz, spread_hz, error_pct, covered, half_width_pct, measured, ruler_pct = how far
the ruler error alone moves the truth), ``cpu_s``.

Command line (one identification ≈ 5 CPU-s; results JSON keeps every param_set, so
band methods can be re-evaluated offline with ``summarise``)::

    python -m benchmarks.realism.run --split validation --n 24 --out results.json [--jobs 2] [--ablate KIND] \
        [--tier issue] [--table]
    python -m benchmarks.realism.attribute --split validation --n 24   # truth-only, per deviation

Baselines (taptune 0c95237, before issue 9): ``benchmarks/realism/baseline_<split>.json``
for ``validation`` (24), ``calibration`` (24) and ``infamily`` (12). Issue tier before the
issue-9 work (taptune main f1b05df): ``before_issue_<split>.json`` (24 each). The code of
today: ``results_<tier>_<split>[_<start>].json`` (calibration 72 holders per tier,
validation 48, in-family 12); the bands are calibrated on them with
``benchmarks/calibrate_bands.py`` (its docstring has the whole loop). Holders the model
describes, stick-out exact and stated to ±0.05 mm (``run --split infamily --stickout-error
0.05``, 48 holders): ``results_infamily_gauge_{calibration,validation,validation_30}.json``
(indices 12–29 / 0–11 / 30–47); their two-tap runs ``two_taps_infamily_<split>.json``,
and the first 12 holders of each tier and split tapped twice, with the joint fit's
misfit (``two_taps_<tier>_<split>_12.json``).
"""
