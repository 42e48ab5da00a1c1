"""``taptune model``: output, JSON keys, exit codes and one-line messages (docs/cli.md)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REFERENCE_TOML
from tests.cli_run import taptune

REPO = Path(__file__).resolve().parents[2]
HOLDER_A = {"k_tt": 1.90e9, "k_rr": 9.37e3, "eta_tt": 1.98e-3, "eta_rr": 8.20e-3,
            "alpha": -10.0, "density_factor": 7478 / 7800, "modulus_factor": 1.0}


def test_nominal_model_prints_a_table_and_writes_the_contract_json(reference_toml, tmp_path, capsys):
    """Nominal parameters, reference assembly: 4797.3 / 14836.9 / 20088.8 Hz
    (the nominal parameters of docs/physics.md §2; converged values of two independent implementations)."""
    out_json = tmp_path / "out" / "model.json"
    code, out, err = taptune(capsys, "model", reference_toml, "--json", out_json)
    assert code == 0, err
    assert "f [Hz]" in out and "DOFs" in out and "nominal" in out
    data = json.loads(out_json.read_text())
    for key in ("bending_hz", "damping_ratio", "dofs", "elements"):
        assert key in data
    assert data["bending_hz"][:3] == pytest.approx([4797.3, 14836.9, 20088.8], rel=5e-4)
    assert data["damping_ratio"][0] == pytest.approx(0.00394, rel=0.02)
    assert len(data["bending_bounds_hz"]) == 3
    assert data["model_options"]["h_max_mm"] == 2.0


def test_params_file_gives_holder_A_and_json_to_stdout_is_pure_json(reference_toml, tmp_path, capsys):
    """Holder A at 53.5 mm: f1 = 4685.8 Hz (converged values of two independent implementations); an identify-style {"params": {...}} file also works."""
    params = tmp_path / "a.json"
    params.write_text(json.dumps({"params": HOLDER_A}))
    code, out, err = taptune(capsys, "model", reference_toml, "--params", params, "--json", "-")
    assert code == 0, err
    data = json.loads(out)
    assert data["bending_hz"][0] == pytest.approx(4685.8, rel=5e-4)
    assert data["params"]["alpha"] == -10.0


def test_holder_from_the_library(reference_toml, tmp_path, capsys):
    from taptune.io.assembly import load_assembly
    from taptune.library.schema import HolderEntry
    from taptune.library.store import HolderLibrary
    from taptune.model.params import HolderParams

    lib = HolderLibrary(tmp_path / "holders.json")
    holder = load_assembly(reference_toml).holder
    lib.put(HolderEntry.create(holder, HolderParams(**HOLDER_A)))
    code, out, err = taptune(capsys, "model", reference_toml, "--holder", holder.name, "--library", lib.path, "--json", "-")
    assert code == 0, err
    assert json.loads(out)["bending_hz"][0] == pytest.approx(4685.8, rel=5e-4)
    code, out, err = taptune(capsys, "model", reference_toml, "--holder", "no such", "--library", lib.path)
    assert code == 2 and err.count("\n") == 1 and "no such" in err


def test_library_holder_keeps_its_model_options_and_bad_ones_are_reported(reference_toml, tmp_path, capsys):
    """The parameters were identified on a mesh: the model uses the options stored with them."""
    from taptune.io.assembly import load_assembly
    from taptune.library.schema import HolderEntry
    from taptune.library.store import HolderLibrary
    from taptune.model.params import HolderParams

    holder = load_assembly(reference_toml).holder
    lib = HolderLibrary(tmp_path / "holders.json")
    lib.put(HolderEntry.create(holder, HolderParams(**HOLDER_A), model_options={"h_max_mm": 1.0, "mass": "core"}))
    code, out, err = taptune(capsys, "model", reference_toml, "--holder", holder.name, "--library", lib.path, "--json", "-")
    assert code == 0, err
    assert json.loads(out)["model_options"]["mass"] == "core"
    lib.put(HolderEntry.create(holder, HolderParams(**HOLDER_A), model_options={"shear": "euler"}))
    code, out, err = taptune(capsys, "model", reference_toml, "--holder", holder.name, "--library", lib.path)
    assert code == 2 and err.count("\n") == 1 and "model_options" in err


BAD_ASSEMBLIES = {
    "missing_file": None,
    "not_toml": "this is [not toml",
    "stickout_too_long": REFERENCE_TOML.replace("stickout = 53.5", "stickout = 93.5"),
    "negative_length": REFERENCE_TOML.replace("{ length = 32.0, od = 48.0", "{ length = -32.0, od = 48.0"),
    "id_ge_od": REFERENCE_TOML.replace("od = 50.0, id = 16.0", "od = 50.0, id = 50.0"),
    "tool_does_not_fit": REFERENCE_TOML.replace("od = 50.0, id = 16.0", "od = 50.0, id = 12.0"),
    "missing_holder": REFERENCE_TOML.split("[tool]")[1].join(["[tool]", ""]),
    "inserted_longer_than_holder": REFERENCE_TOML.replace("stickout = 53.5", "stickout = 3.0").replace(
        "{ length = 58.0,", "{ length = 8.0,"),
    "not_utf8": b"\xff\xfe[holder]",
}


@pytest.mark.parametrize("case", list(BAD_ASSEMBLIES))
def test_every_bad_assembly_exits_2_with_one_line_naming_the_file(case, tmp_path, capsys):
    path = tmp_path / f"{case}.toml"
    content = BAD_ASSEMBLIES[case]
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        path.write_text(content)
    code, out, err = taptune(capsys, "model", path)
    assert code == 2
    assert err.count("\n") == 1 and str(path) in err and "Traceback" not in err


@pytest.mark.parametrize(
    "content", ["{not json", '{"k_tt": 1e9}', '{"k_tt": "big", "k_rr": 1, "eta_tt": 0, "eta_rr": 0, '
                '"alpha": 0, "density_factor": 1, "modulus_factor": 1}', "[1, 2]"],
)
def test_bad_params_file_exits_2_naming_the_file(reference_toml, tmp_path, capsys, content):
    params = tmp_path / "p.json"
    params.write_text(content)
    code, out, err = taptune(capsys, "model", reference_toml, "--params", params)
    assert code == 2 and err.count("\n") == 1 and str(params) in err


def test_missing_params_file_and_holder_with_params_are_usage_errors(reference_toml, tmp_path, capsys):
    code, _, err = taptune(capsys, "model", reference_toml, "--params", tmp_path / "none.json")
    assert code == 2 and "none.json" in err
    code, _, err = taptune(capsys, "model", reference_toml, "--params", "x.json", "--holder", "y")
    assert code == 2


def test_bundled_assets_all_run(capsys):
    for path in sorted((REPO / "assets").glob("*.toml")):
        code, out, err = taptune(capsys, "model", path, "--json", "-")
        assert code == 0, (path, err)
        assert len(json.loads(out)["bending_hz"]) >= 3


def test_help_is_fast_and_imports_no_heavy_library():
    """`python -m taptune --help` works without importing numpy, PySide6, matplotlib or sounddevice."""
    probe = (
        "import sys, runpy\n"
        "sys.argv = ['taptune', '--help']\n"
        "try:\n"
        "    runpy.run_module('taptune', run_name='__main__')\n"
        "except SystemExit as e:\n"
        "    code = e.code\n"
        "heavy = [m for m in ('numpy', 'scipy', 'PySide6', 'matplotlib', 'sounddevice') if m in sys.modules]\n"
        "print('HEAVY=' + ','.join(heavy))\n"
        "print('CODE=' + str(code))\n"
    )
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=REPO, timeout=60)
    assert "usage: taptune" in proc.stdout and "model" in proc.stdout
    assert "HEAVY=\n" in proc.stdout, proc.stdout
    assert "CODE=0" in proc.stdout
    real = subprocess.run([sys.executable, "-m", "taptune", "--help"], capture_output=True, text=True, cwd=REPO, timeout=60)
    assert real.returncode == 0 and "model" in real.stdout


def test_model_help_lists_its_options(capsys):
    code, out, _ = taptune(capsys, "model", "--help")
    assert code == 0 and "--holder" in out and "--params" in out and "--library" in out and "--json" in out
