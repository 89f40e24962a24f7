"""solve_ivp with event location for piecewise-smooth drives (shared by the benchmarks).

A backlash loop is smooth inside each contact mode.  Integrating it with the mode
held and restarting at every switch, located as a zero of a continuous guard, keeps
the integrator's order across switches; this is solve_ivp at its best and, at
tight tolerances, the benchmarks' independent reference.
"""

import numpy as np
from scipy.integrate import solve_ivp

from backlash_df import theta_star


def solve_switched(rhs_of, guards_of, z0, mode, t_end, t_eval, method, rtol, row=0):
    """Component ``row`` of the state on ``t_eval``, integrated mode by mode.

    Parameters
    ----------
    rhs_of : callable
        ``rhs_of(mode)`` gives ``f(t, z)``, smooth, for solve_ivp.
    guards_of : callable
        ``guards_of(mode)`` gives ``[(g, next_mode), ...]``: ``g(t, z)`` is positive
        while ``mode`` holds and falls through zero where ``next_mode`` begins.
    z0, mode : ndarray, int
        Initial state and mode.
    t_end, t_eval : float, ndarray
        End time (s) and output times (s, increasing, in ``[0, t_end]``).
    method, rtol : str, float
        solve_ivp's method and relative tolerance (``atol = 1e-3 rtol``).
    """
    t, z = 0.0, np.asarray(z0, dtype=float)
    out = np.full(t_eval.size, np.nan)
    while True:
        pairs = guards_of(mode)
        for g, _ in pairs:
            g.terminal, g.direction = True, -1.0
        first = int(np.searchsorted(t_eval, t))
        sol = solve_ivp(rhs_of(mode), (t, t_end), z, method=method, rtol=rtol, atol=rtol * 1e-3,
                        t_eval=t_eval[first:], events=[g for g, _ in pairs])
        out[first:first + sol.t.size] = sol.y[row]
        hit = [i for i, times in enumerate(sol.t_events) if times.size]
        if sol.status != 1 or not hit:
            return out
        t, z, mode = sol.t_events[hit[0]][0], sol.y_events[hit[0]][0], pairs[hit[0]][1]


def phase_plane_guards(mode, xv, k, c, alpha):
    """Guards of the phase plane law (19)-(23) with contact held until release.

    Contact (``mode`` +-2) ends where ``k (x -+ alpha) + c v`` changes sign (Theorem 1);
    the free shaft closes on the right where x reaches theta*(v) (v > 0, eq. (19)) or
    ``k (x - alpha) + c v = 0`` (v <= 0), on the left by symmetry.  ``xv(z)`` gives
    (theta_d, dtheta_d) of a state.
    """
    def closing(side):
        def g(t, z):
            x, v = (side * value for value in xv(z))
            return (float(theta_star(v, k, c, alpha)) if v > 0.0 else alpha - c * v / k) - x
        return g

    def release(t, z):
        x, v = xv(z)
        return mode / 2 * (k * (x - mode / 2 * alpha) + c * v)

    return [(release, 0)] if mode else [(closing(1), 2), (closing(-1), -2)]
