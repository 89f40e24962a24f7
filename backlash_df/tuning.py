"""Tune: the fastest loop whose verdict is certified ``no oscillation``.

:func:`tune` searches one or two rig values (``kp``, ``ti``, ``speed_filter``,
and ``kv`` of a cascade) on a log scale for the largest bandwidth whose loop does
not hunt, and says why that answer can be trusted.

**Objective.**  The bandwidth ``omega_b`` of the loop with the gear held in contact
(shaft ``T = k theta_d + c dtheta_d``, linear, the dead time exact): the smallest
``omega > 0`` at which the closed-loop gain from the speed reference to the load
speed (a cascade: from the position reference to the load angle) falls to
``1/sqrt(2)`` (:func:`contact_bandwidth`).  A tuning whose contact loop is unstable
is infeasible (a torque-limited one hunts at the limit instead).

**Constraint: certified no oscillation** (:class:`Certificate`), for the rig's
torque law (or ``model``): (1) the -1/N(A, w) loci do not meet G(jw), the near
miss's distance reported; (2) exact shooting seeded at the near misses and at the
simulations finds no periodic orbit; (3) no sustained oscillation from the
standard disturbance set (:func:`~backlash_df.disturbances.standard_disturbances`)
and the verdict's other probes: the verdict of :func:`~backlash_df.verdict.judge_loop`
with its exact orbits is ``no oscillation``.  With ``tolerance = A > 0`` a stable
cycle whose first-harmonic amplitude of theta_d is at most ``A`` is accepted
(hunting within tolerance) and its amplitude reported.

**Search.**  The range is screened on a grid by the describing function (cheap:
the bandwidth and the DF's stable cycles of every cell, on any
``concurrent.futures.Executor``); the boundary between a cell the DF clears and a
neighbour that hunts is refined by bisection on the log scale; the candidates are
certified in order of decreasing bandwidth, the first certified is the answer,
and where a faster candidate fails its certificate the boundary between the two is
bisected with certificates.  The **margin** is the factor by which the varied
values can move toward the nearest hunting tuning found; the **front** is the
best bandwidth for each tolerance from 0 up to the largest cycle in range, each point's
hunting amplitude that of the stable exact orbit (:mod:`backlash_df.orbits`) on the cycle
its simulation settles to, where shooting converges, else the simulation's.  Where
no tuning in range is certified the answer says so and gives the tuning of the
smallest hunting amplitude.

**Uncertainty.**  Over a box of rig values (``uncertainty``, or the rig's
``[uncertainty]`` table), a tuning counts as certified only if its certificate, gain
margin included, holds at the nominal rig and at every point of the box's design
(:func:`uncertainty_design`), and the DF screen clears a cell only if it clears it at all of them;
the bandwidth is the nominal rig's.  The answer names the binding point: where the
nearest faster tuning fails its certificate.
"""

import collections.abc
import dataclasses
import functools
import itertools
import math
import time

import numpy as np

from ._json import json_ready
from .checkpoint import describe, opened, run_cells
from .config import Uncertainty, rig_from_dict
from .disturbances import shaft_mode
from .equilibria import linear_stability
from .limit_cycles import predict_limit_cycles, verify_limit_cycles
from .loops import drive_loop
from .models import BacklashModel
from .orbits import exact_orbits
from .plotting import ResultPlot, axes_or_new, cell_edges, legend_under, log_scale
from .render.tuning import tuning_report, tuning_sentences, tuning_tables
from .system import closed_loop_response
from .verdict import judge_loop

__all__ = ["TUNABLE", "Candidate", "Certificate", "FrontPoint", "Tuning", "contact_bandwidth", "certify", "tune",
           "uncertainty_design"]

#: Rig values tune varies, with their units (``kv``: a cascade's only).
TUNABLE = {"kp": "N m s/rad", "ti": "s", "speed_filter": "s", "kv": "1/s"}

_DF_GRID = (24, 32)  # the DF scan of a screened cell (the design map's coarse grid)
_SCREEN = {1: 17, 2: 9}  # screened values per varied parameter
_BISECTIONS = 5  # DF bisections of a boundary segment: 1/32 of a screened cell
_CERTIFIED_BISECTIONS = 4  # bisections with certificates where the DF cleared a hunting tuning
_PLATEAU = 0.01  # a bandwidth gaining less than this (relative) over the last factor of 2 of a value has plateaued
_KNEE_BISECTIONS = 7  # log bisections of the knee: to a factor 2**(1/128), 0.5 %
#: The direction of gentler control of each value: a smaller gain, a slower integral action or speed filter.
_GENTLER = {"kp": -1.0, "kv": -1.0, "ti": 1.0, "speed_filter": 1.0}
_VERTICES = 3  # up to this many uncertain values: every vertex of the box; beyond, a fractional design
#: The signs of the uncertain values beyond the three most influential, from those three's signs (s1, s2, s3):
#: the generators of a two-level fractional design of 8 runs (cycled beyond seven values).
_GENERATORS = ((0, 1, 2), (0, 1), (0, 2), (1, 2))


# --------------------------------------------------------------------------- the objective


def contact_bandwidth(rig, model=None):
    """The bandwidth of the loop with the gear in contact (module docs), rad/s.

    Parameters
    ----------
    rig : Rig
    model : str or BacklashModel, optional
        The shaft's k and c (default: the rig's law).

    Returns
    -------
    float
        ``omega_b``; NaN when the contact loop is unstable (or marginal), 0 when the
        gain is below ``1/sqrt(2)`` at every frequency scanned (1e-4 w_n and above).

    Examples
    --------
    >>> import backlash_df as bd
    >>> rig = bd.rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
    ...     "damping": 3.0, "half_gap": 0.05}, "controller": {"kp": 30.0, "ti": 0.5, "feedback": "motor"}})
    >>> round(contact_bandwidth(rig), 2)
    6.99
    """
    shaft = model if isinstance(model, BacklashModel) else rig.make_model(model)
    part = drive_loop(rig, dry_friction=True).linear_part()  # dry friction: the linear loop without it
    if linear_stability(part, shaft.stiffness, shaft.damping).status != "stable":
        return math.nan
    output = part.state_names.index("load_angle" if rig.controller.cascade else "load_speed")

    def gain(omega):
        return np.abs(closed_loop_response(part, omega, shaft.stiffness, shaft.damping, output))

    omega = np.geomspace(1e-4, 30.0, 1200) * shaft_mode(rig)
    below = np.flatnonzero(gain(omega) <= 1.0 / math.sqrt(2.0))
    if below.size == 0:
        return math.inf
    if below[0] == 0:
        return 0.0
    lo, hi = omega[below[0] - 1], omega[below[0]]
    for _ in range(3):  # the first crossing, 64 log-spaced points a round: to 1e-9 relative
        inner = np.geomspace(lo, hi, 64)
        first = int(np.argmax(gain(inner) <= 1.0 / math.sqrt(2.0)))
        lo, hi = inner[first - 1], inner[first]
    return float(math.sqrt(lo * hi))


# --------------------------------------------------------------------------- the range


