"""``taptune cut REC --rpm N --teeth Z [...]``: chatter from the sound of a cut, and the next speed to try.

The verdict (stable / chatter / unclear), the chatter frequency and its level above the
forced vibration come from :func:`taptune.signal.cut.analyse_cut`. The next speed: by
the rule of Smith & Tlusty (tooth passing, or a sub-multiple, on the chatter frequency)
without a model; with ``--holder --assembly --machine`` and the cut, from the holder's
stability lobes at the cut's depth (:mod:`taptune.machine.next_speed`), where the
analysed cut is also kept in the holder's history (unless ``--no-save``).
"""

from __future__ import annotations

import argparse
import sys

DEFAULT_MIN_RPM = 500.0
#: The lobes are computed from half to twice the speed heard, at this many speeds.
LOBE_SPAN = (0.5, 2.0)
LOBE_SPEEDS = 300


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Listen to a milling cut: the speed heard, stable or chatter (the chatter frequency and how far it "
        "stands above the forced vibration), and the next speed to try: by the tooth-passing rule, or from "
        "the holder's stability lobes with --holder, --assembly and --machine (the cut is then kept in the "
        "holder's history)."))
    p.add_argument("wav", metavar="REC", help="recording of the cut (WAV, FLAC, MP3, M4A, phone video …)")
    p.add_argument("--rpm", type=float, required=True, metavar="N", help="commanded spindle speed [rpm]")
    p.add_argument("--teeth", type=int, required=True, metavar="Z", help="number of teeth (flutes)")
    p.add_argument("--from", dest="start_s", type=float, metavar="S",
                   help="start of the steady cut [s] (default: found from the level)")
    p.add_argument("--to", dest="end_s", type=float, metavar="S", help="end of the steady cut [s]")
    cut = p.add_argument_group("the cut (for the lobes)")
    cut.add_argument("--depth", type=float, metavar="MM", help="axial depth of cut [mm]")
    cut.add_argument("--ae", type=float, metavar="MM", help="radial depth of cut [mm]; = diameter is slotting")
    cut.add_argument("--milling", choices=("up", "down"), help="up- or down-milling")
    cut.add_argument("--diameter", type=float, metavar="MM", help="tool diameter [mm] (default: the assembly's)")
    cut.add_argument("--material", metavar="NAME", help="work material instead of --ktc/--krc")
    cut.add_argument("--ktc", type=float, metavar="MPA", help="tangential cutting-force coefficient K_tc [MPa]")
    cut.add_argument("--krc", type=float, metavar="MPA", help="radial cutting-force coefficient K_rc [MPa]")
    model = p.add_argument_group("the holder on the machine")
    model.add_argument("--holder", metavar="NAME", help="library holder (its lobes give the next speed)")
    model.add_argument("--assembly", metavar="FILE", help="assembly TOML with the tool")
    model.add_argument("--machine", metavar="MACHINE_TOML", help="machine file with the spindle receptance")
    model.add_argument("--library", metavar="PATH", help="holder library file")
    p.add_argument("--min-rpm", type=float, metavar="N", help=f"lowest speed to suggest (default {DEFAULT_MIN_RPM:g})")
    p.add_argument("--max-rpm", type=float, metavar="N",
                   help="highest speed to suggest (default: the machine file's max_rpm, else twice --rpm)")
    p.add_argument("--no-save", action="store_true", help="do not keep the cut in the holder's history")
    p.add_argument("--json", metavar="OUT", help="write the verdict as JSON ('-' for stdout)")
    p.add_argument("--plot", metavar="PNG", help="write the spectrum (and the lobes with the observed cuts)")
    return p


