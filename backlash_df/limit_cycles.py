"""Limit cycles of a loop closed through backlash: solving G(jw) N(A, w) = -1.

With the loop cut at the backlash (:mod:`backlash_df.loops`), a harmonic
oscillation ``theta_d = A sin(w t)`` sustains itself when

    F(A, w) = 1 + G(jw) N(A, w) = 0,

two real equations in the amplitude A (rad, first harmonic of theta_d) and the
frequency w (rad/s).  The -1/N(A, w) loci of the damped models depend on w, and
the loci can be nearly tangent to G(jw), so a single local solve is not enough:

1. ``F`` is evaluated on a grid in ``(log(A - alpha), log w)``;
2. every grid cell around which ``F`` winds (topological degree != 0) and every
   interior local minimum of ``|F|`` seeds a damped Newton solve;
3. converged roots are deduplicated; of the minima whose Newton solve found
   no root, the deepest of each valley (a chain of minima at most two grid
   steps apart, the floor of a long narrow valley that nearly tangent loci
   leave) starts a bounded minimisation of ``|F|`` to the closest approach,
   reported as a *near miss* with its distance ``|1 + G N|``, the relative
   change of G (gain and phase together) that would make the loci meet.

N is pointwise (a point's value does not depend on the other points of a call; the
DC-balanced one of a loaded loop too, each point's bias solved on its own), so the
evaluations are batched without changing a digit: G is built once per loop, every
point asked for brings its Jacobian's four neighbours along, the Newton solves
from all seeds advance side by side, one call of ``G`` and ``N`` per round; the
near-miss solves (scipy's least squares) run one after the other.

Stability is Loeb's criterion (Gelb and Vander Velde, 1968, Ch. 2): with
``U + jV = 1 + G(jw) N(A, w)``, a cycle is stable if

    dU/dA dV/dw - dU/dw dV/dA > 0,

i.e. a small increase of the amplitude moves the characteristic root into the
left half plane.  It is a local, first-harmonic statement; the time simulation
(:func:`verify_limit_cycles`) is the check.
"""

import cmath
import dataclasses
import functools
import math

import numpy as np

from ._json import json_ready
from .describing import BiasedDescribing, describing_function
from .loops import DriveLoop, drive_loop, frequency_response_of
from .models import BacklashModel
from .plotting import ResultPlot, adaptive_curve, axes_or_new, legend_below, legend_under, scaled_ticks
from .render.prediction import prediction_report
from .simulation import simulated_limit_cycle
from .slaving import CommandFrictionSlaving, CommandSlaving, FrictionPairSlaving, FrictionSlaving
from .system import frequency_response

__all__ = [
    "LimitCycle",
    "NearMiss",
    "LimitCyclePrediction",
    "solve_harmonic_balance",
    "default_ranges",
    "predict_limit_cycles",
    "verify_limit_cycles",
    "limit_cycle_plot",
]

_NEWTON_TOL = 1e-11
_FD_STEP = 1e-6
# Relative difference of |1 + G N| below which two values count as equal: a flat of the
# residual (the gear in contact, N independent of A) varies by round-off only, ~1e-13.
_FLAT_TOL = 1e-9
# Around a dip of a saturated branch (_dips): its frequency sampled this many times finer than the scan, and the
# scans either side of it reaching this close to it, relative.
_DIP_REFINE = 16
_DIP_NEAREST = 1e-9


@dataclasses.dataclass(frozen=True)
class LimitCycle:
    """One solution (A, w) of G(jw) N(A, w) = -1.

    Attributes
    ----------
    amplitude : float
        A, first-harmonic amplitude of theta_d, rad.
    omega : float
        w, rad/s.
    stable : bool
        Loeb's criterion (module docs).
    loeb : float
        ``dU/dA dV/dw - dU/dw dV/dA`` in (1/rad)(s/rad); its sign decides ``stable``.  On a
        saturated cycle of a torque-limited loop, times the sign of the command amplitude's
        slope along the slaved gain's branch: the criterion taken in the command's amplitude
        (:func:`_slaved_cycle`).
    residual : float
        ``|1 + G(jw) N(A, w)|`` at the solution.
    simulated : MeasuredCycle or None
        The cycle measured in time simulation, once verified.
    bias : float
        Mean of theta_d, rad: 0 without load, set by the DC balance under a load
        torque (:func:`~backlash_df.describing.dc_bias`).
    command_amplitude : float
        With a torque limit: U, the first-harmonic amplitude of the controller's
        command u (N m) on the cycle; NaN without a limit.
    saturated : bool
        True where ``U`` exceeds the torque limit: the cycle's command saturates.
    friction_amplitude : dict
        With dry friction: ``{side: A_w}``, the first-harmonic amplitude of each
        rubbing side's speed on the cycle (rad/s, sides ``"motor"``, ``"load"``);
        empty without.
    """

    amplitude: float
    omega: float
    stable: bool
    loeb: float
    residual: float
    simulated: object = None
    bias: float = 0.0
    command_amplitude: float = math.nan
    saturated: bool = False
    friction_amplitude: dict = dataclasses.field(default_factory=dict, hash=False)

    @property
    def amplitude_error(self):
        """Relative error of the predicted amplitude against simulation (NaN if none, or no period)."""
        if self.simulated is None or not self.simulated.periodic:
            return math.nan
        return self.amplitude / self.simulated.amplitude - 1.0

    @property
    def omega_error(self):
        """Relative error of the predicted frequency against simulation (NaN if none, or no period)."""
        if self.simulated is None or not self.simulated.periodic:
            return math.nan
        return self.omega / self.simulated.omega - 1.0

    def to_dict(self):
        """The entry of the ``predict`` JSON's ``limit_cycles`` (rad, rad/s), without ``model``."""
        return {
            "amplitude": float(self.amplitude),
            "omega": float(self.omega),
            "bias": float(self.bias),
            "stable": bool(self.stable),
            "simulated": None if self.simulated is None else self.simulated.cycle_dict(),
            "command_amplitude": None if math.isnan(self.command_amplitude) else float(self.command_amplitude),
            "saturated": bool(self.saturated),
            **({"friction_amplitude": {side: float(value) for side, value in self.friction_amplitude.items()}}
               if self.friction_amplitude else {}),
        }

    def __repr__(self):
        kind = "stable" if self.stable else "unstable"
        text = f"LimitCycle(A={self.amplitude:.6g} rad, omega={self.omega:.6g} rad/s, {kind}"
        if not math.isnan(self.command_amplitude):
            text += f", command U={self.command_amplitude:.4g} N m{' saturated' if self.saturated else ''}"
        if self.friction_amplitude:
            speeds = ", ".join(f"{side} {value:.4g}" for side, value in self.friction_amplitude.items())
            text += f", rubbing speed {speeds} rad/s"
        if self.simulated is not None:
            text += f", simulated={self.simulated!r}"
        return text + ")"


@dataclasses.dataclass(frozen=True)
class NearMiss:
    """Where the loci come closest without meeting.

    Attributes
    ----------
    amplitude, omega : float
        A (rad) and w (rad/s) of the closest approach.
    distance : float
        ``min |1 + G(jw) N(A, w)|``: the relative change of G (gain and phase)
        that would create a limit cycle there.
    """

    amplitude: float
    omega: float
    distance: float

    def to_dict(self):
        """JSON-ready: ``{"amplitude", "omega", "distance"}`` (rad, rad/s, relative)."""
        return {"amplitude": self.amplitude, "omega": self.omega, "distance": self.distance}

    def __repr__(self):
        return f"NearMiss(A={self.amplitude:.6g} rad, omega={self.omega:.6g} rad/s, distance={100 * self.distance:.3f} %)"


