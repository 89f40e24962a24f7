"""Branches of exact periodic orbits over one rig value, by pseudo-arclength continuation.

The unknowns of the shooting problem of :mod:`backlash_df.orbits` (the state
``q0`` on the section ``dtheta_d = 0`` and the period ``T``) are extended by the
parameter ``p`` (any numeric value of the rig file, :meth:`~backlash_df.config.Rig.with_values`).
With ``y = (q0, T, p)`` scaled component-wise, a branch point solves

    R(q0, T; p) = 0                         (orbits.orbit_residual: phi_T(q0) = q0, dtheta_d(q0) = 0)
    t . (y - y_pred) = 0                    (pseudo-arclength: Keller, 1977)

with the predictor ``y_pred = y_k + ds t_k`` along the unit tangent ``t_k`` (the
null vector of ``[dR/d(q0, T), dR/dp]``, oriented like the previous one).  The
Jacobian in ``(q0, T)`` is the shooting solver's exact one (monodromy with
saltation matrices); ``dR/dp`` is a central difference.  Because the arclength,
not ``p``, parametrises the branch, the corrector passes through folds where the
branch turns back in ``p``.  Every accepted point is polished by
:func:`~backlash_df.orbits.periodic_orbit` at its ``p``, so each point is a periodic
orbit to the shooting tolerance and carries its Floquet multipliers.

Special points are marked between consecutive branch points (AUTO and MatCont
name them the same way):

``fold``
    the tangent's ``p`` component changes sign (a saddle-node of cycles: a
    Floquet multiplier passes +1);
``period doubling``
    stability changes with the critical multiplier near -1;
``torus``
    stability changes with a complex pair leaving the unit circle (Neimark-Sacker);
``stability change``
    stability changes otherwise (a multiplier passes +1 away from a detected fold);
``grazing``
    the number of contact/release events per period changes: a contact is born
    or lost (the grazing bifurcation of a piecewise-smooth loop);
``birth``
    the amplitude shrinks to zero (below alpha / 1000): the cycle is born from
    rest, a Hopf-like onset of the contact loop (extrapolated to A = 0);
``end``
    the branch stops inside the range: the amplitude grows without bound (the
    loop with the shaft in contact loses stability, located from its poles),
    or the corrector fails (``detail`` says which).

Folds are located between branch points where the tangent's parameter
component vanishes (:func:`_locate_fold`), to the corrector's tolerance; the
other special points are placed between the two branch points that bracket them.

Known limitation: the section ``dtheta_d = 0`` is any extremum of theta_d.
Where the section point passes a degenerate extremum (two extrema of theta_d
merging), it slides along the orbit while the parameter hardly moves and the
step size collapses for a while (seen near 0.6 N m and 94.7 N m on the load
branch of ``examples/loaded_feedback.toml`` with ``ds_max`` = 0.3; the default
steps jump over it).

The describing function's branch (:func:`~backlash_df.predict_limit_cycles` at
a set of values) is computed beside it, on an executor if one is given.  Laws and
loops the shooting solver cannot handle (rubber with beta > 0, elasto-backlash, a
breakaway friction, dry friction with a torque limit) raise its ``ValueError``.

A checkpoint (:class:`~backlash_df.checkpoint.Checkpoint`) keeps the first orbit,
each step of the branch (the point, tangent, step size and state scale after it)
and each DF prediction as they are found, so that a stopped continuation resumes
from its last step, identical to an uninterrupted one.
"""

import dataclasses
import functools
import itertools

import numpy as np

from .checkpoint import describe, opened, run_cells, step_counter
from .limit_cycles import predict_limit_cycles
from .loops import drive_loop
from .orbits import OrbitNotFound, orbit_residual, orbit_state_names, periodic_orbit
from .plotting import ResultPlot, axes_or_new, legend_beside, log_scale
from .render.continuation import branch_report, branch_sentences, branch_tables
from .render.sweeps import value_label
from .simulation import simulated_limit_cycle

