"""Peak labels (docs/physics.md §4): ``bending`` modes 1–3, ``local`` interface modes, ``other``.

*local* — the spindle interface's own modes. They are known only as frequency bands
per interface (HSK-A63: 9.35–10.55 kHz around the published 9.7 and 10.2 kHz, wide
enough for the few percent they move from holder to holder); the table is extendable by
a TOML/JSON file. A second recording tapped on the interface itself marks them exactly:
the peaks that grow.

*bending* — with model guidance (``expected_hz`` from nominal or library parameters,
``bounds_hz`` from ``bending_bounds``) the three modes are assigned *jointly*: every ascending choice
of peaks inside the modes' bounds is scored by how well one explanation accounts for
all of them — a shift common to all modes (material factors) plus a contact shift that
moves each mode in proportion to its distance from its rigid-contact bound (contact-
sensitive modes move much, holder modes hardly). A spurious peak that happens to lie
nearer one expected frequency than the true mode then loses, because it asks the other
modes to have moved the other way. The interface band never silently removes a peak the
model claims; it only adds a small cost. Without guidance the three most prominent
peaks outside the bands are a best guess.

*other* — everything else: stationary peaks (hum and its harmonics, present between
taps), axial and torsional modes, doublet partners, room and table resonances.
"""

from __future__ import annotations

import itertools
import json
import os
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from taptune.errors import InputError
from taptune.io.files import BANDS_ENV, read_text
from taptune.signal.peaks import Peak

#: Local-mode bands of one interface: ((lo_hz, hi_hz), ...).
Bands = tuple[tuple[float, float], ...]
#: Built-in local-mode bands [Hz] per spindle interface.
BUILTIN_BANDS: dict[str, Bands] = {
    "HSK-A63": ((9350.0, 10550.0),),
}
#: Frequency factor of the material corner in the upper bounds of ``bending_bounds``
#: (modulus factor 1.10, density factor 0.95).
UPPER_BOUND_MATERIAL = float(np.sqrt(1.10 / 0.95))
# BANDS_ENV (taptune.io.files) names an extra band table (TOML or JSON).


def _norm(name: str) -> str:
    return "".join(ch for ch in str(name).upper() if ch.isalnum())


def load_band_table(path) -> dict[str, Bands]:
    """Read a user table of interface local-mode bands.

    The file (TOML or JSON) maps interface names to lists of ``[lo_hz, hi_hz]`` pairs,
    either directly (``"HSK-A100" = [[6100, 6900]]``) or under a ``local_hz`` key
    (``[interfaces."HSK-A100"] local_hz = [[6100, 6900]]``; an ``interfaces`` table is
    optional).

    Raises
    ------
    InputError
        Unreadable file or malformed entries (names the file and the entry).
    """
    p = Path(path)
    text = read_text(p, "an interface band table", "TOML or JSON")
    try:
        data = json.loads(text) if p.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as err:
        raise InputError(f"{path}: not a valid band table ({' '.join(str(err).split())})") from None
    if isinstance(data, dict) and isinstance(data.get("interfaces"), dict):
        data = data["interfaces"]
    if not isinstance(data, dict):
        raise InputError(f"{path}: a band table maps interface names to [[lo_hz, hi_hz], ...]")
    if not data:
        raise InputError(f"{path}: the band table names no interface")
    table = {}
    for name, entry in data.items():
        if isinstance(entry, dict):
            if "local_hz" not in entry:
                # e.g. an assembly file given by mistake: its [holder] table has no bands.
                raise InputError(f"{path}: interface {name!r} has no local_hz bands (is this a band table?)")
            entry = entry["local_hz"]
        try:
            bands = tuple((float(lo), float(hi)) for lo, hi in entry)
        except (TypeError, ValueError):
            raise InputError(f"{path}: interface {name!r}: bands must be [[lo_hz, hi_hz], ...]") from None
        for lo, hi in bands:
            if not (0 < lo < hi):
                raise InputError(f"{path}: interface {name!r}: band [{lo}, {hi}] must have 0 < lo < hi")
        table[str(name)] = bands
    return table