def _validated(rig, vary, tolerance):
    """``(names, ranges)`` of a ``vary`` mapping, or a one-line ``ValueError``."""
    controller = rig.require_controller()
    if not isinstance(vary, dict) or not 1 <= len(vary) <= 2:
        raise ValueError(f"tune: vary one or two rig values, e.g. {{'kp': (1.0, 1000.0)}}; got {vary!r}")
    if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance) and tolerance >= 0.0):
        raise ValueError(f"tune: the tolerance is a first-harmonic amplitude of theta_d in rad, >= 0; got {tolerance!r}")
    names, ranges = [], []
    for name, bounds in vary.items():
        if name not in TUNABLE:
            raise ValueError(f"tune: {name!r} is not a value tune varies; choose from: {', '.join(TUNABLE)}")
        if name == "kv" and not controller.cascade:
            raise ValueError('tune: kv varies only with [controller] structure = "cascade" (a position loop)')
        if name == "ti" and not math.isfinite(controller.ti):
            raise ValueError("tune: ti does not vary: the rig's speed controller is P (ti = inf)")
        if name in ("kp", "ti") and controller.speed_controller is not None:
            raise ValueError(f"tune: {name} does not vary: the rig's speed controller is a user's LTI")
        try:
            low, high = (float(value) for value in bounds)
        except (TypeError, ValueError):
            raise ValueError(f"tune: the range of {name} is two numbers (low, high), got {bounds!r}") from None
        if not (0.0 < low < high and math.isfinite(high)):
            raise ValueError(f"tune: the range of {name} needs 0 < low < high (searched on a log scale); "
                             f"got {low:g}, {high:g}")
        rig.with_values(**{name: low}).with_values(**{name: high})  # values the rig file accepts
        names.append(name)
        ranges.append((low, high))
    if len(set(names)) != len(names):
        raise ValueError(f"tune: {names[0]} given twice")
    return tuple(names), tuple(ranges)


def _tuned(rig, names, values):
    return rig.with_values(**{name: float(value) for name, value in zip(names, values)})


# --------------------------------------------------------------------------- screening


@dataclasses.dataclass(frozen=True)
class Candidate:
    """One tuning as the describing function screens it.

    Attributes
    ----------
    values : tuple of float
        The varied values, in the order of :attr:`Tuning.names`.
    bandwidth : float
        ``omega_b``, rad/s (:func:`contact_bandwidth`); NaN where the contact loop is unstable.
    amplitude : float
        The largest stable DF cycle's amplitude A of theta_d, rad; 0 where the DF finds none.
    near_miss : float
        The closest approach ``|1 + G N|`` of the loci where they do not meet; NaN if none.
    hunts : bool
        The DF says it hunts beyond the tolerance (or the contact loop is unstable).
    """

    values: tuple
    bandwidth: float
    amplitude: float
    near_miss: float
    hunts: bool

    def to_dict(self):
        """JSON-ready."""
        return json_ready(dataclasses.asdict(self))


@dataclasses.dataclass(frozen=True)
class _Settings:
    """What every cell of one tuning shares (picklable)."""

    rig: object
    names: tuple
    model: str
    tolerance: float
    gain_margin: float = 1.0
    points: tuple = ()  # the uncertainty box's points besides the nominal rig: ((name, value), ...) each


def _box_rigs(settings):
    """The nominal rig, then the rig at each of the box's points (:func:`uncertainty_design`)."""
    return (settings.rig, *(settings.rig.with_values(**dict(point)) for point in settings.points))


def _screen_cell(settings, values):
    """The DF's view of one tuning, the worst over the box: the nominal bandwidth, the largest stable cycle and
    the closest near miss at any of its rigs; it hunts if it hunts at any."""
    cells = [_screen_one(settings, rig, values) for rig in _box_rigs(settings)]
    return _worst(settings, values, cells, cells[0])


def _screen_until(settings, values, first=()):
    """The DF's view of one tuning over the box, its rigs screened one by one until one hunts (the rigs ``first``
    first, then the nominal, then the others; 0 the nominal, the box's points from 1): ``(cell, index)``, ``index``
    the rig where it hunts, None where it hunts at none (``cell`` then :func:`_screen_cell`'s).  A hunting cell's
    figures are those of the rigs screened: a bisection or a margin's screen uses its values alone."""
    rigs = _box_rigs(settings)
    cells, index = {}, None
    for at in dict.fromkeys([*first, 0, *range(1, len(rigs))]):
        cells[at] = _screen_one(settings, rigs[at], values)
        if cells[at].hunts:
            index = at
            break
    return _worst(settings, values, list(cells.values()), cells.get(0)), index


def _worst(settings, values, cells, nominal=None):
    """The worst of one tuning's screened rigs ``cells``, with the bandwidth of ``nominal``, the nominal rig's
    cell (computed where the nominal rig was not screened)."""
    if len(cells) == 1 and nominal is not None:
        return nominal
    misses = [c.near_miss for c in cells if math.isfinite(c.near_miss)]
    bandwidth = (nominal.bandwidth if nominal is not None
                 else contact_bandwidth(_tuned(settings.rig, settings.names, values), settings.model))
    return Candidate(tuple(float(v) for v in values), bandwidth, max(c.amplitude for c in cells),
                     min(misses, default=math.nan), any(c.hunts for c in cells))


def _screen_one(settings, rig, values):
    """The DF's view of one tuning of ``rig``: bandwidth, largest stable cycle, near miss."""
    tuned = _tuned(rig, settings.names, values)
    bandwidth = contact_bandwidth(tuned, settings.model)
    prediction = predict_limit_cycles(tuned, settings.model, grid=_DF_GRID)
    stable = prediction.stable_cycles
    amplitude = max((c.amplitude for c in stable), default=0.0)
    near = prediction.near_misses[0].distance if prediction.near_misses else math.nan
    hunts = (not math.isfinite(bandwidth)) or amplitude > settings.tolerance or bool(prediction.note)
    return Candidate(tuple(float(v) for v in values), bandwidth, float(amplitude), float(near), bool(hunts))


def _bisect_boundary(settings, pair):
    """The last DF-clear point on the log segment from a clear tuning to a hunting one (``_BISECTIONS`` halvings);
    a middle is screened until a rig hunts, the rig where the last middle hunted first (:func:`_screen_until`)."""
    clear, hunting = pair
    first = ()
    for _ in range(_BISECTIONS):
        middle, index = _screen_until(settings, tuple(math.sqrt(a * b) for a, b in zip(clear.values, hunting.values)),
                                      first)
        first = first if index is None else (index,)
        clear, hunting = (clear, middle) if middle.hunts else (middle, hunting)
    return clear, hunting


# --------------------------------------------------------------------------- certificates


@dataclasses.dataclass(frozen=True)
class Certificate:
    """The evidence that a tuning does not hunt (module docs), or that it does.

    Attributes
    ----------
    values : tuple of float
    bandwidth : float
        rad/s.
    verdict : LoopVerdict
        The verdict with its exact orbits and probes.
    certified : bool
        (1) the DF loci do not meet, (2) shooting finds no periodic orbit, (3) every
        probe settles; or, with a tolerance, the loop hunts within it.  With dry
        friction shooting is not tried (the orbits do not model it yet: the verdict's
        ``orbit_note`` says so), and (1) and (3) decide.
    amplitude : float
        The hunting amplitude A of theta_d the simulations reached, rad; 0 where they settle (over an
        uncertainty box: the largest at the rigs certified).
    failed_at : tuple of (str, float)
        Over an uncertainty box (:func:`tune`), the uncertain values of the first of its rigs (the
        nominal one first) where the certificate fails; empty where it holds or there is no box.
    """

    values: tuple
    bandwidth: float
    verdict: object
    certified: bool
    amplitude: float
    failed_at: tuple = ()

    def __repr__(self):
        word = "certified" if self.certified else "not certified"
        return f"<Certificate {word}: {self.verdict.verdict}, bandwidth {self.bandwidth:.4g} rad/s>"

    def to_dict(self):
        """JSON-ready: the three checks and their evidence."""
        verdict = self.verdict
        prediction = verdict.prediction
        near = prediction.near_misses[0].distance if prediction is not None and prediction.near_misses else None
        return json_ready({
            "certified": self.certified,
            "verdict": verdict.verdict,
            "reason": verdict.reason,
            "df": {"cycles": [c.to_dict() for c in prediction.cycles] if prediction is not None else [],
                   "near_miss": near, "loci_meet": bool(prediction.cycles) if prediction is not None else None},
            "exact_orbits": [orbit.to_dict() for orbit in verdict.orbits],
            "orbit_note": verdict.orbit_note or None,
            "probes": [probe.to_dict() for probe in verdict.probes],
            "amplitude": self.amplitude,
        })


