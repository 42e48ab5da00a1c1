"""``taptune library list | show NAME | export OUT | import FILE | remove NAME | receptance NAME``.

The holder library is ``--library PATH|URL`` (accepted before or after the action), else
``$TAPTUNE_LIBRARY``, else ``holders.db`` in the user data folder: an SQLite database, a
``postgresql://`` server or a ``.json`` file. A broken library, an unknown holder or a bad
file to import exits 2 with one line naming the library or file; the library is never
overwritten when it is broken, and ``import`` never executes or unpickles anything.
"""

from __future__ import annotations

import argparse
import sys

#: ``library show`` lists this many of the latest checks.
SHOW_CHECKS = 5
LIBRARY_HELP = ("holder library: a .db file, a postgresql:// URL or a .json file "
                "(default: $TAPTUNE_LIBRARY, else holders.db in the user data folder)")
#: ``library list`` shows at most this many holders unless --limit says otherwise.
LIST_LIMIT = 1000


def add_parser(sub, name: str, help_text: str) -> argparse.ArgumentParser:
    p = sub.add_parser(name, help=help_text, description=help_text + ".")
    p.add_argument("--library", metavar="PATH|URL", default=None, help=LIBRARY_HELP)
    actions = p.add_subparsers(dest="action", metavar="ACTION", required=True)

    def action(action_name: str, text: str) -> argparse.ArgumentParser:
        a = actions.add_parser(action_name, help=text, description=text + ".")
        # SUPPRESS: an action's own default must not overwrite a --library given before it.
        a.add_argument("--library", metavar="PATH|URL", default=argparse.SUPPRESS, help=LIBRARY_HELP)
        return a

    a = action("list", "list the holders: interface, stiffnesses, identifications, last check")
    a.add_argument("--match", metavar="TEXT", help="only holders whose name contains TEXT (any case)")
    a.add_argument("--limit", type=int, default=LIST_LIMIT, metavar="N",
                   help=f"show at most N holders (default {LIST_LIMIT}; 0 for all)")
    a.add_argument("--json", metavar="OUT", help="also write the list as JSON ('-' for stdout only)")

    a = action("show", "one holder: parameters with spread, history, last checks, predicted bending modes")
    a.add_argument("name", metavar="NAME", help="holder name")
    a.add_argument("--no-predict", action="store_true", help="skip the model predictions at the identified stick-outs")
    a.add_argument("--json", metavar="OUT", help="also write the holder as JSON ('-' for stdout only)")

    a = action("export", "write the library as JSON (importable) or CSV (for spreadsheets)")
    a.add_argument("out", metavar="OUT", help="output file")
    a.add_argument("--format", choices=("json", "csv"), default=None,
                   help="file format (default: csv for a .csv file, else json)")

    a = action("import", "validate a library file and merge its holders into the library")
    a.add_argument("file", metavar="FILE", help="holder library JSON file (e.g. from `taptune library export`)")
    a.add_argument("--replace", action="store_true",
                   help="take the imported holder where a name exists with different parameters (history is kept)")

    a = action("remove", "delete a holder from the library")
    a.add_argument("name", metavar="NAME", help="holder name")

    a = action("receptance", "write the tool-tip receptance of a holder with an assembly's tool (UFF58 or CSV)")
    a.add_argument("name", metavar="NAME", help="holder name")
    a.add_argument("--assembly", required=True, metavar="FILE",
                   help="assembly TOML with the tool (and the holder as clamped on it)")
    a.add_argument("--stickout", type=float, metavar="MM", help="stick-out [mm] (default: the assembly's)")
    a.add_argument("--out", required=True, metavar="OUT", help="output file: .uff/.unv (UFF dataset 58) or .csv")
    a.add_argument("--fmin", type=float, default=10.0, metavar="HZ", help="lowest frequency (default 10 Hz)")
    a.add_argument("--fmax", type=float, default=20000.0, metavar="HZ", help="highest frequency (default 20000 Hz)")
    a.add_argument("--df", type=float, default=5.0, metavar="HZ", help="frequency step (default 5 Hz)")
    return p


def run(args) -> int:
    from taptune.library import HolderLibrary, default_library_path

    lib = HolderLibrary(default_library_path(args.library))
    try:
        return _ACTIONS[args.action](lib, args)
    finally:
        lib.close()


# --------------------------------------------------------------------------- formatting