def interface_bands(interface: str | None, table_path=None) -> tuple[Bands, str | None]:
    """Local-mode bands [Hz] of a spindle interface, and a warning when none are known.

    Looks in ``table_path``, then the file named by ``$TAPTUNE_INTERFACE_BANDS``, then
    the built-in table; names match ignoring case, spaces and dashes.

    Returns
    -------
    bands : tuple of (lo_hz, hi_hz)
    warning : str or None
    """
    if not interface:
        return (), None
    tables = []
    for src in (table_path, os.environ.get(BANDS_ENV)):
        if src:
            tables.append(load_band_table(src))
    tables.append(BUILTIN_BANDS)
    key = _norm(interface)
    for t in tables:
        for name, bands in t.items():
            if _norm(name) == key:
                return tuple(bands), None
    return (), (f"no local-mode band known for interface {interface!r}: its local modes are "
                f"not excluded (add it to a band table, see ${BANDS_ENV})")


def in_bands(hz: float, bands) -> bool:
    """Whether ``hz`` lies inside any (lo, hi) band."""
    return any(lo <= hz <= hi for lo, hi in bands)


@dataclass(frozen=True)
class LabelOptions:
    """Weights of the joint bending assignment (see module docstring).

    sigma_mode : float
        Spread of a mode's log-frequency around the two-term explanation (bounds only).
    sigma_mode_spread : float
        The same around the explanation by the model's parameter spreads (sharper).
    sigma_common : float
        Prior spread of the shift common to all modes (material factors, model error).
    sigma_contact : float
        Prior spread of the contact shift, in units of each mode's distance to its
        rigid-contact bound.
    missing_cost : tuple of float
        Cost of leaving mode 1, 2, 3 (and any further) unassigned: mode 1 of a tip tap
        is nearly always clearly there, modes 2 and 3 can be faint.
    band_cost : float
        Extra cost of taking a peak inside an interface band as a bending mode: a
        little below the cost of a missing mode 2 or 3, so the band gives way only to
        a peak that fits the model's explanation closely.
    weak_prominence_db : float
        Peaks less prominent than this pay up to 1 unit, in proportion.
    min_guess_hz : float
        Without model guidance, bending guesses are taken above this frequency
        (free-free tool-holder assemblies have f1 of a few kHz: a 1 kHz f1 would take a
        steel bar about 0.5 m long at 60 mm diameter); loud peaks below it are named in a
        warning, never guessed.
    max_candidates : int
        Candidates per mode considered (the nearest to the expected frequency); loud
        peaks inside the mode's bounds are considered too, however far.
    loud_prominence_db, loud_level_db : float
        A peak at least this prominent and this loud (re the loudest peak of the
        recording), outside the interface bands, is *loud*: a tip tap excites bending
        modes far more than anything else, so it is rarely spurious.
    unexplained_cost : float
        Cost of leaving a loud peak unassigned while a mode whose bounds hold it is
        missing, or took a peak more than ``louder_db`` quieter (docs/physics.md §4: a band
        or a distant guess must not silently drop it).
    louder_db : float
    faint_cost : float
        Extra cost of taking a faint peak (``Peak.reliability == "faint"``) as a bending
        mode: a clear peak that the explanation accounts for as well wins.
    faint_window_sigmas : float
        Half-width of the guided search window of a missing mode (:func:`guided_windows`)
        in standard deviations of its predicted log-frequency.
    """

    # Defaults chosen on synthetic recordings of random holders (the model's tip
    # receptance plus workshop nuisances), not on the development cases.
    sigma_mode: float = 0.03
    sigma_mode_spread: float = 0.02
    sigma_common: float = 0.04
    sigma_contact: float = 1.0
    missing_cost: tuple = (9.0, 3.0, 3.0)
    band_cost: float = 2.5
    weak_prominence_db: float = 12.0
    min_guess_hz: float = 1000.0
    max_candidates: int = 8
    loud_prominence_db: float = 20.0
    loud_level_db: float = -12.0
    unexplained_cost: float = 2.0
    louder_db: float = 6.0
    faint_cost: float = 1.0
    faint_window_sigmas: float = 3.0