__all__ = ["BranchPoint", "SpecialPoint", "Branch", "continue_limit_cycles", "branch_plot"]


@dataclasses.dataclass(frozen=True)
class BranchPoint:
    """One point of a branch: the parameter value and the exact orbit there."""

    parameter: float
    orbit: object

    def to_dict(self):
        """JSON-ready: the parameter and the orbit's summary."""
        return {"parameter": float(self.parameter), **self.orbit.to_dict()}

    def __repr__(self):
        return f"BranchPoint({self.parameter:.6g}: {self.orbit!r})"


@dataclasses.dataclass(frozen=True)
class SpecialPoint:
    """A bifurcation or end marked between two branch points (module docs).

    Attributes
    ----------
    kind : str
        ``fold``, ``period doubling``, ``torus``, ``stability change``, ``grazing``,
        ``birth`` or ``end`` (module docs; ``detail`` says more).
    parameter : float
        Estimated parameter value (linear interpolation between the two points).
    amplitude : float
        Estimated amplitude A (rad) there.
    detail : str
    """

    kind: str
    parameter: float
    amplitude: float
    detail: str = ""

    def to_dict(self):
        """JSON-ready."""
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class Branch:
    """A branch of periodic orbits over one rig value, with the DF branch beside it.

    Attributes
    ----------
    parameter : str
        The rig value continued (e.g. ``"kp"``).
    model : str
    points : tuple of BranchPoint
        In arclength order (the parameter may go back and forth at folds).
    special : tuple of SpecialPoint
    df : tuple of (float, LimitCyclePrediction)
        DF predictions at a set of parameter values.
    value_range : (float, float)
        The requested range.
    rig : Rig
        The rig continued (for :meth:`orbit_at`).
    """

    parameter: str
    model: str
    points: tuple
    special: tuple
    df: tuple
    value_range: tuple
    rig: object = dataclasses.field(default=None, repr=False, compare=False)

    @property
    def values(self):
        """Parameter value of each point."""
        return np.array([point.parameter for point in self.points])

    @property
    def amplitude(self):
        """First-harmonic amplitude A of theta_d, rad, per point."""
        return np.array([point.orbit.amplitude for point in self.points])

    @property
    def omega(self):
        """Angular frequency, rad/s, per point."""
        return np.array([point.orbit.omega for point in self.points])

    @property
    def stable(self):
        """Stability (Floquet) per point."""
        return np.array([point.orbit.stable for point in self.points])

    def orbit_at(self, value):
        """The exact orbit at ``value``, polished from the nearest branch point (raises OrbitNotFound)."""
        nearest = min(self.points, key=lambda point: abs(point.parameter - value))
        return _polish(_rig_of(self.rig, self.parameter, value), self.model, nearest.orbit)

    def tables(self):
        """The terminal's tables: ``[(title, header, rows), ...]``, the exact orbits, then the DF's cycles
        (:func:`~backlash_df.render.continuation.branch_tables`)."""
        return branch_tables(self)

    def sentences(self):
        """One line per special point: kind, where, and what happened
        (:func:`~backlash_df.render.continuation.branch_sentences`)."""
        return branch_sentences(self)

    def __repr__(self):
        kinds = ", ".join(f"{s.kind} at {self.parameter}={s.parameter:.4g}" for s in self.special) or "none"
        return (f"Branch({self.model}, {self.parameter} in [{self.values.min():.4g}, {self.values.max():.4g}], "
                f"{len(self.points)} orbits, A in [{self.amplitude.min():.4g}, {self.amplitude.max():.4g}] rad; "
                f"special points: {kinds})")

    def to_dict(self):
        """JSON: parameter, branch points (orbit summaries), special points and the DF branch."""
        return {
            "parameter": self.parameter,
            "model": self.model,
            "range": list(self.value_range),
            "points": [point.to_dict() for point in self.points],
            "special": [point.to_dict() for point in self.special],
            "df": [{"parameter": float(value), "cycles": prediction.cycle_dicts()} for value, prediction in self.df],
        }

    def plot(self, ax=None):
        """Amplitude and frequency against the parameter; see :func:`branch_plot`."""
        return branch_plot(self, ax=ax)

    def report_html(self, title="", rig_text=""):
        """A self-contained HTML page: the branch figure and the special points.

        Parameters
        ----------
        title : str
            Page title (default "Continuation").
        rig_text : str
            The rig file's text, shown as it is.

        See Also
        --------
        backlash_df.render.continuation.branch_report
        """
        return branch_report(self, self.plot().figure, title, rig_text)


