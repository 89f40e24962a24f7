"""A Lur'e loop's exact orbit followed along a gain of H or a value of its element.

:func:`continue_lure_orbit` steps the parameter through the values given and shoots the
orbit at each from the orbit at the one before (natural-parameter continuation, the state
in the same coordinates: :meth:`~backlash_df.lure.LureLoop.with_value`), or, where that
fails, from a sine of its amplitude and frequency (the element's mode at the section may
change with its value); a step whose shooting fails is halved, up to four times, before
the branch is declared lost there (a fold, where the orbit turns back, or a collision with a
switching surface).  At each point the describing function's nearest cycle is beside
the orbit, and the points where the largest Floquet multiplier crosses the unit circle
are marked: the orbit changes stability there.
"""

import dataclasses
import math

import numpy as np

from ._json import json_ready
from .orbits import OrbitNotFound
from .plotting import ResultPlot, axes_or_new, legend_beside

__all__ = ["LureBranch", "continue_lure_orbit"]

#: Halvings of a step before the branch is lost.
HALVINGS = 4


@dataclasses.dataclass(frozen=True, eq=False)
class LureBranch:
    """An exact orbit along one parameter of a Lur'e loop (module docs).

    Attributes
    ----------
    model : str
        The element's label at the branch's start.
    parameter : str
        ``"gain"`` (H scaled by it) or the element's value (``"limit"``, ``"width"``, ...).
    values : ndarray
        The parameter at every point reached.
    orbits : tuple of LureOrbit
        The orbit at each value.
    df_amplitudes, df_omegas : ndarray
        The describing function's cycle nearest each orbit (NaN where it predicts none).
    stability_changes : tuple of float
        Parameter values (midpoints) where the largest multiplier crosses 1.
    note : str
        Where and why the branch was lost, ``""`` if it reached the last value.
    """

    model: str
    parameter: str
    values: np.ndarray
    orbits: tuple = dataclasses.field(repr=False)
    df_amplitudes: np.ndarray = dataclasses.field(repr=False)
    df_omegas: np.ndarray = dataclasses.field(repr=False)
    stability_changes: tuple = ()
    note: str = ""

    @property
    def amplitudes(self):
        """The orbits' first-harmonic amplitudes of y."""
        return np.array([o.amplitude for o in self.orbits])

    @property
    def omegas(self):
        """The orbits' frequencies, rad/s."""
        return np.array([o.omega for o in self.orbits])

    def __repr__(self):
        span = f"{self.values[0]:.4g} .. {self.values[-1]:.4g}"
        changes = f", stability changes at {', '.join(f'{v:.4g}' for v in self.stability_changes)}" \
            if self.stability_changes else ""
        lost = f"; {self.note}" if self.note else ""
        return f"<LureBranch {self.model}: {self.parameter} {span}, {len(self.orbits)} orbits{changes}{lost}>"

    def to_dict(self):
        """JSON-ready: the parameter, and per point the orbit's A, w, stability and largest multiplier beside the DF's."""
        return json_ready({
            "model": self.model, "parameter": self.parameter, "note": self.note or None,
            "stability_changes": list(self.stability_changes),
            "points": [{"value": v, "amplitude": o.amplitude, "omega": o.omega, "stable": o.stable,
                        "max_multiplier": o.max_multiplier, "df_amplitude": a, "df_omega": w}
                       for v, o, a, w in zip(self.values, self.orbits, self.df_amplitudes, self.df_omegas)],
        })

    def plot(self, ax=None):
        """The orbit's amplitude and frequency against the parameter (solid stable, dashed unstable), the DF's beside."""
        figure, axes = axes_or_new(ax, (2, 1), sharex=True, figsize=(7.5, 5.0), layout="constrained")
        axes = np.ravel(axes)
        stable = np.array([o.stable for o in self.orbits])
        for panel, exact, df, label in ((axes[0], self.amplitudes, self.df_amplitudes, "A"),
                                        (axes[1], self.omegas, self.df_omegas, "w (rad/s)")):
            for kind, style, where in (("stable", "-", stable), ("unstable", "--", ~stable)):
                if where.any():
                    panel.plot(self.values, np.where(where, exact, np.nan), style, color="C0",
                               label=f"exact orbit, {kind}")
            panel.plot(self.values, df, ":", color="C1", label="describing function")
            for value in self.stability_changes:
                panel.axvline(value, color="0.6", lw=0.8)
            panel.set_ylabel(label)
        axes[1].set_xlabel(self.parameter)
        axes[0].set_title(f"{self.model}: the orbit along {self.parameter}", fontsize="medium")
        legend = legend_beside(axes[0], fontsize="small")
        return ResultPlot(figure, axes, legend)