def _explain_cost(r, basis, sigma_mode: float) -> float:
    """Min over a of Σ((r − basis·a)/σ)² + |a|²: how well unit-variance parameter shifts
    explain the log-frequency shifts ``r`` (n,); ``basis`` (n, k) is ln f per unit shift."""
    a = basis / sigma_mode
    b = r / sigma_mode
    coef = np.linalg.solve(a.T @ a + np.eye(a.shape[1]), a.T @ b)
    res = b - a @ coef
    return float(res @ res + coef @ coef)


def _missing(o: LabelOptions, mode_index: int) -> float:
    costs = tuple(np.atleast_1d(o.missing_cost))
    return float(costs[min(mode_index, len(costs) - 1)])


@dataclass(frozen=True)
class Labeling:
    """One assignment of peaks to bending modes and what it costs.

    modes : tuple of (int or None)
        Index into the peaks per mode, None where the mode is left unassigned.
    cost : float
        Total cost (lower is more plausible).
    prior : float
        The part that comes from the model guidance (how well the nominal explanation
        accounts for the chosen frequencies): a fit of the labeling replaces it.
    unexplained : int
        Loud peaks (:func:`loud_peaks`) it leaves out although a mode whose range holds
        them is missing or took a peak more than ``louder_db`` quieter.
    """

    modes: tuple
    cost: float
    prior: float
    unexplained: int = 0

    @property
    def label_cost(self) -> float:
        """The cost without the guidance's explanation: missing modes, band, weak and loud peaks."""
        return self.cost - self.prior


def loud_peaks(peaks: list[Peak], ok, bands, options: LabelOptions) -> list[bool]:
    """Peaks too loud to leave unexplained: clear, outside the interface bands, candidates."""
    return [bool(ok[i]) and not in_bands(p.hz, bands) and p.prominence_db >= options.loud_prominence_db
            and p.level_db >= options.loud_level_db for i, p in enumerate(peaks)]


def _guidance(e, bounds_hz, spread_hz, options: LabelOptions):
    """(bounds (n, 2), log-frequency basis (n, k) per unit parameter shift, σ of a mode)."""
    n = e.size
    if bounds_hz is None:
        bnd = np.column_stack([e / 1.3, e * 1.3])
        rigid = e * 1.05
    else:
        bnd = np.asarray(bounds_hz, dtype=np.float64).reshape(n, 2)
        # The upper bound is the rigid contact with the stiffest, lightest holder
        # material of the search space (``bending_bounds``): take the material factor out.
        rigid = bnd[:, 1] / UPPER_BOUND_MATERIAL
    # Each mode's sensitivity to the contact: log-distance from nominal to rigid contact
    # (the tool's modes move a lot with the contact, a holder mode hardly).
    w = np.maximum(np.log(np.maximum(rigid, e) / e), 0.005)
    if spread_hz is not None:
        basis = np.log1p(np.asarray(spread_hz, dtype=np.float64).reshape(n, -1) / e[:, None])
        return bnd, basis, options.sigma_mode_spread
    basis = np.column_stack([np.full(n, options.sigma_common), options.sigma_contact * w])
    return bnd, basis, options.sigma_mode