def branch_plot(branch, ax=None):
    """Amplitude A (rad) and frequency w (rad/s) of the branch against the parameter.

    Stable stretches solid, unstable dashed; the DF cycles as markers (filled:
    stable by Loeb's criterion); special points annotated.

    Returns
    -------
    ResultPlot
        Axes ``[amplitude, frequency]``; the legend beside the amplitude.
    """
    figure, axes = axes_or_new(ax, (2, 1), sharex=True, figsize=(9, 6), layout="constrained")
    values, stable = branch.values, branch.stable
    for ax, series in zip(axes, (branch.amplitude, branch.omega)):
        start = 0
        for end in list(np.nonzero(stable[1:] != stable[:-1])[0] + 1) + [len(values)]:
            piece = slice(start, min(end + 1, len(values)))
            ax.plot(values[piece], series[piece], color="C0", ls="-" if stable[start] else "--", lw=1.6)
            start = end
        for value, prediction in branch.df:
            for cycle in prediction.cycles:
                y = cycle.amplitude if ax is axes[0] else cycle.omega
                ax.plot(value, y, "o", color="C1", ms=4, mfc="C1" if cycle.stable else "none")
    for point in branch.special:
        axes[0].plot(point.parameter, point.amplitude, "s", color="k", ms=5, mfc="none")
        axes[0].annotate(point.kind, (point.parameter, point.amplitude), textcoords="offset points",
                         xytext=(4, 6), fontsize=8)
    axes[0].plot([], [], color="C0", label="exact orbits, stable")
    axes[0].plot([], [], color="C0", ls="--", label="exact orbits, unstable")
    axes[0].plot([], [], "o", color="C1", ms=4, label="describing function")
    legend = legend_beside(axes[0], fontsize=8)
    axes[0].set_ylabel("A (rad)")
    if branch.amplitude.max() > 20.0 * branch.amplitude.min():
        log_scale(axes[0].yaxis, branch.amplitude.min(), branch.amplitude.max())
    axes[1].set_ylabel("w (rad/s)")
    axes[1].set_xlabel(value_label(branch.parameter))
    axes[0].set_title(f"{branch.model}: limit cycles against {branch.parameter}", fontsize="medium")
    return ResultPlot(figure, axes, legend)


# --------------------------------------------------------------------------- the continuation


@functools.lru_cache(maxsize=64)
def _rig_of(rig, parameter, value):
    return rig.with_values(**{parameter: value})


def _polish(rig, model, seed):
    return periodic_orbit(rig, model, seed)


def _unknowns(orbit):
    return np.append(orbit.state, orbit.period)


def _state_scale(unknowns):
    return np.maximum(np.abs(unknowns), 1e-6 * np.abs(unknowns).max())


