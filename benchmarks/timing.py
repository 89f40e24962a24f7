"""Timing shared by the benchmarks: the best of N runs, both sides measured alike."""

import math
import time


def best_of(function, repeat=3, clock=time.process_time, once_above=math.inf):
    """Run ``function`` up to ``repeat`` times; (best time in s, value of the last run).

    The default clock is this process's CPU time (steadier than wall time on a shared
    machine); pass ``clock=time.perf_counter`` for wall time where other processes or
    I/O are part of what is measured.  A run that takes longer than ``once_above``
    seconds is not repeated (slow runs vary least, and would dominate the time).
    """
    best, value = math.inf, None
    for _ in range(repeat):
        start = clock()
        value = function()
        best = min(best, clock() - start)
        if best > once_above:
            break
    return best, value
