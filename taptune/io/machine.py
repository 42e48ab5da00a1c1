"""Machine-side files (MACHINE.md): spindle receptances at the coupling plane.

SI in every array: m/N, 1/N, rad/(N·m). The readers and writers of the machine TOML,
spindle receptance CSV/UFF58 and dummy-holder FRFs live here; the physics that uses
them lives in :mod:`taptune.machine`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.errors import InputError


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
        f = np.asarray(freq_hz, dtype=float)
        lo, hi = float(self.freq_hz[0]), float(self.freq_hz[-1])
        tol = 1e-9 * hi
        if f.size and (f.min() < lo - tol or f.max() > hi + tol):
            raise InputError(
                f"{self.source or 'spindle receptance'}: covers {lo:g}–{hi:g} Hz, "
                f"but {f.min():g}–{f.max():g} Hz was requested"
            )
        out = np.empty(f.shape + (2, 2), dtype=complex)
        for i in range(2):
            for j in range(2):
                col = self.h[:, i, j]
                out[..., i, j] = np.interp(f, self.freq_hz, col.real) + 1j * np.interp(f, self.freq_hz, col.imag)
        return out
