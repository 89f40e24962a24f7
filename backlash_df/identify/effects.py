"""The effect catalogue: physical causes a two-mass drive with backlash may show.

Each candidate extends the nominal structure (two inertias, elastic damped shaft
with backlash, paper eq. 42 with the rig's torque law) by one physical effect
with one parameter, named like the effect.  Friction acts on either side of the
shaft, and the side is part of the answer: ``coulomb_friction`` on the ``load``
side and on the ``motor`` side are two candidates.  The fit starts the parameter
at :meth:`Effect.start` (the ``null`` value of the nominal structure, rubber inside its
range) and keeps it in :meth:`Effect.bounds`.

=======================  ==========  ==================  ======================================
effect                   side        unit                extension of the nominal model
=======================  ==========  ==================  ======================================
``rubber``               --          rad                 torque law (40) with rubber of width beta
``coulomb_friction``     motor/load  N m                 ``- F_c tanh(w / eps)`` on that side
``viscous_friction``     motor/load  N m s/rad           ``- d w`` on that side
``breakaway_friction``   motor/load  N m                 ``- F_s exp(-(w / w_s)^2) tanh(w / eps)``
``torque_offset``        --          N m                 ``+ T_0`` added to the motor torque
``actuator_delay``       --          s                   applied torque = commanded, delayed
=======================  ==========  ==================  ======================================

The smoothing speed ``eps`` (:data:`COULOMB_SMOOTHING`) and the Stribeck speed
``w_s`` (:data:`STRIBECK_SPEED`) are fractions of the record's largest measured
speed, so that the catalogue is the same for a lab rig and a robot axis.  A
breakaway friction's size depends on its Stribeck speed (a wider bump needs less
height for the same impulse at a reversal): a diagnosis chooses ``w_s`` among
:data:`STRIBECK_GRID` by the fits' residuals and reports it with the size.
"""

import dataclasses

import numpy as np

__all__ = ["Effect", "EFFECTS", "EFFECT_NAMES", "get_effect", "COULOMB_SMOOTHING", "STRIBECK_SPEED", "STRIBECK_GRID",
           "COULOMB_GRID"]

#: Coulomb smoothing speed ``eps`` as a fraction of the record's largest speed: ``F tanh(w / eps)``.
COULOMB_SMOOTHING = 0.01
#: Stribeck speed ``w_s`` of the breakaway friction, as a fraction of the record's largest speed: the
#: prediction's default.
STRIBECK_SPEED = 0.05
#: The Stribeck speeds a diagnosis tries for a breakaway friction, as fractions of the record's largest speed
#: (ratio 1.5); the fit holds the one whose estimation residual is least (``diagnose``).
STRIBECK_GRID = (0.015, 0.0225, 0.034, 0.05)
#: The Coulomb smoothing speeds a diagnosis tries for a Coulomb friction, as fractions of the record's largest
#: speed; the fit holds the one whose estimation residual is least (``diagnose``).
COULOMB_GRID = (0.01, 0.003, 0.001)


def peak_speed(measurements):
    """The record's largest measured speed (rad/s; 1 where it never moves): the scale of the friction law's
    speeds and of a viscous friction's bounds."""
    return float(np.max(np.abs(measurements.speeds))) or 1.0


def smoothing_speeds(measurements):
    """``(eps, w_s)`` in rad/s for a record: Coulomb smoothing and Stribeck speed."""
    peak = peak_speed(measurements)
    return COULOMB_SMOOTHING * peak, STRIBECK_SPEED * peak