def certify(rig, model=None, tolerance=0.0, refinement=1):
    """Certify one tuning: the verdict with exact orbits, and the three checks of the module docs.

    Parameters
    ----------
    rig : Rig
        The tuned rig.
    model : str, optional
        Torque law (default the rig's).
    tolerance : float
        Largest first-harmonic amplitude of theta_d (rad) accepted as hunting within tolerance.
    refinement : int
        The verdict's simulation step divided by this, its shooting seeded from this
        many near misses (:func:`~backlash_df.verdict.judge_loop`): a certificate
        that holds at 2 holds under refinement.

    Returns
    -------
    Certificate
    """
    name = rig.make_model(model).name
    prediction = verify_limit_cycles(rig, predict_limit_cycles(rig, name))
    verdict = judge_loop(rig, prediction, exact=True, refinement=refinement)
    amplitude = verdict.cycle.amplitude if verdict.cycle is not None else 0.0
    quiet = verdict.verdict == "no oscillation" and not prediction.cycles and not verdict.orbits
    within = (tolerance > 0.0 and verdict.verdict in ("limit cycle", "bistable") and verdict.cycle is not None
              and amplitude <= tolerance and not any(p.outcome in ("diverged", "unsettled") for p in verdict.probes))
    return Certificate((), contact_bandwidth(rig, name), verdict, bool(quiet or within), float(amplitude))


def _certify_cell(settings, values, kept=None, executor=None, first=()):
    """The certificate of one tuning over the box: the nominal rig's, certified only if it holds at every
    point of the box too (:attr:`Certificate.failed_at`: the first where it fails).

    The nominal rig is certified first, then the box points ``first`` (indices from 1: where other tunings
    failed lately) one by one, then the others: one by one until one fails, or on ``executor`` together.
    """
    values = tuple(float(v) for v in values)
    nominal = _certify_at(settings, settings.rig, ("certify", *values), values, kept)
    if not settings.points:
        return nominal
    if not nominal.certified:
        box = {name: value for point in settings.points for name, value in point}
        return dataclasses.replace(nominal, failed_at=tuple((name, getattr(_owner(settings.rig, name), name))
                                                            for name in box))
    rest = [index for index in range(1, len(settings.points) + 1) if index not in first]
    one_by_one = [*first, *rest] if executor is None else list(first)
    found = {}
    for index in one_by_one:
        found[index] = _certify_point(settings, values, index, kept)
        if not found[index].certified:
            break
    if executor is not None and all(c.certified for c in found.values()):
        found.update(zip(rest, run_cells(functools.partial(_certify_point, settings, values), rest,
                                         executor=executor, checkpoint=kept,
                                         keys=[("certify", "box", index, *values) for index in rest])))
    amplitude = max([nominal.amplitude] + [c.amplitude for c in found.values()])
    failed = [index for index in found if not found[index].certified]
    if failed:
        return dataclasses.replace(nominal, certified=False, amplitude=amplitude,
                                   failed_at=settings.points[failed[0] - 1])
    return dataclasses.replace(nominal, amplitude=amplitude)


def _certify_point(settings, values, index, kept=None):
    """The certificate of ``values`` at the box's point ``index`` (from 1)."""
    return _certify_at(settings, settings.rig.with_values(**dict(settings.points[index - 1])),
                       ("certify", "box", index, *values), values, kept)


def _owner(rig, name):
    """The table of ``rig`` holding the uncertain value ``name`` (``[plant]``, ``[friction]`` or ``[load]``)."""
    return next(table for table in (rig.plant, rig.friction, rig.load) if hasattr(table, name))


def _certify_at(settings, rig, key, values, kept):
    """The certificate of ``values`` on ``rig``; taken from the checkpoint ``kept`` if it holds ``key``, added to
    it if not."""
    if kept is not None and key in kept:
        return kept[key]
    certificate = certify(_tuned(rig, settings.names, values), settings.model, settings.tolerance)
    certificate = dataclasses.replace(certificate, values=values)
    if kept is not None:
        kept.add(key, certificate)
    return certificate


# --------------------------------------------------------------------------- the answer


@dataclasses.dataclass(frozen=True)
class FrontPoint:
    """The best bandwidth at one tolerance of hunting.

    Attributes
    ----------
    tolerance : float
        Largest accepted amplitude A of theta_d, rad.
    values : tuple of float
    bandwidth : float
        rad/s.
    amplitude : float
        The hunting amplitude of that tuning, rad: simulated where the simulation
        reached a cycle, the DF's otherwise; 0 for the certified tuning (over an
        uncertainty box: the nominal rig's, 0 where its DF finds no stable cycle).
    """

    tolerance: float
    values: tuple
    bandwidth: float
    amplitude: float