def continue_lure_orbit(loop, parameter, values, seed):
    """Follow the orbit of ``loop`` at ``values[0]`` (from ``seed``) through ``values`` (module docs).

    Parameters
    ----------
    loop : LureLoop
        The loop at gain 1 (for ``"gain"``) or with any value of the element's parameter.
    parameter : str
        ``"gain"`` (H scaled by it) or a value of the element (its dataclass field:
        ``limit``, ``half_width``, ``slope``, ``level``, ``hysteresis``, ``width``).
    values : array_like
        Monotonic, at least two.
    seed : LimitCycle, LureOrbit or (amplitude, omega)
        The orbit at ``values[0]``, or a seed for it (of the loop at that value).

    Returns
    -------
    LureBranch

    Raises
    ------
    ValueError
        An unknown parameter, values that are not finite and monotonic, a value the
        element refuses: one line.  :class:`~backlash_df.orbits.OrbitNotFound` if no
        orbit is found at ``values[0]``.
    """
    values = np.asarray(values, dtype=float).reshape(-1)
    steps = np.diff(values)
    if values.size < 2 or not np.all(np.isfinite(values)) or not (np.all(steps > 0) or np.all(steps < 0)):
        raise ValueError(f"values must be at least two finite numbers, strictly monotonic, got {values.tolist()!r}")
    at = loop.with_value(parameter, values[0])
    orbits, reached = [at.periodic_orbit(seed)], [values[0]]
    note = ""
    for target in values[1:]:
        found = _step(loop, parameter, reached[-1], target, orbits[-1])
        reached.extend(v for v, _ in found)
        orbits.extend(o for _, o in found)
        if not found or reached[-1] != target:
            note = (f"shooting lost the orbit between {parameter} = {reached[-1]:.6g} and {target:.6g} "
                    "(a fold, where it turns back, or a switch it grazes)")
            break
    df = [_nearest_df(loop.with_value(parameter, v), o) for v, o in zip(reached, orbits)]
    largest = np.array([o.max_multiplier for o in orbits])
    crossing = np.flatnonzero((largest[:-1] < 1.0) != (largest[1:] < 1.0))
    return LureBranch(
        model=loop.label, parameter=parameter, values=np.array(reached), orbits=tuple(orbits),
        df_amplitudes=np.array([a for a, _ in df]), df_omegas=np.array([w for _, w in df]),
        stability_changes=tuple(float(0.5 * (reached[i] + reached[i + 1])) for i in crossing), note=note,
    )


def _step(loop, parameter, start, target, orbit):
    """``[(value, orbit)]`` from ``start`` to ``target``: one shot, or steps halved where a shot fails."""
    found, value, step = [], start, target - start
    for _ in range(HALVINGS + 1):
        while value != target:
            following = target if abs(target - value) <= abs(step) * (1.0 + 1e-9) else value + step
            shot = _shoot_at(loop.with_value(parameter, following), orbit)
            if shot is None:
                break
            orbit = shot
            value = following
            found.append((value, orbit))
        if value == target:
            return found
        step *= 0.5
    return found


def _shoot_at(loop, orbit):
    """The orbit of ``loop`` near the previous ``orbit``: from its state, else from its (A, w) as a sine
    (the element's mode at the section may have changed with its value), else None."""
    for seed in (orbit, (orbit.amplitude, orbit.omega)):
        try:
            return loop.periodic_orbit(seed)
        except OrbitNotFound:
            continue
    return None


def _nearest_df(loop, orbit):
    """``(A, w)`` of the DF cycle of ``loop`` nearest ``orbit`` (in log A and log w), NaN where none."""
    cycles = loop.predict().cycles
    if not cycles:
        return math.nan, math.nan
    nearest = min(cycles, key=lambda c: math.hypot(math.log(c.amplitude / orbit.amplitude),
                                                  math.log(c.omega / orbit.omega)))
    return nearest.amplitude, nearest.omega
