"""Machine-side files (docs/machine.md): spindle receptances, dummy-holder FRFs, tool-point FRFs.

SI in every array: m/N, 1/N, rad/(N·m); frequencies in Hz. Every reader validates the
whole file and raises one-line :class:`~taptune.errors.InputError` messages that name
the file and the problem (missing file or column, text in a number, NaN, an unsorted,
duplicate or non-positive frequency axis, an empty table). The physics that uses these
files lives in :mod:`taptune.machine`.

* :func:`load_machine` — the machine TOML (``[machine]`` name, interface, optional
  max_rpm; ``[spindle]`` x and optional y, paths relative to the TOML) → :class:`Machine`.
* :func:`read_spindle` / :func:`write_spindle_csv` — the spindle receptance of one
  bending direction, CSV ``f_hz,h_wf_re,h_wf_im,h_wm_re,h_wm_im,h_tm_re,h_tm_im`` or
  UFF58 (three functions, told apart by their response/reference directions).
* :func:`read_frf` — one translational FRF w/f (dummy-holder measurements): CSV
  ``f_hz,re,im``, CutPro-style ``.frf`` text or UFF58.
* :func:`read_toolpoint_csv` / :func:`write_toolpoint_csv` — the tool-point FRF
  ``f_hz,xx_re,xx_im,yy_re,yy_im`` that ``taptune lobes --frf`` reads;
  :func:`read_toolpoint` — that CSV, or one FRF file per direction in any format of
  :func:`read_frf` (``lobes --frf X --frf-y Y``).

Interpolation onto another grid (:meth:`SpindleReceptance.at`, :meth:`Frf.at`,
:meth:`ToolpointFrf.at`) is linear in re and im and never extrapolates: a band the file
does not cover is an InputError naming the file and both ranges.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from taptune.errors import InputError
from taptune.io.atomic import atomic_write
from taptune.io.files import read_text

SPINDLE_COLUMNS = ("f_hz", "h_wf_re", "h_wf_im", "h_wm_re", "h_wm_im", "h_tm_re", "h_tm_im")
FRF_COLUMNS = ("f_hz", "re", "im")
TOOLPOINT_COLUMNS = ("f_hz", "xx_re", "xx_im", "yy_re", "yy_im")
UFF_SUFFIXES = (".uff", ".unv")

# Plausible ranges: a hammer test or a tap never reaches 1 MHz, and no spindle, holder or
# tool point is as soft as 1 cm/N. A value beyond them is a unit or column mistake
# (kHz written as Hz, µm/N as m/N) or a broken file, not a measurement: refused, not used.
MAX_FREQ_HZ = 1e6
#: Largest plausible |receptance| per kind of term [SI]: translational w/f [m/N],
#: cross w/m = θ/f [1/N], rotational θ/m [rad/(N·m)].
MAX_RECEPTANCE = {"translational": (1e-2, "m/N"), "cross": (1.0, "1/N"), "rotational": (100.0, "rad/(N·m)")}


def _interp(source: str, grid: np.ndarray, values: np.ndarray, freq_hz) -> np.ndarray:
    """``values`` (shape (n, ...), complex) on ``freq_hz``, linear in re and im, no extrapolation."""
    f = np.asarray(freq_hz, dtype=float)
    lo, hi = float(grid[0]), float(grid[-1])
    tol = 1e-9 * hi
    if f.size and (f.min() < lo - tol or f.max() > hi + tol):
        raise InputError(f"{source}: covers {lo:g}–{hi:g} Hz, but {f.min():g}–{f.max():g} Hz was requested")
    flat = values.reshape(len(grid), -1)
    out = np.empty((f.size, flat.shape[1]), dtype=complex)
    for k in range(flat.shape[1]):
        out[:, k] = np.interp(f.ravel(), grid, flat[:, k].real) + 1j * np.interp(f.ravel(), grid, flat[:, k].imag)
    return out.reshape(f.shape + values.shape[1:])


@dataclass(frozen=True)
class SpindleReceptance:
    """The machine side at the coupling plane in one bending direction.

    Attributes
    ----------
    freq_hz : ndarray, shape (n,)
        Strictly ascending, positive frequencies [Hz].
    h : ndarray, shape (n, 2, 2), complex
        ``[[h_wf, h_wm], [h_tf, h_tm]]`` per frequency [m/N, 1/N; 1/N, rad/(N·m)],
        with h_tf = h_wm (reciprocity).
    source : str
        Where it came from (file name), for messages.
    """

    freq_hz: np.ndarray = field(repr=False)
    h: np.ndarray = field(repr=False)
    source: str = ""

    def at(self, freq_hz) -> np.ndarray:
        """The receptance on another grid, shape (m, 2, 2), interpolated linearly in re and im.

        Raises
        ------
        InputError
            When ``freq_hz`` reaches outside the measured band (no extrapolation).
        """
        return _interp(self.source or "spindle receptance", self.freq_hz, self.h, freq_hz)

    @classmethod
    def from_terms(cls, freq_hz, h_wf, h_wm, h_tm, source: str = "") -> "SpindleReceptance":
        """Build from the three independent terms (each shape (n,), complex)."""
        h = np.empty((len(freq_hz), 2, 2), dtype=complex)
        h[:, 0, 0] = h_wf
        h[:, 0, 1] = h[:, 1, 0] = h_wm
        h[:, 1, 1] = h_tm
        return cls(np.asarray(freq_hz, dtype=float), h, source)


@dataclass(frozen=True)
class Frf:
    """One translational FRF w/f [m/N] on a frequency grid [Hz] (a dummy-holder measurement)."""

    freq_hz: np.ndarray = field(repr=False)
    h: np.ndarray = field(repr=False)
    source: str = ""

    def at(self, freq_hz) -> np.ndarray:
        """The FRF on another grid [m/N]; InputError outside the file's band."""
        return _interp(self.source or "FRF", self.freq_hz, self.h, freq_hz)