@dataclasses.dataclass(frozen=True)
class LimitCyclePrediction:
    """Predicted limit cycles of one loop with one torque law.

    Attributes
    ----------
    model : str
        Torque-law name.
    cycles : tuple of LimitCycle
        All solutions in the searched range, by increasing amplitude.
    near_misses : tuple of NearMiss
        Closest approaches that are not solutions, by increasing distance.
    amplitude_range, omega_range : tuple of float
        The searched box, rad and rad/s.
    simulation : MeasuredCycle or None
        After :func:`verify_limit_cycles`: what the time simulation settled to
        (started on the first stable predicted cycle, or from the default kick
        when none is predicted).
    linear : object
        The linear part (DriveLoop, LTI or callable), for plots.
    describing : callable
        ``N(A, w)`` used, for plots.
    half_gap : float
        alpha, rad.
    note : str
        Why the describing function could not be applied to this loop (then
        ``cycles`` and ``near_misses`` are empty and the verdict rests on the
        simulations); ``""`` otherwise.
    law : BacklashModel or None
        The torque law the cycles are of, as an object: later stages simulate
        and shoot with it.  None for a user's ``describing`` without a named law.
    rig : Rig
        The rig the loop was built from, its shaft the law's
        (:meth:`~backlash_df.config.Rig.with_law`).
    user_linear : control.LTI, callable or None
        The user's linear part, None for the rig's own loop.
    void_cycles : tuple of LimitCycle
        With dry friction: solutions of the harmonic balance where the friction holds
        the side through the cycle (:class:`~backlash_df.slaving.FrictionSlaving` has no fixed point): the
        describing function of a sliding side does not hold there, so they are not
        ``cycles`` and no later stage takes them as evidence.
    amplitude_unit, linear_name, linear_unit : str
        How plots and text name the amplitude's unit and the linear part: ``"rad"``,
        ``"G"``, ``"rad/(N m)"`` for a drive; ``""``, ``"H"``, ``""`` for a user's
        Lur'e loop (:mod:`backlash_df.lure`), whose units are the user's.
    """

    model: str
    cycles: tuple
    near_misses: tuple
    amplitude_range: tuple
    omega_range: tuple
    simulation: object = None
    linear: object = dataclasses.field(repr=False, default=None)
    describing: object = dataclasses.field(repr=False, default=None)
    half_gap: float = dataclasses.field(repr=False, default=0.0)
    note: str = ""
    law: object = dataclasses.field(repr=False, default=None)
    rig: object = dataclasses.field(repr=False, default=None)
    user_linear: object = dataclasses.field(repr=False, default=None)
    void_cycles: tuple = ()
    amplitude_unit: str = "rad"
    linear_name: str = "G"
    linear_unit: str = "rad/(N m)"

    def loop(self, rig=None, linear=None):
        """``(rig, law, user_linear)``: what a later stage simulates, the prediction's own.

        A later stage (verification, the verdict, the exact orbits) takes them from
        here, never rebuilds them.  A ``rig`` or ``linear`` handed to that stage must
        be the prediction's (a rig with the law's shaft, the same linear object):
        anything else is refused in one line, as is a prediction without a law to
        simulate (a user's describing function for which no law was named).

        Raises
        ------
        ValueError
            As above.
        """
        if self.law is None:
            raise ValueError(f"the prediction '{self.model}' used a describing function with no torque law named: "
                             f"pass model= (the law whose DF it is) to predict_limit_cycles to simulate it")
        if rig is not None and self.rig is not None and rig.with_law(self.law) != self.rig:
            raise ValueError(f"the rig given ({rig.source}) is not the one the '{self.model}' prediction was "
                             f"computed for ({self.rig.source}, with the law's shaft): predict on this rig first")
        if linear is not None and not isinstance(linear, DriveLoop) and linear is not self.user_linear:
            raise ValueError(f"the linear part given is not the one the '{self.model}' prediction was computed "
                             f"with: predict with linear= this system first")
        return (self.rig if self.rig is not None else rig), self.law, self.user_linear

    @property
    def stable_cycles(self):
        """The cycles Loeb's criterion calls stable (those a simulation can show)."""
        return tuple(cycle for cycle in self.cycles if cycle.stable)

    @property
    def balanced(self):
        """Whether the DF solved the DC balance under a load torque (:class:`~backlash_df.describing.BiasedDescribing`):
        the cycles' biases are the balance's."""
        return isinstance(self.describing, BiasedDescribing)

    def __repr__(self):
        cycles = ", ".join(f"{'stable' if c.stable else 'unstable'} A={c.amplitude:.4g}{_unit(self)} w={c.omega:.4g} "
                           f"rad/s" for c in self.cycles) or (f"no DF: {self.note}" if self.note else "no cycle")
        if self.void_cycles:
            cycles += f"; {len(self.void_cycles)} void (the friction holds the side through the cycle)"
        miss = f"; closest miss {100 * self.near_misses[0].distance:.2f} %" if self.near_misses else ""
        sim = "" if self.simulation is None else f"; simulated: {self.simulation.verdict}"
        return f"<LimitCyclePrediction {self.model}: {cycles}{miss}{sim}>"

    def cycle_dicts(self):
        """The ``limit_cycles`` entries of the ``predict`` JSON (contract page): one per cycle."""
        return [{"model": self.model, **cycle.to_dict()} for cycle in self.cycles]

    def to_dict(self):
        """JSON-ready: the cycles, near misses, what the simulation settled to and the searched box."""
        return json_ready({
            "model": self.model,
            "cycles": [cycle.to_dict() for cycle in self.cycles],
            "near_misses": [miss.to_dict() for miss in self.near_misses],
            "simulated": None if self.simulation is None else self.simulation.cycle_dict(),
            "amplitude_range": list(self.amplitude_range),
            "omega_range": list(self.omega_range),
            "note": self.note or None,
            **({"void_cycles": [cycle.to_dict() for cycle in self.void_cycles]} if self.void_cycles else {}),
        })

    def plot(self, ax=None, **kwargs):
        """Nyquist overlay of G(jw) and the -1/N(A, w) loci; see :func:`limit_cycle_plot`."""
        return limit_cycle_plot([self], ax=ax, **kwargs)

    def report_html(self, title="", rig_text=""):
        """A self-contained HTML page: the Nyquist overlay and the predicted (and simulated) cycles
        (:func:`~backlash_df.render.prediction.prediction_report`)."""
        return prediction_report([self], self.plot().figure, title or f"Limit-cycle prediction: {self.model}", rig_text)


# --------------------------------------------------------------------------- solver