@dataclasses.dataclass(frozen=True, eq=False)
class Tuning:
    """What :func:`tune` found: the best tuning, its certificate and margin, the front, the searched range.

    Attributes
    ----------
    names : tuple of str
        The varied rig values.
    ranges : tuple of (float, float)
        Their searched ranges (the rig file's units).
    tolerance : float
        rad.
    model : str
        The torque law certified.
    feasible : bool
        A tuning in range is certified.
    best : Certificate
        The certified tuning of largest bandwidth; where none is, the tuning of the
        smallest hunting amplitude (``feasible`` False).
    margin : dict
        ``{"factor", "toward", "source"}``: the nearest hunting tuning found (its
        values), by what factor (``exp`` of the log distance) the best one can move
        toward it, and where it was found (``"DF boundary"`` or ``"certificate"``);
        empty where none is known.
    front : tuple of FrontPoint
        By increasing tolerance; the bandwidth never decreases along it.
    screen : tuple of Candidate
        The screened grid (``shape``), then the refined boundary points in ``boundary``.
    shape : tuple of int
    boundary : tuple of Candidate
        The last DF-clear points found by bisection toward a hunting neighbour.
    certificates : tuple of Certificate
        Every certificate tried, in order.
    seconds : dict
        Wall time of ``screening``, ``refinement``, ``certification``, (the gain margin held) ``plateau`` and
        (over an uncertainty box) ``binding``, s.
    on_bound : tuple of str
        The varied values at a bound of their range in the answer (its true best may lie beyond).
    plateau : dict
        Per value whose bandwidth plateaued at the fastest certified tuning
        (less than 1 % gained over its last factor of 2): ``{"bandwidth", "reached_at"}``,
        the plateau's bandwidth (rad/s) and the gentlest value within 1 % of it, which
        the answer takes (module docs); empty where none did.
    gain_margin : dict
        ``{"requested": g, "achieved": {name: factor}}``: every varied value can be
        scaled by ``g`` and ``1/g`` (and their combinations) with the tuning still
        certified; ``achieved``: per value alone, the largest factor checked both ways
        (``g`` and up to three probes beyond it; ``g`` where ``g`` is 1); empty where
        none is certified.
    simulated : tuple of (tuple, float)
        Where none is certified: every tuning whose hunting was simulated, with its
        amplitude A of theta_d (rad; inf where a simulation diverged), smallest first;
        the answer is the first.  Empty where a tuning is certified.
    source : str
        The rig's file.
    uncertainty : dict
        Over an uncertainty box (:func:`tune`): ``{"box": {name: (low, high)}, "points": n,
        "binding": {name: value} or None, "worst_bandwidth": rad/s}``: the box, the number of
        rigs certified (the nominal one included), the box point where the nearest faster tuning
        that fails its certificate fails (None where none was found), and the answer's smallest
        bandwidth over those rigs; empty without a box.
    """

    names: tuple
    ranges: tuple
    tolerance: float
    model: str
    feasible: bool
    best: Certificate
    margin: dict
    front: tuple
    screen: tuple
    shape: tuple
    boundary: tuple
    certificates: tuple
    seconds: dict
    on_bound: tuple = ()
    plateau: dict = dataclasses.field(default_factory=dict)
    gain_margin: dict = dataclasses.field(default_factory=dict)
    simulated: tuple = ()
    source: str = ""
    uncertainty: dict = dataclasses.field(default_factory=dict)

    def values(self, point=None):
        """The varied values of ``point`` (default the best tuning) by name."""
        point = self.best if point is None else point
        return dict(zip(self.names, point.values))

    @property
    def units(self):
        """The varied values' units by name (:data:`TUNABLE`)."""
        return {name: TUNABLE[name] for name in self.names}

    def __repr__(self):
        best = ", ".join(f"{name} = {value:.4g}" for name, value in self.values().items())
        word = "certified" if self.feasible else "NO tuning in range certified; least hunting"
        return (f"<Tuning {word}: {best}, bandwidth {self.best.bandwidth:.4g} rad/s "
                f"({self.best.verdict.verdict}); {len(self.front)} front points>")

    def to_dict(self):
        """The ``tune`` JSON (contract page)."""
        return json_ready({
            "best": {"values": self.values(), "bandwidth": self.best.bandwidth, "verdict": self.best.verdict.verdict,
                     "certificate": self.best.to_dict(), "margin": self.margin or None,
                     "on_bound": list(self.on_bound), "plateau": self.plateau or None,
                     "gain_margin": self.gain_margin or None},
            "front": [{"tolerance": p.tolerance, "values": self.values(p), "bandwidth": p.bandwidth,
                       "amplitude": p.amplitude} for p in self.front],
            "feasible": self.feasible,
            "model": self.model,
            "tolerance": self.tolerance,
            "vary": {name: list(bounds) for name, bounds in zip(self.names, self.ranges)},
            "rig": self.source,
            "searched": {"screened": len(self.screen), "boundary": len(self.boundary),
                         "certified": [{"values": self.values(c), "bandwidth": c.bandwidth,
                                        "verdict": c.verdict.verdict, "certified": c.certified}
                                       for c in self.certificates],
                         "simulated": [{"values": dict(zip(self.names, values)), "amplitude": amplitude}
                                       for values, amplitude in self.simulated]},
            "seconds": self.seconds,
            "uncertainty": {"box": {name: list(box) for name, box in self.uncertainty["box"].items()},
                            "points": self.uncertainty["points"], "binding": self.uncertainty["binding"],
                            "worst_bandwidth": self.uncertainty["worst_bandwidth"]} if self.uncertainty else None,
        })

    def plot(self, ax=None):
        """The searched range with the DF's hunting cells, the boundary and the best tuning; the front beside.

        One varied value: the bandwidth against it, the tunings the DF says hunt
        marked x on it (those whose loop in contact is unstable, which have no
        bandwidth, as shaded cells), the DF boundary as dotted lines
        through its points; two: the bandwidth's colour map over the grid, hunting
        cells hatched.  The star is the best tuning (:attr:`best`: certified, or the
        least hunting), drawn under the boundary's points.  The second panel is the
        front: the best bandwidth against the accepted amplitude (from 0; its last
        step runs on to the edge).

        Returns
        -------
        ResultPlot
            Axes ``[range, front]``; the legend under the range panel.
        """
        figure, axes = axes_or_new(ax, (1, 2), figsize=(11, 4.8), layout="constrained")
        legend = _draw_range(self, axes[0])
        _draw_front(self, axes[1])
        return ResultPlot(figure, axes, legend)

    def sentences(self):
        """The answer, its verdict and why, and the margin: the lines ``backlash-df tune`` prints
        (:func:`~backlash_df.render.tuning.tuning_sentences`)."""
        return tuning_sentences(self)

    def tables(self):
        """The terminal's tables: ``[(title, header, rows)]``, the front
        (:func:`~backlash_df.render.tuning.tuning_tables`)."""
        return tuning_tables(self)

    def report_html(self, title="", rig_text=""):
        """A self-contained HTML page: the answer and its certificate, the map with the boundary, the front.

        Parameters
        ----------
        title : str
            Page title (default "Tuning" and the rig's source).
        rig_text : str
            The rig file's text, shown as it is.

        See Also
        --------
        backlash_df.render.tuning.tuning_report
        """
        return tuning_report(self, self.plot().figure, title, rig_text)


def _best_words(tuning):
    """The star's legend entry: the best certified tuning, or the least hunting one where none is certified."""
    return "best certified" if tuning.feasible else "least hunting (none certified)"


def _draw_range(tuning, ax):
    """The screened range: bandwidth and hunting cells; boundary points; the best tuning.  Returns the legend."""
    from matplotlib.patches import Patch  # here: importing backlash_df does not import matplotlib

    points = np.array([c.values for c in tuning.screen])
    bandwidth = np.array([c.bandwidth for c in tuning.screen])
    hunts = np.array([c.hunts for c in tuning.screen])
    unit = {name: TUNABLE[name] for name in tuning.names}
    star = {"marker": "*", "ls": "none", "ms": 15, "zorder": 3, "label": _best_words(tuning)}
    boundary = np.array([c.values for c in tuning.boundary]).reshape(-1, len(tuning.names))
    shaded = []  # legend entries of areas (patches not drawn themselves)
    if len(tuning.names) == 1:
        order = np.argsort(points[:, 0])
        ax.plot(points[order, 0], bandwidth[order], "-", color="0.5", lw=1, label="bandwidth (DF screen)")
        drawn = hunts & np.isfinite(bandwidth)
        if drawn.any():
            ax.plot(points[drawn, 0], bandwidth[drawn], "x", color="C3", zorder=3.5, label="DF: hunts")
        lost = (hunts & ~np.isfinite(bandwidth))[order]
        if lost.any():  # no bandwidth to draw at: their cells shaded, not data at 0
            edges = cell_edges(points[order, 0], "log")
            for index in np.flatnonzero(lost):
                ax.axvspan(edges[index], edges[index + 1], color="C3", alpha=0.12, lw=0, zorder=0)
            shaded.append(Patch(color="C3", alpha=0.12, lw=0, label="DF: hunts, unstable in contact"))
        for value in boundary[:, 0]:
            ax.axvline(value, color="C1", ls=":", lw=1.0, zorder=1)
        ax.plot(tuning.best.values[0], tuning.best.bandwidth, color="C2" if tuning.feasible else "C3", **star)
        if boundary.size:
            ax.plot(boundary[:, 0], [c.bandwidth for c in tuning.boundary], "o", color="C1", mec="k", mew=0.5,
                    ms=5, zorder=4, label="DF boundary")
        log_scale(ax.xaxis, *tuning.ranges[0])
        ax.set_xlabel(f"{tuning.names[0]} ({unit[tuning.names[0]]})")
        ax.set_ylabel("bandwidth omega_b (rad/s)")
        marks = " or ".join(word for word, shown in (("x", drawn.any()), ("shaded", lost.any())) if shown)
        title = f"{marks} where the DF says it hunts" if marks else "the DF finds no hunting"
    else:
        rows, columns = tuning.shape
        x = points[:, 0].reshape(rows, columns)[:, 0]
        y = points[:, 1].reshape(rows, columns)[0]
        grid = bandwidth.reshape(rows, columns)
        mesh = ax.pcolormesh(x, y, grid.T, shading="nearest", cmap="viridis")
        ax.figure.colorbar(mesh, ax=ax, label="bandwidth omega_b (rad/s)")
        if hunts.any():
            ax.contourf(x, y, hunts.reshape(rows, columns).T.astype(float), levels=[0.5, 1.5], colors="none",
                        hatches=["//"])
            shaded.append(Patch(facecolor="none", edgecolor="k", hatch="//", label="DF: hunts"))
        ax.plot(*tuning.best.values, color="w" if tuning.feasible else "C3", mec="k", **star)
        if boundary.size:
            ax.plot(boundary[:, 0], boundary[:, 1], "o", color="C1", mec="k", mew=0.5, ms=5, zorder=4,
                    label="DF boundary")
        log_scale(ax.xaxis, *tuning.ranges[0])
        log_scale(ax.yaxis, *tuning.ranges[1])
        ax.set_xlabel(f"{tuning.names[0]} ({unit[tuning.names[0]]})")
        ax.set_ylabel(f"{tuning.names[1]} ({unit[tuning.names[1]]})")
        title = "hatched where the DF says it hunts" if hunts.any() else "the DF finds no hunting"
    ax.set_title(f"{tuning.model}: {title}", fontsize="medium")
    handles = [line for line in ax.get_lines() if not line.get_label().startswith("_")] + shaded
    return legend_under(ax, handles=handles, fontsize=7)