@dataclass(frozen=True)
class ToolpointFrf:
    """Tool-point FRFs Φ_xx, Φ_yy [m/N] on a frequency grid [Hz] (input of the stability lobes).

    ``y_from_x`` is True when the file had no yy columns and Φ_yy = Φ_xx was assumed.
    """

    freq_hz: np.ndarray = field(repr=False)
    xx: np.ndarray = field(repr=False)
    yy: np.ndarray = field(repr=False)
    source: str = ""
    y_from_x: bool = False

    def at(self, freq_hz) -> tuple[np.ndarray, np.ndarray]:
        """(Φ_xx, Φ_yy) on another grid; InputError outside the file's band."""
        both = _interp(self.source or "tool-point FRF", self.freq_hz, np.stack([self.xx, self.yy], axis=1), freq_hz)
        return both[..., 0], both[..., 1]


@dataclass(frozen=True)
class Machine:
    """A machine file: the spindle receptance at the coupling plane in x and y.

    ``y_from_x`` is True when the file gives no ``[spindle] y`` and x is used for y;
    ``max_rpm`` is the spindle's top speed (``[machine] max_rpm``, optional; the default
    top of the lobe diagram).
    """

    name: str
    interface: str
    x: SpindleReceptance
    y: SpindleReceptance
    source: str = ""
    y_from_x: bool = False
    max_rpm: float | None = None

    def to_dict(self) -> dict:
        return {"name": self.name, "interface": self.interface, "file": self.source, "max_rpm": self.max_rpm,
                "spindle_x": self.x.source, "spindle_y": self.y.source}


# --------------------------------------------------------------------------- text tables


