"""Importing backlash_df loads only what every path needs (issue 13).

python-control, ``scipy.signal``, ``scipy.optimize`` and ``matplotlib.pyplot`` each
take from a fraction of a second to two seconds to import; they are imported by the
paths that use them.  Each check runs in a fresh interpreter and reads ``sys.modules``
(no timing assertions: the times are measured by ``benchmarks/bench_startup.py``).
"""

import json
import subprocess
import sys

HEAVY = ("control", "scipy.signal", "scipy.optimize", "matplotlib.pyplot")


def loaded_after(code):
    """The HEAVY modules present in ``sys.modules`` after running ``code`` in a fresh interpreter."""
    probe = f"import json, sys\n{code}\nprint(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return set(json.loads(done.stdout.splitlines()[-1]))


def test_import_loads_no_heavy_module():
    assert loaded_after("import backlash_df") == set()


def test_the_predict_path_needs_no_heavy_module():
    # a torque law and its ufuncs, theta*, and G(jw) of the loop from its state-space form
    code = (
        "import backlash_df as bd\n"
        "from backlash_df.config import Controller, Plant\n"
        "law = bd.make_model('phase-plane', stiffness=5895.0, damping=3.0, half_gap=0.05)\n"
        "assert abs(float(law.torque(0.06, 0.0)) - 5895.0 * 0.01) < 1e-9\n"
        "assert float(bd.theta_star(0.0, 5895.0, 3.0, 0.05)) == 0.05\n"
        "loop = bd.DriveLoop(Plant(0.4, 5.6, 5895.0, 0.05), Controller(kp=30.0, ti=0.5))\n"
        "loop.frequency_response([1.0, 10.0])"
    )
    assert loaded_after(code) == set()


def test_a_path_that_needs_control_still_imports_it():
    # the lazy import sits inside the function: a rational G(s) brings python-control in
    code = (
        "import backlash_df as bd\n"
        "from backlash_df.config import Controller, Plant\n"
        "loop = bd.DriveLoop(Plant(0.4, 5.6, 5895.0, 0.05), Controller(kp=30.0, ti=0.5))\n"
        "g = loop.transfer_function()\n"
        "assert abs(g(2j) - loop.frequency_response(2.0)) < 1e-12 * abs(g(2j))"
    )
    assert "control" in loaded_after(code)


def test_a_command_imports_only_the_stages_it_runs():
    """Issue 49: ``backlash-df predict`` imports neither the diagnosis, nor the tuning, nor the sweeps."""
    code = (
        "import sys\n"
        "from backlash_df.cli import main\n"
        "sys.argv = ['backlash-df', 'predict', '--help']\n"
        "try:\n"
        "    main()\n"
        "except SystemExit:\n"
        "    pass\n"
        "import backlash_df.analysis\n"  # what predict runs, imported as it runs it
        "print(json.dumps(sorted(m for m in sys.modules if m.startswith('backlash_df'))))"
    )
    done = subprocess.run([sys.executable, "-c", "import json\n" + code], capture_output=True, text=True, check=True)
    loaded = set(json.loads(done.stdout.splitlines()[-1]))
    assert "backlash_df.analysis" in loaded and "backlash_df.cli.predict" in loaded
    unneeded = {"backlash_df.identify", "backlash_df.tuning", "backlash_df.sweeps", "backlash_df.continuation",
                "backlash_df.reproduce", "backlash_df.checkpoint", "backlash_df.cli.diagnose", "backlash_df.cli.tune"}
    assert loaded & unneeded == set()