def _check(args):
    from taptune.errors import InputError

    if not (args.rpm > 0 and args.rpm < 1e6):
        raise InputError(f"--rpm must be > 0 rpm, got {args.rpm:g}")
    if not 1 <= args.teeth <= 200:
        raise InputError(f"--teeth must lie in 1…200, got {args.teeth}")
    for flag, v in (("--depth", args.depth), ("--ae", args.ae), ("--diameter", args.diameter),
                    ("--min-rpm", args.min_rpm), ("--max-rpm", args.max_rpm)):
        if v is not None and not (v > 0 and v < 1e6):
            raise InputError(f"{flag} must be > 0, got {v:g}")
    model = [n for n, v in (("--holder", args.holder), ("--assembly", args.assembly), ("--machine", args.machine))
             if v is not None]
    if model and len(model) < 3:
        missing = [n for n in ("--holder", "--assembly", "--machine") if n not in model]
        raise InputError(f"the lobes need --holder, --assembly and --machine; missing {', '.join(missing)}")
    if model:
        need = [n for n, v in (("--depth", args.depth), ("--ae", args.ae), ("--milling", args.milling)) if v is None]
        if need:
            raise InputError(f"--holder with --machine: the cut needs {', '.join(need)}")
        if args.material is None and (args.ktc is None or args.krc is None):
            raise InputError("--holder with --machine: give the cutting coefficients: --material NAME, or --ktc and --krc")
    return bool(model)


def _model_inputs(args):
    """(entry, library, machine, frf, cut, diameter_mm, warnings, flute length [m] or None, the holder's band):
    what the lobes need, checked."""
    from taptune.cli.cmd_toolpoint import frequency_grid, machine_inputs, toolpoint_frfs
    from taptune.cli.cut import cut_options, tool_diameter_mm
    from taptune.library.store import HolderLibrary, default_library_path

    library = HolderLibrary(default_library_path(args.library))
    entry = library.get(args.holder)  # an unknown holder is one line, before any work
    ns = argparse.Namespace(**vars(args))
    ns.rpm, ns.params, ns.assembly = None, None, args.assembly
    ns.freq, ns.contact = None, "distributed"
    cut = cut_options(ns)
    assembly, machine, holder, warnings = machine_inputs(ns, "cut")
    frfs, _ = toolpoint_frfs(assembly, machine, holder, frequency_grid(ns, machine), None, "distributed")
    flutes = assembly.tool.flute_length
    from taptune.machine.band import band_from_prediction

    band = band_from_prediction(entry.predict(assembly))
    diameter = cut.diameter_mm if cut.diameter_mm is not None else tool_diameter_mm(assembly)
    if cut.ae_mm > diameter * (1 + 1e-9):
        from taptune.errors import InputError

        raise InputError(f"--ae {cut.ae_mm:g} mm exceeds the tool diameter {diameter:g} mm")
    return entry, library, machine, frfs[0], cut, diameter, warnings, flutes, band


def run(args) -> int:
    from taptune.cli.common import command_inputs, output_path, write_json
    from taptune.io.audio import read_audio
    from taptune.signal.cut import analyse_cut

    inputs = command_inputs(args)
    for path, what in ((args.json, "JSON"), (args.plot, "plot")):
        output_path(path, what, library=args.library, inputs=inputs)
    with_model = _check(args)
    if with_model:  # an unknown holder, a bad material: one line before any work
        from taptune.cli.cut import cutting_coefficients
        from taptune.library.store import HolderLibrary, default_library_path

        HolderLibrary(default_library_path(args.library)).get(args.holder)
        cutting_coefficients(args)
    recording = read_audio(args.wav)
    analysis = analyse_cut(recording, args.rpm, args.teeth, start_s=args.start_s, end_s=args.end_s)
    model = _model_inputs(args) if with_model else None
    warnings = list(recording.warnings) + list(analysis.warnings)
    max_rpm = args.max_rpm
    if max_rpm is None and model is not None:
        max_rpm = model[2].max_rpm
    min_rpm = args.min_rpm if args.min_rpm is not None else min(DEFAULT_MIN_RPM, 0.5 * analysis.spindle_rpm)
    if max_rpm is not None and max_rpm <= min_rpm:
        from taptune.errors import InputError

        raise InputError(f"--max-rpm {max_rpm:g} must lie above the lowest speed {min_rpm:g} rpm")
    out = {"recording": args.wav, "verdict": analysis.verdict, "chatter_hz": analysis.chatter_hz,
           "spindle_rpm": analysis.spindle_rpm, "tooth_passing_hz": analysis.tooth_passing_hz,
           "chatter_level_db": analysis.chatter_level_db, "suggested_rpm": [], "suggestion_basis": None}
    details = analysis.to_dict()
    lobes_info = None
    if model is not None:
        lobes_info = _with_lobes(args, analysis, model, min_rpm, max_rpm, warnings)
        out.update(suggested_rpm=lobes_info["suggested_rpm"], suggestion_basis="lobes")
        details["lobes"] = lobes_info["summary"]
    else:
        from taptune.machine.next_speed import advise

        out.update(suggested_rpm=[round(n) for n in advise(analysis, min_rpm=min_rpm, max_rpm=max_rpm).suggested_rpm],
                   suggestion_basis="rule")
    out["analysis"] = details
    out["warnings"] = warnings
    if lobes_info is not None and not args.no_save:
        _save(args, analysis, model, recording)
    write_json(out, args.json)
    if args.json != "-":
        _print(args, analysis, out, lobes_info)
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    if args.plot:
        _plot(args, analysis, lobes_info)
    return 0