def _date(iso: str | None) -> str:
    """``2026-11-22 12:38`` from an ISO-8601 UTC date ('' when there is none)."""
    from taptune.library.schema import date_label

    return date_label(iso)


def _hz(values) -> str:
    """Frequencies to 0.1 Hz, ``-`` for a mode that was not measured."""
    return " ".join("-" if f is None else f"{f:.1f}" for f in values) or "-"


def _warn(entries) -> None:
    """Print what reading found implausible but kept (one line per holder, on stderr)."""
    for e in entries:
        for w in e.warnings:
            print(f"warning: {w}", file=sys.stderr)


# --------------------------------------------------------------------------- actions


def _list(lib, args) -> int:
    from taptune.cli.common import format_table, write_json
    from taptune.errors import InputError

    if args.limit < 0:
        raise InputError(f"--limit must be 0 (all) or more, got {args.limit}")
    limit = args.limit or None
    rows = lib.summaries(match=args.match, limit=limit)
    total = len(rows) if limit is None or len(rows) < limit else lib.count(args.match)
    for r in rows:
        for w in r.warnings:
            print(f"warning: {w}", file=sys.stderr)
    write_json({"library": lib.location, "match": args.match, "total": total,
                "holders": [r.to_dict() for r in rows]}, args.json)
    if args.json == "-":
        return 0
    if not rows:
        if args.match and total == 0 and lib.count():
            print(f"{lib.location}: no holder name contains {args.match!r}")
        else:
            print(f"{lib.location}: no holders yet (taptune identify saves one; taptune library import adds a file)")
        return 0
    table = [
        [r.name, r.interface, f"{r.k_tt:.3g}", f"{r.k_rr:.3g}", str(r.identifications), _date(r.last_identified),
         f"{r.last_verdict} {_date(r.last_checked)}" if r.last_verdict else ""]
        for r in rows
    ]
    print(format_table(table, ["name", "interface", "k_tt [N/m/mm]", "k_rr [N*m/rad/mm]", "identified", "last (UTC)",
                               "last check (UTC)"]))
    what = f" whose name contains {args.match!r}" if args.match else ""
    shown = f"{len(rows)} of {total:,} holders{what}" if total > len(rows) else \
        f"{len(rows)} holder{'s' if len(rows) != 1 else ''}{what}"
    more = " (--limit N shows more, --match TEXT fewer)" if total > len(rows) else ""
    print(f"{shown} in {lib.location}{more}")
    return 0


def _predictions(entry) -> list[dict]:
    """Predicted f1–f3 (± spread) at every identified tool and stick-out; failures as messages."""
    from taptune.errors import TaptuneError
    from taptune.library.exchange import identified_setups, predict_setup

    out = []
    for tool, stickout_mm in identified_setups(entry):
        row = {"tool": tool["name"], "stickout": stickout_mm}
        try:
            row.update(predict_setup(entry, tool, stickout_mm).to_dict())
        except (TaptuneError, ImportError) as err:
            # One unpredictable set-up must not hide the rest of the holder's record.
            row["error"] = str(err)
        out.append(row)
    return out


