"""A cold numba cache filled on two cores: a command's kernels compiled half here, half in a second process.

A first ``predict`` compiles two families of kernels one after the other: the
describing function's (the harmonic balance, first) and the simulation's (the
verdict, after it), each several seconds of one core.  :func:`warm_kernels` compiles
the simulation's here with one short run of the rig's loop per law and, only if that
compiles anything (a cold cache), starts a second Python process that meanwhile
predicts the rig's cycles: its describing-function kernels land in numba's disk cache,
and this process loads them from there instead of compiling them.  On a warm cache
the short runs cost milliseconds and no process is started.  The second process is
a cache fill and nothing else: it writes no output, and if it fails this process
compiles what it misses itself (numba writes its cache files atomically).

The second process runs :data:`SECOND_PROCESS` (``python -c``) with the rig file and the laws as arguments.
"""

import os
import subprocess
import sys

from .._jit import on_first_compile
from ..config import load_rig
from ..limit_cycles import predict_limit_cycles
from ..loops import drive_loop
from ..simulation import default_step, simulate_rig

__all__ = ["warm_kernels", "SECOND_PROCESS"]

#: The second process's program: each law's harmonic balance (not ``-m`` of this module, which
#: the command line has imported already).
SECOND_PROCESS = "import sys; from backlash_df.cli.warmup import _predict_only; _predict_only(sys.argv[1], sys.argv[2:])"

#: Steps of a warm-up run (of the loop's default step): whatever the rig's time scale, a run that
#: compiles the kernel and costs milliseconds.
_WARM_STEPS = 100


def warm_kernels(rig, rig_file, models):
    """Compile the kernels that predicting and judging ``rig``'s loop under ``models`` needs.

    Parameters
    ----------
    rig : Rig
        The loop, as read from ``rig_file``.
    rig_file : str or path
        The rig file the second process reads again.
    models : sequence of str
        Torque-law names.
    """
    second = []

    def start_second():
        if _cores() > 1:  # on one core a second process only takes turns with this one
            second.append(subprocess.Popen(
                [sys.executable, "-c", SECOND_PROCESS, os.fspath(rig_file), *models],
                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))

    try:
        with on_first_compile(start_second):
            system = drive_loop(rig, dry_friction=True).linear_part()
            for name in models:
                model = rig.make_model(name)
                dt = default_step(system, model)
                simulate_rig(rig, model, t_end=_WARM_STEPS * dt, dt=dt, kick=1.0)
        for process in second:
            process.wait()
    finally:
        for process in second:
            process.kill()  # an interrupted command leaves nothing running (a no-op once it has ended)


def _cores():
    """Cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _predict_only(rig_file, models):
    """The second process: the harmonic balance of each law, for the compiled kernels it leaves in the cache."""
    rig = load_rig(rig_file)
    for name in models:
        predict_limit_cycles(rig, name)