def _with_lobes(args, analysis, model, min_rpm, max_rpm, warnings) -> dict:
    """Lobes of the holder at this cut with its band weighed by the observed cuts (this one too), the
    speeds they allow at its depth, the mode match, the cuts that contradict the lobes."""
    from taptune.library.exchange import frequency_grid as uniform_grid
    from taptune.machine.next_speed import advise, observation_warnings
    from taptune.machine.observed import comparable, lobes_with_observations

    entry, library, machine, frf, cut, diameter, more, flutes, band = model
    warnings += [w for w in more if w not in warnings]
    # The speeds a machinist moves to after one cut: half to twice the present one, within the machine's range.
    n = analysis.spindle_rpm
    lo = max(min_rpm, LOBE_SPAN[0] * n)
    hi = min(max_rpm, LOBE_SPAN[1] * n) if max_rpm is not None else LOBE_SPAN[1] * n
    rpm = uniform_grid(lo, hi, max(1.0, round((hi - lo) / LOBE_SPEEDS)))
    seen = list(entry.observations) + [_observation(args, analysis, cut, None)]
    same = comparable(seen, teeth=cut.teeth, ae_mm=cut.ae_mm, milling=cut.milling, ktc_mpa=cut.ktc / 1e6,
                      krc_mpa=cut.krc / 1e6)
    lobes, observed = lobes_with_observations(
        frf.freq_hz, frf.xx, frf.yy, teeth=cut.teeth, ktc=cut.ktc, krc=cut.krc, diameter=diameter * 1e-3,
        ae=cut.ae_mm * 1e-3, milling=cut.milling, rpm=rpm, method="auto", band=band,
        depth_cap=flutes or float("inf"), cuts=[(o.rpm, o.depth_mm * 1e-3, o.verdict) for o in same])
    warnings += [w for w in lobes.warnings if w not in warnings]
    safe = observed.band
    advice = advise(analysis, min_rpm=min_rpm, max_rpm=max_rpm, depth=args.depth * 1e-3, rpm=rpm,
                    a_lim=safe.a_safe if safe.samples > 1 else lobes.a_lim, modes=frf.modes, holder=entry.name)
    warnings += list(advice.warnings)
    # Without a band (one sample) the cuts are checked against the central lobes with a margin.
    contradictions = observed.warnings if safe.samples > 1 else observation_warnings(same, rpm, lobes.a_lim)
    warnings += [w for w in dict.fromkeys(contradictions) if w not in warnings]
    summary = advice.lobes.to_dict() | {"method": getattr(lobes, "method", "zoa"), "a_crit_mm": lobes.a_crit * 1e3,
                                        "chatter_hz_tool": advice.chatter_hz,
                                        "chatter_matches_tool_mode": advice.matches_tool,
                                        "tool_mode_hz": advice.tool_mode_hz,
                                        "observations": len(seen) - (1 if args.no_save else 0),
                                        "band": safe.sources} | observed.to_dict()
    return {"suggested_rpm": [round(n) for n in advice.suggested_rpm], "summary": summary, "lobes": lobes,
            "band": safe, "observations": seen, "cut": cut, "diameter": diameter, "holder": entry.name}