def _show_lines(lib, entry, predictions) -> list[str]:
    from taptune.library.schema import PARAM_UNITS
    from taptune.model.params import NAMES

    h = entry.holder
    length = sum(s["length"] for s in h["segments"])
    options = ", ".join(f"{k}={v}" for k, v in entry.model_options.items()) or "(defaults)"
    lines = [
        entry.name,
        f"  library    {lib.location}",
        f"  interface  {entry.interface}",
        f"  holder     {length:g} mm long, clamp length {h['clamp_length']:g} mm, {len(h['segments'])} segments, "
        f"{h['material']['density']:g} kg/m³, {h['material']['youngs_modulus']:g} GPa",
        f"  model      {options}",
        f"parameters (best; ± half-width over {len(entry.param_sets)} near-optimal sets)",
    ]
    spread = entry.spread()
    for k in NAMES:
        lines.append(f"  {k:<15} {getattr(entry.params, k):>11.4g} ± {spread[k]:<9.2g} {PARAM_UNITS[k]}")
    lines.append(f"identifications ({len(entry.identifications)})")
    for i, r in enumerate(entry.identifications, 1):
        lines.append(
            f"  {i:>2}. {r.date}  {r.recording}  sha256 {r.sha256[:12]}…  tool '{r.tool_name}' at {r.stickout_mm:g} mm"
        )
        lines.append(
            f"      seed {r.seed}, {r.evaluations} evaluations, objective {r.objective:.4g}, taptune {r.taptune_version}; "
            f"f measured [Hz] {_hz(r.bending_measured_hz)}, model {_hz(r.bending_model_hz)}"
        )
    if entry.checks:
        shown = entry.checks[-SHOW_CHECKS:]
        more = f", the last {len(shown)}" if len(shown) < len(entry.checks) else ""
        lines.append(f"checks by one tap ({len(entry.checks)}{more})")
        for c in shown:
            modes = ", ".join(f"f{m['mode']} {'-' if m['measured_hz'] is None else format(m['measured_hz'], '.1f')} "
                              f"vs {m['predicted_hz']:.1f} ± {m['band_hz']:.1f}" for m in c.modes)
            lines.append(f"  {_date(c.date)}  {c.verdict:<12}  {c.recording}  tool '{c.tool}' at {c.stickout_mm:g} mm: {modes} Hz")
    if predictions is not None:
        lines.append("predicted bending modes (± half-width of the band of the near-optimal sets, as taptune predict)")
        if not predictions:
            lines.append("  (no identification records: no tool to predict with)")
        for p in predictions:
            head = f"  tool '{p['tool']}' at {p['stickout']:g} mm:"
            if "error" in p:
                lines.append(f"{head} cannot predict ({p['error']})")
            else:
                modes = ", ".join(
                    f"f{n} {f:.1f} ± {s:.1f} Hz" for n, (f, s) in enumerate(zip(p["bending_hz"], p["bending_hz_spread"]), 1)
                )
                lines.append(f"{head} {modes}")
    return lines


def _show(lib, args) -> int:
    from taptune.cli.common import write_json

    entry = lib.get(args.name)
    _warn([entry])
    predictions = None if args.no_predict else _predictions(entry)
    data = {"library": lib.location, "holder": entry.to_dict(), "spread": entry.spread()}
    if predictions is not None:
        data["predictions"] = predictions
    write_json(data, args.json)
    if args.json != "-":
        print("\n".join(_show_lines(lib, entry, predictions)))
    return 0


def _export(lib, args) -> int:
    from taptune.library.exchange import export_library

    from taptune.cli.common import refuse_library_output

    fmt = args.format or ("csv" if args.out.lower().endswith(".csv") else "json")
    refuse_library_output(args.out, "export", args.library, protect=(lib.path,))
    count = export_library(lib, args.out, fmt)
    print(f"exported {count} holder{'s' if count != 1 else ''} from {lib.location} to {args.out} ({fmt})")
    return 0


def _import(lib, args) -> int:
    from taptune.library.exchange import import_library

    report = import_library(lib, args.file, replace=args.replace)
    print("\n".join(report.lines()))
    return 0


def _remove(lib, args) -> int:
    entry = lib.remove(args.name)
    print(f"removed holder '{entry.name}' from {lib.location}")
    return 0


def _receptance(lib, args) -> int:
    from taptune.io.assembly import load_assembly
    from taptune.library.exchange import frequency_grid, holder_receptance, receptance_format, write_receptance

    from taptune.cli.common import refuse_library_output

    receptance_format(args.out)  # a wrong extension fails before the model runs
    refuse_library_output(args.out, "receptance", args.library, protect=(lib.path,))
    entry = lib.get(args.name)
    freq = frequency_grid(args.fmin, args.fmax, args.df)
    assembly = load_assembly(args.assembly)
    if args.stickout is not None:
        assembly = assembly.with_stickout(args.stickout * 1e-3)
    if assembly.holder.name != entry.name:
        print(
            f"taptune library: note: {args.assembly} describes holder '{assembly.holder.name}'; "
            f"using its geometry with the contact parameters of library holder '{entry.name}'",
            file=sys.stderr,
        )
    H = holder_receptance(entry, assembly, freq)
    stickout_mm = assembly.stickout * 1e3
    kind = write_receptance(
        args.out, freq, H, name=entry.name, description=f"tool {assembly.tool.name} at {stickout_mm:g} mm stick-out"
    )
    print(
        f"wrote {args.out} ({kind}): tool-tip receptance [m/N] of '{entry.name}' with '{assembly.tool.name}' "
        f"at {stickout_mm:g} mm, {freq.size} frequencies {freq[0]:g}–{freq[-1]:g} Hz"
    )
    return 0


_ACTIONS = {
    "list": _list,
    "show": _show,
    "export": _export,
    "import": _import,
    "remove": _remove,
    "receptance": _receptance,
}