class _Problem:
    """F(A, w) = 1 + G(jw) N(A, w) in the variables p = log(A - alpha), q = log w.

    ``g_of_w(omega)``, or ``g_of_w(omega, amplitude)`` where the linear part depends
    on the amplitude through a second nonlinearity (``amplitude_dependent``).

    The solver asks for F through :meth:`values`, a list of groups of points, evaluated
    in one call: N is *pointwise* (a point's value does not depend on the other points
    of the call; :class:`BiasedDescribing` solves each point's DC balance on its own),
    and every point asked for brings the four neighbours of its finite-difference
    Jacobian along.

    With a ``centre`` w_0 (rad/s) the frequency is ``w = w_0 + side e^q`` instead (``side``
    +1 or -1): the variables of a scan around a frequency where a branch of the slaved
    saturation gain lives in a sliver that narrows with A (:func:`_dips`).  F may be NaN
    where a slaved gain's branch does not exist: such points are neither cycles' cells nor
    minima, and Newton stops on them.
    """

    def __init__(self, g_of_w, n_of, half_gap, amplitude_dependent=False, centre=0.0, side=1.0):
        self.g_of_w, self.n_of, self.half_gap = g_of_w, n_of, half_gap
        self.amplitude_dependent = amplitude_dependent
        self.centre, self.side = centre, side

    def to_aw(self, p, q):
        omega = np.exp(q)
        return self.half_gap + np.exp(p), omega if self.centre == 0.0 else self.centre + self.side * omega

    def dw_dq(self, q):
        """dw/dq, rad/s: ``e^q`` (times ``side`` around a ``centre``)."""
        return self.side * math.exp(q)

    def residual(self, p, q):
        amplitude, omega = self.to_aw(np.asarray(p, dtype=float), np.asarray(q, dtype=float))
        if not self.centre:
            return self._balance(amplitude, omega)
        outside = omega <= 0.0  # below a centre, a step may pass w = 0: F is NaN there
        return np.where(outside, np.nan, self._balance(amplitude, np.where(outside, self.centre, omega)))

    def _balance(self, amplitude, omega):
        g = self.g_of_w(omega, amplitude) if self.amplitude_dependent else self.g_of_w(omega)
        return 1.0 + g * self.n_of(amplitude, omega)

    def values(self, groups):
        """F at each group ``(p, q)`` of 1-D arrays: a list of complex arrays, one per group."""
        flat = self.residual(np.concatenate([p for p, _ in groups]), np.concatenate([q for _, q in groups]))
        return np.split(flat, np.cumsum([len(p) for p, _ in groups])[:-1])

    def request(self, p, q):
        """The group that asks for F at (p, q), with its Jacobian's neighbours."""
        return _neighbours(p, q, centre=True)

    def answer(self, values):
        """``(F, Jacobian)`` from the values of a :meth:`request`."""
        return complex(values[0]), _jacobian_of(values[1:])

    def jacobian(self, p, q):
        """d(Re F, Im F)/d(p, q) by central differences."""
        return _jacobian_of(self.values([_neighbours(p, q)])[0])

    def at(self, p, q):
        """``(F, Jacobian)`` at (p, q)."""
        return self.answer(self.values([self.request(p, q)])[0])

    def newton(self, p, q, box, iterations=60):
        """Damped Newton from (p, q), a coroutine (:func:`_run_together`): yields lists of point groups and
        is sent their values; returns (p, q) of a root in ``box`` or None."""
        f, jac = self.answer((yield [self.request(p, q)])[0])
        for _ in range(iterations):
            if not (cmath.isfinite(f) and all(map(math.isfinite, jac.flat))):  # off a slaved gain's branch
                return None
            if abs(f) < _NEWTON_TOL:
                return p, q
            try:
                step = np.linalg.solve(jac, -np.array([f.real, f.imag]))
            except np.linalg.LinAlgError:
                return None
            scale = min(1.0, 2.0 / max(np.linalg.norm(step), 1e-300))  # at most e^2 per step
            for _ in range(30):
                p_new, q_new = p + scale * step[0], q + scale * step[1]
                f_new, jac_new = self.answer((yield [self.request(p_new, q_new)])[0])
                if np.isfinite(f_new) and abs(f_new) < abs(f):
                    break
                scale *= 0.5
            else:
                return None
            p, q, f, jac = p_new, q_new, f_new, jac_new
            if not (box[0][0] - 1.0 <= p <= box[0][1] + 1.0 and box[1][0] - 0.1 <= q <= box[1][1] + 0.1):
                return None
        return (p, q) if abs(f) < 1e3 * _NEWTON_TOL else None

    def closest(self, p, q, box, flat=False):
        """Local minimum of |F| from (p, q) inside ``box``: (p, q, |F|).

        A trust-region least-squares solve on (Re F, Im F) with the
        finite-difference Jacobian: it follows the narrow curved valleys of
        nearly tangent loci down to the closest approach (or to a root).  The
        Jacobian of each point where F was evaluated is kept for the solver's
        call at that point.  On a ``flat`` (F does not depend on p) the solve
        runs in q alone: a step in p there is round-off's choice.
        """
        from scipy import optimize  # lazy: scipy.optimize takes a fraction of a second to import

        known = {}
        free = slice(1, 2) if flat else slice(0, 2)

        def point(y):
            return (p, y[0]) if flat else (y[0], y[1])

        def residual(y):
            f, known[y.tobytes()] = self.answer(self.values([self.request(*point(y))])[0])
            return _split(f)

        def jacobian(y):
            jac = known.pop(y.tobytes(), None)
            return (self.jacobian(*point(y)) if jac is None else jac)[:, free]

        lower, upper = np.array([box[0][0], box[1][0]])[free], np.array([box[0][1], box[1][1]])[free]
        start = np.clip(np.array([p, q])[free], lower, upper)
        found = optimize.least_squares(
            residual, start, jac=jacobian,
            bounds=(lower, upper), method="trf", xtol=1e-13, ftol=1e-15, gtol=1e-15, max_nfev=200,
        )
        p, q = point(found.x)
        return p, q, float(np.hypot(*found.fun))


def _neighbours(p, q, centre=False):
    """The points of the central-difference Jacobian at (p, q) (after (p, q) itself with ``centre``)."""
    h = _FD_STEP
    ps, qs = [p + h, p - h, p, p], [q, q, q + h, q - h]
    return (np.array([p] + ps), np.array([q] + qs)) if centre else (np.array(ps), np.array(qs))


def _jacobian_of(values):
    """d(Re F, Im F)/d(p, q) from F at the four points of :func:`_neighbours`."""
    h = _FD_STEP
    dp = (values[0] - values[1]) / (2 * h)
    dq = (values[2] - values[3]) / (2 * h)
    return np.array([[dp.real, dq.real], [dp.imag, dq.imag]])


def _run_together(problem, coroutines):
    """Run solver coroutines side by side, each round's requests evaluated together; their results, in order."""
    results = [None] * len(coroutines)
    pending = {}
    for k, coroutine in enumerate(coroutines):
        pending[k] = next(coroutine)
    while pending:
        keys = list(pending)
        values = problem.values([group for k in keys for group in pending[k]])
        start = 0
        for k in keys:
            count = len(pending[k])
            try:
                pending[k] = coroutines[k].send(values[start:start + count])
            except StopIteration as stop:
                results[k] = stop.value
                del pending[k]
            start += count
    return results


def _split(value):
    value = complex(value)
    return np.array([value.real, value.imag])


def _winding_cells(values):
    """Cells (i, j) of a complex grid around which the values wind (degree != 0)."""
    corners = [values[:-1, :-1], values[1:, :-1], values[1:, 1:], values[:-1, 1:], values[:-1, :-1]]
    total = np.zeros(corners[0].shape)
    with np.errstate(divide="ignore", invalid="ignore"):  # NaN corners (off a branch) wind nowhere
        for a, b in zip(corners[:-1], corners[1:]):
            total += np.angle(b / a)
    return np.argwhere(np.abs(np.round(total / (2 * math.pi))) >= 1)


def _local_minima(magnitude):
    """Interior grid points whose |F| no neighbour of the 8 undercuts by more than ``_FLAT_TOL`` relative.

    On a flat of |F| (the gear in contact: N does not depend on A) neighbours differ by
    round-off only; a strict comparison would keep or drop the flat's points as the CPU's
    rounding falls, so values within ``_FLAT_TOL`` count as equal and every point of the
    flat's floor is a minimum (:func:`_deepest_per_valley` keeps one per valley).
    """
    core = magnitude[1:-1, 1:-1]
    is_min = np.ones(core.shape, dtype=bool)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                neighbour = magnitude[1 + di:magnitude.shape[0] - 1 + di, 1 + dj:magnitude.shape[1] - 1 + dj]
                is_min &= core <= neighbour * (1.0 + _FLAT_TOL)
    return np.argwhere(is_min) + 1