def _draw_front(tuning, ax):
    """The front: best bandwidth against the accepted hunting amplitude, from 0, its last step run on to the edge
    (beyond the amplitudes met, or to the play 2 alpha where nothing hunts)."""
    tolerance = np.array([p.tolerance for p in tuning.front])
    bandwidth = np.array([p.bandwidth for p in tuning.front])
    if not tuning.front:
        ax.text(0.5, 0.5, "no front: no tuning found", transform=ax.transAxes, ha="center", va="center")
        return
    prediction = tuning.best.verdict.prediction
    scale = max([float(tolerance.max(initial=0.0)), tuning.tolerance]
                + [c.amplitude for c in tuning.screen if math.isfinite(c.amplitude)])
    scale = scale or 2.0 * (prediction.half_gap if prediction is not None else 0.0)  # nothing hunts: the play
    right = 1.15 * scale if scale > 0.0 else 1.0
    ax.step(np.append(tolerance, right), np.append(bandwidth, bandwidth[-1:]), where="post", color="C0")
    ax.plot(tolerance, bandwidth, "o", color="C0", ms=4, clip_on=False, zorder=3)
    ax.set_xlim(0.0, right)
    if np.ptp(bandwidth) == 0.0:  # one level: a band around it, not matplotlib's +-0.1 % of round-off ticks
        ax.set_ylim(0.9 * bandwidth[0], 1.1 * bandwidth[0])
    ax.set_xlabel("accepted hunting: amplitude A of theta_d (rad)")
    ax.set_ylabel("best bandwidth omega_b (rad/s)")
    ax.set_title("front: bandwidth bought by accepted hunting", fontsize="medium")
    ax.grid(True, alpha=0.3)


# --------------------------------------------------------------------------- the search


def _grid(ranges):
    """The screened values: log-spaced, the ends included."""
    count = _SCREEN[len(ranges)]
    axes = [np.geomspace(low, high, count) for low, high in ranges]
    mesh = np.meshgrid(*axes, indexing="ij")
    return [tuple(float(m.flat[i]) for m in mesh) for i in range(mesh[0].size)], tuple(a.size for a in axes)


def _pairs(screen, shape):
    """Grid neighbours (clear, hunting) worth refining: the clear side's bandwidth near the best clear one."""
    clear = [c.bandwidth for c in screen if not c.hunts and math.isfinite(c.bandwidth)]
    if not clear:
        return []
    best = max(clear)
    index = np.arange(len(screen)).reshape(shape)
    found = []
    for axis in range(len(shape)):
        for a, b in zip(np.take(index, range(shape[axis] - 1), axis).ravel(),
                        np.take(index, range(1, shape[axis]), axis).ravel()):
            for c, h in ((screen[a], screen[b]), (screen[b], screen[a])):
                if (not c.hunts and h.hunts and c.bandwidth >= 0.5 * best
                        and not (math.isfinite(h.bandwidth) and h.bandwidth <= c.bandwidth)):
                    found.append((c, h))
    return found


def _log_distance(a, b):
    return math.sqrt(sum(math.log(x / y) ** 2 for x, y in zip(a, b)))


def _margin(names, best, hunting_points):
    """The nearest hunting tuning to the best one, and the factor to it."""
    if not hunting_points:
        return {}
    values, source = min(hunting_points, key=lambda item: _log_distance(best.values, item[0]))
    return {"factor": math.exp(_log_distance(best.values, values)), "toward": dict(zip(names, values)),
            "source": source}


def _front(settings, screen, best, feasible, executor, kept, progress=None, simulated=None):
    """Best bandwidth per tolerance: 0 (the certified tuning), then the hunting cells' amplitudes, simulated
    (``simulated``: amplitudes already simulated, by values) and taken from the exact orbit where shooting
    converges (stage ``front orbits``)."""
    stable = [c for c in screen if math.isfinite(c.bandwidth) and c.amplitude > 0.0]
    levels = sorted({c.amplitude for c in stable})
    if len(levels) > 6:
        levels = [levels[int(round(i))] for i in np.linspace(0, len(levels) - 1, 6)]
    chosen = []
    for level in levels:
        inside = [c for c in stable if c.amplitude <= level]
        top = max(inside, key=lambda c: c.bandwidth)
        if (feasible and top.bandwidth <= best.bandwidth) or (chosen and top.bandwidth <= chosen[-1][1].bandwidth):
            continue
        chosen.append((level, top))
    known = simulated or {}
    todo = [c.values for _, c in chosen if c.values not in known]
    found = dict(zip(todo, run_cells(functools.partial(_simulated_amplitude, settings), todo, executor=executor,
                                     checkpoint=kept, keys=[("front", *values) for values in todo],
                                     progress=progress, stage="front")))
    simulated = [known[c.values] if c.values in known else found[c.values] for _, c in chosen]
    points = [(c.values, amplitude) for (_, c), amplitude in zip(chosen, simulated)]
    simulated = run_cells(functools.partial(_orbit_amplitude, settings), points, executor=executor, checkpoint=kept,
                          keys=[("front orbit", *values) for values, _ in points], progress=progress,
                          stage="front orbits")
    front = [FrontPoint(0.0, best.values, best.bandwidth, 0.0)] if feasible else []
    for (level, candidate), amplitude in zip(chosen, simulated):
        front.append(FrontPoint(float(max(level, amplitude)), candidate.values, candidate.bandwidth, float(amplitude)))
    front.sort(key=lambda p: p.tolerance)
    monotone, top = [], -math.inf
    for point in front:  # a larger tolerance never buys less: keep the points that buy more
        if point.bandwidth > top:
            monotone.append(point)
            top = point.bandwidth
    return tuple(monotone)


def _least_hunting(settings, screen, search, executor, kept, progress):
    """The tuning of the smallest simulated hunting amplitude, none being certified: ``(certificate, simulated)``.

    A tuning's hunting is the largest cycle its simulations end on.  Every screened
    tuning the DF says hunts on a stable cycle is simulated from its cycles
    (:func:`_simulated_amplitude`), every certificate tried brings its probes' largest
    cycle (inf where a probe diverged or did not settle); the DF
    levels only choose what to simulate.  (Its certificates are not reported: the
    stage's total is the simulations'.)  The smallest is certified (for its
    verdict), its amplitude the larger of the two, and the smallest taken again,
    until the smallest is a certified one: the answer is the least hunting of all.
    """
    cells = [c.values for c in screen if c.hunts and c.amplitude > 0.0]
    amplitudes = run_cells(functools.partial(_simulated_amplitude, settings), cells, executor=executor,
                           checkpoint=kept, keys=[("front", *values) for values in cells], progress=progress,
                           stage="least hunting")
    simulated = dict(zip(cells, amplitudes))
    measured = {}  # values -> the amplitude with its certificate's

    def certified(certificate):
        diverged = any(p.outcome in ("diverged", "unsettled") for p in certificate.verdict.probes)
        runaway = certificate.verdict.verdict == "unstable" and certificate.amplitude == 0.0
        reached = [p.amplitude for p in certificate.verdict.probes if p.measured.found] + [certificate.amplitude]
        own = math.inf if diverged or runaway else max(reached)  # the largest cycle a disturbance falls into
        measured[certificate.values] = max(own, simulated.get(certificate.values, 0.0))

    for certificate in search.tried:
        certified(certificate)
    if not simulated and not measured:  # the DF applies nowhere (each prediction's note): the fastest, certified
        certified(search.certify(max(screen, key=lambda c: (c.bandwidth, c.values)).values, None))
    while True:
        merged = {**simulated, **measured}
        least = min(merged, key=lambda values: (merged[values], values))
        if least in measured:
            best = search.certify(least, None)
            return dataclasses.replace(best, amplitude=float(merged[least])), merged
        certified(search.certify(least, None))


