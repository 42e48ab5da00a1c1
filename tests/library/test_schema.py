"""The library file format: exact round trips, validation messages, nothing ever executed."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import pickle

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from taptune.errors import InputError
from taptune.io.assembly import parse_assembly
from taptune.library import HolderEntry, HolderLibrary, LibraryFormatError, ProvenanceRecord, tool_from_dict, tool_to_dict
from taptune.library.schema import check_param_sets, check_params, decode, encode, parse_library
from taptune.model.params import NAMES, HolderParams
from tests.library.entries import REFERENCE, make_entry, make_record


def document(*entries: HolderEntry) -> dict:
    return json.loads(encode({e.name: e for e in entries}, "<test>"))


def test_entry_round_trips_through_json_exactly():
    entry = make_entry(records=3)
    again = HolderEntry.from_dict(json.loads(json.dumps(entry.to_dict())), "<test>")
    assert again == entry
    assert parse_library(document(entry), "<test>") == {entry.name: entry}


def test_tool_geometry_round_trips_for_both_tool_descriptions():
    stepped = parse_assembly(
        {
            "holder": {"name": "H", "clamp_length": 40, "segments": [{"length": 100, "od": 50, "id": 16}]},
            "tool": {"name": "stepped", "total_length": 90, "segments": [{"length": 50, "od": 16}, {"length": 40, "od": 12}]},
            "setup": {"stickout": 50},
        }
    ).tool
    for tool in (REFERENCE.tool, stepped):
        assert tool_from_dict(json.loads(json.dumps(tool_to_dict(tool)))) == tool


def test_entry_rebuilds_the_identified_assembly():
    entry = make_entry()
    record = entry.identifications[0]
    asm = entry.assembly(record.tool, record.stickout_mm)
    assert asm.holder == REFERENCE.holder and asm.tool == REFERENCE.tool
    assert asm.stickout == pytest.approx(REFERENCE.stickout, abs=1e-12)
    assert entry.holder_geometry() == REFERENCE.holder


def test_the_stated_stickout_tolerance_round_trips_and_is_optional():
    stated = ProvenanceRecord(**{**make_record().__dict__, "stickout_tolerance_mm": 0.05})
    assert ProvenanceRecord.from_dict(json.loads(json.dumps(stated.to_dict())), "<test>") == stated
    older = make_record()
    assert "stickout_tolerance_mm" not in older.to_dict()
    assert ProvenanceRecord.from_dict(older.to_dict(), "<test>").stickout_tolerance_mm is None


def test_a_mode_not_measured_keeps_its_place():
    record = ProvenanceRecord(**{**make_record().__dict__, "bending_measured_hz": [3050.0, None, 12990.25]})
    again = ProvenanceRecord.from_dict(json.loads(json.dumps(record.to_dict())), "<test>")
    assert again == record and again.bending_measured_hz == (3050.0, None, 12990.25)


def test_spread_is_the_half_width_over_best_and_near_optimal_sets():
    entry = make_entry()
    spread = entry.spread()
    # k_tt: best 2.81e9, sets 1.1x and 0.95x -> half-width (1.1 - 0.95) / 2 x 2.81e9
    assert spread["k_tt"] == pytest.approx(0.075 * 2.81e9)
    assert spread["eta_tt"] == pytest.approx((9e-3 - 2e-3) / 2)
    assert spread["alpha"] == pytest.approx((-6.5 - -12.0) / 2)
    assert spread["k_rr"] == 0.0


def test_last_identified_is_the_latest_date():
    entry = make_entry(records=3, first=4)
    assert entry.last_identified == "2026-11-22T12:00:06Z"
    assert make_entry(records=0).last_identified is None


# --------------------------------------------------------------------------- validation

NAME = "ER32 collet chuck HSK-A63 x 100"


# A valid check record (taptune check) to break one key at a time.
CHECK = {"date": "2026-11-22T12:00:00Z", "recording": "tap.wav", "sha256": "0" * 64, "tool": "end mill",
         "stickout_mm": 50.0, "verdict": "consistent", "taptune_version": "0.1.0",
         "modes": [{"mode": 1, "measured_hz": 3000.0, "predicted_hz": 3010.0, "band_hz": 30.0}]}


def mutate(path: tuple, value):
    def apply(doc):
        node = doc["holders"][NAME]
        for key in path[:-1]:
            node = node[key]
        if value is KeyError:
            del node[path[-1]]
        else:
            node[path[-1]] = value
        return doc

    return apply


@pytest.mark.parametrize(
    "change, key, problem",
    [
        (mutate(("params", "k_tt"), "stiff"), "params.k_tt", "finite number"),
        (mutate(("params", "k_tt"), 10**400), "params.k_tt", "finite number"),
        (mutate(("holder", "clamp_length"), -(10**400)), "holder.clamp_length", "finite number"),
        (mutate(("params", "k_rr"), -1.0), "k_rr", "> 0"),
        (mutate(("params", "eta_rr"), KeyError), "params.eta_rr", "is missing"),
        (mutate(("params", "extra"), 1.0), "params.extra", "not a known key"),
        (mutate(("param_sets", 1, "alpha"), 150.0), "alpha", "(-100, 100)"),
        (mutate(("holder", "segments", 1, "od"), -48.0), "holder.segments[2].od", "> 0"),
        (mutate(("holder", "clamp_length"), 500.0), "holder.clamp_length", "exceeds the holder length"),
        (mutate(("interface",), "SK40"), "interface", "differs from holder.interface"),
        (mutate(("identifications", 0, "sha256"), "abc"), "identifications[0].sha256", "64 lower-case hex"),
        (mutate(("identifications", 0, "date"), "yesterday"), "identifications[0].date", "ISO-8601"),
        (mutate(("identifications", 0, "date"), "2026-11-22T12:00:00+01:00"), "identifications[0].date", "UTC"),
        (mutate(("identifications", 0, "seed"), 1.5), "identifications[0].seed", "integer"),
        (mutate(("identifications", 0, "tool", "segments"), []), "identifications[0].tool.segments", "non-empty"),
        (mutate(("identifications", 0, "bending_measured_hz"), "3 kHz"), "bending_measured_hz", "list of frequencies"),
        (mutate(("identifications", 0, "bending_model_hz"), [3000.0, -1.0]), "bending_model_hz[1]", "> 0"),
        (mutate(("identifications", 0, "stickout_tolerance_mm"), -0.3), "identifications[0].stickout_tolerance_mm",
         ">= 0"),
        (mutate(("identifications", 0, "stickout_tolerance_mm"), "0.3 mm"), "identifications[0].stickout_tolerance_mm",
         "finite number"),
        (mutate(("identifications", 0, "stickout_tolerance_mm"), 300.0), "identifications[0].stickout_tolerance_mm",
         "<= 20 mm"),
        (mutate(("model_options",), [1, 2]), "model_options", "JSON object"),
        (mutate(("__class__",), "os.system"), "__class__", "not a known key"),
        (mutate(("name",), "other"), "name", "differs from its key"),
        (mutate(("param_sets",), {}), "param_sets", "must be a list of parameter objects"),
        (mutate(("identifications",), "tap.wav"), "identifications", "must be a list, got a string"),
        (mutate(("checks",), "oops"), "checks", "must be a list, got a string"),
        (mutate(("checks",), [CHECK | {"modes": {}}]), "checks[0].modes", "must be a list, got an object"),
        (mutate(("checks",), [CHECK | {"verdict": "fine"}]), "checks[0].verdict", "must be one of consistent"),
        (mutate(("checks",), [CHECK | {"sha256": "abc"}]), "checks[0].sha256", "64 lower-case hex"),
        (mutate(("checks",), [CHECK | {"modes": [{"mode": 1, "measured_hz": None, "predicted_hz": 3000.0,
                                                  "band_hz": -1.0}]}]), "checks[0].modes[0].band_hz", ">= 0"),
    ],
)
def test_validation_names_file_holder_and_key(tmp_path, change, key, problem):
    path = tmp_path / "holders.json"
    path.write_text(json.dumps(change(document(make_entry(NAME)))))
    with pytest.raises(LibraryFormatError) as info:
        HolderLibrary(path).entries()
    message = str(info.value)
    assert message.startswith(f"{path}: holder {NAME!r}: "), message
    assert key in message and problem in message, message


@pytest.mark.parametrize(
    "text, problem",
    [
        ('{"schema": "taptune-holder-library", "version": 5, "holders": {}}', "newer taptune"),
        ('{"schema": "taptune-holder-library", "version": "1", "holders": {}}', "version must be a positive integer"),
        ('{"schema": "taptune-holder-library", "version": 1, "holders": []}', "holders must be a JSON object"),
        ('{"schema": "taptune-holder-library", "version": 1, "holders": {}, "x": 1}', "x is not a known key"),
        ('{"schema": "taptune-holder-library", "version": 1, "holders": {"a": NaN}}', "NaN is not a JSON number"),
        ('{"schema": "taptune-holder-library", "version": 1, "holders": {}, "holders": {}}', "duplicate key 'holders'"),
        ('{"version": 1, "holders": {}}', "not a taptune holder library"),
        ("[" * 100000, "nested too deeply"),
    ],
)
def test_document_level_problems_name_the_file(text, problem):
    with pytest.raises(LibraryFormatError, match=problem) as info:
        parse_library(decode(text.encode(), "lib.json"), "lib.json")
    assert str(info.value).startswith("lib.json: ")


def test_nothing_invalid_is_ever_written(lib):
    bad = make_entry("A")
    bad = HolderEntry(**{**bad.__dict__, "identifications": (ProvenanceRecord(**{**make_record().__dict__, "sha256": "xyz"}),)})
    with pytest.raises(LibraryFormatError, match=r"new entry for holder 'A': identifications\[0\]\.sha256"):
        lib.put(bad)
    assert not lib.path.exists()


# --------------------------------------------------------------------------- never executed


class Exploit:
    """Unpickling this would create a marker file: proof that pickle ran code."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