class _Extended:
    """Residual and Jacobian of the shooting problem in the scaled unknowns y = (q0, T, p) / scale."""

    def __init__(self, rig, parameter, model, scale):
        self.rig, self.parameter, self.model, self.scale = rig, parameter, model, scale

    def rescale(self, unknowns):
        """Scale the states by their current size; returns old / new scale (to carry a tangent over).

        A scale shrinks by at most half per point, so a state passing through zero
        does not shrink the steps to nothing.
        """
        old = self.scale.copy()
        self.scale[:-1] = np.maximum(_state_scale(unknowns), 0.5 * old[:-1])
        return old / self.scale

    def split(self, y):
        x = y * self.scale
        return x[:-1], float(x[-1])

    def __call__(self, y):
        unknowns, value = self.split(y)
        residual, jacobian = orbit_residual(_rig_of(self.rig, self.parameter, value), self.model, unknowns)
        step = 1e-6 * max(abs(value), self.scale[-1] * 1e-3)
        sides = [self._shifted(value + sign * step, unknowns) for sign in (1.0, -1.0)]
        if sides[0] is None or sides[1] is None:  # at the end of the value's range (a friction of 0): one-sided
            sides = [residual if side is None else side for side in sides]
            step *= 0.5
        d_value = (sides[0] - sides[1]) / (2.0 * step)
        return residual, np.column_stack([jacobian, d_value]) * self.scale

    def _shifted(self, value, unknowns):
        """The residual with the parameter at ``value``, None where the rig refuses the value (out of its range)."""
        try:
            rig = self.rig.with_values(**{self.parameter: value})
        except ValueError:
            return None
        return orbit_residual(rig, self.model, unknowns)[0]


def _tangent(jacobian, previous):
    """Unit null vector of ``jacobian`` (n x n+1), oriented along ``previous``."""
    bordered = np.vstack([jacobian, previous])
    rhs = np.zeros(bordered.shape[0])
    rhs[-1] = 1.0
    tangent = np.linalg.solve(bordered, rhs)
    tangent /= np.linalg.norm(tangent)
    return tangent if tangent @ previous >= 0.0 else -tangent


def _correct(extended, y_pred, tangent, tol=1e-9, iterations=10):
    """Newton on [R(y); t (y - y_pred)] = 0.

    Returns (y, iterations used, Jacobian of R at the last iterate but one), or (None, iterations, None).
    """
    y = y_pred.copy()
    for count in range(1, iterations + 1):
        try:
            residual, jacobian = extended(y)
        except OrbitNotFound:
            return None, count, None
        system = np.vstack([jacobian, tangent])
        rhs = -np.append(residual, tangent @ (y - y_pred))
        try:
            delta = np.linalg.solve(system, rhs)
        except np.linalg.LinAlgError:
            return None, count, None
        y = y + delta
        if np.abs(delta).max() < tol:
            return y, count, jacobian
    return None, iterations, None


def _critical(orbit):
    """Kind of stability change from the largest non-trivial multiplier."""
    mu = orbit.multipliers[1] if orbit.multipliers.size > 1 else 1.0
    if abs(mu.imag) > 1e-6 * abs(mu):
        return "torus"
    return "period doubling" if mu.real < 0.0 else "stability change"


def _interpolate(a, b, fa, fb):
    """Parameter and amplitude where ``f`` (linear between a and b) changes sign."""
    w = fa / (fa - fb) if fa != fb else 0.5
    return (float(a.parameter + w * (b.parameter - a.parameter)),
            float(a.orbit.amplitude + w * (b.orbit.amplitude - a.orbit.amplitude)))


def _special_points(points, tangents):
    """Stability changes (away from folds, located by :func:`_trace`) and grazing between consecutive points."""
    marks = []
    for (a, ta), (b, tb) in zip(zip(points[:-1], tangents[:-1]), zip(points[1:], tangents[1:])):
        fold = ta[-1] * tb[-1] < 0.0
        if a.orbit.stable != b.orbit.stable and not fold:
            unstable = b.orbit if a.orbit.stable else a.orbit
            value, amplitude = _interpolate(a, b, a.orbit.max_multiplier - 1.0, b.orbit.max_multiplier - 1.0)
            mu = unstable.multipliers[1]
            marks.append(SpecialPoint(_critical(unstable), value, amplitude,
                                      f"critical multiplier {mu.real:.4g}{mu.imag:+.4g}j"))
        if len(a.orbit.events) != len(b.orbit.events):
            marks.append(SpecialPoint("grazing", 0.5 * (a.parameter + b.parameter),
                                      0.5 * (a.orbit.amplitude + b.orbit.amplitude),
                                      f"contact events per period {len(a.orbit.events)} -> {len(b.orbit.events)}"))
    return marks


