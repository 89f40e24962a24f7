"""What a loop is disturbed by: one definition, one unit each, shared by the verdict and the tuning.

A disturbance is a change of one state of the loop at rest, all other states at
their rest values (:class:`backlash_df.equilibria.Rest`; without a load torque
the rest is the middle of the gap with every state zero):

* a **released twist**: ``theta_d(0) = theta_rest + value`` (rad), all speeds at
  rest (the gear wound up against a flank, or held in the gap, and let go);
* a **motor-speed kick**: ``w_m(0) = w_rest + value`` (rad/s), the load at rest
  (a torque impulse on the motor of ``J_m value`` N m s).

Each prints in its own unit (``twist 0.075 rad``, ``motor speed 16.7 rad/s``)
wherever it appears: the terminal, the JSON (``{"kind", "value", "unit"}``),
the report.  The **standard set** of a rig is the twists ``m alpha`` for
``m = 1.5, 3, 8, -20`` and the kicks ``s alpha omega_n`` for ``s = 2, 10, 50``,
``omega_n = sqrt(k (1/J_m + 1/J_l))`` the shaft mode: a loop that settles from
all of them "does not hunt" for :func:`backlash_df.tune` and the verdict alike.
"""

import dataclasses
import math

__all__ = ["Disturbance", "TWIST", "MOTOR_SPEED", "KINDS", "standard_disturbances", "shaft_mode"]

#: The kinds of disturbance and their units.
TWIST, MOTOR_SPEED = "twist", "motor speed"
KINDS = (TWIST, MOTOR_SPEED)
_UNITS = {TWIST: "rad", MOTOR_SPEED: "rad/s"}
_STATES = {TWIST: "theta_d", MOTOR_SPEED: "motor_speed"}
_PLURALS = {TWIST: "twists", MOTOR_SPEED: "motor-speed kicks"}

#: The standard set: released twists in half gaps alpha, motor-speed kicks in alpha omega_n.
TWIST_MULTIPLES = (1.5, 3.0, 8.0, -20.0)
KICK_MULTIPLES = (2.0, 10.0, 50.0)


@dataclasses.dataclass(frozen=True, order=True)
class Disturbance:
    """An initial state of the loop: a released twist (rad) or a motor-speed kick (rad/s), the rest zero.

    Attributes
    ----------
    kind : str
        :data:`TWIST` or :data:`MOTOR_SPEED`.
    value : float
        ``theta_d(0)`` in rad, or ``w_m(0)`` in rad/s.

    Examples
    --------
    >>> str(Disturbance(TWIST, 0.075)), Disturbance(MOTOR_SPEED, 16.7).initial()
    ('twist 0.075 rad', {'motor_speed': 16.7})
    """

    kind: str
    value: float

    def __post_init__(self):
        if self.kind not in _UNITS:
            raise ValueError(f"disturbance: kind must be {TWIST!r} or {MOTOR_SPEED!r}, got {self.kind!r}")
        if not math.isfinite(self.value):
            raise ValueError(f"disturbance: the {self.kind} must be finite, got {self.value!r}")

    @property
    def unit(self):
        """``"rad"`` or ``"rad/s"``."""
        return _UNITS[self.kind]

    @property
    def state(self):
        """The name of the state it changes: ``"theta_d"`` or ``"motor_speed"``."""
        return _STATES[self.kind]

    def initial(self):
        """The initial state by name from the rest at zero, as :func:`backlash_df.simulate` takes it (``initial=``).

        From another rest: :meth:`backlash_df.equilibria.Rest.initial`.
        """
        return {self.state: float(self.value)}

    def scaled(self, factor):
        """The same kind, ``factor`` times the value."""
        return Disturbance(self.kind, factor * self.value)

    def size(self, rig):
        """The disturbance in the rig's own scale: twist / alpha, or speed / (alpha omega_n)."""
        alpha = rig.plant.half_gap
        return abs(self.value) / (alpha if self.kind == TWIST else alpha * shaft_mode(rig))

    def __str__(self):
        return f"{self.kind} {self.value:.4g} {self.unit}"

    def to_dict(self):
        """``{"kind", "value", "unit"}``."""
        return {"kind": self.kind, "value": float(self.value), "unit": self.unit}


def shaft_mode(rig):
    """``omega_n = sqrt(k (1/J_m + 1/J_l))``, rad/s: the two-mass shaft's mode."""
    plant = rig.plant
    return math.sqrt(plant.stiffness * (1.0 / plant.motor_inertia + 1.0 / plant.load_inertia))


def standard_disturbances(rig):
    """The standard set of a rig (module docs): four released twists, then three motor-speed kicks."""
    alpha = rig.plant.half_gap
    kick = alpha * shaft_mode(rig)
    return tuple([Disturbance(TWIST, m * alpha) for m in TWIST_MULTIPLES]
                 + [Disturbance(MOTOR_SPEED, s * kick) for s in KICK_MULTIPLES])


def kind_words(kind, count=2):
    """``"twist"`` / ``"twists"``, ``"motor-speed kick"`` / ``"motor-speed kicks"``: the kind in a sentence."""
    return _PLURALS[kind] if count != 1 else ("twist" if kind == TWIST else "motor-speed kick")