def _float(path, lineno: int, column: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{path}: line {lineno}, column {column}: {text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{path}: line {lineno}, column {column}: {text.strip()} is not a finite number")
    return value


def _data_lines(text: str):
    """(line number, stripped line) of every line that is neither blank nor a ``#`` comment."""
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if s and not s.startswith("#"):
            yield lineno, s


def read_csv_columns(path, required: tuple[str, ...], what: str, optional: tuple[str, ...] = ()) -> dict:
    """The named numeric columns of a CSV with a header line and ``#`` comments.

    Returns ``{name: ndarray}`` for every required column and each optional one present,
    plus ``"_lines"``: the file line number of each row (for messages). Extra columns are
    ignored; a missing required column, a short row, text or NaN in a number, or no data
    rows is an InputError naming the file.
    """
    lines = list(_data_lines(read_text(path, what, "CSV")))
    if not lines:
        raise InputError(f"{path}: is empty (expected a header line {','.join(required)})")
    header = [c.strip().lower() for c in lines[0][1].split(",")]
    missing = [c for c in required if c not in header]
    if missing:
        raise InputError(f"{path}: missing column {', '.join(missing)} (the header must name {','.join(required)})")
    wanted = [c for c in required + optional if c in header]
    index = {c: header.index(c) for c in wanted}
    rows, linenos = [], []
    for lineno, line in lines[1:]:
        cells = line.split(",")
        if len(cells) < len(header):
            raise InputError(f"{path}: line {lineno} has {len(cells)} values, the header {len(header)}")
        rows.append([_float(path, lineno, c, cells[index[c]]) for c in wanted])
        linenos.append(lineno)
    if not rows:
        raise InputError(f"{path}: has a header but no data rows")
    data = np.array(rows, dtype=float)
    out = {c: data[:, k] for k, c in enumerate(wanted)}
    out["_lines"] = np.array(linenos)
    return out


def check_frequency_axis(path, freq_hz: np.ndarray, lines=None) -> np.ndarray:
    """``freq_hz`` if it has ≥ 2 positive, strictly ascending values; else an InputError naming the file."""
    f = np.asarray(freq_hz, dtype=float)
    where = (lambda i: f" (line {int(lines[i])})") if lines is not None else (lambda i: "")
    if f.ndim != 1 or f.size < 2:
        raise InputError(f"{path}: needs at least two frequencies, got {f.size}")
    if not np.isfinite(f).all():
        raise InputError(f"{path}: frequencies must be finite numbers")
    if f[0] <= 0:
        raise InputError(f"{path}: frequencies must be > 0 Hz, the first is {f[0]:g}{where(0)}")
    if np.any(f > MAX_FREQ_HZ):
        i = int(np.argmax(f > MAX_FREQ_HZ))
        raise InputError(f"{path}: frequency {f[i]:g} Hz{where(i)} is above {MAX_FREQ_HZ:g} Hz, "
                         "far beyond any tap or hammer test (a wrong column or unit?)")
    step = np.diff(f)
    if np.any(step == 0):
        i = int(np.argmax(step == 0)) + 1
        raise InputError(f"{path}: frequency {f[i]:g} Hz appears twice{where(i)}")
    if np.any(step < 0):
        i = int(np.argmax(step < 0)) + 1
        raise InputError(f"{path}: frequencies must ascend, {f[i]:g} Hz follows {f[i - 1]:g} Hz{where(i)}")
    return f


def check_receptance(path, name: str, kind: str, freq_hz: np.ndarray, h: np.ndarray, lines=None) -> np.ndarray:
    """``h`` if every |value| is plausible for a receptance of ``kind`` (:data:`MAX_RECEPTANCE`).

    Raises
    ------
    InputError
        Naming the file, the row (line number, else frequency), the term and the limit.
    """
    h = np.asarray(h)
    limit, unit = MAX_RECEPTANCE[kind]
    big = np.abs(h) > limit
    if np.any(big):
        i = int(np.argmax(big))
        row = f"line {int(lines[i])}" if lines is not None else f"at {float(freq_hz[i]):g} Hz"
        raise InputError(f"{path}: {row}: |{name}| = {abs(h[i]):.3g} {unit} is not a plausible receptance "
                         f"(a machine stays far below {limit:g} {unit}; the file must be in SI, {unit})")
    return h


def _atomic_write_text(path, text: str, what: str) -> None:
    """Write ``text`` atomically (:func:`taptune.io.atomic.atomic_write`); InputError when it cannot."""
    def write(tmp) -> None:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)

    try:
        atomic_write(path, write)
    except OSError as err:
        raise InputError(f"{path}: cannot write the {what} ({err.strerror})") from None


def _check_values(name: str, freq_hz, *arrays) -> np.ndarray:
    f = np.asarray(freq_hz, dtype=float)
    check_frequency_axis(name, f)
    for a in arrays:
        a = np.asarray(a)
        if a.shape != f.shape:
            raise ValueError(f"{name}: values of shape {a.shape} for {f.size} frequencies")
        if not np.isfinite(a).all():
            raise ValueError(f"{name}: values must be finite")
    return f


def _table_text(header: tuple[str, ...], columns, comments=()) -> str:
    lines = [f"# {c}" for c in comments] + [",".join(header)]
    data = np.column_stack(columns)
    # Frequencies exact (a grid point stays a grid point), values to 10 significant digits.
    lines += [",".join([f"{row[0]:.15g}"] + [f"{v:.10g}" for v in row[1:]]) for row in data]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- spindle receptance


def read_spindle(path) -> SpindleReceptance:
    """The spindle receptance of one direction from CSV (header :data:`SPINDLE_COLUMNS`) or UFF58."""
    if Path(path).suffix.lower() in UFF_SUFFIXES:
        return _read_spindle_uff(path)
    c = read_csv_columns(path, SPINDLE_COLUMNS, "a spindle receptance file")
    f = check_frequency_axis(path, c["f_hz"], c["_lines"])
    terms = [check_receptance(path, f"h_{key}", kind, f, c[f"h_{key}_re"] + 1j * c[f"h_{key}_im"], c["_lines"])
             for key, kind in _SPINDLE_TERMS]
    return SpindleReceptance.from_terms(f, *terms, str(path))


_SPINDLE_TERMS = (("wf", "translational"), ("wm", "cross"), ("tm", "rotational"))


def write_spindle_csv(path, spindle: SpindleReceptance, comments=()) -> None:
    """Write a spindle receptance as CSV (values to 10 significant digits), ``comments`` as ``#`` lines first."""
    h = np.asarray(spindle.h, dtype=complex)
    f = _check_values(str(path), spindle.freq_hz, h[:, 0, 0], h[:, 0, 1], h[:, 1, 1])
    cols = [f]
    for z in (h[:, 0, 0], h[:, 0, 1], h[:, 1, 1]):
        cols += [z.real, z.imag]
    _atomic_write_text(path, _table_text(SPINDLE_COLUMNS, cols, comments), "spindle receptance")


def _uff_sets(path, what: str) -> list[dict]:
    """Every dataset 58 of a universal file (pyuff imported here)."""
    try:
        import pyuff
    except ImportError:
        raise InputError(f"{path}: reading UFF files needs pyuff (pip install 'taptune[export]')") from None
    read_text(path, what, "UFF")  # the one-line errors of a missing or unreadable file
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as err:  # noqa: BLE001 - pyuff raises anything on a malformed file
        raise InputError(f"{path}: not a readable universal file ({type(err).__name__}: {err})") from None
    sets = [sets] if isinstance(sets, dict) else list(sets)
    return [s for s in sets if isinstance(s, dict) and s.get("type") == 58]


def _uff_frf(path, s: dict) -> tuple[np.ndarray, np.ndarray]:
    f = np.asarray(s.get("x"), dtype=float)
    h = np.asarray(s.get("data"), dtype=complex)
    if h.shape != f.shape:
        raise InputError(f"{path}: dataset 58 {s.get('id1', '')!r} has {h.size} values for {f.size} frequencies")
    if not np.isfinite(h).all():
        raise InputError(f"{path}: dataset 58 {s.get('id1', '')!r} holds NaN or infinite values")
    return check_frequency_axis(path, f), h


def _read_spindle_uff(path) -> SpindleReceptance:
    """Three datasets 58 of one direction: w/f (both directions translational, 1–3), w/m or θ/f
    (one rotational, 4–6), θ/m (both rotational). A negative direction flips the sign."""
    sets = _uff_sets(path, "a spindle receptance file")
    terms: dict[str, np.ndarray] = {}
    freq = None
    for s in sets:
        rsp, ref = int(s.get("rsp_dir", 0)), int(s.get("ref_dir", 0))
        if rsp == 0 or ref == 0:
            raise InputError(f"{path}: dataset 58 {s.get('id1', '')!r} has no response/reference direction")
        key = {(False, False): "wf", (False, True): "wm", (True, False): "wm", (True, True): "tm"}[(abs(rsp) > 3, abs(ref) > 3)]
        f, h = _uff_frf(path, s)
        if freq is not None and (f.shape != freq.shape or not np.allclose(f, freq, rtol=1e-9)):
            raise InputError(f"{path}: the three functions must share one frequency grid")
        if key in terms and not (key == "wm" and np.allclose(terms[key], np.sign(rsp * ref) * h, rtol=1e-6)):
            raise InputError(f"{path}: holds more than one {'h_' + key} function (one bending direction per file)")
        freq, terms[key] = f, np.sign(rsp * ref) * h
    missing = [k for k in ("wf", "wm", "tm") if k not in terms]
    if missing:
        raise InputError(f"{path}: needs three FRF datasets 58 (h_wf, h_wm, h_tm); missing {', '.join('h_' + k for k in missing)}")
    terms = [check_receptance(path, f"h_{key}", kind, freq, terms[key]) for key, kind in _SPINDLE_TERMS]
    return SpindleReceptance.from_terms(freq, *terms, str(path))


# --------------------------------------------------------------------------- dummy-holder FRFs


def read_frf(path) -> Frf:
    """One translational FRF w/f [m/N]: CSV ``f_hz,re,im``, ``.frf`` text or UFF58 by the suffix."""
    suffix = Path(path).suffix.lower()
    if suffix in UFF_SUFFIXES:
        sets = _uff_sets(path, "an FRF file")
        if len(sets) != 1:
            raise InputError(f"{path}: needs exactly one FRF dataset 58, found {len(sets)}")
        f, h = _uff_frf(path, sets[0])
        return Frf(f, check_receptance(path, "w/f", "translational", f, h), str(path))
    if suffix == ".frf":
        return _read_frf_text(path)
    c = read_csv_columns(path, FRF_COLUMNS, "an FRF file")
    data, lines = drop_static_row(np.column_stack([c["f_hz"], c["re"], c["im"]]), c["_lines"])
    f = check_frequency_axis(path, data[:, 0], lines)
    return Frf(f, check_receptance(path, "w/f", "translational", f, data[:, 1] + 1j * data[:, 2], lines), str(path))


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _read_frf_text(path) -> Frf:
    """CutPro-style text: frequency, real, imaginary per line (tabs or spaces), ``#``/``%`` comments.

    As CutPro and its peers write it, the first row may carry the column names after its
    three numbers (``0 2.04e-07 0 Freq Hz Real m/N Imag m/N``); a static (0 Hz) first row
    is dropped (:func:`drop_static_row`).
    """
    rows, linenos = [], []
    for lineno, line in _data_lines(read_text(path, "an FRF file", "text (frequency, real, imaginary)")):
        if line.startswith("%"):
            continue
        cells = line.replace(",", " ").split()
        if not rows and len(cells) > 3 and all(_is_number(c) for c in cells[:3]) \
                and not any(_is_number(c) for c in cells[3:]):
            cells = cells[:3]  # header words after the first row's numbers
        if len(cells) != 3:
            raise InputError(f"{path}: line {lineno} has {len(cells)} values, expected frequency, real, imaginary")
        rows.append([_float(path, lineno, name, v) for name, v in zip(("frequency", "real", "imaginary"), cells)])
        linenos.append(lineno)
    if not rows:
        raise InputError(f"{path}: holds no data (expected lines of frequency, real, imaginary)")
    data, linenos = drop_static_row(np.array(rows), linenos)
    f = check_frequency_axis(path, data[:, 0], linenos)
    return Frf(f, check_receptance(path, "w/f", "translational", f, data[:, 1] + 1j * data[:, 2], linenos), str(path))


def drop_static_row(data: np.ndarray, linenos):
    """``data`` (rows of frequency, values…) without a first row at exactly 0 Hz, the static
    value many FRF programs write first; the FRF is used at positive frequencies only."""
    if len(data) > 1 and data[0, 0] == 0.0:
        return data[1:], list(linenos)[1:]
    return data, list(linenos)


# --------------------------------------------------------------------------- tool-point FRF


def check_direct_frf(path, name: str, h: np.ndarray) -> np.ndarray:
    """A direct (driving-point) receptance of a damped structure has Im ≤ 0 at every
    frequency (e^{iωt}, docs/machine.md): refuse one of the other sign convention, from which
    the lobes would be wrong, not merely noisy (a conjugated FRF gave 0.06 mm). Noise may
    lift some values above 0, and a rigid direction may be given as (near) zero, pure
    noise about as much above as below: only an imaginary part three times more positive
    than negative is refused (a conjugated FRF has almost no negative part)."""
    negative, positive = float(np.sum(np.clip(-h.imag, 0, None))), float(np.sum(np.clip(h.imag, 0, None)))
    if positive > 3 * negative:
        raise InputError(f"{path}: {name} has mostly positive imaginary parts: a tool-point FRF has Im ≤ 0 in "
                         f"taptune's sign convention (displacement/force with e^{{iωt}}); conjugate the file's "
                         f"imaginary parts")
    return h


def read_toolpoint_csv(path) -> ToolpointFrf:
    """Tool-point FRFs from CSV ``f_hz,xx_re,xx_im[,yy_re,yy_im]`` (y = x when yy is absent)."""
    c = read_csv_columns(path, TOOLPOINT_COLUMNS[:3], "a tool-point FRF file", optional=TOOLPOINT_COLUMNS[3:])
    if c["f_hz"].size > 1 and c["f_hz"][0] == 0.0:  # the static row (drop_static_row)
        c = {k: v[1:] for k, v in c.items()}
    f = check_frequency_axis(path, c["f_hz"], c["_lines"])
    xx = check_receptance(path, "xx", "translational", f, c["xx_re"] + 1j * c["xx_im"], c["_lines"])
    has_y = [k in c for k in TOOLPOINT_COLUMNS[3:]]
    if any(has_y) and not all(has_y):
        raise InputError(f"{path}: has only one of yy_re, yy_im; give both or neither (y = x)")
    yy = check_receptance(path, "yy", "translational", f, c["yy_re"] + 1j * c["yy_im"], c["_lines"]) if all(has_y) else xx
    check_direct_frf(path, "xx", xx)
    check_direct_frf(path, "yy", yy)
    return ToolpointFrf(f, xx, yy, str(path), y_from_x=not all(has_y))


def read_toolpoint(path_x, path_y=None) -> ToolpointFrf:
    """The tool-point FRFs from one file per direction, or one tool-point CSV with both.

    ``path_x``: a tool-point CSV (``f_hz,xx_re,xx_im[,yy_re,yy_im]``, :func:`read_toolpoint_csv`)
    or one direct FRF as :func:`read_frf` reads it (CSV ``f_hz,re,im``, CutPro-style
    ``.frf``, UFF58). ``path_y``: the y FRF in any of the one-FRF formats, interpolated onto
    x's frequencies (it must cover them); without it y = x. Both must follow the sign
    convention of :func:`check_direct_frf` (e^{iωt}: Im ≤ 0 below resonance).
    """
    suffix = Path(path_x).suffix.lower()
    header = ""
    if suffix not in UFF_SUFFIXES and suffix != ".frf":
        lines = list(_data_lines(read_text(path_x, "a tool-point FRF file", "CSV")))
        header = lines[0][1].lower() if lines else ""
    if "xx_re" in header:
        t = read_toolpoint_csv(path_x)
        if path_y is not None:
            if not t.y_from_x:
                raise InputError(f"{path_y}: {path_x} already holds the yy columns; give the y FRF in one place")
            return _with_y(t, path_y)
        return t
    g = read_frf(path_x)
    xx = check_direct_frf(path_x, "the FRF", g.h)
    t = ToolpointFrf(g.freq_hz, xx, xx, str(path_x), y_from_x=True)
    return _with_y(t, path_y) if path_y is not None else t


def _with_y(t: ToolpointFrf, path_y) -> ToolpointFrf:
    if Path(path_y).resolve() == Path(t.source).resolve():
        raise InputError(f"{path_y}: is the x FRF's file too; leave --frf-y out for y = x")
    gy = read_frf(path_y)
    yy = check_direct_frf(path_y, "the FRF", gy.at(t.freq_hz))
    return ToolpointFrf(t.freq_hz, t.xx, yy, f"{t.source} (x), {path_y} (y)", y_from_x=False)


def write_toolpoint_csv(path, freq_hz, xx, yy, comments=()) -> None:
    """Write tool-point FRFs Φ_xx, Φ_yy [m/N] as the CSV :func:`read_toolpoint_csv` reads."""
    xx, yy = np.asarray(xx, dtype=complex), np.asarray(yy, dtype=complex)
    f = _check_values(str(path), freq_hz, xx, yy)
    text = _table_text(TOOLPOINT_COLUMNS, [f, xx.real, xx.imag, yy.real, yy.imag], comments)
    _atomic_write_text(path, text, "tool-point FRF")


# --------------------------------------------------------------------------- machine file


def load_machine(path) -> Machine:
    """Read a machine TOML file and the spindle receptance files it names (relative to it)."""
    from taptune.io.assembly import _Reader

    text = read_text(path, "a machine file", "TOML")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: not valid TOML ({err})") from None
    r = _Reader(str(path))
    m = r.table(data, "machine")
    s = r.table(data, "spindle")
    for key in m:
        # A misspelt optional key (max_rmp) would silently leave the lobes at their default top speed.
        close = [k for k in ("name", "interface", "max_rpm") if k != key and _close(str(key), k)]
        if close:
            r.fail(f"[machine] {key}", f"is not a known key; did you mean {close[0]!r}?")
    name = r.text(m, "name", "[machine]")
    interface = r.text(m, "interface", "[machine]")
    max_rpm = r.number(m, "max_rpm", "[machine]") if "max_rpm" in m else None
    if max_rpm is not None and max_rpm <= 0:
        r.fail("[machine] max_rpm", f"must be > 0, got {max_rpm:g}")
    unknown = sorted(set(s) - {"x", "y"})
    if unknown:
        r.fail(f"[spindle] {unknown[0]}", "is not a direction (x and y are)")
    folder = Path(path).parent
    x = read_spindle(_relative(folder, r.text(s, "x", "[spindle]")))
    y_name = r.text(s, "y", "[spindle]", "")
    y = read_spindle(_relative(folder, y_name)) if y_name else x
    return Machine(name, interface, x, y, str(path), y_from_x=not y_name, max_rpm=max_rpm)


def machine_file_inputs(path) -> list[str]:
    """The spindle files a machine TOML names (paths as :func:`load_machine` reads them);
    [] when the file cannot be read (its reader reports that)."""
    try:
        spindle = tomllib.loads(Path(path).read_text(encoding="utf-8")).get("spindle", {})
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return []
    if not isinstance(spindle, dict):
        return []
    folder = Path(path).parent
    return [_relative(folder, spindle[k]) for k in ("x", "y") if isinstance(spindle.get(k), str) and spindle[k]]


def _close(a: str, b: str) -> bool:
    """True when ``a`` looks like a misspelling of ``b``."""
    import difflib

    return difflib.SequenceMatcher(None, a.lower(), b).ratio() >= 0.75


def _relative(folder: Path, name: str) -> str:
    p = Path(name).expanduser()
    return str(p if p.is_absolute() else folder / p)