def guided_windows(expected_hz, bounds_hz=None, spread_hz=None, found=None, *,
                   options: LabelOptions = LabelOptions()) -> dict[int, tuple[float, float]]:
    """Where each missing bending mode can plausibly be, given the modes already found.

    The found modes' log-frequency shifts from the expectation are explained by unit-
    variance parameter shifts (as in :func:`ranked_labelings`: the model's spreads, or a
    common and a contact shift); the explanation predicts each missing mode's shift and
    its variance. The window is that prediction ± ``options.faint_window_sigmas``
    standard deviations (the prediction's and the model's ``σ`` of a mode combined),
    inside the physical bounds and strictly between the neighbouring found modes.

    Parameters
    ----------
    expected_hz, bounds_hz, spread_hz : array_like
        Model guidance, shapes (n,), (n, 2), (n, k) [Hz] (see :func:`assign_bending`).
    found : dict, optional
        {mode (1-based): frequency [Hz]} of the modes already labelled.

    Returns
    -------
    dict
        {mode: (lo_hz, hi_hz)} for each missing mode with a non-empty window.
    """
    e = np.asarray(expected_hz, dtype=np.float64)
    n = e.size
    found = dict(found or {})
    bnd, basis, sigma = _guidance(e, bounds_hz, spread_hz, options)
    known = sorted(m - 1 for m in found if 1 <= m <= n)
    a = basis[known] / sigma if known else np.zeros((0, basis.shape[1]))
    cov = np.linalg.inv(a.T @ a + np.eye(basis.shape[1]))
    coef = cov @ (a.T @ (np.log([found[m + 1] / e[m] for m in known]) / sigma)) if known else np.zeros(basis.shape[1])
    out = {}
    for m in range(n):
        if m + 1 in found:
            continue
        shift = float(basis[m] @ coef)
        sd = float(np.sqrt(basis[m] @ cov @ basis[m] + sigma**2))
        half = options.faint_window_sigmas * sd
        lo, hi = e[m] * np.exp(shift - half), e[m] * np.exp(shift + half)
        lo, hi = max(lo, bnd[m, 0]), min(hi, bnd[m, 1])
        below = [found[j + 1] for j in known if j < m]
        above = [found[j + 1] for j in known if j > m]
        if below:
            lo = max(lo, 1.01 * max(below))
        if above:
            hi = min(hi, min(above) / 1.01)
        if hi > lo:
            out[m + 1] = (float(lo), float(hi))
    return out


def faint_windows(windows, bands=(), peaks=(), guard_rel: float = 3e-3, guard_hz: float = 20.0):
    """The search windows without the interface bands and the surroundings of known peaks.

    Parameters
    ----------
    windows : iterable of (lo_hz, hi_hz)
    bands : sequence of (lo, hi)
        Interface bands [Hz]: the loud local modes and their skirts are not searched.
    peaks : sequence of Peak
        Peaks already picked: ± max(``guard_rel`` × f, ``guard_hz``) around each is left
        out (the guided search looks for what the picking missed, not for its skirts).

    Returns
    -------
    list of (lo_hz, hi_hz)
        Disjoint, ascending.
    """
    cuts = [(lo, hi) for lo, hi in bands]
    cuts += [(p.hz - max(guard_rel * p.hz, guard_hz), p.hz + max(guard_rel * p.hz, guard_hz)) for p in peaks]
    out = []
    for lo, hi in sorted(windows):
        parts = [(float(lo), float(hi))]
        for c0, c1 in cuts:
            nxt = []
            for a, b in parts:
                if c1 <= a or c0 >= b:
                    nxt.append((a, b))
                    continue
                if c0 > a:
                    nxt.append((a, c0))
                if c1 < b:
                    nxt.append((c1, b))
            parts = nxt
        out.extend(parts)
    merged = []
    for a, b in sorted(out):
        if merged and a <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(b, merged[-1][1]))
        else:
            merged.append((a, b))
    return merged


