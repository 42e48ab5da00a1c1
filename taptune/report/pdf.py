"""PDF reports of identifications: one page per recording (and a summary for a batch).

A page holds the measured spectrum with its peak labels and the fit
(:func:`taptune.report.fit_plot.draw_identification`), the identified parameters with
their spread over the near-optimal set, predicted f1–f3 ± the honest band at the
recorded stick-out and ±10/20 mm with how the band was made, and the provenance (file,
sha256, date, seed).

The work is split so that a batch can do the expensive part (predictions) in its worker
processes: :func:`report_pages` turns an identification into picklable
:class:`ReportPage` records; :func:`write_report` draws them. matplotlib (Agg) is
imported only when drawing.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Sequence

from taptune.errors import InputError
from taptune.identify.bands import WIDE_BAND
from taptune.io.atomic import atomic_write
from taptune.report.text import number

PAGE_SIZE_IN = (11.69, 8.27)  # A4 landscape
STICKOUT_OFFSETS_MM = (-20.0, -10.0, 0.0, 10.0, 20.0)
SUMMARY_ROWS_PER_PAGE = 28
_SPREAD_FORMAT = "{:.2g}"
# Symbols of the parameters on the page; values print with 4 significant digits unless set here.
_SYMBOLS = {"eta_tt": "η_tt", "eta_rr": "η_rr", "alpha": "α", "density_factor": "ρ factor", "modulus_factor": "E factor"}
_FORMATS = {"eta_tt": "{:.3g}", "eta_rr": "{:.3g}", "alpha": "{:+.2f}", "density_factor": "{:.4f}", "modulus_factor": "{:.4f}"}


@dataclass(frozen=True)
class PredictionRow:
    """Predicted f1–f3 ± spread [Hz] and ζ1 at one stick-out [mm]; ``note`` says why not, if impossible."""

    stickout_mm: float
    bending_hz: tuple[float, ...] = ()
    bending_hz_spread: tuple[float, ...] = ()
    damping_ratio: float | None = None
    note: str = ""
    band: dict | None = None  # the band's make-up (identify.bands.Band.to_dict)
    band_text: str = ""  # how sure, in plain words


@dataclass(frozen=True)
class ReportPage:
    """Everything one report page shows (picklable: a batch worker builds it, the parent draws it)."""

    file: str
    holder: str
    tool: str
    stickout_mm: float
    sha256: str
    date: str
    result: object  # Identification of this recording alone (see recording_view)
    analysis: object  # SpectrumAnalysis
    predictions: tuple[PredictionRow, ...]
    joint_files: tuple[str, ...] = ()
    joint_objective: float | None = None
    machine: object | None = None  # report.machine_page.MachineView (batch --machine): a row of FRF and lobes


def recording_view(result, index: int):
    """The identification as seen by recording ``index`` of a (joint) fit.

    The parameters and the near-optimal set are shared; the per-recording fields
    (frequencies, damping, window, shapes, objective terms) are this recording's, and
    ``objective`` is this recording's share of the joint objective.
    """
    if len(result.bending_measured_hz) == 1 and index == 0:
        return result
    terms = result.objective_terms[index]
    return replace(
        result,
        bending_measured_hz=(result.bending_measured_hz[index],),
        bending_model_hz=(result.bending_model_hz[index],),
        damping_model=(result.damping_model[index],),
        objective=float(sum(terms)),
        objective_terms=(terms,),
        window_hz=(result.window_hz[index],),
        measured_shape=(result.measured_shape[index],),
        model_shape=(result.model_shape[index],),
    )


def report_stickouts_mm(stickout_mm: float) -> list[float]:
    """The stick-outs a page predicts [mm]: the recorded one and ±10, ±20 mm."""
    return [round(stickout_mm + d, 6) for d in STICKOUT_OFFSETS_MM]


def predict_rows(param_sets, assembly, model_options=None, relative_floor: float = 5e-4,
                 identified=None, measured_modes=None) -> tuple[PredictionRow, ...]:
    """Predictions at :func:`report_stickouts_mm`; an impossible stick-out gets a note, not an error.

    ``identified`` are the assemblies the parameters were identified on (default
    ``[assembly]``): they set the honest band (:mod:`taptune.identify.bands`).
    """
    from taptune.identify import predict

    identified = list(identified) if identified else [assembly]
    rows = []
    for s in report_stickouts_mm(assembly.stickout * 1e3):
        try:
            p = predict(param_sets, assembly.with_stickout(s * 1e-3), model_options, relative_floor=relative_floor,
                        identified=identified, measured_modes=measured_modes)
        except InputError:
            rows.append(PredictionRow(s, note="geometry not possible"))
            continue
        rows.append(PredictionRow(s, p.bending_hz, p.bending_hz_spread, p.damping_ratio[0],
                                  band=p.band.to_dict(), band_text=p.band_text()))
    return tuple(rows)


def band_lines(rows: Sequence[PredictionRow], width: int = 66) -> list[str]:
    """How the ± of the prediction table was made, for the page (the farthest stick-out's words)."""
    rows = [r for r in rows if r.band]
    if not rows:
        return []
    far = max(rows, key=lambda r: r.band.get("delta_stickout_mm") or 0.0)
    b = far.band
    lines = textwrap.wrap(f"band ± = {b['method']} (set: near-optimal fits; geometry: stated tolerances; "
                          f"model form: calibrated, {b['calibration']})", width, subsequent_indent="  ")
    lines += textwrap.wrap(f"at {far.stickout_mm:g} mm: {far.band_text}", width, subsequent_indent="  ")
    if b.get("recordings", 0) < 2 and max(s / f for s, f in zip(far.bending_hz_spread, far.bending_hz)) > WIDE_BAND:
        lines += textwrap.wrap("to narrow it: tap once more at a stick-out ~20 mm different and identify both "
                               "recordings together", width, subsequent_indent="  ")
    return lines


def _sha256(path: str) -> str:
    from taptune.library.schema import sha256_file

    try:
        return sha256_file(path) if path else ""
    except OSError:
        return ""


def report_pages(result, analyses, recordings, assemblies, model_options=None, sha256s=None) -> list[ReportPage]:
    """One :class:`ReportPage` per recording of an identification (predictions computed here).

    ``sha256s``: the recordings' hashes where the caller has them already (batch hashes
    every file while planning); otherwise each file is hashed here.
    """
    from taptune.identify.bands import measured_modes
    from taptune.library.schema import utc_now

    date = utc_now()
    files = tuple(getattr(r, "path", "") for r in recordings)
    joint = len(recordings) > 1
    pages = []
    for k, (rec, asm, analysis) in enumerate(zip(recordings, assemblies, analyses)):
        pages.append(ReportPage(
            file=files[k] or "<recording>",
            holder=asm.holder.name,
            tool=asm.tool.name,
            stickout_mm=asm.stickout * 1e3,
            sha256=sha256s[k] if sha256s is not None else _sha256(files[k]),
            date=date,
            result=recording_view(result, k),
            analysis=analysis,
            predictions=predict_rows(result.param_sets, asm, model_options, result.relative_floor, assemblies,
                                     measured_modes(result.bending_measured_hz)),
            joint_files=files if joint else (),
            joint_objective=result.objective if joint else None,
        ))
    return pages


# ----------------------------------------------------------------------------- drawing


def _table(ax, cells, header, col_widths, title: str, font: float = 8.5, left=(0,)) -> None:
    """A plain table filling the top of ``ax`` (axis hidden); text columns ``left`` are left-aligned."""
    ax.axis("off")
    ax.set_title(title, fontsize=10, loc="left", fontweight="bold")
    table = ax.table(cellText=cells, colLabels=header, colWidths=col_widths, loc="upper center", cellLoc="right")
    table.auto_set_font_size(False)
    table.set_fontsize(font)
    table.scale(1.0, 1.25)
    for (r, c), cell in table.get_celld().items():
        cell.set_edgecolor("0.75")
        if r == 0:
            cell.set_facecolor("0.92")
            cell.set_text_props(fontweight="bold")
        if c in left:
            cell.set_text_props(ha="left")
            cell._loc = "left"


def parameter_cells(result) -> list[list[str]]:
    """Rows (parameter, value, ± spread, unit) of the parameter table, in :data:`NAMES` order."""
    from taptune.library.schema import PARAM_UNITS
    from taptune.model.params import NAMES

    spread = result.param_spread
    return [
        [_SYMBOLS.get(name, name), number(getattr(result.params, name), _FORMATS.get(name, "{:.4g}")),
         "± " + _SPREAD_FORMAT.format(spread[name]), PARAM_UNITS[name]]
        for name in NAMES
    ]


def prediction_cells(rows: Sequence[PredictionRow], recorded_mm: float) -> list[list[str]]:
    """Rows (stick-out, f1, f2, f3 ± spread, ζ1) of the prediction table; the recorded stick-out is marked."""
    out = []
    for p in rows:
        mark = " *" if abs(p.stickout_mm - recorded_mm) < 1e-6 else ""
        if p.note:
            out.append([f"{p.stickout_mm:.1f}{mark}", p.note, "", "", ""])
            continue
        freqs = [f"{f:.0f} ± {s:.0f}" for f, s in zip(p.bending_hz, p.bending_hz_spread)]
        freqs += [""] * (3 - len(freqs))
        out.append([f"{p.stickout_mm:.1f}{mark}", *freqs[:3], f"{100 * p.damping_ratio:.3f}"])
    return out


def provenance_text(page: ReportPage) -> str:
    """The provenance block: file, hash, date, seed, objective, joint partners, warnings."""
    r = page.result
    lines = [
        f"file      {Path(page.file).name}",
        f"folder    {_shorten(str(Path(page.file).parent), 60)}",
        f"sha256    {page.sha256[:16] + '…' if page.sha256 else '—'}",
        f"date      {page.date}",
        f"seed      {r.seed}    evaluations {r.evaluations}    {r.seconds:.1f} s",
        f"objective {r.objective:.4g}" + (f"  (joint {page.joint_objective:.4g})" if page.joint_objective is not None else ""),
        f"tool      {_shorten(page.tool, 60)}",
    ]
    if page.joint_files:
        others = [Path(f).name for f in page.joint_files if f != page.file]
        lines.append(_shorten("joint fit with " + ", ".join(others), 80))
    lines += band_lines(page.predictions)
    warnings = list(getattr(page.analysis, "warnings", ())) + list(r.warnings)
    for w in warnings[:3]:
        lines += textwrap.wrap("warning: " + w, 66, subsequent_indent="  ")[:2]
    if len(warnings) > 3:
        lines.append(f"… and {len(warnings) - 3} more warnings")
    return "\n".join(lines)


def _shorten(text: str, width: int, keep_start: bool = False) -> str:
    """At most ``width`` characters; paths keep their end, names their start."""
    if len(text) <= width:
        return text
    return text[: width - 1] + "…" if keep_start else "…" + text[-(width - 1):]


def draw_page(fig, page: ReportPage) -> None:
    """Fill an A4-landscape figure with one recording's report page."""
    from taptune.report.fit_plot import draw_identification

    fig.suptitle(f"{page.holder} — {Path(page.file).name} — stick-out {page.stickout_mm:.1f} mm",
                 fontsize=12, fontweight="bold")
    left, right = _machine_row(fig, page).subfigures(1, 2, width_ratios=[1.2, 1], wspace=0.02)
    draw_identification(left, page.result, [page.analysis], title="")
    left.suptitle("")  # the parameters are in the table on the right, with their spread
    axes = right.subplots(3, 1, gridspec_kw={"height_ratios": [1.15, 0.95, 1.3]})
    _table(axes[0], parameter_cells(page.result), ["parameter", "value", "spread", "unit"],
           [0.22, 0.28, 0.22, 0.28], "Identified parameters (± half-range of the near-optimal set)")
    _table(axes[1], prediction_cells(page.predictions, page.stickout_mm),
           ["stick-out", "f1", "f2", "f3", "ζ1 [%]"],
           [0.17, 0.22, 0.22, 0.22, 0.14], "Predicted bending modes [Hz] (stick-out in mm, * = recorded)")
    axes[2].axis("off")
    axes[2].set_title("Provenance", fontsize=10, loc="left", fontweight="bold")
    axes[2].text(0.0, 1.0, provenance_text(page), va="top", ha="left", family="monospace", fontsize=7.5,
                 transform=axes[2].transAxes)


def _machine_row(fig, page: ReportPage):
    """Draw the machine row (tool-point FRF, lobes) at the bottom if the page has one; the figure left above."""
    if page.machine is None:
        return fig
    from taptune.report.machine_page import draw_machine

    top, bottom = fig.subfigures(2, 1, height_ratios=[1.9, 1], hspace=0.02)
    draw_machine(bottom, page.machine)
    return top


def draw_summary_page(fig, rows, first: int, title: str) -> None:
    """A table of batch rows ``first…first+SUMMARY_ROWS_PER_PAGE`` (file, holder, status, f1–f3, message)."""
    ax = fig.add_subplot(1, 1, 1)
    chunk = rows[first:first + SUMMARY_ROWS_PER_PAGE]
    cells = []
    for r in chunk:
        model = ["" if f is None else f"{f:.0f}" for f in r.model_hz]
        cells.append([_shorten(r.file, 46), _shorten(r.holder, 26, True), r.status, *model,
                      _shorten(r.message, 70, True)])
    fig.suptitle(title, fontsize=12, fontweight="bold")
    _table(ax, cells, ["file", "holder", "status", "f1 [Hz]", "f2 [Hz]", "f3 [Hz]", "message"],
           [0.27, 0.15, 0.06, 0.06, 0.06, 0.06, 0.34], "", font=7, left=(0, 1, 2, 6))


def write_report(path, pages: Sequence[ReportPage], summary_rows: Sequence = (), title: str = "taptune report") -> None:
    """Write the PDF: summary pages for ``summary_rows`` (if any), then one page per :class:`ReportPage`."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    def write(tmp) -> None:
        with PdfPages(tmp, metadata={"Title": title, "Creator": "taptune"}) as pdf:
            n_summary = -(-len(summary_rows) // SUMMARY_ROWS_PER_PAGE)
            for k in range(n_summary):
                fig = plt.figure(figsize=PAGE_SIZE_IN, layout="constrained")
                draw_summary_page(fig, summary_rows, k * SUMMARY_ROWS_PER_PAGE, f"{title} — summary ({k + 1}/{n_summary})")
                pdf.savefig(fig)
                plt.close(fig)
            for page in pages:
                fig = plt.figure(figsize=PAGE_SIZE_IN, layout="constrained")
                draw_page(fig, page)
                pdf.savefig(fig)
                plt.close(fig)

    try:
        atomic_write(path, write)  # a reader never sees half a report
    except OSError as err:
        raise InputError(f"{path}: cannot write the report ({err.strerror})") from None


def write_identification_report(path, result, analyses, recordings, assemblies, model_options=None) -> None:
    """The report of one ``taptune identify`` run: one page per recording."""
    write_report(path, report_pages(result, analyses, recordings, assemblies, model_options),
                 title=f"taptune identification — {assemblies[0].holder.name}")


def write_batch_report(path, pages: Sequence[ReportPage], rows: Sequence) -> None:
    """The report of a batch: the summary table of every file, then a page per identified recording."""
    write_report(path, sorted(pages, key=lambda p: p.file), rows, title="taptune batch")