@dataclasses.dataclass(frozen=True)
class Effect:
    """One entry of the catalogue.

    Attributes
    ----------
    name : str
        The effect's name as reported in ``causes[i]["effect"]``; its parameter
        carries the same name.
    side : str or None
        ``motor`` or ``load`` for friction, None where the side is no choice.
    unit : str
        Unit of the parameter.
    description : str
        What the extension adds to the model.
    action : str
        Sentence (``{value}``, ``{low}``, ``{high}`` in the parameter's unit,
        ``{side}`` and ``{where}``, the side as a subject) telling a person what to do about it.
    signed : bool
        Whether negative values are physical (a torque offset); friction, delay
        and rubber are never negative.
    null : float
        The parameter's value in the nominal structure (0).
    """

    name: str
    side: str | None
    unit: str
    description: str
    action: str
    signed: bool = False
    null: float = 0.0

    @property
    def key(self):
        """Identifier of the candidate: ``name@side`` (or ``name`` without a side)."""
        return f"{self.name}@{self.side}" if self.side else self.name

    @property
    def parameter(self):
        """Name of the parameter (the effect's own name)."""
        return self.name

    @property
    def value_key(self):
        """Key of the parameter in a model's value dictionary: ``name_side``, ``rubber_thickness`` or ``name``."""
        if self.name == "rubber":
            return "rubber_thickness"
        return f"{self.name}_{self.side}" if self.side else self.name

    def bounds(self, rig, measurements):
        """Lower and upper bound of the parameter for this rig and record."""
        torque_scale = float(np.max(np.abs(measurements.motor_torque))) or 1.0
        speed_scale = peak_speed(measurements)
        if self.name == "rubber":
            return 0.0, 1.4 * rig.plant.half_gap  # <= 2 alpha for alpha >= 0.7 alpha_nominal
        if self.name in ("coulomb_friction", "breakaway_friction"):
            return 0.0, torque_scale
        if self.name == "viscous_friction":
            return 0.0, torque_scale / speed_scale
        if self.name == "torque_offset":  # a held constant load (gravity on a robot axis) needs about its size
            return -torque_scale, torque_scale
        return 0.0, min(0.05, 0.1 * measurements.duration)  # actuator_delay

    def start(self, rig):
        """Starting value of a fit: the null value, except rubber (half the half gap), whose
        prediction error is flat at beta = 0 (the rubber law (40) tends to (23) to second order)."""
        return 0.5 * rig.plant.half_gap if self.name == "rubber" else self.null

    def scale(self, rig, measurements):
        """Typical size of the parameter, used to scale the fit."""
        low, high = self.bounds(rig, measurements)
        return 0.05 * (high - low)

    def describe(self, value, low, high, rigid=False):
        """The action sentence for a fitted value and its 95 % interval; ``rigid``: fitted by the rigid-body
        model, whose one body carries friction of either side (the side is then not named)."""
        if self.name == "actuator_delay":
            value, low, high = 1e3 * value, 1e3 * low, 1e3 * high
        where = "The drive (motor and load as one rigid body)" if rigid else f"The {self.side} side"
        return self.action.format(value=value, low=low, high=high, side=self.side, where=where)


_FRICTION_ACTION = ("{{where}} has {what} of {{value:.4g}} {unit} (95 % CI {{low:.4g}} to {{high:.4g}}): "
                    "add it to the model, or compensate it (friction feed-forward) in the controller.")


def _friction(name, side, unit, description, what):
    return Effect(name, side, unit, description.replace("SIDE", side),
                  _FRICTION_ACTION.format(what=what, unit=unit))


EFFECTS = {
    effect.key: effect
    for effect in (
        Effect(
            "rubber", None, "rad",
            "a flexible coupling: rubber of width beta in the gap, torque law (40)",
            "The coupling behaves like a flexible coupling with rubber of width beta = {value:.3g} rad "
            "(95 % CI {low:.3g} to {high:.3g}): model the shaft with the rubber law (40), "
            "rubber_thickness = {value:.3g} in the rig file.",
        ),
        *[_friction("coulomb_friction", side, "N m", "Coulomb friction on the SIDE side, -F_c sign(w) (smoothed)",
                    "Coulomb friction") for side in ("load", "motor")],
        *[_friction("viscous_friction", side, "N m s/rad", "viscous friction on the SIDE side, -d w",
                    "viscous friction") for side in ("load", "motor")],
        *[_friction("breakaway_friction", side, "N m",
                    "breakaway (Stribeck) friction on the SIDE side, -F_s exp(-(w/w_s)^2) sign(w)",
                    "breakaway friction near zero speed") for side in ("load", "motor")],
        Effect(
            "torque_offset", None, "N m",
            "a constant torque added to the commanded motor torque (sensor bias or an unmodelled load)",
            "The applied torque differs from the recorded one by a constant {value:.4g} N m (95 % CI {low:.4g} "
            "to {high:.4g}): a torque-sensor bias or an unmodelled load torque; a load that changes with the "
            "pose (gravity on a robot axis) shows here as its mean over the record.",
            signed=True,
        ),
        Effect(
            "actuator_delay", None, "s",
            "dead time between commanded and applied motor torque",
            "The applied torque lags the commanded torque by {value:.3g} ms (95 % CI {low:.3g} to {high:.3g} ms): "
            "include this dead time in the loop model (rig file [controller] delay) before tuning the controller.",
        ),
    )
}

#: Keys of the catalogue entries (``name@side`` for friction).
EFFECT_NAMES = tuple(EFFECTS)


def get_effect(key):
    """The catalogue entry ``key`` (``name@side``; a friction name alone means its load side).

    Raises
    ------
    ValueError
        Unknown name, listing the catalogue.
    """
    if key in EFFECTS:
        return EFFECTS[key]
    if f"{key}@load" in EFFECTS:
        return EFFECTS[f"{key}@load"]
    raise ValueError(f"unknown effect {key!r}; the catalogue has: {', '.join(EFFECT_NAMES)}")
