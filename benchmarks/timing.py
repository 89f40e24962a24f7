"""Timing shared by the benchmarks: the best of N runs, both sides measured alike."""

import math
import time


def best_of(function, repeat=3, clock=time.process_time):
    """Run ``function`` ``repeat`` times; (best time in s, value of the last run).

    The default clock is this process's CPU time (steadier than wall time on a shared
    machine); pass ``clock=time.perf_counter`` for wall time where other processes or
    I/O are part of what is measured.
    """
    best, value = math.inf, None
    for _ in range(repeat):
        start = clock()
        value = function()
        best = min(best, clock() - start)
    return best, value