def _achieved(search, best, met):
    """Per varied value alone: the largest factor ``h`` checked with the value scaled by ``h`` and ``1/h``
    certified, from the requested margin, bisected toward the nearest hunting tuning known on that axis
    (or stepping by 1.5) in three probes; the requested margin where it is 1; 1 where it is not ``met``."""
    g = search.settings.gain_margin if met else 1.0
    achieved = {}
    for index, name in enumerate(search.settings.names):
        lower, upper = g, None
        if g > 1.0:  # (a margin not met is 1: its corners fail)
            on_axis = [abs(math.log(values[index] / best.values[index])) for values, _ in search.hunting
                       if all(math.isclose(v, b, rel_tol=1e-12) for i, (v, b) in enumerate(zip(values, best.values))
                              if i != index) and values[index] != best.values[index]]
            beyond = [math.exp(d) for d in on_axis if math.exp(d) > g]
            upper = min(beyond) if beyond else None
            for _ in range(3):
                factor = 1.5 * lower if upper is None else math.sqrt(lower * upper)
                scaled = [tuple(v * (f if i == index else 1.0) for i, v in enumerate(best.values))
                          for f in (factor, 1.0 / factor)]
                if search.all_certified(scaled, "gain margin"):
                    lower = factor
                else:
                    upper = factor
        achieved[name] = lower
    search.finish("gain margin")
    return achieved


def _simulated_amplitude(settings, values):
    """The nominal rig's hunting amplitude: where a simulation from the DF's largest stable cycle settles to (the
    DF's if it finds none); 0 where the DF finds no stable cycle (over an uncertainty box the screen's cycle may
    be another rig's)."""
    tuned = _tuned(settings.rig, settings.names, values)
    prediction = verify_limit_cycles(tuned, predict_limit_cycles(tuned, settings.model, grid=_DF_GRID))
    found = [c.simulated.amplitude for c in prediction.stable_cycles if c.simulated is not None and c.simulated.found]
    return max(found) if found else max((c.amplitude for c in prediction.stable_cycles), default=0.0)


def _orbit_amplitude(settings, point):
    """A front point's amplitude: ``point = (values, simulated)``, the stable exact orbit's on the simulated cycle
    where shooting converges (:func:`_exact_amplitude`), else the simulated amplitude."""
    values, simulated = point
    if not simulated > 0.0:
        return simulated
    tuned = _tuned(settings.rig, settings.names, values)
    return _exact_amplitude(tuned, predict_limit_cycles(tuned, settings.model, grid=_DF_GRID), simulated)


def _exact_amplitude(rig, prediction, simulated):
    """The amplitude of the stable exact orbit within 1 % of ``simulated`` (rad), else ``simulated`` (shooting
    failed, or the loop has a friction or a law the orbits do not model)."""
    try:
        orbits = exact_orbits(rig, prediction)
    except ValueError:
        return simulated
    on = [o.amplitude for o in orbits if o.stable and abs(o.amplitude / simulated - 1.0) <= 0.01]
    return min(on, key=lambda a: abs(a - simulated)) if on else simulated


def tune(rig, vary, *, tolerance=0.0, gain_margin=1.25, uncertainty=None, model=None, executor=None, progress=None,
         checkpoint=None):
    """The tuning of largest contact-loop bandwidth whose verdict is certified ``no oscillation`` (module docs).

    Parameters
    ----------
    rig : Rig
        Plant, ``[controller]`` and ``[load]``; the varied values are replaced.
    vary : dict of str to (float, float)
        One or two of :data:`TUNABLE` and their ranges ``(low, high)``, searched on a
        log scale (``{"kp": (1.0, 1000.0), "ti": (0.01, 2.0)}``).
    tolerance : float
        Largest accepted hunting amplitude A of theta_d, rad (0: none).
    gain_margin : float
        ``g >= 1``: the answer stays certified with every varied value scaled by
        ``g`` or ``1/g`` (each alone and all combinations: ``3**n - 1`` scaled
        tunings, certified as the answer is, out of the range too).  Default 1.25
        (a gain 25 % off); 1 checks no scaled tuning.
    uncertainty : dict of str to (float, float), optional
        A box of rig values the real drive may have: any numeric ``[plant]``,
        ``[friction]`` or ``[load]`` key and its absolute ``(low, high)``, holding the
        rig's value (``{"load_inertia": (4.0, 8.0), "half_gap": (0.03, 0.1)}``).
        Default: the rig's ``[uncertainty]`` table; ``{}``: none.  A tuning is
        certified only if it is certified (gain margin included) at the nominal rig
        and at every point of the box's design (every vertex for up to three values;
        beyond, a two-level fractional design of 8 rigs: the contract page, ``tune --json``),
        and the DF screen clears a cell only if it clears it at all
        of them.  The objective stays the nominal rig's bandwidth; the least hunting
        tuning (none certified) and the front are the nominal rig's.
    model : str, optional
        Torque law (default the rig's).
    executor : concurrent.futures.Executor, optional
        Runs the screened cells, the boundary bisections, the front's simulations and its exact orbits.
    progress : callable, optional
        ``progress(stage, done, total)`` (the package's one protocol) as the stages
        ``screening``, ``refinement``, ``certification``, ``plateau``, ``least hunting``
        (none certified), ``gain margin``, ``binding`` (a box: certificates of the nearest
        faster tuning), ``front`` (its simulations) and ``front orbits`` (the exact orbits on them) advance.
    checkpoint : str, Path or Checkpoint, optional
        Keep every screened cell, boundary bisection, certificate and front point
        as it finishes (:class:`~backlash_df.checkpoint.Checkpoint`; a path: a new
        file); a tuning resumed from it computes only the others and returns the
        same answer as an uninterrupted one.

    Returns
    -------
    Tuning

    Raises
    ------
    ValueError
        An unknown or non-varying value, a range with low >= high or not positive,
        a tolerance < 0, a gain margin < 1 or not finite, an uncertain value that is unknown or not
        numeric, with low > high or a box that excludes the rig's value: one line; a checkpoint that exists
        (without ``resume``) or belongs to another run.
    """
    names, ranges = _validated(rig, vary, tolerance)
    if not (isinstance(gain_margin, (int, float)) and math.isfinite(gain_margin) and gain_margin >= 1.0):
        raise ValueError(f"tune: the gain margin is a factor >= 1 (1: none); got {gain_margin!r}")
    name = rig.make_model(model).name
    rig = _boxed(rig, uncertainty)
    settings = _Settings(rig, names, name, float(tolerance), float(gain_margin), _design(rig, names, name))
    with opened(checkpoint, "tune", {"settings": describe(settings, omit={"source"}), "ranges": ranges}) as kept:
        return _search(settings, ranges, executor, progress, kept)


def _boxed(rig, uncertainty):
    """``rig`` with the box ``uncertainty`` (None: its own) as its ``[uncertainty]`` table, checked as the rig
    file's is (a one-line ``ValueError``)."""
    if uncertainty is None:
        return rig
    if not isinstance(uncertainty, collections.abc.Mapping):
        raise ValueError(f"tune: uncertainty is a mapping name -> (low, high), e.g. {{'load_inertia': (4.0, 8.0)}}; "
                         f"got {uncertainty!r}")
    data = {**rig.to_dict(), "uncertainty": dict(uncertainty)}
    return dataclasses.replace(rig, uncertainty=rig_from_dict(data, source="tune: uncertainty").uncertainty)