@dataclasses.dataclass
class _Trace:
    """Where a trace stands: the points, tangents and folds so far, and the next predictor's y, tangent, ds."""

    points: list
    tangents: list
    folds: list
    y: np.ndarray
    tangent: np.ndarray
    ds: float

    def apply(self, step, extended):
        """Take one step of :func:`_step` (computed now or read from a checkpoint)."""
        self.points += step["points"]
        self.tangents += step["tangents"]
        self.folds += step["folds"]
        if not step["done"]:
            self.y, self.tangent, self.ds = step["y"], step["tangent"], step["ds"]
            extended.scale = np.array(step["scale"])


def _end(reason, points=(), tangents=()):
    """The last step of a trace; ``reason`` None: the bound was reached."""
    return {"points": list(points), "tangents": list(tangents), "folds": [], "reason": reason, "done": True}


def _step(extended, trace, direction, bound, ds_max, max_points, amplitude_bounds):
    """From the last point of ``trace`` to the next accepted one (halving ds on failure), or to the trace's end.

    Returns the step as a dict (what a checkpoint keeps): the points, tangents and
    folds to append and, unless ``done``, the new y, tangent, ds and state scale.
    """
    rig, parameter, model = extended.rig, extended.parameter, extended.model
    y, tangent, ds = trace.y, trace.tangent, trace.ds
    if len(trace.points) >= max_points:
        return _end(f"stopped after {max_points} points")
    orbit = None
    while orbit is None:
        y_new, used, jacobian = _correct(extended, y + ds * tangent, tangent)
        if y_new is not None:
            unknowns, value = extended.split(y_new)
            seed = dataclasses.replace(trace.points[-1].orbit, state=unknowns[:-1], period=float(unknowns[-1]))
            try:
                orbit = _polish(_rig_of(rig, parameter, value), model, seed)
            except (OrbitNotFound, ValueError):
                orbit = None
        if orbit is None:
            ds *= 0.5
            if ds < 1e-6:
                return _end("the corrector failed at every step size (the orbit grazes or is lost)")
    if (value - bound) * direction > 0.0:  # past the end: land on it
        try:
            return _end(None, [BranchPoint(bound, _polish(_rig_of(rig, parameter, bound), model, orbit))], [tangent])
        except OrbitNotFound:
            return _end(None)
    point = BranchPoint(value, orbit)
    if orbit.amplitude > amplitude_bounds[1]:
        return _end("amplitude cap", [point], [tangent])
    if orbit.amplitude < amplitude_bounds[0]:
        return _end("amplitude floor", [point], [tangent])
    # the corrector's last Jacobian (a step of < tol before) gives the new tangent;
    # then the states are rescaled to their current size: relative steps as the orbit grows
    new_tangent = _tangent(jacobian, tangent)
    folds = []
    if tangent[-1] * new_tangent[-1] < 0.0:
        folds.append(_locate_fold(extended, y, tangent, ds, new_tangent[-1], [trace.points[-1], point]))
    factor = extended.rescale(_unknowns(orbit))
    new_tangent = new_tangent * factor / np.linalg.norm(new_tangent * factor)
    ds = min(ds * 2.0, ds_max) if used <= 4 else (0.5 * ds if used >= 7 else ds)
    return {"points": [point], "tangents": [new_tangent], "folds": folds, "done": False,
            "y": np.append(_unknowns(orbit), value) / extended.scale, "tangent": new_tangent, "ds": ds,
            "scale": extended.scale.copy()}