def ranked_labelings(peaks: list[Peak], expected_hz, bounds_hz=None, bands=(), *,
                     candidates=None, spread_hz=None, options: LabelOptions = LabelOptions(),
                     keep: int = 1, must_try=()) -> list[Labeling]:
    """The most plausible joint assignments of peaks to bending modes, best first.

    Parameters are those of :func:`assign_bending`; ``keep`` labelings are returned
    (fewer if fewer exist). ``must_try`` lists peak indices for which the best labeling
    that uses each of them, among those assigning the most modes, is appended (if not already among the kept): a prominent
    peak far from where the guidance expects a mode must stay a candidate for the
    fit to judge (docs/physics.md §4: the model decides).
    """
    e = np.asarray(expected_hz, dtype=np.float64)
    n = e.size
    bnd, basis, sigma = _guidance(e, bounds_hz, spread_hz, options)
    ok = [True] * len(peaks) if candidates is None else list(candidates)
    hz = np.array([p.hz for p in peaks])
    loud = loud_peaks(peaks, ok, bands, options)
    per_mode = []
    for m in range(n):
        idx = [i for i in range(len(peaks)) if ok[i] and bnd[m, 0] <= hz[i] <= bnd[m, 1]]
        idx.sort(key=lambda i: abs(np.log(hz[i] / e[m])))
        # The nearest few, and every loud one wherever it lies inside the bounds.
        near = idx[:options.max_candidates]
        per_mode.append(near + [i for i in idx[options.max_candidates:] if loud[i]] + [None])
    unit = np.array([
        (options.band_cost if in_bands(p.hz, bands) else 0.0)
        + (options.faint_cost if p.reliability == "faint" else 0.0)
        + max(0.0, (options.weak_prominence_db - p.prominence_db) / options.weak_prominence_db)
        for p in peaks
    ])
    found: list[Labeling] = []
    for combo in itertools.product(*per_mode):
        chosen = [(m, i) for m, i in enumerate(combo) if i is not None]
        fs = [hz[i] for _, i in chosen]
        if any(b <= a for a, b in zip(fs, fs[1:])):
            continue  # modes are ordered and distinct
        cost = sum(_missing(options, m) for m, i in enumerate(combo) if i is None)
        prior = 0.0
        if chosen:
            ms = np.array([m for m, _ in chosen])
            prior = _explain_cost(np.log(np.array(fs) / e[ms]), basis[ms], sigma)
            cost += prior + float(sum(unit[i] for _, i in chosen))
        # A loud peak left unexplained inside the bounds of a mode (between its assigned
        # neighbours) that is missing or took a quieter peak costs: a tip tap rings
        # the bending modes loudest, so it is most likely that mode.
        left_out = set()
        for m, i in enumerate(combo):
            lo = max([hz[j] for mm, j in chosen if mm < m] + [bnd[m, 0]])
            hi = min([hz[j] for mm, j in chosen if mm > m] + [bnd[m, 1]])
            ceiling = -np.inf if i is None else peaks[i].level_db + options.louder_db
            here = {k for k in range(len(peaks))
                    if loud[k] and k not in combo and lo < hz[k] < hi and peaks[k].level_db > ceiling}
            if here:
                cost += options.unexplained_cost
            left_out |= here
        found.append(Labeling(tuple(combo), float(cost), float(prior), len(left_out)))
    found.sort(key=lambda lab: lab.cost)
    out = found[:max(keep, 1)]
    for k in must_try:
        if not any(k in lab.modes for lab in out):
            using = [lab for lab in found if k in lab.modes]
            # The fullest labeling with it: the fit judges the peak alongside the others.
            out += sorted(using, key=lambda lab: (-sum(i is not None for i in lab.modes), lab.cost))[:1]
    return out