def uncertainty_design(rig, vary, *, model=None):
    """The rigs of the box ``rig.uncertainty`` that :func:`tune` certifies beside the nominal one.

    Parameters
    ----------
    rig : Rig
        With its ``[uncertainty]`` table (:attr:`~backlash_df.config.Rig.uncertainty`).
    vary : dict or sequence of str
        The varied values (their nominal values rank the influence of more than three
        uncertain values).
    model : str, optional
        Torque law (default the rig's).

    Returns
    -------
    tuple of dict
        Each point's uncertain values by name, absolute (the rig file's units): every
        vertex for up to three values (values whose low equals their high left out),
        beyond three the 8 rigs of a two-level fractional design (the contract page,
        ``tune --json``).

    Examples
    --------
    >>> import backlash_df as bd
    >>> rig = bd.rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
    ...     "half_gap": 0.05}, "controller": {"kp": 30.0, "ti": 0.5},
    ...     "uncertainty": {"load_inertia": [5.0, 6.0], "half_gap": [0.04, 0.06]}})
    >>> uncertainty_design(rig, {"kp": (1.0, 100.0)})[-1]
    {'load_inertia': 6.0, 'half_gap': 0.06}
    """
    return tuple(dict(point) for point in _design(rig, tuple(vary), rig.make_model(model).name))


def _design(rig, names, model):
    """The points of the rig's uncertainty box certified beside the nominal rig: ``((name, value), ...)`` each.

    Up to three uncertain values (of ``low < high``): every vertex of the box, ``2**k``
    points.  Beyond three: 8 points, two levels each: the vertices of the three most
    influential values, every other value at its low or high end by the sign of a
    generator of those three's signs (:data:`_GENERATORS`: ``s1 s2 s3``, ``s1 s2``,
    ``s1 s3``, ``s2 s3``, cycled), a two-level fractional design.  A value's influence:
    the change of the nominal tuning's DF view from its low to its high end, the others
    nominal: ``|ln(omega_b(high) / omega_b(low))|`` plus the change of the closest
    approach of the loci (0 where they meet), an unstable contact loop counting as
    infinite; ties by the table's order.
    """
    box = {name: (low, high) for name, (low, high) in rig.uncertainty.items() if low < high}
    if not box:
        return ()
    if len(box) <= _VERTICES:
        return tuple(tuple(zip(box, corner)) for corner in itertools.product(*box.values()))
    settings = _Settings(dataclasses.replace(rig, uncertainty=Uncertainty()), names, model, 0.0)
    nominal = tuple(getattr(rig.controller, name) for name in names)

    def view(name, value):
        cell = _screen_one(settings, settings.rig.with_values(**{name: value}), nominal)
        return cell.bandwidth, (cell.near_miss if math.isfinite(cell.near_miss) else 0.0)

    def influence(name):
        (low_band, low_miss), (high_band, high_miss) = (view(name, end) for end in box[name])
        bands = abs(math.log(high_band / low_band)) if math.isfinite(low_band * high_band) and low_band * high_band > 0 \
            else math.inf
        return bands + abs(high_miss - low_miss)

    order = sorted(box, key=lambda name: -influence(name))
    first, rest = order[:_VERTICES], order[_VERTICES:]
    points = []
    for signs in itertools.product((0, 1), repeat=_VERTICES):
        point = {name: box[name][sign] for name, sign in zip(first, signs)}
        for index, name in enumerate(rest):
            lows = sum(1 - signs[i] for i in _GENERATORS[index % len(_GENERATORS)])
            sign = 1 if lows % 2 == 0 else 0  # the product of the signs (low -1, high +1)
            point[name] = box[name][sign]
        points.append(tuple((name, point[name]) for name in box))
    return tuple(points)


def _search(settings, ranges, executor, progress, kept):
    """:func:`tune`'s stages: screen, refine the boundary, certify, the plateau, the gain margin, the front."""
    names, name = settings.names, settings.model
    report = progress or (lambda stage, done, total: None)
    seconds = {}

    start = time.perf_counter()
    points, shape = _grid(ranges)
    screen = run_cells(functools.partial(_screen_cell, settings), points, executor=executor, checkpoint=kept,
                       keys=[("screen", *values) for values in points], progress=progress, stage="screening")
    seconds["screening"] = time.perf_counter() - start

    start = time.perf_counter()
    pairs = _pairs(screen, shape)
    refined = run_cells(functools.partial(_bisect_boundary, settings), pairs, executor=executor, checkpoint=kept,
                        keys=[("refine", *clear.values, *hunting.values) for clear, hunting in pairs],
                        progress=progress, stage="refinement")
    boundary = tuple(clear for clear, _ in refined)
    seconds["refinement"] = time.perf_counter() - start

    start = time.perf_counter()
    search = _Certifier(settings, kept, report, executor)
    search.hunting += [(h.values, "DF boundary") for _, h in refined] + [(c.values, "DF screen")
                                                                          for c in screen if c.hunts]
    candidates = sorted([c for c in list(screen) + list(boundary) if not c.hunts and math.isfinite(c.bandwidth)],
                        key=lambda c: -c.bandwidth)
    report("certification", 0, None)  # it stops at the first certified: no total ahead
    best, rejected = None, []
    for candidate in candidates:
        certificate, holds = search.holds(candidate.values, "certification")
        if holds:
            best = certificate
            break
        rejected.append((candidate, certificate))
    met = best is not None
    if met:  # toward the faster candidates a certificate refused (not those the margin's DF screen refused)
        best = _tighten(search, best, [c for c, certificate in rejected if certificate is not None])
    else:  # none holds the gain margin: the fastest certified one, if any, its margin short of the request
        certified = (search.certify(c.values, "certification") for c, _ in rejected)
        best = next((c for c in certified if c.certified), None)
    search.finish("certification")  # the stage ends: its total is now known
    seconds["certification"] = time.perf_counter() - start

    feasible, plateau = best is not None, {}
    if met:
        start = time.perf_counter()
        best, plateau = _plateaus(search, ranges, best)
        search.finish("plateau")
        seconds["plateau"] = time.perf_counter() - start
    simulated = {}
    if not feasible:  # the least hunting tuning among those simulated (module docs)
        best, simulated = _least_hunting(settings, screen, search, executor, kept, progress)
    achieved = _achieved(search, best, met) if feasible else {}
    box = {}
    if settings.points:
        start = time.perf_counter()
        box = _box_answer(search, best, feasible)
        seconds["binding"] = time.perf_counter() - start
    front = _front(settings, screen, best, feasible, executor, kept, progress, simulated)
    on_bound = tuple(n for n, v, (low, high) in zip(names, best.values, ranges)
                     if math.isclose(v, low, rel_tol=1e-9) or math.isclose(v, high, rel_tol=1e-9))
    return Tuning(names, ranges, settings.tolerance, name, feasible, best,
                  _margin(names, best, search.hunting) if feasible else {}, front, tuple(screen), shape, boundary,
                  tuple(search.tried), seconds, on_bound, plateau,
                  {"requested": settings.gain_margin, "achieved": achieved} if feasible else {},
                  tuple(sorted(simulated.items(), key=lambda item: item[1])), settings.rig.source, box)


def _box_answer(search, best, feasible):
    """:attr:`Tuning.uncertainty`: the box, its rigs, the binding point and the answer's worst bandwidth.

    The binding point: where the nearest (log distance) faster tuning whose certificate
    failed in the search fails it; where none failed a certificate, the faster tunings the
    DF said hunt are certified (stage ``binding``), nearest first, until one fails (at
    most three; None where none does).
    """
    settings = search.settings
    binding = None
    if feasible:
        faster = [c for c in search.tried if not c.certified and c.failed_at
                  and not c.bandwidth <= best.bandwidth]  # NaN: an unstable contact loop is faster than any
        if faster:
            nearest = min(faster, key=lambda c: (_log_distance(best.values, c.values), c.values))
            binding = dict(nearest.failed_at)
        else:
            hunting = sorted({values for values, source in search.hunting if source.startswith("DF")},
                             key=lambda values: (_log_distance(best.values, values), values))
            hunting = [values for values in hunting if not contact_bandwidth(
                _tuned(settings.rig, settings.names, values), settings.model) <= best.bandwidth]
            for values in hunting[:3]:
                certificate = search.certify(values, "binding")
                if not certificate.certified:
                    binding = dict(certificate.failed_at)
                    break
            search.finish("binding")
    worst = min((contact_bandwidth(_tuned(rig, settings.names, best.values), settings.model)
                 for rig in _box_rigs(settings)), key=lambda band: (not math.isnan(band), band))
    return {"box": dict(settings.rig.uncertainty), "points": 1 + len(settings.points), "binding": binding,
            "worst_bandwidth": worst}