def test_a_pickle_is_rejected_without_being_unpickled(tmp_path):
    marker = tmp_path / "pwned"
    path = tmp_path / "holders.json"
    path.write_bytes(pickle.dumps(Exploit(str(marker))))
    with pytest.raises(LibraryFormatError, match="not (UTF-8|valid JSON)"):
        HolderLibrary(path).entries()
    assert not marker.exists()


def test_code_like_strings_stay_data(tmp_path):
    marker = tmp_path / "pwned"
    payload = f"__import__('os').system('touch {marker}')"
    doc = document(make_entry(NAME))
    doc["holders"][NAME]["identifications"][0]["recording"] = payload
    doc["holders"][NAME]["model_options"] = {"__reduce__": payload, "py/object": "os.system"}
    path = tmp_path / "holders.json"
    path.write_text(json.dumps(doc))
    entry = HolderLibrary(path).get(NAME)
    assert entry.identifications[0].recording == payload
    assert entry.model_options["py/object"] == "os.system"
    assert not marker.exists()


def test_encoding_refuses_a_non_entry():
    with pytest.raises(Exception, match="must be a HolderEntry"):
        encode({"A": copy.deepcopy(make_entry("A").to_dict())}, "<test>")


# --------------------------------------------------------------------------- property

def plausible(lo, hi):
    """Any float inside HolderParams.from_dict's plausibility limits."""
    return st.floats(min_value=lo, max_value=hi, allow_nan=False, allow_infinity=False)


