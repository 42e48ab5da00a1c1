"""The process entry leaves numpy's unused submodules that scipy's import looks up
(cli.UNUSED_MODULES) unexecuted until something really uses them."""

from tests.cli.test_fast_exit import run

CHECK = """
def report():
    import numpy
    print("f2py is", type(sys.modules.get("numpy.f2py")).__name__, flush=True)
    numpy.testing.assert_allclose(1.0, 1.0)  # loads on first use, and works
    print("testing is", type(sys.modules["numpy.testing"]).__name__, flush=True)
atexit.register(report)
"""


def test_a_command_that_imports_scipy_does_not_run_f2py_and_testing_still_works(reference_toml):
    proc = run(["model", str(reference_toml)], before=CHECK)
    assert proc.returncode == 0, proc.stderr
    assert "f2py is _LazyModule" in proc.stdout  # scipy was imported: the look-up happened
    assert "testing is module" in proc.stdout


def test_in_process_main_leaves_the_imports_alone():
    proc = run(["--version"], before="import taptune.cli as c; sys.argv = ['taptune']\n"
                                     "c.main(['--version']); print('finder', any(isinstance(f, c._OnFirstUse) "
                                     "for f in sys.meta_path), flush=True)")
    assert "finder False" in proc.stdout