def assign_bending(peaks: list[Peak], expected_hz, bounds_hz=None, bands=(), *,
                   candidates=None, spread_hz=None,
                   options: LabelOptions = LabelOptions()) -> list[int | None]:
    """Choose the peak of each bending mode with model guidance.

    Parameters
    ----------
    peaks : list of Peak
        Ascending in frequency.
    expected_hz : array_like, shape (n,)
        Model bending frequencies [Hz], ascending.
    bounds_hz : array_like, shape (n, 2), optional
        Physical (lo, hi) bounds per mode [Hz] (``bending_bounds``); without them each mode
        may be within ±30 % of its expected frequency and the rigid bound is taken
        10 % above it.
    bands : sequence of (lo, hi)
        Interface bands [Hz].
    candidates : sequence of bool, optional
        Which peaks may be bending at all (default all).
    spread_hz : array_like, shape (n, k), optional
        How far each bending frequency moves [Hz] when holder parameter k moves by one
        plausible spread (e.g. contact stiffness ×3, modulus +5 %), from the model.
        Without it the shifts are explained by a common (material) shift and a contact
        shift in proportion to each mode's distance to its rigid-contact bound.

    Returns
    -------
    list of (int or None), length n
        Index into ``peaks`` per mode, None where no peak is assigned.
    """
    best = ranked_labelings(peaks, expected_hz, bounds_hz, bands, candidates=candidates,
                            spread_hz=spread_hz, options=options)
    return list(best[0].modes) if best else [None] * len(np.atleast_1d(expected_hz))


def interface_growth(peaks: list[Peak], iface_peaks: list[Peak], tol_rel: float = 2e-3,
                     stationary=None) -> list[float | None]:
    """Level change [dB] of each peak from the tool-tip tap to the interface tap.

    Levels are relative to each recording's loudest peak; the median change over the
    matched ringing peaks is removed, so "grows" means grows relative to the rest.
    Peaks with no partner within ``tol_rel`` (relative frequency), and stationary ones
    (hum: its level says nothing about the tap), get None.
    """
    if not iface_peaks:
        return [None] * len(peaks)
    stat = [False] * len(peaks) if stationary is None else list(stationary)
    fi = np.array([q.hz for q in iface_peaks])
    raw = []
    for p, st in zip(peaks, stat):
        j = int(np.argmin(np.abs(fi - p.hz)))
        near = abs(fi[j] - p.hz) <= tol_rel * p.hz
        raw.append(iface_peaks[j].level_db - p.level_db if near and not st else None)
    vals = [g for g in raw if g is not None]
    if not vals:
        return raw
    med = float(np.median(vals))
    return [None if g is None else g - med for g in raw]


def label_peaks(peaks: list[Peak], *, bands=(), expected_hz=None, bounds_hz=None, spread_hz=None,
                stationary=None, growth_db=None, grow_threshold_db: float = 10.0,
                n_modes: int = 3, options: LabelOptions = LabelOptions()) -> tuple[list[Peak], list[str]]:
    """Label peaks ``bending`` / ``local`` / ``other``.

    Parameters
    ----------
    peaks : list of Peak
        Ascending in frequency.
    bands : sequence of (lo, hi)
        Interface local-mode bands [Hz].
    expected_hz, bounds_hz, spread_hz : array_like, optional
        Model guidance, shapes (n,), (n, 2), (n, k) [Hz] (see :func:`assign_bending`).
    stationary : sequence of bool, optional
        Peaks also present between taps (hum, room noise): never bending or local.
    growth_db : sequence of (float or None), optional
        Growth on an interface tap (:func:`interface_growth`); peaks growing by at least
        ``grow_threshold_db`` are local and then the bands are not needed.
    n_modes : int
        Bending modes sought without guidance.

    Returns
    -------
    peaks : list of Peak
        Same order, with ``kind``, ``mode`` and ``note`` set.
    warnings : list of str
    """
    warnings: list[str] = []
    p = len(peaks)
    stat = [False] * p if stationary is None else list(stationary)
    grown = [False] * p
    if growth_db is not None:
        grown = [g is not None and g >= grow_threshold_db for g in growth_db]
    use_bands = bands if growth_db is None else ()
    cand = [not stat[i] and not grown[i] for i in range(p)]
    if expected_hz is not None and len(expected_hz):
        modes = assign_bending(peaks, expected_hz, bounds_hz, use_bands, candidates=cand,
                               spread_hz=spread_hz, options=options)
        n_sought = len(modes)
    else:
        pool = [i for i in range(p) if cand[i] and not in_bands(peaks[i].hz, use_bands)
                and peaks[i].hz >= options.min_guess_hz]
        loudest = sorted(pool, key=lambda i: -peaks[i].prominence_db)[:n_modes]
        pool = sorted(loudest, key=lambda i: peaks[i].hz)
        modes = pool + [None] * (n_modes - len(pool))
        n_sought = n_modes
        if pool:
            warnings.append("no assembly given: the bending labels are a best guess "
                            "(the most prominent peaks outside the interface band)")
        low = [peaks[i] for i in range(p) if cand[i] and peaks[i].hz < options.min_guess_hz
               and peaks[i].level_db >= options.loud_level_db]
        if low:
            loudest = max(low, key=lambda q: q.level_db)
            warnings.append(f"no assembly given: the loud peak{'s' if len(low) > 1 else ''} below "
                            f"{options.min_guess_hz:.0f} Hz (loudest {loudest.hz:.0f} Hz) cannot be bending: a free-free "
                            "tool-holder assembly's first bending mode rings at a few kHz; is this a tap on a "
                            "tool-holder assembly? (give the assembly file for labels the model can check)")
    out = apply_labels(peaks, modes, use_bands, stationary=stat, grown=grown,
                       source="model" if expected_hz is not None else "guess")
    warnings.extend(missing_warnings(modes, n_sought))
    return out, warnings