def _deepest_per_valley(indices, magnitude, reach=2):
    """Of grid minima in one valley (chained at most ``reach`` grid steps apart), the deepest, in grid order.

    Nearly tangent loci leave a long narrow valley of |F| whose floor the grid
    samples as a chain of local minima; a minimisation from each ends at the
    same closest approach.
    """
    if not indices:
        return []
    from scipy.sparse.csgraph import connected_components  # lazy, as scipy.optimize below

    points = np.array(indices)
    near = np.abs(points[:, None, :] - points[None, :, :]).max(axis=2) <= reach
    _, valley = connected_components(near, directed=False)
    depth = magnitude[points[:, 0], points[:, 1]]
    deepest = {}
    for a, label in enumerate(valley):  # the first of minima equally deep to _FLAT_TOL is kept
        if label not in deepest or depth[a] < depth[deepest[label]] * (1.0 - _FLAT_TOL):
            deepest[label] = a
    return [indices[a] for a in sorted(deepest.values())]


def solve_harmonic_balance(g_of_w, n_of, half_gap, amplitude_range, omega_range, grid=(60, 80),
                           near_miss_cutoff=0.5, amplitude_dependent=False):
    """All roots of ``1 + G(jw) N(A, w) = 0`` in a box, their stability and the near misses.

    Parameters
    ----------
    g_of_w : callable
        ``omega -> G(j omega)`` (complex, vectorised); with ``amplitude_dependent``,
        ``(omega, A) -> G``: a linear part holding a second nonlinearity by its
        describing function slaved to A (the torque limit, :class:`~backlash_df.slaving.CommandSlaving`).
    n_of : callable
        ``(A, omega) -> N`` (complex, broadcasting), zero for ``A <= half_gap``.
    half_gap : float
        alpha, rad: the searched amplitudes exceed it.
    amplitude_range, omega_range : (float, float)
        Search box: A in rad (lower bound > alpha), w in rad/s.
    grid : (int, int)
        Scan points in A and w (log-spaced in ``A - alpha`` and ``w``).
    near_miss_cutoff : float
        Largest ``|1 + G N|`` reported as a near miss.
    amplitude_dependent : bool
        ``g_of_w`` takes the amplitude too.

    Returns
    -------
    cycles : list of LimitCycle
    near_misses : list of NearMiss

    Examples
    --------
    Classical dead zone (k = 1, alpha = 1) against ``G = 4 / (s (s + 1)^2)``;
    the Nyquist curve crosses the negative real axis at w = 1, -2:

    >>> import numpy as np
    >>> def dead_zone(a, w):
    ...     r = np.minimum(1.0 / np.asarray(a), 1.0)
    ...     return 1 - 2 / np.pi * (np.arcsin(r) + r * np.sqrt(1 - r * r)) + 0j * w
    >>> cycles, _ = solve_harmonic_balance(lambda w: 4 / (1j * w * (1j * w + 1) ** 2), dead_zone,
    ...                                    1.0, (1.001, 100.0), (0.1, 10.0))
    >>> [(round(c.omega, 6), c.stable) for c in cycles]  # dead zone: amplitude grows past it
    [(1.0, False)]
    """
    box = _log_box(half_gap, amplitude_range, omega_range)
    return _solve(_Problem(g_of_w, n_of, half_gap, amplitude_dependent), box, grid, near_miss_cutoff)


def _log_box(half_gap, amplitude_range, omega_range):
    """The search box in (log(A - alpha), log w), checked."""
    lo_a, hi_a = amplitude_range
    lo_w, hi_w = omega_range
    if not (half_gap < lo_a < hi_a and 0.0 < lo_w < hi_w and math.isfinite(hi_a * hi_w)):
        raise ValueError(
            f"search box must have half_gap = {half_gap!r} < A_min < A_max and 0 < w_min < w_max; "
            f"got A in {amplitude_range!r}, w in {omega_range!r}"
        )
    return (math.log(lo_a - half_gap), math.log(hi_a - half_gap)), (math.log(lo_w), math.log(hi_w))


def _solve(problem, box, grid, near_miss_cutoff, values=None):
    """:func:`solve_harmonic_balance` of a :class:`_Problem` in its box of (p, q): cycles and near misses
    (``values``: F on the scan grid, if known)."""
    ps = np.linspace(*box[0], grid[0])
    qs = np.linspace(*box[1], grid[1])
    values = problem.residual(ps[:, None], qs[None, :]) if values is None else values
    magnitude = np.abs(values)
    seeds = [(0.5 * (ps[i] + ps[i + 1]), 0.5 * (qs[j] + qs[j + 1])) for i, j in _winding_cells(values)]
    lowest = _local_minima(magnitude)
    seeded = [k for k, (i, j) in enumerate(lowest) if not _on_flat(magnitude, i, j)]  # a flat has no Newton step
    minima = [(ps[lowest[k][0]], qs[lowest[k][1]]) for k in seeded]
    roots, rooted = [], set()  # rooted: the minima whose Newton solve ends on a root
    found = _run_together(problem, [problem.newton(p0, q0, box) for p0, q0 in seeds + minima])
    for k, root in enumerate(found):
        if root is None or not (box[0][0] <= root[0] <= box[0][1] and box[1][0] <= root[1] <= box[1][1]):
            continue
        if k >= len(seeds):
            rooted.add(seeded[k - len(seeds)])
        if all(abs(root[0] - p) > 1e-6 or abs(root[1] - q) > 1e-6 for p, q in roots):
            roots.append(root)
    cycles = sorted((_cycle(problem, p, q) for p, q in roots), key=lambda c: (c.amplitude, c.omega))
    near = []
    open_minima = [index for k, index in enumerate(lowest) if k not in rooted]
    starts = [(ps[i], qs[j], _on_flat(magnitude, i, j)) for i, j in _deepest_per_valley(open_minima, magnitude)]
    for p, q, distance in (_closest_on_flat(p0, q0, box, problem, on) for p0, q0, on in starts):
        at_edge = min(p - box[0][0], box[0][1] - p, q - box[1][0], box[1][1] - q) < 1e-6
        at_root = any(abs(p - pr) < 1e-3 and abs(q - qr) < 1e-3 for pr, qr in roots)
        if distance < 1e-6 or distance > near_miss_cutoff or at_edge or at_root:
            continue
        amplitude, omega = problem.to_aw(p, q)
        if all(abs(math.log(omega / m.omega)) > 1e-4 or abs(amplitude / m.amplitude - 1) > 1e-4 for m in near):
            near.append(NearMiss(float(amplitude), float(omega), float(distance)))
    return cycles, sorted(near, key=lambda m: m.distance)


def _on_flat(magnitude, i, j):
    """Whether grid point (i, j) lies on a flat of |F| in p: both neighbours in p equal to ``_FLAT_TOL``."""
    centre = magnitude[i, j]
    return all(abs(magnitude[i + di, j] - centre) <= _FLAT_TOL * centre for di in (-1, 1))


def _closest_on_flat(p, q, box, problem, flat=False):
    """:meth:`_Problem.closest` from (p, q), moved to the top of a flat (:func:`_flat_top`): (p, q, |F|).

    A start on a ``flat`` of the grid is minimised in q alone and then moved to the flat's top:
    a Newton or least-squares step in p there is decided by round-off (F does not depend on p),
    and could end on the flat's top or slide past it into a root beyond, as the CPU rounds.
    """
    p, q, distance = problem.closest(p, q, box, flat=flat)
    return _flat_top(problem, p, q, distance, box[0][1]), q, distance