def _trace(extended, start, direction, bound, ds, ds_max, max_points, amplitude_bounds, kept=None, name="forward",
           step_done=None):
    """Continue from ``start`` (a polished orbit) with the parameter first moving in ``direction``.

    Each step (:func:`_step`) is kept in the checkpoint ``kept`` under ``(name, k)``;
    the steps it holds already are taken from it, not computed again.

    Returns (points, tangents, reason, folds): reason is None when ``bound`` was
    reached; folds are :class:`SpecialPoint` located by :func:`_locate_fold`.
    """
    y = np.append(_unknowns(start.orbit), start.parameter) / extended.scale
    along = np.zeros(y.size)
    along[-1] = direction
    tangent = _tangent(extended(y)[1], along)
    trace = _Trace([start], [tangent], [], y, tangent, ds)
    for count in itertools.count():
        key = (name, count)
        if kept is not None and key in kept:
            step = kept[key]
        else:
            step = _step(extended, trace, direction, bound, ds_max, max_points, amplitude_bounds)
            if kept is not None:
                kept.add(key, step)
        trace.apply(step, extended)
        if step_done is not None:
            step_done()
        if step["done"]:
            return trace.points, trace.tangents, step["reason"], trace.folds


def _locate_fold(extended, y, tangent, ds, t_end, pair, tol=1e-7, iterations=12):
    """The turning point between two branch points: where the tangent's parameter component vanishes.

    Regula falsi (Illinois) on the fraction ``f`` of the step ``ds`` from ``y``
    (scaled unknowns of ``pair[0]``, tangent ``tangent``): the predictor
    ``y + f ds tangent`` is corrected and its tangent's parameter component is
    driven to zero; the parameter there is the fold's, to the corrector tolerance.
    """
    lo, hi, g_lo, g_hi = 0.0, 1.0, tangent[-1], t_end
    value, fraction = None, 0.5
    for _ in range(iterations):
        fraction = lo - g_lo * (hi - lo) / (g_hi - g_lo)
        corrected, _, jacobian = _correct(extended, y + fraction * ds * tangent, tangent)
        if corrected is None:
            break
        value = extended.split(corrected)[1]
        g = _tangent(jacobian, tangent)[-1]
        if abs(g) < tol:
            break
        if g * g_lo > 0.0:
            lo, g_lo, g_hi = fraction, g, 0.5 * g_hi
        else:
            hi, g_hi, g_lo = fraction, g, 0.5 * g_lo
    a, b = pair
    value = 0.5 * (a.parameter + b.parameter) if value is None else value
    amplitude = a.orbit.amplitude + fraction * (b.orbit.amplitude - a.orbit.amplitude)
    return SpecialPoint("fold", float(value), float(amplitude),
                        "the branch turns back in the parameter (a Floquet multiplier passes +1)")


def _extrapolate_to_zero(pair):
    """Parameter where the amplitude reaches zero, linear through two points (last one nearer zero)."""
    a, b = pair
    if b.orbit.amplitude == a.orbit.amplitude:
        return float(b.parameter)
    w = b.orbit.amplitude / (a.orbit.amplitude - b.orbit.amplitude)
    return float(b.parameter + w * (b.parameter - a.parameter))


def _contact_instability(rig, parameter, model, inside, outside):
    """Where the loop with the shaft in full contact loses stability between two values (text), by bisection."""
    shaft = rig.make_model(model)

    def unstable(value):
        tuned = _rig_of(rig, parameter, value)
        if tuned.controller.delay > 0.0:
            return None
        return bool(np.any(drive_loop(tuned, dry_friction=True).linear_poles(shaft.stiffness, shaft.damping).real
                           > 0.0))

    beyond = outside + 0.5 * (outside - inside)
    if unstable(inside) is not False or not unstable(beyond):
        return ""
    for _ in range(60):
        middle = 0.5 * (inside + beyond)
        inside, beyond = (inside, middle) if unstable(middle) else (middle, beyond)
    return f"; the loop with the shaft in contact loses stability at {parameter} = {0.5 * (inside + beyond):.6g}"


def _df_prediction(rig, parameter, model, grid, value):
    return predict_limit_cycles(rig.with_values(**{parameter: value}), model, grid=grid)