def _observation(args, analysis, cut, sha):
    from taptune.library.observations import CutObservation

    return CutObservation.from_analysis(analysis, depth_mm=args.depth, ae_mm=cut.ae_mm, milling=cut.milling,
                                        ktc_mpa=cut.ktc / 1e6, krc_mpa=cut.krc / 1e6, material=cut.material,
                                        recording=args.wav, sha256=sha)


def _save(args, analysis, model, recording) -> None:
    from dataclasses import replace

    from taptune.library.schema import sha256_file

    entry, library, *_ = model
    cut = model[4]
    obs = _observation(args, analysis, cut, sha256_file(args.wav))
    library.update(entry.name, lambda e: replace(e, observations=e.observations + (obs,)))


def _print(args, analysis, out, lobes_info) -> None:
    a = analysis
    print(f"recording: {args.wav}\ncut:       {a.cut_s[0]:.1f}–{a.cut_s[1]:.1f} s"
          + (f" (idle {a.idle_s:.1f} s used for the machine's own tones)" if a.idle_s else ""))
    print(f"speed:     {a.spindle_rpm:.0f} rpm heard ({a.commanded_rpm:g} commanded), tooth passing "
          f"{a.tooth_passing_hz:.1f} Hz, {a.harmonics_found} harmonics")
    line = {"stable": "STABLE: only the spindle and tooth-passing harmonics",
            "chatter": "CHATTER", "unclear": "UNCLEAR: a line off the harmonics, not clearly chatter"}[a.verdict]
    if a.chatter_hz is not None and a.verdict != "stable":
        line += f" at {a.chatter_hz:.0f} Hz, {a.chatter_level_db:+.0f} dB against the tooth-passing vibration"
    print(f"verdict:   {line}")
    if out["suggested_rpm"]:
        basis = "the holder's lobes at this depth" if out["suggestion_basis"] == "lobes" else \
            "tooth passing (or a sub-multiple) on the chatter frequency"
        print(f"next:      {', '.join(f'{n:.0f}' for n in out['suggested_rpm'])} rpm (best first; {basis})")
    if lobes_info is not None:
        s = lobes_info["summary"]
        now = s["a_lim_now_mm"]
        print(f"lobes:     {s['method'].upper()}, limit at {a.spindle_rpm:.0f} rpm "
              + (f"{now:.3g} mm" if now is not None else "unknown") + f" (cut {args.depth:g} mm); "
              f"{s['observations']} cut(s) observed with {lobes_info['holder']}"
              + ("" if args.no_save else " (this one saved)"))
        if s["observed_cuts_used"] and s["band_width_before_pct"] > 0:
            print(f"band:      {s['observed_cuts_used']} cut(s) of this kind narrow the holder's band of tool-point "
                  f"frequencies from {s['band_width_before_pct']:.1f} % to {s['band_width_after_pct']:.1f} % wide "
                  f"(shifted {s['toolpoint_frequency_shift_pct']:+.1f} %)"
                  + (f" and of its dynamic stiffness from {s['stiffness_band_width_before_pct']:.0f} % to "
                     f"{s['stiffness_band_width_after_pct']:.0f} % wide (limits {s['toolpoint_stiffness_shift_pct']:+.0f} %)"
                     if s["stiffness_band_width_before_pct"] > 0 else ""))


def _plot(args, analysis, lobes_info) -> None:
    from taptune.report.cut_plot import plot_cut

    lobes = None
    if lobes_info is not None:
        lb = lobes_info["lobes"]
        band = lobes_info["band"]
        lobes = (lb.rpm, lb.a_lim, band.a_safe if band.samples > 1 else None, lobes_info["observations"], args.depth)
    plot_cut(analysis, args.plot, lobes=lobes, title=args.wav)