params_strategy = st.builds(
    HolderParams,
    k_tt=plausible(1e2, 1e12),
    k_rr=plausible(1.0, 1e7),
    eta_tt=plausible(0.0, 1.0),
    eta_rr=plausible(0.0, 1.0),
    alpha=st.floats(min_value=-99.999, max_value=99.999),
    density_factor=plausible(0.1, 10.0),
    modulus_factor=plausible(0.1, 10.0),
)
names = st.text(st.characters(min_codepoint=32, blacklist_categories=("Cs",)), min_size=1, max_size=40).filter(str.strip)


@settings(max_examples=60, derandomize=True, deadline=None)
@given(names=st.lists(names, min_size=1, max_size=4, unique=True), best=params_strategy,
       sets=st.lists(params_strategy, max_size=3))
def test_any_valid_library_round_trips_bit_for_bit(names, best, sets):
    base = make_entry(records=2)
    entries = {n: HolderEntry(**{**base.__dict__, "name": n, "params": best, "param_sets": tuple(sets)}) for n in names}
    raw = encode(entries, "<test>")
    again = parse_library(decode(raw, "<test>"), "<test>")
    assert again == entries
    assert encode(again, "<test>") == raw


# --------------------------------------------------------------------------- the fast checks

BEST = make_entry().params.to_dict()
EDGE_VALUES = [1e2, 1e12, 99.0, 1.0, 1e7, 0.0, 0.1, 10.0, 0.5, -0.0, math.nextafter(1e12, math.inf), 0.09999999,
               math.nextafter(100.0, 0.0), 100.0, -100.0, math.nextafter(-100.0, 0.0), 150.0, -1.0, 1e300, math.inf,
               -math.inf, math.nan, 5, 0, True, None, "1.0", 10**400]