def _start(rig, parameter, model, values, seed):
    """First orbit: from ``seed`` at ``values[0]``, else from the DF's or a simulation's cycle at the first value that has one."""
    for value in values:
        tuned = _rig_of(rig, parameter, value)
        seeds = [seed] if seed is not None else []
        if seed is None:
            seeds += list(reversed(predict_limit_cycles(tuned, model, grid=(30, 40)).stable_cycles))
            cycle = seeds[0] if seeds else None
            kick = cycle.amplitude * cycle.omega if cycle is not None else 2.0 * tuned.plant.half_gap * 100.0
            measured, _ = simulated_limit_cycle(tuned, model, t_end=10.0, max_t_end=40.0, kick=kick)
            seeds += [measured] if measured.periodic else []
        for candidate in seeds:
            try:
                return BranchPoint(float(value), periodic_orbit(tuned, model, candidate))
            except (OrbitNotFound, ValueError):
                continue
        seed = None
    raise OrbitNotFound(f"no periodic orbit found to start from at any of {len(values)} values of the parameter")


def continue_limit_cycles(rig, parameter, values_or_range, model=None, *, seed=None, ds=0.05, ds_max=1.0,
                          max_points=200, max_amplitude=40.0, df_values=25, df_grid=(30, 40), executor=None,
                          progress=None, checkpoint=None):
    """Trace the branch of exact periodic orbits over one rig value (module docs).

    Parameters
    ----------
    rig : Rig
    parameter : str
        A numeric rig value (a key of :meth:`~backlash_df.config.Rig.with_values`: ``"kp"``,
        ``"ti"``, ``"stiffness"``, ``"load.torque"``, ...).
    values_or_range : (float, float) or array_like
        The range ``(from, to)``; with more values, their first and last are the
        range and the DF is evaluated at all of them.
    model : str, optional
        Torque law (default the rig's); piecewise affine (:mod:`backlash_df.orbits`).
    seed : optional
        A seed of :func:`~backlash_df.orbits.periodic_orbit` at ``from``; default
        the DF's largest stable cycle, else a simulated cycle, at the first of
        a few values across the range that has one.
    ds, ds_max : float
        First and largest arclength step in the scaled unknowns (the range is 1).
    max_points : int
        Most branch points per direction.
    max_amplitude : float
        The branch ends where A exceeds this many half gaps (the cycle is then
        growing without bound towards the loss of stability of the loop in contact).
    df_values : int
        DF predictions at this many values across the range (ignored if values are given).
    df_grid : (int, int)
        Scan grid of each DF prediction.
    executor : concurrent.futures.Executor, optional
        Runs the DF predictions (the continuation itself is sequential).
    progress : callable, optional
        ``progress(stage, done, total)`` (the package's one protocol): stage
        ``"branch"`` after each step (``total`` None: the branch's length is not
        known ahead), then ``"DF values"`` as the DF predictions finish.
    checkpoint : str, Path or Checkpoint, optional
        Keeps the first orbit, every step of the branch (its point, tangent and
        step size) and every DF prediction in this file as they are found
        (:class:`~backlash_df.checkpoint.Checkpoint`; a path: a new file).
        ``Checkpoint(path, resume=True)`` continues a stopped continuation: it
        recomputes only the step in progress when it stopped (from the last kept
        point), the DF predictions not kept, and the special points' cheap
        post-processing (stability changes, grazing, the contact loop's limit);
        the branch is identical to an uninterrupted one.  The file stays when the
        branch is done.

    Returns
    -------
    Branch

    Raises
    ------
    ValueError
        Unknown parameter, range of one value, a law the shooting solver cannot handle;
        a checkpoint that exists without ``resume`` or belongs to another run.
    OrbitNotFound
        No orbit to start from anywhere in the range.
    """
    rig = rig.without_uncertainty(parameter)  # the branch explores its value, boxed or not
    rig.require_modelled(dry_friction=True)
    orbit_state_names(rig, model)  # a law or a friction the orbits cannot hold stops here, in one line
    values = np.atleast_1d(np.asarray(values_or_range, dtype=float))
    if values.size < 2 or values[0] == values[-1] or not np.all(np.isfinite(values)):
        raise ValueError(f"continue: give a range of {parameter} (two different finite values), got {values_or_range!r}")
    lo, hi = float(values[0]), float(values[-1])
    model = rig.make_model(model).name
    rig.with_values(**{parameter: lo}).with_values(**{parameter: hi})  # names and values checked before any work
    inputs = describe({"rig": rig, "parameter": parameter, "range": (lo, hi), "model": model, "seed": seed, "ds": ds,
                       "ds_max": ds_max, "max_points": max_points, "max_amplitude": max_amplitude,
                       "df_grid": tuple(df_grid)}, omit={"source"})
    with opened(checkpoint, "continue", inputs) as kept:
        points, special = _branch(rig, parameter, model, (lo, hi), seed, (ds, ds_max, max_points, max_amplitude),
                                  kept, progress)
        df_at = np.linspace(lo, hi, df_values) if values.size == 2 else values
        df_at = [float(value) for value in df_at]
        predictions = run_cells(functools.partial(_df_prediction, rig, parameter, model, tuple(df_grid)), df_at,
                                executor=executor, checkpoint=kept, keys=[("df", value) for value in df_at],
                                progress=progress,
                                stage="DF values")
    return Branch(parameter, model, tuple(points), tuple(special), tuple(zip(df_at, predictions)), (lo, hi), rig)