#: Notes of the peaks that can never be bending (see :func:`label_candidates`).
NOTE_STATIONARY = "stationary (hum or noise)"
NOTE_GROWN = "grows on the interface tap"


def apply_labels(peaks: list[Peak], modes, bands=(), *, stationary=None, grown=None,
                 source: str = "model") -> list[Peak]:
    """The peaks with ``kind``, ``mode`` and ``note`` set for one bending assignment.

    ``modes`` holds the index into ``peaks`` per bending mode (None: unassigned);
    ``source`` says who chose them (``model``, ``guess``, ``fit``) in the note.
    """
    stat = [False] * len(peaks) if stationary is None else list(stationary)
    grow = [False] * len(peaks) if grown is None else list(grown)
    mode_of = {i: m + 1 for m, i in enumerate(modes) if i is not None}
    out = []
    for i, pk in enumerate(peaks):
        if i in mode_of:
            note = f"bending ({source})"
            if in_bands(pk.hz, bands):
                note += ", inside the interface band"
            if pk.reliability == "faint":
                note += ", faint"
            out.append(replace(pk, kind="bending", mode=mode_of[i], note=note))
        elif grow[i]:
            out.append(replace(pk, kind="local", mode=None, note=NOTE_GROWN))
        elif stat[i]:
            out.append(replace(pk, kind="other", mode=None, note=NOTE_STATIONARY))
        elif in_bands(pk.hz, bands):
            out.append(replace(pk, kind="local", mode=None, note="interface band"))
        else:
            out.append(replace(pk, kind="other", mode=None, note="faint" if pk.reliability == "faint" else ""))
    return out


def missing_warnings(modes, n_sought: int) -> list[str]:
    """The warning when fewer than ``n_sought`` bending modes are assigned."""
    found = sorted(m + 1 for m, i in enumerate(modes) if i is not None)
    if not found:
        return ["no bending peak found"]
    if len(found) < n_sought:
        missing = [m for m in range(1, n_sought + 1) if m not in found]
        return [f"only {len(found)} of {n_sought} bending modes found "
                f"(missing mode {', '.join(map(str, missing))})"]
    return []


def label_candidates(peaks: list[Peak]) -> tuple[list[bool], list[bool]]:
    """(stationary, grown) flags recovered from labelled peaks' notes."""
    return [p.note == NOTE_STATIONARY for p in peaks], [p.note == NOTE_GROWN for p in peaks]