class _Certifier:
    """The certificates of one search: each tuning certified once (the checkpoint's, else this run's), every one
    tried kept in order, the hunting tunings found, and the scaled tunings of the gain margin.  Over a box, the
    points where certificates failed are tried first (the latest first), the others on ``executor``."""

    def __init__(self, settings, kept, report, executor=None):
        self.settings, self.kept, self.report, self.executor = settings, kept, report, executor
        self.tried, self.hunting, self._done, self.counts = [], [], {}, collections.Counter()
        self._failing = []  # box point indices (from 1) where certificates failed, the latest first
        self._screened = {}  # values -> the DF screen says it hunts (the gain margin's scaled tunings)
        self._screen_failing = []  # box rig indices (0 the nominal) where screens hunted, the latest first

    def certify(self, values, stage):
        """The certificate of ``values`` (a new one is reported to ``stage``, unless None, and kept in
        :attr:`tried`)."""
        values = tuple(float(v) for v in values)
        if values not in self._done:
            if stage is not None:
                self.report(stage, self.counts[stage], None)
                self.counts[stage] += 1
            certificate = _certify_cell(self.settings, values, self.kept, self.executor, tuple(self._failing))
            if certificate.failed_at in self.settings.points:
                index = self.settings.points.index(certificate.failed_at) + 1
                self._failing = [index] + [i for i in self._failing if i != index]
            self._done[values] = certificate
            self.tried.append(certificate)
            if not certificate.certified:
                self.hunting.append((values, "certificate"))
        return self._done[values]

    def finish(self, stage):
        """Report ``stage`` done: its certificates counted, its total now known."""
        self.report(stage, self.counts[stage], self.counts[stage])

    def holds(self, values, stage, most=False):
        """``(certificate, holds)``: ``values`` certified, and every tuning of its values scaled by a factor in
        ``{1/g, 1, g}`` each (``g`` the gain margin; with ``most`` only the most aggressive one), checked until
        one fails; the scaled tunings are all screened first, and where the DF says one hunts ``values`` is not
        certified (``certificate`` None)."""
        values = tuple(float(v) for v in values)
        scaled = [tuple(v * f for v, f in zip(values, factors))
                  for factors in _scalings(self.settings.names, self.settings.gain_margin)]
        if not self.clear(scaled):
            return None, False
        certificate = self.certify(values, stage)
        return certificate, certificate.certified and self.all_certified(scaled[:1] if most else scaled, stage)

    def all_certified(self, tunings, stage):
        """Every tuning of ``tunings`` certified: none the DF screen says hunts (:meth:`clear`), then each
        certified in turn until one fails."""
        return self.clear(tunings) and all(self.certify(values, stage).certified for values in tunings)

    def clear(self, tunings):
        """No tuning of ``tunings`` hunts by the DF screen (:func:`_screen_hunts`): the first alone (the most
        aggressive of a gain margin's), then the others together on the executor (a certificate costs tens of
        screens); those that hunt join :attr:`hunting`."""
        if any(self._screened.get(values, False) for values in tunings):
            return False
        todo = [values for values in tunings if values not in self._screened]
        for batch in (todo[:1], todo[1:]):
            found = run_cells(functools.partial(_screen_hunts, self.settings, first=tuple(self._screen_failing)),
                              batch, executor=self.executor if len(batch) > 1 else None, checkpoint=self.kept,
                              keys=[("margin screen", *values) for values in batch])
            for values, index in zip(batch, found):
                self._screened[values] = index is not None
                if index is not None:
                    self.hunting.append((values, "DF screen"))
                    self._screen_failing = [index] + [i for i in self._screen_failing if i != index]
            if any(self._screened[values] for values in batch):
                return False
        return True


def _screen_hunts(settings, values, first=()):
    """The index of the first rig of the box (the points ``first`` first, then the nominal 0, then the others) at
    which the DF screen says ``values`` hunts (:func:`_screen_until`); None where it hunts at none."""
    return _screen_until(settings, values, first)[1]


def _scalings(names, margin):
    """The factors ``(f_1, ...)`` of the varied values ``names``, each in ``{1/g, 1, g}``, not all 1, the most
    aggressive first (the most values scaled away from :data:`_GENTLER`: the likeliest to fail); none where
    ``g`` is 1."""
    if margin == 1.0:
        return []
    factors = [f for f in itertools.product((1.0 / margin, 1.0, margin), repeat=len(names)) if any(x != 1.0 for x in f)]
    return sorted(factors, key=lambda f: sum(_GENTLER[n] * math.log(x) for n, x in zip(names, f)) / math.log(margin))


def _tighten(search, best, rejected):
    """Bisect, with certificates, toward every faster candidate in ``rejected`` (those a certificate refused).

    With a gain margin the bisection certifies each midpoint and its most aggressive scaled tuning (all its
    scaled tunings screened), and the fastest midpoint found must then hold the whole margin (else the next
    fastest, and so on): a full margin per midpoint would cost eight certificates over the box each.
    """
    for fast in [c for c in rejected if c.bandwidth > best.bandwidth]:
        lo, hi, held = best, fast.values, []
        for _ in range(_CERTIFIED_BISECTIONS):
            values = tuple(math.sqrt(a * b) for a, b in zip(lo.values, hi))
            middle, holds = search.holds(values, "certification", most=True)
            lo, hi = (middle, hi) if holds else (lo, values)
            held += [middle] if holds else []
        for middle in sorted(held, key=lambda c: -c.bandwidth):
            if middle.bandwidth <= best.bandwidth:
                break
            if search.holds(middle.values, "certification")[1]:
                best = middle
                break
    return best


def _plateaus(search, ranges, best):
    """The answer moved to the knee of every value whose bandwidth has plateaued (module docs).

    Along each varied value in turn (the others held), toward gentler control
    (:data:`_GENTLER`): where the bandwidth a factor 2 gentler is within 1 % of the
    answer's, the gentlest value still within 1 % of it (log bisection) is the knee; the
    knee's tuning must hold its certificates (and the gain margin), else the segment
    back to the answer is bisected with certificates.  Returns ``(best, plateau)``.
    """
    plateau = {}
    for index, name in enumerate(search.settings.names):
        low, high = ranges[index]
        top = best.bandwidth

        def moved(value):
            return tuple(value if i == index else v for i, v in enumerate(best.values))

        def bandwidth(value):
            return contact_bandwidth(_tuned(search.settings.rig, search.settings.names, moved(value)),
                                     search.settings.model)

        def within(value):
            return bandwidth(value) >= (1.0 - _PLATEAU) * top

        step = 2.0 ** _GENTLER[name]
        half = best.values[index] * step
        if not (low <= half <= high and bandwidth(half) * (1.0 + _PLATEAU) > top):
            continue
        inside, outside = half, None
        while outside is None:
            further = min(max(inside * step, low), high)
            if further == inside:  # the range's bound is within 1 %: the knee is there
                break
            inside, outside = (further, None) if within(further) else (inside, further)
        for _ in range(_KNEE_BISECTIONS if outside is not None else 0):
            middle = math.sqrt(inside * outside)
            inside, outside = (middle, outside) if within(middle) else (inside, middle)
        held = best  # the knee's tuning, or the gentlest holding one on the way back to the answer
        knee, holds = search.holds(moved(inside), "plateau")
        if holds:
            held = knee
        else:
            failed = moved(inside)
            for _ in range(_CERTIFIED_BISECTIONS):
                values = tuple(math.sqrt(a * b) for a, b in zip(held.values, failed))
                middle, holds = search.holds(values, "plateau")
                held, failed = (middle, failed) if holds else (held, values)
        if held is not best:
            plateau[name] = {"bandwidth": top, "reached_at": held.values[index]}
            best = held
    return best, plateau
