"""The machine part of a job (``taptune batch --machine``): the identified holder on the spindle.

After the identification, in the worker: the tool-point FRF (x, y) of the recording's
assembly with the identified parameters, coupled to the machine's spindle (as ``taptune
toolpoint``), and the stability lobes of the cut (as ``taptune lobes``). The lobes go to
a CSV beside the result JSON; the JSON gets a moderate ``machine`` object (modes,
critical depth, best pockets, the CSV's name). A failure here (e.g. a tool reaching
behind the coupling plane) fails only this part: the identification stays.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from taptune.batch.records import MachineSetup, one_line
from taptune.cli.cmd_lobes import lobes_json, write_lobes_csv
from taptune.cli.cut import rpm_grid, tool_diameter_mm
from taptune.errors import InputError
from taptune.machine import toolpoint_frf
from taptune.machine.band import band_from_prediction, lobes_with_band
from taptune.machine.plane import interface_warning, plane_warning
from taptune.report.machine_page import MachineView

JSON_POCKETS = 10  # the best pockets in the JSON; every speed is in the CSV
LOBES_SUFFIX = ".lobes.csv"
MACHINE_FAILED = "machine part failed:"  # how a summary message starts when only the machine part failed


@dataclass(frozen=True)
class MachinePart:
    """The machine part of one recording: the JSON object, the summary numbers, the report view.

    ``error`` is the one-line reason when it failed (then only ``record`` and ``view`` say so).
    """

    record: dict
    a_crit_mm: float | None = None
    best_pocket: tuple[float, float] | None = None  # (rpm, a_lim [mm])
    view: MachineView | None = None
    error: str = ""


def lobes_csv_path(json_path: Path) -> Path:
    """``tap.json`` → ``tap.lobes.csv`` beside it."""
    return json_path.with_name(json_path.stem + LOBES_SUFFIX)


def machine_part(params, model_options, assembly, setup: MachineSetup, json_path: Path) -> MachinePart:
    """Tool-point FRF and lobes of ``assembly`` with the identified ``params`` on ``setup.machine``.

    Writes the lobes CSV beside ``json_path``. Bad input (a tool behind the coupling
    plane, an ae wider than the tool…) gives a failed part, never an exception.
    """
    machine, cut = setup.machine, setup.cut
    base = {"machine": machine.name, "file": setup.path, "contact": setup.contact}
    title = f"On {machine.name}"
    try:
        frf = toolpoint_frf(assembly, params, {"x": machine.x, "y": machine.y}, setup.freq_hz, model_options,
                            contact=setup.contact)
        diameter_mm = cut.diameter_mm if cut.diameter_mm is not None else tool_diameter_mm(assembly)
        rpm = rpm_grid(cut.rpm, frf.freq_hz, frf.xx, frf.yy, cut.teeth, machine.max_rpm)
        flute = assembly.tool.flute_length
        lobes, band = lobes_with_band(frf.freq_hz, frf.xx, frf.yy, teeth=cut.teeth, ktc=cut.ktc, krc=cut.krc,
                                      diameter=diameter_mm * 1e-3, ae=cut.ae_mm * 1e-3, milling=cut.milling, rpm=rpm,
                                      method="auto", band=identified_band(params, model_options, assembly),
                                      depth_cap=flute if flute is not None else float("inf"))
    except InputError as err:
        lobes_csv_path(json_path).unlink(missing_ok=True)  # a --force rerun leaves no lobes of an older result
        return failed_part(base, title, one_line(err))
    out = lobes_json(lobes, band)
    csv_path = lobes_csv_path(json_path)
    write_lobes_csv(str(csv_path), out)
    record = {
        **base,
        "stickout_mm": round(frf.stickout * 1e3, 6),
        "coupling_plane_mm": round(frf.coupling_plane * 1e3, 6),
        "frequency_hz": [float(frf.freq_hz[0]), float(frf.freq_hz[-1])],
        "modes": [{**m.to_dict(), "magnitude_um_per_n": float(f"{m.magnitude * 1e6:.5g}")} for m in frf.modes],
        "cut": cut.to_dict(diameter_mm),
        "rpm": [out["rpm"][0], out["rpm"][-1]],
        "a_crit_mm": out["a_crit_mm"],
        "pockets": out["pockets"][:JSON_POCKETS],
        "method": out["method"],
        "confidence": out["confidence"],
        "safe_pockets": out["safe_pockets"][:JSON_POCKETS],
        "depth_cap_mm": out["depth_cap_mm"],
        "band_sources": out["band_sources"],
        "lobes_csv": csv_path.name,
        "warnings": _warnings(assembly, machine, lobes),
    }
    # The best safe pocket is the advice (a window a machinist can hold); the sharpest lobe
    # peak when there is none.
    best = ((out["safe_pockets"][0]["rpm"], out["safe_pockets"][0]["a_mm"]) if out["safe_pockets"]
            else (out["pockets"][0]["rpm"], out["pockets"][0]["a_lim_mm"]) if out["pockets"] else None)
    view = MachineView(
        title=(f"On {machine.name}: tool point (contact {setup.contact}) and lobes — "
               f"critical depth {out['a_crit_mm']:.3g} mm"),
        freq_hz=frf.freq_hz, xx=frf.xx, yy=frf.yy,
        modes=tuple((m.hz, m.direction) for m in frf.modes),
        rpm=lobes.rpm, a_lim_mm=np.where(np.isfinite(lobes.a_lim), lobes.a_lim * 1e3, np.nan),
        a_crit_mm=out["a_crit_mm"], pockets=tuple(out["pockets"][:JSON_POCKETS]), cut=cut.describe(diameter_mm),
    )
    return MachinePart(record, out["a_crit_mm"], best, view)


def identified_band(params, model_options, assembly) -> tuple:
    """The prediction band of the just-identified holder on its own assembly (one parameter
    set: the fit's floor, the assembly's geometry tolerances and the model-form term)."""
    from taptune.identify.core import predict

    try:
        return band_from_prediction(predict([params], assembly, model_options, identified=[assembly]))
    except InputError as err:
        return 0.0, 0.9, f"none ({one_line(err)})"


def failed_part(base: dict, title: str, message: str) -> MachinePart:
    """A machine part that could not be computed: the reason in the JSON, the summary and the page."""
    return MachinePart({**base, "error": message}, view=MachineView(title=title, error=message), error=message)


def _warnings(assembly, machine, lobes) -> list[str]:
    warnings = list(lobes.warnings)
    if interface := interface_warning(machine.interface, assembly.holder):
        warnings.append(interface)
    if machine.y_from_x:
        warnings.append("the machine file has no [spindle] y; the x receptance is used for y")
    if plane := plane_warning(assembly.holder, assembly.source):
        warnings.append(plane)
    return warnings


def skipped_note(row, data: dict | None, setup: MachineSetup | None, assembly, json_path: Path | None = None,
                 params=None, model_options=None):
    """A skipped row with its machine numbers: those of its previous result JSON ``data`` when
    they were computed on the same machine file with the same cut and contact, else computed
    now from the parameters identified before (``params``, or the JSON's ``params``); the
    JSON at ``json_path`` gets the new ``machine`` object (atomically; nothing else changes)."""
    if setup is None:
        return row
    from dataclasses import replace

    previous = (data or {}).get("machine")
    diameter_mm = setup.cut.diameter_mm if setup.cut.diameter_mm is not None else tool_diameter_mm(assembly)
    same = (isinstance(previous, dict) and "error" not in previous and previous.get("file") == setup.path
            and previous.get("contact") == setup.contact and previous.get("cut") == setup.cut.to_dict(diameter_mm)
            and "safe_pockets" in previous)
    if not same:
        params = params if params is not None else _previous_params(data)
        if params is None or json_path is None:
            return replace(row, message=f"{row.message}; machine part not run: the parameters identified before "
                                        "are not at hand (--force to identify it again with --machine)")
        part = machine_part(params, model_options, assembly, setup, json_path)
        if data is not None and json_path.is_file():
            from taptune.cli.common import write_json

            write_json({**data, "machine": part.record}, str(json_path))
        if part.error:
            return replace(row, message=f"{row.message}; {MACHINE_FAILED} {part.error}")
        best = part.best_pocket or (None, None)
        return replace(row, message=f"{row.message}; machine part computed now", a_crit_mm=part.a_crit_mm,
                       best_pocket_rpm=best[0], best_pocket_a_lim_mm=best[1])
    pockets = previous.get("safe_pockets") or [{}]
    return replace(row, a_crit_mm=previous.get("a_crit_mm"), best_pocket_rpm=pockets[0].get("rpm"),
                   best_pocket_a_lim_mm=pockets[0].get("a_mm"))


def _previous_params(data: dict | None):
    """The holder parameters a previous result JSON holds, or None."""
    from taptune.model.params import HolderParams

    raw = (data or {}).get("params")
    if not isinstance(raw, dict):
        return None
    try:
        return HolderParams.from_dict(raw, "previous result")
    except (InputError, ValueError, TypeError, KeyError):
        return None
