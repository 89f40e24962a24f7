"""The effect catalogue: physical causes a two-mass drive with backlash may show.

Each candidate extends the nominal structure (two inertias, elastic damped shaft
with backlash, paper eq. 42 with the rig's torque law) by one physical effect
with one parameter.  The fit starts the parameter at ``initial`` and keeps it in
``bounds``; ``null`` is the value at which the extension vanishes (the
nominal structure).

=====================  ==========================  =======================================
name                   parameter (unit)            extension of the nominal model
=====================  ==========================  =======================================
``none``               --                          nominal structure (42)
``rubber``             ``rubber_thickness`` (rad)  torque law (40) with rubber of width beta
``coulomb_friction``   ``coulomb_friction`` (N m)  ``- F_c sign(w_l)`` on the load (smoothed)
``viscous_friction``   ``viscous_friction``        ``- d_l w_l`` on the load
                       (N m s/rad)
``actuator_delay``     ``actuator_delay`` (s)      applied torque = commanded torque delayed
=====================  ==========================  =======================================
"""

import dataclasses

import numpy as np

__all__ = ["Effect", "EFFECTS", "EFFECT_NAMES", "get_effect", "COULOMB_SMOOTHING_SPEED"]

#: Speed (rad/s) over which the fitted Coulomb friction is smoothed: ``F tanh(w / eps)``.
COULOMB_SMOOTHING_SPEED = 0.05


@dataclasses.dataclass(frozen=True)
class Effect:
    """One entry of the catalogue.

    Attributes
    ----------
    name : str
        The cause's name as reported in ``Diagnosis.cause`` and the JSON.
    parameter : str or None
        Name of its parameter (None for ``none``).
    unit : str
        Unit of the parameter.
    description : str
        What the extension adds to the model.
    action : str
        Sentence template (``{value}``, ``{low}``, ``{high}`` in the parameter's
        unit) telling a person what to do about it.
    null : float
        Parameter value at which the extended model is the nominal one.
    """

    name: str
    parameter: str | None
    unit: str
    description: str
    action: str
    null: float = 0.0

    def bounds(self, rig, measurements):
        """Lower and upper bound of the parameter for this rig and record."""
        plant = rig.plant
        torque_scale = float(np.max(np.abs(measurements.motor_torque))) or 1.0
        speed_scale = float(np.max(np.abs(measurements.speeds))) or 1.0
        if self.name == "rubber":
            return 0.0, 1.4 * plant.half_gap  # <= 2 alpha for alpha >= 0.7 alpha_nominal
        if self.name == "coulomb_friction":
            return 0.0, 0.5 * torque_scale
        if self.name == "viscous_friction":
            return 0.0, 0.5 * torque_scale / speed_scale
        if self.name == "actuator_delay":
            return 0.0, min(0.05, 0.1 * measurements.duration)
        raise ValueError(f"effect {self.name!r} has no parameter")

    def initial(self, rig, measurements):
        """Starting value of the parameter: a small fraction of its range."""
        low, high = self.bounds(rig, measurements)
        if self.name == "actuator_delay":
            return max(2.0 * measurements.dt, 0.05 * high)
        return low + 0.05 * (high - low)

    def scale(self, rig, measurements):
        """Typical size of the parameter, used to scale the fit."""
        low, high = self.bounds(rig, measurements)
        return 0.1 * (high - low)


EFFECTS = {
    effect.name: effect
    for effect in (
        Effect(
            "none", None, "",
            "the nominal structure: two inertias, elastic damped shaft with backlash (42)",
            "The nominal model explains the data: no extension needed; use the calibrated values.",
        ),
        Effect(
            "rubber", "rubber_thickness", "rad",
            "a flexible coupling: rubber of width beta in the gap, torque law (40)",
            "The coupling behaves like a flexible coupling with rubber of width beta = {value:.3g} rad "
            "(95 % CI {low:.3g} to {high:.3g}): model the shaft with the rubber law (40), "
            "rubber_thickness = {value:.3g} in the rig file.",
        ),
        Effect(
            "coulomb_friction", "coulomb_friction", "N m",
            "Coulomb friction on the load side, -F_c sign(w_l) (smoothed)",
            "The load side has Coulomb friction of {value:.3g} N m (95 % CI {low:.3g} to {high:.3g}): "
            "add it to the model, or compensate it (friction feed-forward) in the controller.",
        ),
        Effect(
            "viscous_friction", "viscous_friction", "N m s/rad",
            "viscous friction on the load side, -d_l w_l",
            "The load side has viscous friction of {value:.3g} N m s/rad (95 % CI {low:.3g} to "
            "{high:.3g}): add load damping to the model (it adds damping to the speed loop).",
        ),
        Effect(
            "actuator_delay", "actuator_delay", "s",
            "dead time between commanded and applied motor torque",
            "The applied torque lags the commanded torque by {value_ms:.3g} ms (95 % CI {low_ms:.3g} "
            "to {high_ms:.3g} ms): include this dead time in the loop model (rig file [controller] "
            "delay) before tuning the controller.",
        ),
    )
}

#: Names of the catalogue entries, ``none`` first.
EFFECT_NAMES = tuple(EFFECTS)


def get_effect(name):
    """The catalogue entry ``name``; a ``ValueError`` listing the names if unknown."""
    try:
        return EFFECTS[name]
    except KeyError:
        raise ValueError(f"unknown effect {name!r}; the catalogue has: {', '.join(EFFECT_NAMES)}") from None
