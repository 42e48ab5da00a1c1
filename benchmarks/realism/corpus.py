"""The realism corpus: holders outside taptune's model family, as a careful user describes them.

Each :class:`Case` is one tap recording of one assembly. Its DESCRIBED assembly is what the
user's TOML says (nominal stick-out read off a ruler, nominal holder diameters,
flute_ratio 0.8); the TRUTH differs in several ways at once (see :data:`KINDS`):

* ``profile``  contact intensity not linear along the grip (soft front edge, crowned, gap);
* ``stickout`` true stick-out = described ± up to 0.4 mm (always; again at every query; a
  ``stickout_error_mm`` of :func:`make_case` other than 0.4 reads it with a gauge instead, and the
  described assembly then states that ``stickout_tolerance``);
* ``diameters`` holder outer diameters off by up to ±1.5 % (segment by segment);
* ``flute``    true flute ratio 0.72–0.86 instead of the described 0.8;
* ``mass``     a collet nut (collet chucks) or a coolant tube / clamping unit in the HSK
  bore that the file leaves out;
* ``doublet``  asymmetric holder: the bending planes' contact or section stiffness differ
  by 0.3–1.5 %, the tap hits at a random angle;
* ``lowgrade`` a phone-like recording: 44.1 kHz, 16 bit, a steep low-pass at 15–17 kHz,
  20–30 dB SNR.

The holder's own parameters are drawn inside the published ranges of docs/physics.md §2.
Queries: the same tool at other described stick-outs (+10/+20 mm, or −10 mm where the tool
cannot come out further), with the truth's bending frequencies there.

Splits have disjoint seeds: ``calibration`` (for tuning band methods), ``validation``
(never tune on it), ``infamily`` (the control: truth = the product model, description
exact). :func:`check_pairs` gives held-out pairs for ``taptune check``.

Two tiers (``make_case(..., tier=)``):

* ``harsh`` (default, the names above, e.g. ``cal003``): each deviation drawn with the
  probabilities of :func:`_try_case` and the wide ranges listed above (gaps in the grip,
  flute ratios 0.72–0.86, any stick-out the holder allows).
* ``issue`` (names prefixed ``i``, e.g. ``ical003``; seeds = the split's + 500 000, so
  disjoint from the harsh tier): the holders issue 9 describes. Every grip has a
  non-linear contact profile (soft front edge or crowned), the stick-out is read off a
  ruler (±0.4 mm, at the identification and afresh at every query), holder diameters
  ±1.5 %, a true flute ratio 0.77–0.83, stick-outs 3–6·D with the flutes clear of the
  holder, a collet nut on half the collet chucks, a doublet on a third of the cases and a
  phone-like recording on 40 %.

:func:`case_of` rebuilds the case of a stored record (split, index, tier, stick-out error, ablation).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from benchmarks.realism.geometry import FAMILIES, TOOLS, assemble_geometry, make_holder, make_tool, max_insertion_mm
from benchmarks.realism.truth import ExtraMass, Profile, TruthHolder, TruthModes, truth_modes
from taptune.errors import InputError
from taptune.io.assembly import Assembly, Tolerances
from taptune.model.params import HolderParams
from taptune.signal.synth import Nuisances

MM = 1e-3
KINDS = ("profile", "stickout", "diameters", "flute", "mass", "doublet", "lowgrade")
SPLIT_SEEDS = {"calibration": 1_000_000, "validation": 2_000_000, "check": 3_000_000, "infamily": 4_000_000}
TIERS = ("harsh", "issue")
#: Added to the split's seeds in the ``issue`` tier (disjoint from the harsh tier's).
ISSUE_SEED_OFFSET = 500_000
# Interface local modes of HSK-A63 (taptune.synthetic): (f_hz, zeta, rel_peak).
LOCAL_MODES = ((9700.0, 0.0015, 1.5), (10200.0, 0.0018, 0.8))
RULER_MM = 0.4
DIAMETER_REL = 0.015


@dataclass(frozen=True)
class Query:
    """A prediction request: the described stick-out and the truth there.

    ``ruler_hz`` is the true holder at the DESCRIBED stick-out: ``truth`` minus it is what
    the ruler error alone moves the frequencies (a floor no holder model can beat).
    """

    stickout_mm: float  # described
    true_stickout_mm: float
    truth: TruthModes
    ruler_hz: tuple = ()

    def to_dict(self) -> dict:
        return {"stickout_mm": self.stickout_mm, "true_stickout_mm": round(self.true_stickout_mm, 4),
                **self.truth.to_dict(), "ruler_hz": [round(f, 3) for f in self.ruler_hz]}


def make_query(true_asm: Assembly, holder: TruthHolder, stickout_mm: float, true_stickout_mm: float) -> Query:
    """The truth at a query: at the true stick-out, and at the described one (ruler floor)."""
    at = truth_modes(true_asm.with_stickout(true_stickout_mm * MM), holder)
    ruler = at if true_stickout_mm == stickout_mm else truth_modes(true_asm.with_stickout(stickout_mm * MM), holder)
    return Query(stickout_mm, true_stickout_mm, at, ruler.bending_hz)


@dataclass(frozen=True)
class RecordingSetup:
    """How the tap was recorded: synthesis nuisances plus what ``synth`` does not do."""

    nuisances: Nuisances
    extra_modes: tuple  # non-bending peaks (f_hz, zeta, rel_peak)
    bits: int = 24  # quantisation of the file
    phone_lp_hz: float | None = None  # a steep (8th-order) low-pass, as in phones

    def to_dict(self) -> dict:
        n = self.nuisances
        return {"sample_rate": n.sample_rate, "bits": self.bits, "phone_lp_hz": self.phone_lp_hz,
                "snr_db": n.snr_db, "hum_hz": n.hum_hz, "mic_lp_hz": n.mic_lp_hz, "taps": len(n.tap_times_s),
                "contact_s": n.contact_s, "radiation_exponent": n.radiation_exponent,
                "reflections": [list(r) for r in n.reflections],
                "extra_modes": [list(m) for m in self.extra_modes]}


@dataclass(frozen=True)
class Case:
    """One tap recording of a holder outside the model family, with its truth.

    Attributes
    ----------
    name : str
    split : str
    seed : int
        Everything about the case (and its recording's noise) follows from it.
    family : str
    described : Assembly
        What the user's assembly file says (recorded stick-out).
    true_assembly : Assembly
        The real geometry at the recorded stick-out.
    holder : TruthHolder
        Contact profile, hidden mass, asymmetry, holder parameters.
    recording : RecordingSetup
    truth : TruthModes
        Bending modes at the recorded geometry.
    queries : tuple of Query
    kinds : tuple of str
        Which deviations of :data:`KINDS` this case has.
    true_od_factors : tuple of float
    true_flute_ratio : float
    """

    name: str
    split: str
    seed: int
    family: str
    described: Assembly
    true_assembly: Assembly
    holder: TruthHolder
    recording: RecordingSetup
    truth: TruthModes
    queries: tuple
    kinds: tuple
    true_od_factors: tuple = field(default=())
    true_flute_ratio: float = 0.8
    tier: str = "harsh"
    stickout_error_mm: float = RULER_MM  # the largest stick-out reading error (0 in the family, or the one stated)

    def described_at(self, stickout_mm: float) -> Assembly:
        """The described assembly at another stick-out [mm] (what the user would predict)."""
        return self.described.with_stickout(stickout_mm * MM)

    def true_at(self, true_stickout_mm: float) -> Assembly:
        """The true geometry at a true stick-out [mm]."""
        return self.true_assembly.with_stickout(true_stickout_mm * MM)

    def to_dict(self) -> dict:
        t = self.described.tool
        return {
            "name": self.name, "split": self.split, "tier": self.tier, "seed": self.seed, "family": self.family,
            "stickout_error_mm": self.stickout_error_mm,
            "kinds": list(self.kinds),
            "holder_name": self.described.holder.name,
            "tool": {"diameter_mm": t.flute_diameter / MM, "total_length_mm": t.total_length / MM,
                     "flute_length_mm": t.flute_length / MM},
            "stickout_mm": round(self.described.stickout / MM, 4),
            "true_stickout_mm": round(self.true_assembly.stickout / MM, 4),
            "true_od_factors": [round(f, 5) for f in self.true_od_factors],
            "true_flute_ratio": round(self.true_flute_ratio, 4),
            "truth_holder": self.holder.to_dict(),
            "recording": self.recording.to_dict(),
            "truth": self.truth.to_dict(),
            "queries": [q.to_dict() for q in self.queries],
        }


# ----------------------------------------------------------------------------- drawing


def _loguniform(rng, lo, hi) -> float:
    return float(10 ** rng.uniform(np.log10(lo), np.log10(hi)))


def draw_params(rng) -> HolderParams:
    """Holder parameters inside the published ranges of docs/physics.md §2 (five real holders)."""
    return HolderParams(
        k_tt=_loguniform(rng, 1.8e9, 4.7e9),
        k_rr=_loguniform(rng, 2.95e3, 4.83e4),
        eta_tt=_loguniform(rng, 1.98e-3, 1.21e-2),
        eta_rr=_loguniform(rng, 1.1e-7, 8.45e-3),
        alpha=float(rng.uniform(-23.0, 11.0)),
        density_factor=float(rng.uniform(7428.0, 8045.0) / 7800.0),
        modulus_factor=float(rng.uniform(200.0, 213.0) / 210.0),
    )


def draw_profile(rng, clamp_mm: float) -> Profile:
    """A non-linear contact profile: soft front edge 45 %, crowned 30 %, gap 25 %."""
    kind = rng.choice(["soft_front", "crowned", "gap"], p=[0.45, 0.30, 0.25])
    if kind == "soft_front":
        return Profile("soft_front", depth=float(rng.uniform(0.2, 0.7)),
                       length_mm=float(rng.uniform(0.15, 0.30) * clamp_mm))
    if kind == "crowned":
        return Profile("crowned", depth=float(rng.uniform(0.3, 0.8)))
    return Profile("gap", depth=float(rng.uniform(0.0, 0.2)), length_mm=float(rng.uniform(0.15, 0.30) * clamp_mm),
                   position_mm=float(rng.uniform(0.35, 0.65) * clamp_mm))


def draw_mass(rng, collet: bool, holder_len_mm: float) -> ExtraMass:
    """A nut over the front 22 mm (collet chucks) or a coolant tube / clamping unit in the HSK bore."""
    if collet:
        return ExtraMass(mass=float(rng.uniform(0.03, 0.10)), z_from_front=11.0 * MM, length=22.0 * MM,
                         radius2=(25.0**2 + 18.0**2) * MM**2)
    return ExtraMass(mass=float(rng.uniform(0.02, 0.06)), z_from_front=(holder_len_mm - 16.0) * MM,
                     length=25.0 * MM, radius2=(17.0**2 + 6.0**2) * MM**2)


def draw_recording(rng, low_grade: bool, truth_hz) -> RecordingSetup:
    """Workshop nuisances; ``low_grade`` is a phone: 44.1 kHz, 16 bit, steep low-pass, noisy."""
    n_taps = int(rng.integers(2, 5))
    times = tuple(float(0.2 + 0.6 * k + rng.uniform(0, 0.1)) for k in range(n_taps))
    strengths = tuple(float(s) for s in rng.uniform(0.5, 1.0, n_taps))
    common = dict(
        duration_s=float(times[-1] + 0.6), tap_times_s=times, tap_strengths=strengths,
        contact_s=float(rng.uniform(30e-6, 70e-6)), radiation_exponent=float(rng.uniform(1.5, 2.5)),
        mic_hp_hz=float(rng.uniform(60, 150)),
        reflections=tuple((float(rng.uniform(0.4e-3, 3e-3)), float(rng.uniform(0.05, 0.3)))
                          for _ in range(int(rng.integers(1, 3)))),
        hum_hz=float(rng.choice([50.0, 60.0])), hum_rel_db=float(rng.uniform(-45, -30)), level=0.5,
    )
    locals_ = tuple((f * float(rng.uniform(0.97, 1.03)), z, rel * float(rng.uniform(0.5, 1.5)))
                    for f, z, rel in LOCAL_MODES)
    extra = locals_
    if rng.uniform() < 0.25:  # an axial mode or a table resonance, clear of the bending modes
        for _ in range(20):
            f = float(rng.uniform(2000, 18000))
            if np.min(np.abs(np.asarray(truth_hz) / f - 1)) > 0.03:
                extra = extra + ((f, float(rng.uniform(0.002, 0.01)), float(rng.uniform(0.05, 0.3))),)
                break
    if low_grade:
        nu = Nuisances(sample_rate=44100, snr_db=float(rng.uniform(20, 30)), mic_lp_hz=None, **common)
        return RecordingSetup(nu, extra, bits=16, phone_lp_hz=float(rng.uniform(15000, 17000)))
    fs = int(rng.choice([44100, 48000, 96000]))
    nu = Nuisances(sample_rate=fs, snr_db=float(rng.uniform(30, 45)), mic_lp_hz=float(rng.uniform(18000, 22000)), **common)
    return RecordingSetup(nu, extra, bits=int(rng.choice([16, 24])))


def min_insertion_mm(family, d: float) -> float:
    """Shortest grip a careful user clamps [mm]: a hydraulic sleeve must be covered
    completely; collets and shrink fits need about two thirds of the grip and 2.5 × D."""
    if family.key == "hydraulic":
        return family.clamp_mm
    return max(0.65 * family.clamp_mm, 2.5 * d, 15.0)


def _query_offsets(rng, insert_mm: float, min_insert: float, max_insert: float, stickout: float, flute: float,
                   stickout_range=(0.0, np.inf)):
    """Two described stick-out offsets [mm]: +10/+20 when the tool can come out so far, else −10 too
    (the stick-out there inside ``stickout_range`` [mm])."""
    ok = [o for o in (10.0, 20.0, -10.0, 5.0, 15.0, -5.0)
          if min_insert <= insert_mm - o <= max_insert and stickout + o >= flute + 1.0
          and stickout_range[0] <= stickout + o <= stickout_range[1]]
    if len(ok) < 2:
        return None
    preferred = [o for o in ok if o in (10.0, 20.0)]
    if len(preferred) == 2 and rng.uniform() < 0.7:
        return tuple(preferred)
    return tuple(sorted(rng.choice(ok, size=2, replace=False).tolist()))


def make_case(split: str, index: int, in_family: bool = False, tier: str = "harsh",
              stickout_error_mm: float = RULER_MM) -> Case:
    """Case ``index`` of ``split`` in ``tier`` (deterministic; redraws until the geometry is valid).

    ``tier``: ``"harsh"`` (default) or ``"issue"`` (see the module docstring).
    ``stickout_error_mm``: the largest error of every stick-out reading (uniform; default
    a ruler). Another value draws the same case with every reading error scaled (the same
    random numbers), and the described assembly states it as its ``stickout_tolerance``:
    the user who measured with a gauge and said so. In the family (``infamily``) every
    stick-out is exact and such a value is only stated (0 states nothing).
    """
    if tier not in TIERS:
        raise ValueError(f"unknown tier {tier!r}: use {' or '.join(TIERS)}")
    if not stickout_error_mm >= 0:
        raise ValueError(f"stickout_error_mm must be >= 0 mm, got {stickout_error_mm}")
    seed = SPLIT_SEEDS[split] + index + (ISSUE_SEED_OFFSET if tier == "issue" else 0)
    rng = np.random.default_rng(seed)
    try_ = _try_case if tier == "harsh" else _try_issue_case
    in_family = in_family or split == "infamily"
    for _ in range(100):
        case = try_(rng, split, index, seed, in_family, stickout_error_mm)
        if case is not None:
            if in_family and stickout_error_mm not in (RULER_MM, 0.0):
                # The exact stick-out, stated to this tolerance (a gauge): the in-family
                # control of a user who measured well and said so (0, what in-family
                # records store otherwise, keeps the assembly's default tolerance).
                tol = Tolerances(stickout=stickout_error_mm * MM)
                case = replace(case, described=replace(case.described, tolerances=tol),
                               stickout_error_mm=stickout_error_mm)
            return case
    raise RuntimeError(f"no valid geometry for {split} {index} ({tier} tier)")


def case_of(record: dict) -> Case:
    """The case of a stored :func:`benchmarks.realism.run.run_case` record (split, index,
    tier; records without a tier are ``harsh``), with its ablation applied."""
    case = make_case(record["split"], record["index"], tier=record.get("tier", "harsh"),
                     stickout_error_mm=record.get("stickout_error_mm", RULER_MM))
    if record.get("ablate") and record["ablate"] in case.kinds:
        case = without(case, record["ablate"])
    return case


def _draw_tool(rng, index: int, name_prefix: str):
    """The family (every one equally often), tool and described holder of a case, and the
    tool's insertion limits [mm] (the first random draws of both tiers)."""
    family = FAMILIES[index % len(FAMILIES)]
    d = float(rng.choice(family.diameters))
    total, flute = TOOLS[int(d)][int(rng.integers(2))]
    name = f"{name_prefix}{index:03d}-{family.key}-D{d:g}"
    holder_name = f"{family.title} D{d:g} [realism {name}]"
    described_holder = make_holder(family, d, holder_name)
    max_insert = min(max_insertion_mm(described_holder, d), total - flute - 1.0)
    return family, d, total, flute, name, holder_name, described_holder, max_insert, min_insertion_mm(family, d)


def _draw_doublet_and_recording(rng, p_doublet: float, kinds: list) -> tuple[float, str, float, bool]:
    """A slight asymmetry (a doublet) with probability ``p_doublet`` and a low-grade (phone)
    recording with probability 0.4, the last deviation draws of both tiers; appends their
    kinds. Returns (asymmetry, its kind, its angle [deg], low grade)."""
    asym, asym_kind, angle = 0.0, "contact", 0.0
    if rng.uniform() < p_doublet:
        asym, asym_kind, angle = float(rng.uniform(0.003, 0.015)), str(rng.choice(["contact", "section"])), float(rng.uniform(0, 90))
        kinds.append("doublet")
    low_grade = bool(rng.uniform() < 0.4)
    if low_grade:
        kinds.append("lowgrade")
    return asym, asym_kind, angle, low_grade


def _try_case(rng, split, index, seed, in_family, stickout_error_mm=RULER_MM) -> Case | None:
    family, d, total, flute, name, holder_name, described_holder, max_insert, min_insert = \
        _draw_tool(rng, index, split[:3])
    if max_insert < min_insert + 10.0:
        return None
    insert = float(np.round(rng.uniform(min_insert, max_insert) * 2) / 2)
    stickout = total - insert
    offsets = _query_offsets(rng, insert, min_insert, max_insert, stickout, flute)
    if offsets is None:
        return None

    kinds = ["stickout"]
    ruler = 0.0 if in_family else stickout_error_mm
    od_f = (1.0,) * len(described_holder.segments)
    ratio = 0.8
    profile, mass, asym, asym_kind, angle = Profile("linear"), ExtraMass(), 0.0, "contact", 0.0
    low_grade = False
    if in_family:
        kinds = []
    else:
        if rng.uniform() < 0.75:
            profile = draw_profile(rng, family.clamp_mm)
            kinds.append("profile")
        if rng.uniform() < 0.7:
            od_f = tuple(float(f) for f in 1 + rng.uniform(-DIAMETER_REL, DIAMETER_REL, len(od_f)))
            kinds.append("diameters")
        if rng.uniform() < 0.7:
            ratio = float(rng.uniform(0.72, 0.86))
            kinds.append("flute")
        if rng.uniform() < (0.7 if family.collet else 0.3):
            mass = draw_mass(rng, family.collet, described_holder.length / MM)
            kinds.append("mass")
        asym, asym_kind, angle, low_grade = _draw_doublet_and_recording(rng, 0.5, kinds)
    holder = TruthHolder(draw_params(rng), profile, mass, asym, asym_kind, angle)
    return _build_case(rng, name, split, seed, family, d, (total, flute), described_holder, holder_name, holder,
                       stickout, offsets, ruler, od_f, ratio, low_grade, kinds)


def _build_case(rng, name, split, seed, family, d, tool_mm, described_holder, holder_name, holder, stickout,
                offsets, ruler, od_f, ratio, low_grade, kinds, tier="harsh") -> Case | None:
    """The drawn case's assemblies, truths and recording (the last random draws of both
    tiers, in the same order); None when a geometry is not possible."""
    total, flute = tool_mm
    try:
        described = assemble_geometry(described_holder, make_tool(d, total, flute), stickout, f"{name}.toml")
        if "stickout" in kinds and ruler != RULER_MM:  # read otherwise than with a ruler, and the file says so
            described = replace(described, tolerances=Tolerances(stickout=ruler * MM))
        true_holder = make_holder(family, d, holder_name, od_f)
        true_tool = make_tool(d, total, flute, ratio)
        true_so = stickout + float(rng.uniform(-ruler, ruler))
        true_asm = assemble_geometry(true_holder, true_tool, true_so, f"{name} (truth)")
        queries = []
        for off in offsets:
            q_true = stickout + off + float(rng.uniform(-ruler, ruler))
            queries.append(make_query(true_asm, holder, stickout + off, q_true))
        truth = truth_modes(true_asm, holder)
    except InputError:
        return None
    recording = draw_recording(rng, low_grade, truth.bending_hz)
    return Case(name=name, split=split, seed=seed, family=family.key, described=described,
                true_assembly=true_asm, holder=holder, recording=recording, truth=truth,
                queries=tuple(queries), kinds=tuple(kinds), true_od_factors=od_f, true_flute_ratio=ratio,
                tier=tier, stickout_error_mm=ruler)


def _try_issue_case(rng, split, index, seed, in_family, stickout_error_mm=RULER_MM) -> Case | None:
    """A case of the ``issue`` tier (module docstring): the deviations issue 9 describes."""
    family, d, total, flute, name, holder_name, described_holder, max_insert, min_insert = \
        _draw_tool(rng, index, "i" + split[:3])
    # Stick-outs 3–6·D, here and at the queries (flutes clear of the holder: insert ≤ total − flute − 1).
    lo, hi = max(min_insert, total - 6.0 * d), min(max_insert, total - 3.0 * d)
    if hi < lo + 2.0 or max_insert < min_insert + 10.0:
        return None
    insert = float(np.round(rng.uniform(lo, hi) * 2) / 2)
    stickout = total - insert
    offsets = _query_offsets(rng, insert, min_insert, max_insert, stickout, flute, (3.0 * d, 6.0 * d))
    if offsets is None:
        return None
    ruler = 0.0 if in_family else stickout_error_mm
    od_f = (1.0,) * len(described_holder.segments)
    ratio = 0.8
    profile, mass, asym, asym_kind, angle = Profile("linear"), ExtraMass(), 0.0, "contact", 0.0
    low_grade = False
    kinds = []
    if not in_family:
        kinds = ["stickout", "profile", "diameters", "flute"]
        if rng.uniform() < 0.6:
            profile = Profile("soft_front", depth=float(rng.uniform(0.2, 0.7)),
                              length_mm=float(rng.uniform(0.15, 0.30) * family.clamp_mm))
        else:
            profile = Profile("crowned", depth=float(rng.uniform(0.3, 0.8)))
        od_f = tuple(float(f) for f in 1 + rng.uniform(-DIAMETER_REL, DIAMETER_REL, len(od_f)))
        ratio = float(rng.uniform(0.77, 0.83))
        if family.collet and rng.uniform() < 0.5:
            mass = draw_mass(rng, True, described_holder.length / MM)
            kinds.append("mass")
        asym, asym_kind, angle, low_grade = _draw_doublet_and_recording(rng, 1 / 3, kinds)
    holder = TruthHolder(draw_params(rng), profile, mass, asym, asym_kind, angle)
    return _build_case(rng, name, split, seed, family, d, (total, flute), described_holder, holder_name, holder,
                       stickout, offsets, ruler, od_f, ratio, low_grade, kinds, tier="issue")


def make_corpus(split: str, n: int, tier: str = "harsh") -> list[Case]:
    """The first ``n`` cases of a split (``calibration``, ``validation`` or ``infamily``) in ``tier``."""
    if split not in SPLIT_SEEDS or split == "check":
        raise ValueError(f"unknown split {split!r}: use calibration, validation or infamily (check_pairs for pairs)")
    return [make_case(split, i, tier=tier) for i in range(n)]


# ----------------------------------------------------------------------------- check pairs


def worn(case: Case, factor: float, stickout_mm: float | None = None) -> Case:
    """The same holder with its contact stiffness intensities × ``factor``, recorded anew.

    ``stickout_mm`` (described) moves the tool too (with a fresh ruler error); the
    recording nuisances are the case's own.
    """
    holder = case.holder.worn(factor)
    return _moved(case, holder, stickout_mm, f"{case.name}-worn{factor:g}", salt=int(round(1000 * factor)))


def elsewhere(case: Case, stickout_mm: float) -> Case:
    """The same holder, the same tool, clamped again at another described stick-out."""
    return _moved(case, case.holder, stickout_mm, f"{case.name}-at{stickout_mm:g}", salt=7)


def _moved(case: Case, holder: TruthHolder, stickout_mm, name: str, salt: int) -> Case:
    rng = np.random.default_rng([case.seed, salt])
    so = case.described.stickout / MM if stickout_mm is None else float(stickout_mm)
    ruler = case.stickout_error_mm if "stickout" in case.kinds else 0.0
    true_so = so + float(rng.uniform(-ruler, ruler))
    described = case.described_at(so)
    true_asm = case.true_at(true_so)
    return replace(case, name=name, described=replace(described, source=f"{name}.toml"), true_assembly=true_asm,
                   holder=holder, truth=truth_modes(true_asm, holder), queries=(),
                   seed=int(rng.integers(2**31)))


def check_pairs(n: int) -> list[tuple[Case, Case, str]]:
    """Held-out pairs for ``taptune check``: (reference, other, expected verdict).

    For every reference holder (split ``check``): the same holder at its first query
    stick-out (``consistent``), and worn to 0.5 and to 0.3 of its contact stiffness at
    the recorded stick-out (``differs``). ``n`` references give 3·n pairs.
    """
    out = []
    for i in range(n):
        ref = make_case("check", i)
        out.append((ref, elsewhere(ref, ref.queries[0].stickout_mm), "consistent"))
        for factor in (0.5, 0.3):
            out.append((ref, worn(ref, factor), "differs"))
    return out


# ----------------------------------------------------------------------------- ablation


def without(case: Case, kind: str) -> Case:
    """The case with one deviation of :data:`KINDS` removed (truth recomputed), to attribute errors.

    ``lowgrade`` becomes an ordinary 48 kHz, 24-bit recording at 40 dB SNR with the same taps.
    """
    from benchmarks.realism.geometry import FAMILIES

    if kind not in KINDS:
        raise ValueError(f"unknown deviation {kind!r}")
    kinds = tuple(k for k in case.kinds if k != kind)
    holder, rec = case.holder, case.recording
    od_f, ratio = case.true_od_factors, case.true_flute_ratio
    rec_so = case.true_assembly.stickout / MM
    q_so = [q.true_stickout_mm for q in case.queries]
    if kind == "profile":
        holder = replace(holder, profile=Profile())
    elif kind == "mass":
        holder = replace(holder, extra_mass=ExtraMass())
    elif kind == "doublet":
        holder = replace(holder, asymmetry=0.0)
    elif kind == "diameters":
        od_f = (1.0,) * len(od_f)
    elif kind == "flute":
        ratio = 0.8
    elif kind == "stickout":
        rec_so, q_so = case.described.stickout / MM, [q.stickout_mm for q in case.queries]
    elif kind == "lowgrade":
        rec = replace(rec, nuisances=replace(rec.nuisances, sample_rate=48000, snr_db=40.0, mic_lp_hz=20000.0),
                      bits=24, phone_lp_hz=None)
    family = next(f for f in FAMILIES if f.key == case.family)
    t = case.described.tool
    d = t.flute_diameter / MM
    true_holder = make_holder(family, d, case.described.holder.name, od_f)
    true_tool = make_tool(d, t.total_length / MM, t.flute_length / MM, ratio)
    true_asm = assemble_geometry(true_holder, true_tool, rec_so, case.true_assembly.source)
    queries = tuple(make_query(true_asm, holder, q.stickout_mm, s) for q, s in zip(case.queries, q_so))
    return replace(case, name=f"{case.name}-no{kind}", true_assembly=true_asm, holder=holder, recording=rec,
                   truth=truth_modes(true_asm, holder), queries=queries, kinds=kinds, true_od_factors=od_f,
                   true_flute_ratio=ratio)