def _flat_top(problem, p, q, distance, top):
    """The largest p' in [p, top] up to which |F(., q)| stays at ``distance`` (to 1e-9 relative), else p.

    Where the gear stays in contact at small amplitudes N(A, w) does not depend on A,
    so |F| is flat in p below the amplitude at which the gap opens, and the minimiser
    stops anywhere on the flat (round-off decides).  The miss is reported at the top
    of the flat: the largest amplitude at which the loci pass that close (33 points,
    then 40 bisections, four at a time: the midpoints of the next four steps, all 15
    candidates, are evaluated in one call).
    """
    def on_flat(xs):
        values = problem.values([(np.array([x]), np.array([q])) for x in xs])
        return [abs(abs(complex(v[0])) - distance) <= 1e-9 * max(distance, 1e-300) for v in values]

    if not on_flat([p + 1e-6 * max(1.0, abs(p))])[0]:
        return p
    points = np.linspace(p, top, 33)
    flat = on_flat(points)
    if all(flat):
        return top
    first_off = flat.index(False)
    low, high = points[first_off - 1], points[first_off]
    depth = 4
    for _ in range(40 // depth):
        brackets, middles = [(low, high)], []
        for _ in range(depth):
            middles += [0.5 * (lo + hi) for lo, hi in brackets]
            brackets = [half for (lo, hi), mid in zip(brackets, middles[-len(brackets):])
                        for half in ((lo, mid), (mid, hi))]
        middle_flat = dict(zip(middles, on_flat(middles)))
        for _ in range(depth):
            middle = 0.5 * (low + high)
            low, high = (middle, high) if middle_flat[middle] else (low, middle)
    return low


def _cycle(problem, p, q):
    amplitude, omega = problem.to_aw(p, q)
    f, jac = problem.at(p, q)
    # d/dA = d/dp / (A - alpha), d/dw = d/dq / (dw/dq): without a centre positive factors, same sign
    loeb = np.linalg.det(jac) / ((amplitude - problem.half_gap) * problem.dw_dq(q))
    return LimitCycle(float(amplitude), float(omega), bool(loeb > 0.0), float(loeb), abs(f))


# --------------------------------------------------------------------------- rig level


def default_ranges(rig, linear=None):
    """Default search box: A in (alpha (1 + 1e-4), 200 alpha), w within 3 decades of the shaft mode.

    The shaft mode is ``w_n = sqrt(k (1/J_m + 1/J_l))`` (rad/s); the box is
    ``w_n / 300 .. 3 w_n``.
    """
    plant = rig.plant
    w_n = math.sqrt(plant.stiffness * (1.0 / plant.motor_inertia + 1.0 / plant.load_inertia))
    alpha = plant.half_gap
    return (alpha * (1.0 + 1e-4), 200.0 * alpha), (w_n / 300.0, 3.0 * w_n)


def predict_limit_cycles(rig, model=None, *, linear=None, amplitude_range=None, omega_range=None, bias=0.0,
                         grid=(60, 80), describing=None, near_miss_cutoff=0.5, load_torque=None):
    """Predict the limit cycles of a rig's loop by the describing function.

    The describing function the loop needs is picked here: ``N(A, w, bias)`` of
    the torque law, or, under a constant load torque, the dual-input DF with the
    bias slaved to the DC balance (:class:`~backlash_df.describing.BiasedDescribing`:
    ``N0(A, w, b) = -T_l``), whose cycles carry their ``bias`` and may be smaller
    than alpha (a cycle that lifts off one flank only).

    Parameters
    ----------
    rig : Rig
        Plant, ``[controller]`` (unless ``linear`` is given) and default model.
    model : str or BacklashModel, optional
        Torque law (default: the rig's ``[model] backlash``).  A law built with shaft
        values of its own stands for the rig's shaft (:meth:`~backlash_df.config.Rig.with_law`):
        the search box, and every later stage, use its gap.
    linear : DriveLoop, control.LTI or callable, optional
        The linear part G (shaft torque -> -theta_d); default the rig's PI loop.  The
        result keeps it: later stages need not (and must not) be given another.
    amplitude_range, omega_range : (float, float), optional
        Search box in rad and rad/s (default :func:`default_ranges`; under a load
        the amplitudes reach down to alpha / 50).
    bias : float
        Mean of theta_d, rad, passed to the describing function (no DC balance).
    grid : (int, int)
        Scan points in A and w.
    describing : callable, optional
        ``N(A, w)`` to use instead of the law's describing function.  The result is
        labelled ``"<law> (user DF)"`` and later stages simulate the law named by
        ``model``; without ``model`` it is labelled ``"user DF"`` and they refuse.
    near_miss_cutoff : float
        Largest ``|1 + G N|`` reported as a near miss.
    load_torque : float, optional
        T_l, N m: solve with the DC balance under this load (default: the rig's
        ``[load] torque``, balanced when it is not zero).

    Returns
    -------
    LimitCyclePrediction

    Notes
    -----
    With a torque limit the loop holds two nonlinearities; both are replaced by
    their describing functions (Gelb and Vander Velde's multiple-nonlinearity
    method): the saturation's real gain ``N_s(U)`` of the command's first harmonic
    ``U`` is slaved to the amplitude (:class:`~backlash_df.slaving.CommandSlaving`), and each cycle
    reports ``U`` and whether it exceeds the limit.  The slaved gain can have several
    values at one (A, w) (the unsaturated 1 and saturated ones): the balance is solved on
    each of them, on the box and, where a saturated one lives in a sliver of the (A, w)
    plane (a near-rigid shaft: the rigid loop's own saturation cycle), in scans around that
    sliver, and the cycles and near misses of all are merged; a saturated cycle's stability
    is Loeb's criterion taken in ``U``.  Under a load torque the saturation's DC balance is
    not solved: the prediction says so in ``note``.

    Dry friction on one side is a third, its describing function a damper slaved to the
    side's speed amplitude (:class:`~backlash_df.slaving.FrictionSlaving`; with a torque limit
    slaved together with the saturation's gain, :class:`~backlash_df.slaving.CommandFrictionSlaving`).
    Under a load torque the DC balance stays the backlash's alone where the loop holds both
    mean speeds at zero (a cascade, or integral action in the speed loop): the friction of a
    zero-mean speed has no mean.  A P speed loop under a load torque slides at a mean speed,
    which that describing function does not take: the prediction says so in ``note``, as
    with a torque limit under any load torque.  Dry friction on both sides is two dampers
    slaved together (:class:`~backlash_df.slaving.FrictionPairSlaving`), without a torque
    limit (with one the prediction has a ``note``).
    """
    named = model is not None
    if not isinstance(model, BacklashModel):
        model = rig.make_model(model)
    rig = rig.with_law(model)
    user_linear = None if linear is None or isinstance(linear, DriveLoop) else linear
    linear = drive_loop(rig, dry_friction=True) if linear is None else linear
    default_a, default_w = default_ranges(rig)
    label, law = model.name, model
    if describing is not None:
        label, law = (f"{model.name} (user DF)", model) if named else ("user DF", None)
    carried = dict(law=law, rig=rig, user_linear=user_linear)
    balanced = describing is None and bias == 0.0 and (load_torque is not None or rig.load.torque != 0.0)
    if balanced:
        n_of = BiasedDescribing(model, rig.load.torque if load_torque is None else float(load_torque))
        half_gap, default_a = 0.0, (0.02 * model.half_gap, default_a[1])
    else:
        n_of = describing or functools.partial(describing_function, model, bias=bias)
        half_gap = model.half_gap
    amplitude_range = default_a if amplitude_range is None else tuple(amplitude_range)
    omega_range = default_w if omega_range is None else tuple(omega_range)
    part = linear.linear_part() if isinstance(linear, DriveLoop) else None
    limited = part is not None and part.command is not None
    rubbing = part is not None and part.sticking is not None
    pair = rubbing and len(part.sticking.names) > 1
    if rubbing and ((pair and limited) or (balanced and (limited or not _mean_speed_held(rig)))):
        return LimitCyclePrediction(
            model=label, cycles=(), near_misses=(), amplitude_range=amplitude_range, omega_range=omega_range,
            linear=linear, describing=n_of, half_gap=half_gap, **carried,
            note=f"the describing function of dry friction is solved on one side, or on both without a torque "
                 f"limit (under a load torque where the loop holds both mean speeds at zero and has no torque "
                 f"limit), and this loop has {_friction_companions(part, rig, balanced)}; the simulations decide",
        )
    if limited and balanced:
        return LimitCyclePrediction(
            model=label, cycles=(), near_misses=(), amplitude_range=amplitude_range, omega_range=omega_range,
            linear=linear, describing=n_of, half_gap=half_gap, **carried,
            note="the describing function of a torque-limited loop under a load torque (the saturation's DC balance) "
                 "is not implemented; the simulations decide",
        )
    void = ()
    if limited:
        g_of_w = CommandFrictionSlaving(part) if rubbing else CommandSlaving(part)
        cycles, near, void = _slaved_balance(g_of_w, n_of, half_gap, amplitude_range, omega_range, grid,
                                             near_miss_cutoff)
        return LimitCyclePrediction(
            model=label, cycles=tuple(cycles), near_misses=tuple(near), amplitude_range=amplitude_range,
            omega_range=omega_range, linear=g_of_w, describing=n_of, half_gap=half_gap, void_cycles=tuple(void),
            **carried,
        )
    if rubbing:
        g_of_w = FrictionPairSlaving(part) if pair else FrictionSlaving(part)
    elif part is not None:
        g_of_w = functools.partial(frequency_response, part)  # the loop built once, not at every residual
    else:
        g_of_w = functools.partial(frequency_response_of, linear)
    cycles, near = solve_harmonic_balance(
        g_of_w, n_of, half_gap, amplitude_range, omega_range, grid=grid, near_miss_cutoff=near_miss_cutoff,
        amplitude_dependent=rubbing,
    )
    if balanced:
        cycles = [dataclasses.replace(c, bias=float(n_of.bias(c.amplitude, c.omega))) for c in cycles]
    if rubbing:
        cycles = [dataclasses.replace(c, friction_amplitude=_floats(g_of_w.speed_amplitudes(c.amplitude, c.omega)))
                  for c in cycles]
        void = tuple(c for c in cycles if g_of_w.sticks(c.amplitude, c.omega))
        cycles = [c for c in cycles if c not in void]
    return LimitCyclePrediction(
        model=label, cycles=tuple(cycles), near_misses=tuple(near), amplitude_range=amplitude_range,
        omega_range=omega_range, linear=g_of_w if rubbing else linear, describing=n_of, half_gap=half_gap,
        void_cycles=void, **carried,
    )


def _slaved_balance(slaving, n_of, half_gap, amplitude_range, omega_range, grid, near_miss_cutoff):
    """The harmonic balance of a torque-limited loop on every branch of its slaved saturation gain.

    Each branch of :class:`~backlash_df.slaving.CommandSlaving` that exists at a scan point is solved as a
    balance of its own (:func:`solve_harmonic_balance`'s scan, Newton and near misses),
    first on the searched box, then around every frequency where a saturated branch
    reaches into the box at its narrowest (:func:`_dips`), on a box of ``(log(A - alpha),
    log|w - w_0|)`` either side of it, where the branch's sliver of the (A, w) plane is as
    wide as the scan.  The cycles carry their branch's command amplitude U; a cycle (or a
    near miss) found again, within 1e-6 relative in A and w, counts once (the first: the
    box before the dips, the lower branch first).

    Returns
    -------
    cycles : list of LimitCycle
        By increasing amplitude.
    near_misses : list of NearMiss
        By increasing distance.
    void : list of LimitCycle
        With dry friction: the solutions where the friction holds the side through the
        cycle (:meth:`~backlash_df.slaving.CommandFrictionSlaving.sticks`), by increasing
        amplitude.
    """
    (lo_w, hi_w), hi_a = omega_range, amplitude_range[1]
    span, band = _log_box(half_gap, amplitude_range, omega_range)
    boxes = [(0.0, 1.0, (span, band))]
    for centre in _dips(slaving, omega_range, hi_a, (grid[1] - 1) * _DIP_REFINE + 1):
        for side, room in ((-1.0, centre - lo_w), (1.0, hi_w - centre)):
            far = min(room, 0.5 * centre)
            if far > _DIP_NEAREST * centre:
                boxes.append((centre, side, (span, (math.log(_DIP_NEAREST * centre), math.log(far)))))
    cycles, near, void = [], [], []
    for centre, side, box in boxes:
        # the scan's values of every branch from one evaluation of the channels, the roots and N
        problem = _Problem(None, n_of, half_gap, True, centre, side)
        amplitudes, omegas = problem.to_aw(np.linspace(*box[0], grid[0])[:, None], np.linspace(*box[1], grid[1]))
        channels = slaving.channels(omegas)
        roots = slaving.branch_roots(amplitudes, channels)
        n = n_of(amplitudes, omegas)
        for branch in range(roots.shape[-1]):
            if not np.isfinite(roots[..., branch]).any():
                continue
            problem.g_of_w = functools.partial(slaving, branch=branch)
            values = 1.0 + slaving.response(amplitudes, channels, roots[..., branch]) * n
            found, missed = _solve(problem, box, grid, near_miss_cutoff, values)
            for cycle in found:
                if not any(_same(cycle, other) for other in cycles + void):
                    cycle = _slaved_cycle(slaving, branch, cycle, half_gap)
                    (void if slaving.sticks(cycle.amplitude, cycle.omega, branch) else cycles).append(cycle)
            near += [miss for miss in missed if not any(_same(miss, other) for other in near + cycles + void)]
    by_size = functools.partial(sorted, key=lambda c: (c.amplitude, c.omega))
    return by_size(cycles), sorted(near, key=lambda m: m.distance), by_size(void)


def _slaved_cycle(slaving, branch, cycle, half_gap):
    """A cycle on a branch of the slaving with its command amplitude U and, if saturated, Loeb's criterion in U.

    On a saturated branch Loeb's criterion is taken with the command's amplitude U as the
    amplitude, as in the Lur'e loop of the saturation alone: its sign is that of ``loeb /
    (dU/dA)``, dU/dA along the branch at the cycle's w (central differences, step 1e-6 (A -
    alpha)), and ``loeb`` (in A's units) is multiplied by the sign of dU/dA.  Where the
    slaving's root falls as U rises (``N_s - N_sat(U(N_s))`` decreases through it: on a
    near-rigid shaft, the root above the peak of U), U falls as A grows along the branch, and
    the criterion in A would call the Lur'e loop's own stable cycle unstable; elsewhere U grows
    with A and nothing changes.  A saturated cycle where dU/dA is not a nonzero number keeps the
    criterion in A.
    """
    amplitude, omega = cycle.amplitude, cycle.omega
    u = float(slaving.command_amplitude(amplitude, omega, branch))
    saturated = bool(u > slaving.part.command.limit)
    loeb = cycle.loeb
    if saturated:
        step = 1e-6 * (amplitude - half_gap)
        ends = slaving.command_amplitude(np.array([amplitude + step, amplitude - step]), omega, branch)
        slope = float(ends[0] - ends[1]) / (2.0 * step)
        if math.isfinite(slope) and slope != 0.0:
            loeb = math.copysign(1.0, slope) * cycle.loeb
    return dataclasses.replace(cycle, command_amplitude=u, saturated=saturated, loeb=loeb, stable=bool(loeb > 0.0),
                               friction_amplitude=_floats(slaving.speed_amplitudes(amplitude, omega, branch)))


def _floats(values):
    """``{side: float}`` of a slaving's ``speed_amplitudes`` at one point."""
    return {side: float(value) for side, value in values.items()}


def _same(one, other, tol=1e-6):
    """Whether two cycles or near misses are one: A and w within ``tol`` relative."""
    return abs(one.amplitude / other.amplitude - 1.0) <= tol and abs(one.omega / other.omega - 1.0) <= tol


def _dips(slaving, omega_range, largest, samples):
    """The frequencies (rad/s) at which a saturated branch of ``slaving`` reaches down to its least amplitude,
    where that amplitude is below ``largest`` (rad).

    A saturated root of the slaving exists at (A, w) where the peak of ``U`` over the gain
    exceeds the limit: ``A > L mu(w)``, ``mu = min_N |theta(N)| / |c|``
    (:class:`~backlash_df.slaving.CommandSlaving`'s notes), and ``mu`` dips towards 0 where the loop with a rigid
    gear has a saturation cycle of its own: the branch is a sliver of the (A, w) plane
    there, narrowing with A.  ``mu`` is sampled at ``samples`` frequencies (log-spaced),
    every interior sample no neighbour undercuts by more than ``_FLAT_TOL`` relative is
    refined by a bounded scalar minimisation over its two neighbours' interval (to
    ``1e-12`` relative), and dips closer than 1e-9 relative count once.
    """
    from scipy import optimize  # lazy, as in _Problem.closest

    omegas = np.geomspace(*omega_range, samples)
    least = slaving.least_amplitude(omegas)
    core = least[1:-1]
    lows = np.flatnonzero((core <= least[:-2] * (1.0 + _FLAT_TOL)) & (core <= least[2:] * (1.0 + _FLAT_TOL))) + 1
    dips = []
    for k in lows:
        if not least[k] < largest:
            continue
        found = optimize.minimize_scalar(lambda w: float(slaving.least_amplitude(w)), method="bounded",
                                         bounds=(omegas[k - 1], omegas[k + 1]),
                                         options={"xatol": 1e-12 * omegas[k]})
        centre = float(found.x)
        if float(slaving.least_amplitude(centre)) < largest and all(abs(centre / d - 1.0) > 1e-9 for d in dips):
            dips.append(centre)
    return dips




def _friction_companions(part, rig, balanced):
    """What a loop with dry friction holds beside it that its describing function does not take, in words."""
    pair = len(part.sticking.names) > 1
    words = ["dry friction on both sides and a torque limit"] if pair and part.command is not None else []
    if balanced and part.command is not None:
        words.append("a load torque with a torque limit")
    elif balanced and not _mean_speed_held(rig):
        words.append("a load torque on a P speed loop (its sides slide at a mean speed)")
    return " and ".join(words)


def _mean_speed_held(rig):
    """Whether a periodic orbit of the loop has both speeds' means at zero under a load torque.

    In a cascade the load angle is a state of the orbit, so periodic, and so is theta_d: both
    sides' mean speeds are zero.  A speed loop with integral action (a finite ``ti``, or a
    user's speed controller with a pole at s = 0) holds the mean speed error, and so both
    mean speeds, at zero.  A P speed loop under a load torque runs at a mean speed, where
    the friction's describing function of a zero-mean speed (and the DC balance without
    the friction's mean) does not hold.
    """
    controller = rig.controller
    if controller.cascade:
        return True
    if controller.speed_controller is not None:
        a = np.asarray(controller.speed_controller.A, dtype=float)
        return a.size > 0 and np.linalg.matrix_rank(a) < a.shape[0]
    return math.isfinite(controller.ti)


# --------------------------------------------------------------------------- verification


def verify_limit_cycles(rig, prediction, *, linear=None, kick=None, t_end=None, max_t_end=320.0, dt=None,
                        progress=None):
    """Check a prediction by closed-loop time simulation with the same torque law.

    Every stable predicted cycle is simulated from the kick ``dtheta_d(0) = A w``
    (theta_d(0) = 0, the cycle's zero crossing) until steady state
    (:func:`~backlash_df.simulation.simulated_limit_cycle`); unstable cycles cannot
    be observed and keep ``simulated = None``.  Without a stable prediction the
    loop is simulated once from ``kick`` to see whether it settles.

    Parameters
    ----------
    rig : Rig
        The prediction's rig (refused if it is another: :meth:`LimitCyclePrediction.loop`).
    prediction : LimitCyclePrediction
        Its law and linear part are simulated.
    linear : control.LTI, optional
        The prediction's own linear part (it is read from the prediction; another is refused).
    kick : float, optional
        Initial dtheta_d (rad/s) when no stable cycle is predicted (default
        ``2 alpha w_n``, w_n the shaft mode of :func:`default_ranges`).
    t_end, max_t_end, dt : float, optional
        First and largest simulated time and the step, s (default first time:
        60 periods of the cycle, or 20 s).
    progress : callable, optional
        ``progress(stage, done, total)`` (the package's one protocol), stage
        ``"simulating"``, after each simulation.

    Returns
    -------
    LimitCyclePrediction
        A copy with ``simulated`` filled in and ``simulation`` set.
    """
    rig, model, user_linear = prediction.loop(rig, linear)
    total = max(1, len(prediction.stable_cycles))

    def simulated(done):
        if progress is not None:
            progress("simulating", done, total)

    cycles = []
    first = None
    for cycle in prediction.cycles:
        if not cycle.stable:
            cycles.append(cycle)
            continue
        start = t_end or max(60.0 * 2.0 * math.pi / cycle.omega, 5.0)
        measured, _ = simulated_limit_cycle(
            rig, model, t_end=start, max_t_end=max(max_t_end, start), dt=dt,
            kick=cycle.amplitude * cycle.omega, linear=user_linear,
            initial={"theta_d": cycle.bias} if cycle.bias else None,
        )
        first = measured if first is None else first
        cycles.append(dataclasses.replace(cycle, simulated=measured))
        simulated(sum(c.simulated is not None for c in cycles))
    if first is None:
        if kick is None:
            _, (_, w_hi) = default_ranges(rig)
            kick = 2.0 * model.half_gap * w_hi / 3.0
        first, _ = simulated_limit_cycle(rig, model, t_end=t_end or 20.0, max_t_end=max_t_end, dt=dt,
                                         kick=kick, linear=user_linear)
        simulated(1)
    return dataclasses.replace(prediction, cycles=tuple(cycles), simulation=first)


# --------------------------------------------------------------------------- plot


def limit_cycle_plot(predictions, ax=None, *, n_loci=7, n_amplitudes=200, g_omega=None):
    """Nyquist overlay: G(jw) with the -1/N(A, w) loci of one or several models.

    For each model the loci ``A -> -1/N(A, w_i)`` are drawn thin at ``n_loci``
    frequencies spread (log) over the searched band, each labelled with its w
    (rad/s) where it enters the view, and bold at each predicted cycle's own
    frequency.  Cycles (o stable, x unstable by Loeb's criterion) and near
    misses (diamonds) are listed with A, w and distance in the legend, so no
    label covers another.  Both axes are in rad/(N m): G maps the shaft torque
    to theta_d, and a cycle solves G(jw) = -1/N(A, w).  The view is centred on
    the cycles and near misses, its height fitted to what is drawn across its
    width (no empty half), its tick labels share a scale factor
    (:func:`~backlash_df.plotting.scaled_ticks`), and G is sampled where it
    turns in the view (:func:`~backlash_df.plotting.adaptive_curve`), so that it
    stays smooth through the shaft's resonance.

    Parameters
    ----------
    predictions : sequence of LimitCyclePrediction
        Same linear part; one colour per model.
    ax : matplotlib Axes, optional
        Draw into these axes, the legend under them
        (:func:`~backlash_df.plotting.legend_under`); by default a new figure with
        constrained layout, its height fitted to the view, and the legend below the
        axes (nothing is cut off by ``savefig``).
    n_loci : int
        Loci per model across the frequency band.
    n_amplitudes : int
        Points along each locus.
    g_omega : array_like, optional
        Frequencies (rad/s) for the G curve (default: the searched band, sampled
        adaptively).

    Returns
    -------
    ResultPlot
        One panel and its legend.
    """
    import matplotlib.pyplot as plt

    first = predictions[0]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    loci = [_loci(prediction, colors[index % len(colors)], n_loci, n_amplitudes)
            for index, prediction in enumerate(predictions)]
    curves = [locus[np.isfinite(locus)] for model in loci for locus, *_ in model]

    def g_in(view):
        if g_omega is not None:
            return frequency_response_of(first.linear, np.asarray(g_omega, dtype=float))
        return adaptive_curve(lambda w: frequency_response_of(first.linear, w), *first.omega_range, view)[1]

    square = _zoom(predictions, curves)
    g = g_in(square)
    view = _zoom(predictions, curves, drawn=curves + [g])
    if g_omega is None and view != square:  # sampled again where it turns in the view drawn
        g = g_in(view)
    own_figure = ax is None
    panel = (view[3] - view[2]) / (view[1] - view[0])  # the view's height over its width
    figure, axes = axes_or_new(ax, figsize=(8, 2.6 + 6.6 * min(max(panel, 0.5), 0.9)), layout="constrained")
    ax = axes[0]
    name, unit = first.linear_name, f" ({first.linear_unit})" if first.linear_unit else ""
    ax.plot(g.real, g.imag, color="k", lw=1.6, label=f"{name}(jw)")
    for prediction, model in zip(predictions, loci):
        for k, (locus, _, color, bold) in enumerate(model):
            ax.plot(locus.real, locus.imag, color=color, lw=1.4 if bold else 0.6, alpha=1.0 if bold else 0.5,
                    label=f"-1/N(A, w) {prediction.model}" if k == 0 else None)
        _mark_cycles(ax, prediction, model[0][2])
    ax.set_xlim(view[0], view[1])
    ax.set_ylim(view[2], view[3])
    _label_loci(ax, [(locus, omega, color) for model in loci for locus, omega, color, bold in model if not bold])
    ax.axhline(0.0, color="0.7", lw=0.5)
    ax.axvline(0.0, color="0.7", lw=0.5)
    scaled_ticks(ax.xaxis)
    scaled_ticks(ax.yaxis)
    ax.set_xlabel(f"real part{unit}")
    ax.set_ylabel(f"imaginary part{unit}")
    ax.set_title(f"{name}(jw) and -1/N(A, w); thin loci labelled with w (rad/s)", fontsize="medium")
    if own_figure:
        legend = legend_below(figure, fontsize=8)
    else:
        legend = legend_under(ax, fontsize=7)
    return ResultPlot(figure, axes, legend)


def _loci(prediction, color, n_loci, n_amplitudes):
    """``(locus, w, colour, bold)`` of one model: thin at ``n_loci`` w over the band, bold at each cycle's w."""
    lo_w, hi_w = prediction.omega_range
    lo_a, hi_a = prediction.amplitude_range
    amplitudes = prediction.half_gap + np.geomspace(lo_a - prediction.half_gap, hi_a - prediction.half_gap,
                                                    n_amplitudes)
    band = [(omega, False) for omega in np.geomspace(lo_w, hi_w, n_loci)]
    band += [(cycle.omega, True) for cycle in prediction.cycles]
    return [(-1.0 / prediction.describing(amplitudes, omega), omega, color, bold) for omega, bold in band]


def _mark_cycles(ax, prediction, color):
    """The cycles (o stable, x unstable) and the first three near misses (diamonds), listed in the legend."""
    for cycle in prediction.cycles:
        at = -1.0 / complex(prediction.describing(cycle.amplitude, cycle.omega))
        kind = "stable" if cycle.stable else "unstable"
        ax.plot(at.real, at.imag, "o" if cycle.stable else "x", color=color, ms=8, ls="none",
                mfc=color if cycle.stable else "none",
                label=f"{prediction.model}: {kind} cycle A = {cycle.amplitude:.4g}{_unit(prediction)}, "
                      f"w = {cycle.omega:.4g} rad/s")
    for miss in prediction.near_misses[:3]:
        at = -1.0 / complex(prediction.describing(miss.amplitude, miss.omega))
        ax.plot(at.real, at.imag, "d", color=color, ms=6, mfc="none", ls="none",
                label=f"{prediction.model}: near miss {100 * miss.distance:.2f} % at A = {miss.amplitude:.4g}"
                      f"{_unit(prediction)}, "
                      f"w = {miss.omega:.4g} rad/s")


def _unit(prediction):
    """`` rad`` (a space and the amplitude's unit), or nothing where the unit is the user's."""
    return f" {prediction.amplitude_unit}" if prediction.amplitude_unit else ""


def _label_loci(ax, loci, gap=(0.06, 0.025)):
    """Write each thin locus's w where it enters the view, where the loci fan out; a label
    closer than ``gap`` (axes fractions, x and y) to one already written is left out."""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    placed = []
    for locus, omega, color in loci:
        inside = np.flatnonzero((locus.real > x0) & (locus.real < x1) & (locus.imag > y0) & (locus.imag < y1))
        if not inside.size:
            continue
        at = locus[inside[0]]
        spot = ((at.real - x0) / (x1 - x0), (at.imag - y0) / (y1 - y0))
        if any(abs(spot[0] - u) < gap[0] and abs(spot[1] - v) < gap[1] for u, v in placed):
            continue
        placed.append(spot)
        ax.annotate(f"{omega:.3g}", (at.real, at.imag), textcoords="offset points", xytext=(2, 2),
                    fontsize=7, color=color)


def _zoom(predictions, loci, drawn=None, margin=0.06, flattest=0.25):
    """``(x0, x1, y0, y1)``: the view around the cycles and near misses (or the loci's ends).

    The real part spans a square around the marks: centred on them, half its side
    the larger of their spread and half the largest ``|-1/N|`` among them.  Without
    ``drawn`` the imaginary part spans the same square.  With ``drawn`` (the curves
    to show: loci and G, complex arrays) it spans what of them lies inside the
    square (a curve that only passes beyond it does not count), and the marks, plus
    ``margin`` of that height each side: no empty half of the panel.  The height is
    at least ``flattest`` times the width, around the data.
    """
    marks = []
    for prediction in predictions:
        for item in list(prediction.cycles) + list(prediction.near_misses[:3]):
            marks.append(-1.0 / complex(prediction.describing(item.amplitude, item.omega)))
    marks = np.array(marks if marks else [locus[-1] for locus in loci if locus.size])
    span = max(np.ptp(marks.real), np.ptp(marks.imag), 0.5 * np.abs(marks).max())
    center = 0.5 * (marks.real.min() + marks.real.max()) + 0.5j * (marks.imag.min() + marks.imag.max())
    x0, x1, y0, y1 = center.real - span, center.real + span, center.imag - span, center.imag + span
    if drawn is None:
        return x0, x1, y0, y1
    low, high = marks.imag.min(), marks.imag.max()
    for curve in drawn:
        seen = _inside_band(np.asarray(curve, dtype=complex), x0, x1).imag
        seen = seen[(seen >= y0) & (seen <= y1)]
        if seen.size:
            low, high = min(low, seen.min()), max(high, seen.max())
    height = max(high - low, flattest * (x1 - x0) / (1.0 + 2.0 * margin))
    middle = 0.5 * (low + high)
    half = 0.5 * height * (1.0 + 2.0 * margin)
    return x0, x1, float(middle - half), float(middle + half)


def _inside_band(curve, x0, x1):
    """The points of a polyline with ``x0 <= Re <= x1``, and where its segments cross those two lines."""
    curve = curve[np.isfinite(curve)]
    inside = curve[(curve.real >= x0) & (curve.real <= x1)]
    crossings = [inside]
    a, b = curve[:-1], curve[1:]
    for edge in (x0, x1):
        crossing = (a.real - edge) * (b.real - edge) < 0.0
        t = (edge - a.real[crossing]) / (b.real[crossing] - a.real[crossing])
        crossings.append(a[crossing] + t * (b[crossing] - a[crossing]))
    return np.concatenate(crossings)