def _params_outcome(check, data):
    try:
        return check(data)
    except (LibraryFormatError, InputError) as err:
        return str(err).rsplit(": ", 1)[-1]  # the problem, without the source each check names its own way


@pytest.mark.parametrize("key", NAMES)
@pytest.mark.parametrize("value", EDGE_VALUES, ids=repr)
def test_the_fast_parameter_check_accepts_and_refuses_what_the_full_check_does(key, value):
    data = {**BEST, key: value}
    fast = _params_outcome(lambda d: check_params(d, "<test>", "params"), data)
    full = _params_outcome(lambda d: HolderParams.from_dict(d, "<test>: params"), data)
    if isinstance(full, HolderParams):
        assert fast == full and all(type(v) is float for v in fast.to_dict().values())
    else:
        assert not isinstance(fast, HolderParams), f"{key} = {value!r} passed the fast check only"


def test_parameter_objects_with_a_key_missing_or_extra_are_refused():
    with pytest.raises(LibraryFormatError, match="params.eta_rr is missing"):
        check_params({k: v for k, v in BEST.items() if k != "eta_rr"}, "<test>", "params")
    with pytest.raises(LibraryFormatError, match="params.spare is not a known key"):
        check_params({**{k: v for k, v in BEST.items() if k != "eta_rr"}, "spare": 1.0}, "<test>", "params")
    assert [f.name for f in dataclasses.fields(HolderParams)] == list(NAMES)  # the fast path builds by position


@pytest.mark.parametrize("key", NAMES)
@pytest.mark.parametrize("value", EDGE_VALUES, ids=repr)
def test_the_parameter_sets_are_checked_as_one_by_one(key, value):
    good = make_entry().param_sets[0].to_dict()
    sets = [good, {**BEST, key: value}, good]
    full = [_params_outcome(lambda d: HolderParams.from_dict(d, "<test>"), s) for s in sets]
    if all(isinstance(p, HolderParams) for p in full):
        assert check_param_sets(sets, "<test>", "param_sets") == tuple(full)
    else:
        with pytest.raises(LibraryFormatError, match=rf"^<test>: param_sets\[1\]"):
            check_param_sets(sets, "<test>", "param_sets")


def test_parameter_sets_that_are_not_all_objects_of_seven_are_refused_naming_the_set():
    assert check_param_sets([], "<test>", "param_sets") == ()
    for bad, problem in (([BEST, [1.0] * 7], "param_sets\\[1\\] must be a JSON object"),
                         ([BEST, {**BEST, "spare": 1.0}], "param_sets\\[1\\].spare is not a known key"),
                         ([{k: v for k, v in BEST.items() if k != "alpha"} | {"spare": 1.0}], "param_sets\\[0\\].spare")):
        with pytest.raises(LibraryFormatError, match=problem):
            check_param_sets(bad, "<test>", "param_sets")
