"""One identified holder and taps of it (good, elsewhere, worn) for the check tests.

The identification (a synthetic tap of the reference assembly at 53.5 mm, published
holder A, ~6 CPU-s) runs once per test session, shared by the identify and CLI
check tests through ``identified_holder``.
"""

from __future__ import annotations

import atexit
import functools
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path

from taptune.model.params import HolderParams

# Published holder A (CIRP JMST 2022) on the reference assembly (the example of docs/assembly-format.md).
HOLDER_A = HolderParams(1.90e9, 9.37e3, 1.98e-3, 8.20e-3, -10.0, 7478 / 7800, 1.0)
HOLDER_NAME = "ER32 collet chuck HSK-A63 x 100"
#: The tap sound of the test recordings (as in the identify tests).
TAP = dict(snr_db=36.0, contact_s=50e-6, radiation_exponent=2.0, mic_lp_hz=20000.0)


def worn(params: HolderParams, factor: float) -> HolderParams:
    """A holder whose contact stiffnesses (both) are ``factor`` times as stiff."""
    return replace(params, k_tt=params.k_tt * factor, k_rr=params.k_rr * factor)


@functools.lru_cache(maxsize=None)
def identified_holder():
    """(folder, assembly TOML, Identification, the library entry) of holder A identified at 53.5 mm."""
    from taptune.identify import IdentifyOptions
    from taptune.identify.pipeline import identify_recordings
    from taptune.io.assembly import load_assembly
    from taptune.io.audio import read_audio
    from taptune.library.record import entry_from_identification
    from taptune.synthetic import write_tap_recording
    from tests.conftest import REFERENCE_TOML

    folder = Path(tempfile.mkdtemp(prefix="taptune-check-"))
    atexit.register(shutil.rmtree, folder, True)
    toml = folder / "reference.toml"
    toml.write_text(REFERENCE_TOML)
    asm = load_assembly(toml)
    rec = read_audio(write_tap_recording(folder / "identify.wav", asm, HOLDER_A, seed=2, **TAP))
    _, result = identify_recordings([rec], [asm], IdentifyOptions(seed=0, jobs=1))
    return folder, toml, result, entry_from_identification(result, [rec], [asm])


def tap_file(folder: Path, stickout_mm: float, factor: float = 1.0, seed: int = 7) -> tuple[Path, Path]:
    """A tap of holder A (contact × ``factor``) at ``stickout_mm`` and its assembly TOML."""
    from taptune.io.assembly import load_assembly
    from taptune.synthetic import write_tap_recording
    from tests.conftest import REFERENCE_TOML

    toml = folder / f"so{stickout_mm:g}.toml"
    toml.write_text(REFERENCE_TOML.replace("stickout = 53.5", f"stickout = {stickout_mm:g}"))
    wav = folder / f"tap_{stickout_mm:g}_{factor:g}_{seed}.wav"
    if not wav.exists():
        write_tap_recording(wav, load_assembly(toml), worn(HOLDER_A, factor), seed=seed, **TAP)
    return wav, toml
