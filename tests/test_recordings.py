"""The example recordings are what ``scripts/make_recordings.py`` makes, byte for byte:
"Regenerate (deterministic)" in recordings/README.md stays true."""

from __future__ import annotations

import importlib.util
import json

import pytest

from tests.conftest import REPO


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("make_recordings", REPO / "scripts" / "make_recordings.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_scripts_truth_and_manifest_are_the_committed_ones(script):
    for case in script.CASES:
        committed = json.loads((REPO / "recordings" / f"{case['name']}.truth.json").read_text())
        assert json.loads(json.dumps(script.truth_of(case))) == committed, case["name"]
        assert (REPO / "recordings" / f"{case['name']}.toml").read_bytes() == (REPO / "assets" / case["asset"]).read_bytes()
    assert script.manifest() == json.loads((REPO / "recordings" / "demo.json").read_text())


def test_the_script_renders_the_committed_recordings(script, tmp_path):
    for case in script.CASES:
        name = case["audio"]["file"]
        script.render(case, tmp_path / name)
        assert (tmp_path / name).read_bytes() == (REPO / "recordings" / name).read_bytes(), name


def test_no_description_names_a_file_users_do_not_have(script):
    for case in script.CASES:
        assert ".md §" not in case["description"] and "MODEL" not in case["description"]