def _branch(rig, parameter, model, value_range, seed, steps, kept, progress=None):
    """The branch points and special points (:func:`continue_limit_cycles`), each step kept in ``kept``."""
    (lo, hi), (ds, ds_max, max_points, max_amplitude) = value_range, steps
    if kept is not None and ("start",) in kept:
        start = kept[("start",)]
    else:
        start = _start(rig, parameter, model, np.linspace(lo, hi, 5) if seed is None else np.array([lo]), seed)
        if kept is not None:
            kept.add(("start",), start)
    unknowns = _unknowns(start.orbit)
    amplitude_bounds = (1e-3 * rig.plant.half_gap, max_amplitude * rig.plant.half_gap)
    direction = 1.0 if hi > lo else -1.0
    extended = _Extended(rig, parameter, model, np.append(_state_scale(unknowns), abs(hi - lo)))
    counted = step_counter(progress, "branch")
    forward, t_forward, why_forward, folds = _trace(extended, start, direction, hi, ds, ds_max, max_points,
                                                    amplitude_bounds, kept, "forward", counted)
    points, tangents, reasons = forward, t_forward, [why_forward]
    if start.parameter != lo:
        extended = _Extended(rig, parameter, model, np.append(_state_scale(unknowns), abs(hi - lo)))
        backward, t_backward, why_backward, back_folds = _trace(extended, start, -direction, lo, ds, ds_max,
                                                                max_points, amplitude_bounds, kept, "backward",
                                                                counted)
        points = backward[::-1] + forward[1:]
        tangents = [-t for t in t_backward[::-1]] + t_forward[1:]
        reasons.append(why_backward)
        folds += back_folds
    special = folds + _special_points(points, tangents)
    for point, reason in zip((points[-1], points[0]), reasons):
        if reason == "amplitude cap":
            reason = f"A > {max_amplitude:g} alpha: the cycle grows without bound" + _contact_instability(
                rig, parameter, model, start.parameter, point.parameter)
        if reason == "amplitude floor":
            value = _extrapolate_to_zero(points[-2:] if point is points[-1] else points[1::-1])
            special.append(SpecialPoint("birth", value, 0.0, "the cycle shrinks to rest: Hopf-like onset of the "
                                        f"contact loop at {parameter} = {value:.6g} (A -> 0 extrapolated)"))
        elif reason is not None:
            special.append(SpecialPoint("end", point.parameter, point.orbit.amplitude, reason))
    return points, special
