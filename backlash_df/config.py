"""The rig file: a TOML description of a drive with backlash (SI units).

::

    [plant]
    motor_inertia = 0.4        # J_m, kg m^2
    load_inertia = 5.6         # J_l, kg m^2
    stiffness = 5895.0         # k, N m / rad
    damping = 3.0              # c, N m s / rad
    half_gap = 0.05            # alpha, rad: HALF the total play
    rubber_thickness = 0.0     # beta, rad
    gear_ratio = 1.0           # motor turns per load turn (motor-side CSV columns are reflected)

    [controller]               # PI speed loop, optionally inside a P position loop
    structure = "speed"        # "speed" (PI speed loop) or "cascade" (P position loop around it)
    feedback = "load"          # "motor" or "load": the speed the PI controller measures
    kp = 30.0                  # N m s / rad
    ti = 0.5                   # s (inf: a P speed controller)
    speed_filter = 0.002       # s
    torque_lag = 0.0           # s
    delay = 0.0                # s, on every measured signal
    kv = 20.0                  # 1/s, cascade only: speed reference = kv (r - position), r the position reference
    position_feedback = "load" # cascade only: "motor" or "load", the angle the position loop measures
    torque_limit = 0.0         # N m, |torque command| limit with a clamped integrator (0: none)

    [load]                     # optional
    torque = 0.0               # N m, constant torque applied to the load
    torque_offset = 0.0        # N m, constant torque added to the motor torque (either sign)

    [friction]                 # optional; every value on the load side, like [plant]
    coulomb_motor = 0.0        # N m, sliding (Coulomb) friction of the motor side
    coulomb_load = 0.0         # N m
    viscous_motor = 0.0        # N m s/rad
    viscous_load = 0.0         # N m s/rad
    breakaway_motor = 0.0      # N m, static excess over Coulomb (Stribeck), decaying with speed
    breakaway_load = 0.0       # N m
    stribeck_speed = 0.0       # rad/s, required (> 0) with a breakaway friction

    [model]
    backlash = "phase-plane"

    [uncertainty]              # optional: where the real drive's values may lie, absolute [low, high]
    load_inertia = [4.0, 8.0]  # any numeric [plant], [friction] or [load] key; the box holds the value above

Every problem is reported as one line naming the file and the key, raised as
:class:`RigError` (a ``ValueError``).

**Accepted ranges.**  Values must be finite; the signs are fixed by the physics (inertias, stiffness,
gap, gains and time constants positive or zero, a load torque of either sign).
Beyond that, each value must lie in a range (:data:`RANGES`) wide enough for
every real drive, from a miniature servo (rotor inertia ~1e-7 kg m^2) to a wind
turbine or rolling mill (load inertia ~1e8 kg m^2, shaft stiffness ~1e10 N m/rad),
and narrow enough that the analysis stays in floating point: a total play below
one turn, a dead time below 10 s.  The stiffness and the inertias are also checked
together: the shaft mode sqrt(k (1/J_m + 1/J_l)) and the damper's rate
c (1/J_m + 1/J_l) must not exceed :data:`MAX_SHAFT_MODE` = 1e5 1/s (16 kHz; the
bundled rigs have modes of 112-126 rad/s, a miniature servo about 2e3 rad/s),
beyond which the time simulation would need billions of steps; and the load torque
must not twist the shaft by more than a turn (``|T| / k + alpha <= 2 pi`` rad).
A value outside its range is refused with the key, the value and the range (a
value of 1e300 is a typing error, not a drive).

=================================  ====================  ==========================================
key                                range                 why
=================================  ====================  ==========================================
motor_inertia, load_inertia        [1e-10, 1e10] kg m^2  miniature motors to wind-turbine rotors
stiffness                          [1e-6, 1e12] N m/rad  torsion springs to the stiffest drive trains
damping                            [0, 1e12] N m s/rad   as the stiffness, times 1 s
half_gap                           [1e-9, pi] rad        the total play 2 alpha is below one turn
rubber_thickness                   [0, 2 half_gap] rad   the rubber band lies inside the gap (28)
gear_ratio                         [1e-4, 1e5]           motor turns per load turn, gear-ups included
kp                                 (0, 1e10] N m s/rad   the loop gain kp / J of any drive above
ti                                 [1e-6, 1e6] s or inf  integral action from microseconds to days (inf: P)
speed_filter, torque_lag           [0, 100] s            first-order lags
delay                              [0, 10] s             dead time of a speed loop
kv                                 (0, 1e6] 1/s          position-loop gain (cascade only)
torque_limit                       [0, 1e9] N m          torque-command limit (0: none)
[load] torque                      [-1e9, 1e9] N m       load torque of either sign
[load] torque_offset               [-1e9, 1e9] N m       a constant torque added to the motor torque
coulomb_motor, coulomb_load        [0, 1e9] N m          as a torque limit
viscous_motor, viscous_load        [0, 1e12] N m s/rad   as the damping
breakaway_motor, breakaway_load    [0, 1e9] N m          as a torque limit
stribeck_speed                     [0, 1e6] rad/s        speeds of any drive (> 0 with a breakaway friction)
=================================  ====================  ==========================================

``[friction]`` is the friction law of :mod:`backlash_df.friction` on each side,
``F(w) = viscous w + (coulomb + breakaway exp(-(w / stribeck_speed)^2)) sign(w)``, the
catalogue's effects (:mod:`backlash_df.identify.effects`) as a diagnosis names them, with
true stiction at rest (:class:`~backlash_df.system.Sticking`).  The time simulation models
all of it, the describing-function prediction takes dry friction on one side as a slaved
damper, the verdict's probes (and so the tuning's certificates) simulate it; viscous
friction is linear and part of every analysis' ``G``; the exact orbits and the sweeps do
not model dry (Coulomb, breakaway) friction yet and refuse it, and no loop models ``torque_offset`` yet (:meth:`Rig.require_modelled`, called by
:func:`~backlash_df.loops.drive_loop`); the rig still loads, so that a diagnosed rig
(:meth:`~backlash_df.identify.Diagnosis.rig_out`) can be written and read.

``[uncertainty]`` gives, for any   numeric ``[plant]``, ``[friction]`` or ``[load]`` key, the
absolute interval ``[low, high]``   the real drive's value lies in (each end inside the
key's range, ``low <= high``, the   rig's own value inside); :attr:`Rig.uncertainty`.  No
command reads it yet.  :func:`wri  te_rig` writes a rig back as a file.
"""

import collections.abc
import dataclasses
import json
import math
import tomllib
from pathlib import Path

import numpy as np

from .models import MODEL_NAMES, make_model

__all__ = ["Plant", "Controller", "Load", "Friction", "Uncertainty", "Rig", "RigError", "RANGES", "MAX_SHAFT_MODE",
           "load_rig", "rig_from_dict", "rig_to_toml", "write_rig"]


class RigError(ValueError):
    """A rig file that cannot be used; the message is one line naming file and key."""


@dataclasses.dataclass(frozen=True)
class Plant:
    """Two-mass drive with an elastic shaft and backlash (SI units)."""

    motor_inertia: float  #: J_m, kg m^2
    load_inertia: float  #: J_l, kg m^2
    stiffness: float  #: k, N m/rad
    half_gap: float  #: alpha, rad (half the total play)
    damping: float = 0.0  #: c, N m s/rad
    rubber_thickness: float = 0.0  #: beta, rad
    gear_ratio: float = 1.0  #: motor turns per load turn; the plant's values are on the load side

    @property
    def shaft(self):
        """The shaft parameters as keyword arguments of :func:`~backlash_df.make_model`."""
        return dict(
            stiffness=self.stiffness,
            damping=self.damping,
            half_gap=self.half_gap,
            rubber_thickness=self.rubber_thickness,
        )


@dataclasses.dataclass(frozen=True)
class LtiBlock:
    """A user's SISO controller as a continuous-time state-space model (hashable, picklable).

    ``dx/dt = A x + B e``, ``y = C x + D e``; from :meth:`from_lti` of a
    python-control LTI (transfer function or state space).

    Attributes
    ----------
    A, B, C, D : tuple of tuple of float
        Shapes (m, m), (m, 1), (1, m), (1, 1).
    """

    A: tuple
    B: tuple
    C: tuple
    D: tuple

    @classmethod
    def from_lti(cls, system, what="controller"):
        """The block of a python-control LTI; a ``ValueError`` naming ``what`` if it is not SISO, proper, continuous."""
        import control as ct  # lazy: python-control takes a second to import

        if not isinstance(system, ct.LTI):
            raise ValueError(f"{what}: a python-control LTI system is needed (ct.tf, ct.ss), got {type(system).__name__}")
        if system.ninputs != 1 or system.noutputs != 1:
            raise ValueError(f"{what}: must be SISO (one input, one output), got {system.ninputs} inputs and "
                             f"{system.noutputs} outputs")
        if not system.isctime():
            raise ValueError(f"{what}: must be a continuous-time system (dt = 0), got dt = {system.dt}")
        if isinstance(system, ct.TransferFunction):
            num, den = system.num[0][0], system.den[0][0]
            if len(np.trim_zeros(num, "f")) > len(np.trim_zeros(den, "f")):
                raise ValueError(f"{what}: is not proper (the numerator's degree exceeds the denominator's); "
                                 f"add poles, e.g. a filter")
        try:
            ss = ct.ss(system)
        except ValueError as error:
            raise ValueError(f"{what}: cannot be realised in state space ({error})") from None
        arrays = [np.asarray(m, dtype=float).reshape(shape) for m, shape in
                  zip((ss.A, ss.B, ss.C, ss.D), ((ss.nstates, ss.nstates), (ss.nstates, 1), (1, ss.nstates), (1, 1)))]
        if not all(np.all(np.isfinite(m)) for m in arrays):
            raise ValueError(f"{what}: has non-finite coefficients")
        return cls(*(tuple(map(tuple, m)) for m in arrays))

    @property
    def order(self):
        """Number of states m."""
        return len(self.A)

    def matrices(self):
        """``(A, B, C, D)`` as float arrays."""
        return tuple(np.array(m, dtype=float).reshape(shape) for m, shape in
                     zip((self.A, self.B, self.C, self.D),
                         ((self.order, self.order), (self.order, 1), (1, self.order), (1, 1))))

    def frequency_response(self, omega):
        """``C (jw I - A)^-1 B + D`` at the frequencies ``omega`` (rad/s), complex."""
        a, b, c, d = self.matrices()
        omega = np.asarray(omega, dtype=float)
        if self.order == 0:
            return np.full(omega.shape, d[0, 0], dtype=complex)
        jw = 1j * omega.reshape(-1)[:, None, None]
        response = c @ np.linalg.solve(jw * np.eye(self.order) - a, np.broadcast_to(b, (jw.shape[0],) + b.shape))
        return (response[:, 0, 0] + d[0, 0]).reshape(omega.shape)

    def __repr__(self):
        return f"LtiBlock({self.order} states)"


@dataclasses.dataclass(frozen=True)
class Controller:
    """The loop's controller and linear elements (SI units; the contract page states the loop).

    A PI speed controller (or a user's LTI ``speed_controller``) on the speed error,
    optionally inside a position loop (``structure = "cascade"``: ``kv``, or a user's
    LTI ``position_controller``), its torque command limited to ``torque_limit``
    with a clamped integrator, a speed filter, a torque lag and a dead time on every
    measured signal.
    """

    kp: float  #: proportional gain, N m s/rad
    ti: float  #: integral time, s (Ki = kp / ti; inf: a P speed controller)
    feedback: str = "load"  #: "motor" or "load": which speed is measured
    speed_filter: float = 0.0  #: time constant of the first-order speed filter, s
    torque_lag: float = 0.0  #: time constant of the torque (current) loop, s
    delay: float = 0.0  #: dead time on every measured signal, s
    structure: str = "speed"  #: "speed" (PI speed loop) or "cascade" (a position loop around it)
    kv: float = 0.0  #: position gain, 1/s (cascade): speed reference = kv (position reference - position)
    position_feedback: str = "load"  #: "motor" or "load": which angle the position loop measures
    torque_limit: float = 0.0  #: limit of the torque command's magnitude, N m (0: none)
    speed_controller: LtiBlock | None = None  #: a user's controller in place of the PI (speed error -> torque)
    position_controller: LtiBlock | None = None  #: a user's controller in place of kv (position error -> speed)

    @property
    def ki(self):
        """Integral gain kp / ti, N m / rad (0 for a P controller, ti = inf)."""
        return self.kp / self.ti

    @property
    def cascade(self):
        """True for a position loop around the speed loop."""
        return self.structure == "cascade"


@dataclasses.dataclass(frozen=True)
class Load:
    """What the driven machine applies to the load (SI units, load side)."""

    torque: float = 0.0  #: constant torque applied to the load, N m (gravity, process load)
    torque_offset: float = 0.0  #: constant torque added to the motor torque, N m, either sign (the catalogue's)


@dataclasses.dataclass(frozen=True)
class Friction:
    """Friction of each side of the drive, on the load side like :class:`Plant` (SI units).

    The law of :mod:`backlash_df.friction` on the motor speed (``*_motor``) and on the
    load speed (``*_load``): ``F(w) = viscous w + (coulomb + breakaway exp(-(w /
    stribeck_speed)^2)) sign(w)``, opposing the motion.  All zero: no friction.
    """

    coulomb_motor: float = 0.0  #: sliding (Coulomb) friction of the motor side, N m
    coulomb_load: float = 0.0  #: sliding (Coulomb) friction of the load side, N m
    viscous_motor: float = 0.0  #: viscous friction of the motor side, N m s/rad
    viscous_load: float = 0.0  #: viscous friction of the load side, N m s/rad
    breakaway_motor: float = 0.0  #: static excess over Coulomb of the motor side (Stribeck), N m
    breakaway_load: float = 0.0  #: static excess over Coulomb of the load side (Stribeck), N m
    stribeck_speed: float = 0.0  #: speed over which the breakaway friction decays, rad/s (> 0 with one)

    @property
    def any(self):
        """True if any friction is nonzero (a Stribeck speed alone is no friction)."""
        return any(getattr(self, f.name) != 0.0 for f in dataclasses.fields(self) if f.name != "stribeck_speed")

    @property
    def dry(self):
        """The nonzero Coulomb and breakaway keys, in the table's order: the friction that sticks at rest."""
        return tuple(name for name in ("coulomb_motor", "coulomb_load", "breakaway_motor", "breakaway_load")
                     if getattr(self, name) != 0.0)


class Uncertainty(collections.abc.Mapping):
    """The ``[uncertainty]`` table: rig value name -> ``(low, high)``, absolute, in the key's unit.

    A read-only mapping in the file's order, hashable (a :class:`Rig` stays frozen and
    hashable); equal to a ``dict`` of the same boxes.

    Examples
    --------
    >>> box = Uncertainty({"load_inertia": (4.0, 8.0)})
    >>> box["load_inertia"], dict(box) == {"load_inertia": (4.0, 8.0)}
    ((4.0, 8.0), True)
    """

    def __init__(self, boxes=()):
        self._boxes = {str(name): (float(low), float(high)) for name, (low, high) in dict(boxes).items()}

    def __getitem__(self, name):
        return self._boxes[name]

    def __iter__(self):
        return iter(self._boxes)

    def __len__(self):
        return len(self._boxes)

    def __hash__(self):
        return hash(tuple(self._boxes.items()))

    def __repr__(self):
        return f"Uncertainty({self._boxes!r})"


@dataclasses.dataclass(frozen=True)
class Rig:
    """A parsed rig file: plant, optional controller, load, default backlash model, friction, uncertainty."""

    plant: Plant
    controller: Controller | None = None
    load: Load = Load()
    model: str = "phase-plane"
    source: str = "<dict>"
    friction: Friction = Friction()  #: the ``[friction]`` table (all zero: none)
    uncertainty: Uncertainty = Uncertainty()  #: the ``[uncertainty]`` table: name -> (low, high), absolute

    def __repr__(self):
        """As a dataclass's, without ``friction`` and ``uncertainty`` where the rig has none."""
        shown = [f for f in dataclasses.fields(self)
                 if not (f.name == "friction" and self.friction == Friction())
                 and not (f.name == "uncertainty" and not self.uncertainty)]
        return f"Rig({', '.join(f'{f.name}={getattr(self, f.name)!r}' for f in shown)})"

    def make_model(self, name=None):
        """The rig's shaft as a torque law (default: the ``[model] backlash`` name).

        Raises
        ------
        RigError
            ``rubber`` on a rig without ``rubber_thickness``: with beta = 0 the
            rubber law (40) is the phase plane law (23), and a result labelled
            ``rubber`` would silently be that one.
        """
        return _model(self.source, self.plant, name or self.model)

    def with_law(self, law):
        """A copy whose shaft is ``law``'s and whose default model is ``law.name``.

        The plant's stiffness, damping, half gap and rubber thickness become the law's
        (a :class:`~backlash_df.models.BacklashModel` built with values of its own), so
        that every stage that reads the rig (the search box, the disturbances in gaps,
        the simulation) works with the law's shaft.  The rig itself when they agree.
        """
        shaft = law.plant_params
        if shaft == self.plant.shaft and law.name == self.model:
            return self
        return dataclasses.replace(self, plant=dataclasses.replace(self.plant, **shaft), model=law.name)

    def with_values(self, **changes):
        """A copy with plant, controller or load values replaced, checked as the rig file's are.

        Parameters
        ----------
        **changes
            New values, in the rig file's units, by key of ``[plant]``, ``[controller]``,
            ``[load]`` or ``[friction]`` (``kp=60.0``, ``stiffness=1000.0``, ``torque=250.0``,
            ``coulomb_load=20.0``) or by ``"table.key"`` (``**{"load.torque": 250.0}``);
            several at once.  The ``[uncertainty]`` boxes are kept and must hold the new values.

        Returns
        -------
        Rig
            The rig itself for no changes.  A user's LTI controllers
            (:meth:`with_controller`) are kept.

        Raises
        ------
        ValueError
            An unknown or non-numeric key, two keys naming one value, or a value the
            rig file would reject (:class:`RigError`): one line naming the key.

        Examples
        --------
        >>> rig = rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
        ...     "half_gap": 0.05}, "controller": {"kp": 30.0, "ti": 0.5}})
        >>> rig.with_values(kp=60.0).controller.kp
        60.0
        >>> faster = rig.with_values(kp=60.0, ti=0.3, **{"load.torque": 250.0})
        >>> faster.controller.ti, faster.load.torque
        (0.3, 250.0)
        """
        if not changes:
            return self
        data = self.to_dict()
        named = {}
        for parameter, value in changes.items():
            table, key = _table_of(self, parameter)
            if (table, key) in named:
                raise ValueError(f"{named[table, key]!r} and {parameter!r} name the same value, {table}.{key}")
            named[table, key] = parameter
            data[table][key] = value
        changed = rig_from_dict(data, source=f"{self.source} with " + ", ".join(
            f"{table}.{key} = {_value_text(changes[parameter])}" for (table, key), parameter in named.items()))
        if self.controller is None:
            return changed
        users = {name: getattr(self.controller, name) for name in _PYTHON_ONLY}
        return dataclasses.replace(changed, controller=dataclasses.replace(changed.controller, **users))

    def without_uncertainty(self, *parameters):
        """A copy whose ``[uncertainty]`` holds no box for these values: a sweep's own axes.

        Parameters
        ----------
        *parameters : str
            Keys of :meth:`with_values` (``"coulomb_load"``, ``"friction.coulomb_load"``).

        Returns
        -------
        Rig
            The rig itself where none of them has a box.

        Examples
        --------
        >>> rig = rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
        ...     "half_gap": 0.05}, "uncertainty": {"stiffness": [5000.0, 7000.0], "half_gap": [0.04, 0.06]}})
        >>> dict(rig.without_uncertainty("plant.stiffness").uncertainty)
        {'half_gap': (0.04, 0.06)}
        """
        swept = {_table_of(self, parameter)[1] for parameter in parameters}
        if not swept & set(self.uncertainty):
            return self
        kept = {name: box for name, box in self.uncertainty.items() if name not in swept}
        return dataclasses.replace(self, uncertainty=Uncertainty(kept))

    def require_controller(self):
        """The controller, or a :class:`RigError` saying the rig has none."""
        if self.controller is None:
            raise RigError(f"{self.source}: no [controller] table; this analysis needs the PI speed loop")
        return self.controller

    def require_modelled(self, dry_friction=False):
        """Refuse what the loop's analyses do not model: a torque offset, and dry friction unless ``dry_friction``.

        Parameters
        ----------
        dry_friction : bool
            True for every analysis of the package: the time simulation models Coulomb
            and breakaway friction with stiction, the describing-function prediction
            takes it as a slaved damper (:class:`~backlash_df.slaving.FrictionSlaving`),
            the exact orbits and continuation take Coulomb friction as modes (stuck,
            sliding either way), the verdict's probes simulate it; False for a loop
            that would leave it out.

        Raises
        ------
        RigError
            ``[load] torque_offset`` nonzero, or (without ``dry_friction``) a nonzero
            ``[friction]`` Coulomb or breakaway value: one line naming the first.
        """
        if self.load.torque_offset != 0.0:
            raise RigError(f"{self.source}: [load] torque_offset = {self.load.torque_offset:g}: no analysis of the "
                           f"loop models a torque offset yet (it would be left out); remove the key or set it to 0")
        dry = self.friction.dry
        if dry and not dry_friction:
            raise RigError(f"{self.source}: [friction] {dry[0]} = {getattr(self.friction, dry[0]):g}: this loop "
                           f"leaves dry friction out; build it with drive_loop(rig, dry_friction=True), as every "
                           f"analysis of the package does")

    def to_dict(self):
        """The rig as the rig file's tables (a dict :func:`rig_from_dict` reads back).

        The cascade's keys appear with ``structure = "cascade"`` only; a user's LTI
        controllers (:meth:`with_controller`) are not rig-file keys and are left out;
        ``uncertainty`` holds ``[low, high]`` lists.
        """
        data = {"plant": dataclasses.asdict(self.plant), "load": dataclasses.asdict(self.load),
                "model": {"backlash": self.model}, "friction": dataclasses.asdict(self.friction),
                "uncertainty": {name: list(box) for name, box in self.uncertainty.items()}}
        if self.controller is not None:
            keys = [f.name for f in dataclasses.fields(self.controller) if f.name not in _PYTHON_ONLY]
            if not self.controller.cascade:
                keys = [key for key in keys if key not in ("kv", "position_feedback")]
            data["controller"] = {key: getattr(self.controller, key) for key in keys}
        return data

    def to_toml(self, *, comments=None, header=""):
        """The rig as a rig file's text (:func:`rig_to_toml`)."""
        return rig_to_toml(self, comments=comments, header=header)

    def with_controller(self, speed=None, position=None):
        """A copy whose speed controller and/or position controller is a user's python-control LTI.

        Parameters
        ----------
        speed : control.LTI, optional
            Speed error (rad/s) -> torque command (N m), in place of the PI; SISO,
            proper, continuous time.  The torque limit saturates its output (a
            user's controller has no clamped integrator).
        position : control.LTI, optional
            Position error (rad) -> speed reference (rad/s), in place of ``kv``;
            the rig's ``structure`` must be ``"cascade"``.

        Returns
        -------
        Rig

        Raises
        ------
        ValueError
            No ``[controller]``, a position controller on a speed loop, or a system
            that is not SISO, proper and continuous: one line naming it.

        Examples
        --------
        A P speed controller as a user's LTI gives the same loop as ``ti = inf``:

        >>> import control as ct
        >>> rig = rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
        ...     "half_gap": 0.05}, "controller": {"kp": 30.0, "ti": float("inf")}})
        >>> user = rig.with_controller(speed=ct.tf([30.0], [1.0]))
        >>> user.controller.speed_controller
        LtiBlock(0 states)
        """
        controller = self.require_controller()
        changes = {}
        if speed is not None:
            changes["speed_controller"] = LtiBlock.from_lti(speed, "with_controller(speed=...)")
        if position is not None:
            if not controller.cascade:
                raise RigError(f"{self.source}: with_controller(position=...) needs [controller] structure = "
                               f"\"cascade\" (a position loop)")
            changes["position_controller"] = LtiBlock.from_lti(position, "with_controller(position=...)")
        return dataclasses.replace(self, controller=dataclasses.replace(controller, **changes))


_POSITIVE = {"motor_inertia", "load_inertia", "stiffness", "half_gap", "kp", "ti", "gear_ratio", "kv"}
_SIGNED = {"torque", "torque_offset"}  # may be negative: a load torque or an offset acts in either direction

#: Accepted range of each rig value: (low, high, unit); see the module notes.
RANGES = {
    "motor_inertia": (1e-10, 1e10, "kg m^2"),
    "load_inertia": (1e-10, 1e10, "kg m^2"),
    "stiffness": (1e-6, 1e12, "N m/rad"),
    "damping": (0.0, 1e12, "N m s/rad"),
    "half_gap": (1e-9, math.pi, "rad"),
    "rubber_thickness": (0.0, 2.0 * math.pi, "rad"),
    "gear_ratio": (1e-4, 1e5, ""),
    "kp": (0.0, 1e10, "N m s/rad"),
    "ti": (1e-6, 1e6, "s"),
    "speed_filter": (0.0, 100.0, "s"),
    "torque_lag": (0.0, 100.0, "s"),
    "delay": (0.0, 10.0, "s"),
    "kv": (0.0, 1e6, "1/s"),
    "torque_limit": (0.0, 1e9, "N m"),
    "torque": (-1e9, 1e9, "N m"),
    "torque_offset": (-1e9, 1e9, "N m"),
    "coulomb_motor": (0.0, 1e9, "N m"),
    "coulomb_load": (0.0, 1e9, "N m"),
    "viscous_motor": (0.0, 1e12, "N m s/rad"),
    "viscous_load": (0.0, 1e12, "N m s/rad"),
    "breakaway_motor": (0.0, 1e9, "N m"),
    "breakaway_load": (0.0, 1e9, "N m"),
    "stribeck_speed": (0.0, 1e6, "rad/s"),
}
_TABLES = {"plant": Plant, "controller": Controller, "load": Load, "model": None, "friction": Friction,
           "uncertainty": None}
#: The tables whose numeric keys an ``[uncertainty]`` box may name.
_UNCERTAIN_TABLES = ("plant", "friction", "load")
#: Keys whose value is one of a few words.
_CHOICES = {"feedback": ("motor", "load"), "position_feedback": ("motor", "load"), "structure": ("speed", "cascade")}
#: Fields of a table that no rig file sets (a user's LTI controllers, set by Rig.with_controller).
_PYTHON_ONLY = {"speed_controller", "position_controller"}


def _value_text(value):
    """A value as a rig's source names it: a real number as Python's float repr (``0.5``, not ``np.float64(0.5)``)."""
    real = isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)
    return repr(float(value)) if real else repr(value)


def _table_of(rig, parameter):
    """(table name, key) of a numeric rig value: ``"kp"``, ``"controller.kp"``, ``"load.torque"``."""
    tables = {"plant": rig.plant, "controller": rig.controller, "load": rig.load, "friction": rig.friction}
    if "." in parameter:
        table, key = parameter.split(".", 1)
        found = [(table, key)] if table in tables and tables[table] is not None and hasattr(tables[table], key) else []
    else:
        found = [(table, parameter) for table, value in tables.items()
                 if value is not None and parameter in {f.name for f in dataclasses.fields(value)}]
    numeric = [(t, k) for t, k in found if isinstance(getattr(tables[t], k), float)]
    if len(numeric) != 1:
        names = [f"{t}.{f.name}" for t, v in tables.items() if v is not None for f in dataclasses.fields(v)
                 if isinstance(getattr(v, f.name), float)]
        raise ValueError(f"parameter {parameter!r}: not a numeric value of rig {rig.source}; "
                         f"choose one of: {', '.join(names)}")
    return numeric[0]


def _number(source, table, key, value):
    where = f"{source}: [{table}] {key}"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RigError(f"{where} must be a number, got {value!r}")
    value = float(value)
    if key == "ti" and value == math.inf:  # a P speed controller (TOML: ti = inf)
        return value
    if not math.isfinite(value):
        raise RigError(f"{where} must be finite, got {value!r}" + (" (inf: a P controller)" if key == "ti" else ""))
    if key in _POSITIVE and value <= 0.0:
        raise RigError(f"{where} must be > 0, got {value!r}")
    if value < 0.0 and key not in _SIGNED:
        raise RigError(f"{where} must be >= 0, got {value!r}")
    low, high, unit = RANGES[key]
    if not low <= value <= high:
        unit = f" {unit}" if unit else ""
        raise RigError(f"{where} = {value:g}{unit} is outside the accepted range [{low:g}, {high:g}]{unit}")
    return value


def _table(source, data, name, cls):
    raw = data.get(name)
    if not isinstance(raw, dict):
        raise RigError(f"{source}: [{name}] must be a table")
    fields = {field.name: field for field in dataclasses.fields(cls) if field.name not in _PYTHON_ONLY}
    unknown = sorted(set(raw) - set(fields))
    if unknown:
        raise RigError(f"{source}: unknown key [{name}] {unknown[0]}; allowed: {', '.join(fields)}")
    missing = [key for key, field in fields.items() if field.default is dataclasses.MISSING and key not in raw]
    if missing:
        raise RigError(f"{source}: missing key [{name}] {missing[0]}")
    values = {}
    for key, value in raw.items():
        if key in _CHOICES:
            if value not in _CHOICES[key]:
                words = " or ".join(f'"{word}"' for word in _CHOICES[key])
                raise RigError(f"{source}: [{name}] {key} must be {words}, got {value!r}")
            values[key] = value
        else:
            values[key] = _number(source, name, key, value)
    return cls(**values)


def _check_structure(source, raw):
    """The cascade's keys: ``kv`` with ``structure = "cascade"`` only, and required there."""
    cascade = raw.get("structure", "speed") == "cascade"
    for key in ("kv", "position_feedback"):
        if key in raw and not cascade:
            raise RigError(f'{source}: [controller] {key} needs structure = "cascade" (a position loop around the '
                           f'speed loop); the rig has structure = "{raw.get("structure", "speed")}"')
    if cascade and "kv" not in raw:
        raise RigError(f'{source}: missing key [controller] kv: structure = "cascade" needs the position gain '
                       f"(1/s; speed reference = kv (position reference - position))")


#: Fastest shaft dynamics accepted, 1/s: the mode sqrt(k (1/J_m + 1/J_l)) (rad/s, 1e5 is
#: about 16 kHz) and the damper's rate c (1/J_m + 1/J_l).
MAX_SHAFT_MODE = 1e5


def _check_shaft_mode(source, plant):
    """Refuse a shaft whose mode or damping rate no drive has (a units slip, most likely)."""
    inverse = 1.0 / plant.motor_inertia + 1.0 / plant.load_inertia
    mode, rate = math.sqrt(plant.stiffness * inverse), plant.damping * inverse
    where = f"{source}: [plant] motor_inertia, load_inertia"
    if mode > MAX_SHAFT_MODE:
        raise RigError(f"{where}, stiffness: shaft mode sqrt(k (1/J_m + 1/J_l)) = {mode:.3g} rad/s is above "
                       f"{MAX_SHAFT_MODE:g} rad/s ({MAX_SHAFT_MODE / (2 * math.pi):.0f} Hz); check the units "
                       f"(kg m^2, N m/rad)")
    if rate > MAX_SHAFT_MODE:
        raise RigError(f"{where}, damping: damper rate c (1/J_m + 1/J_l) = {rate:.3g} 1/s is above "
                       f"{MAX_SHAFT_MODE:g} 1/s; check the units (kg m^2, N m s/rad)")


def _check_twist(source, plant, load):
    """Refuse a load torque that would twist the shaft by more than a turn (|T| / k + alpha > 2 pi)."""
    twist = abs(load.torque) / plant.stiffness + plant.half_gap
    if twist > 2.0 * math.pi:
        raise RigError(f"{source}: [load] torque = {load.torque:g} N m twists the shaft by |T| / k + alpha = "
                       f"{twist:.3g} rad, more than a turn ([plant] stiffness = {plant.stiffness:g} N m/rad); "
                       f"check the units")


def _model(source, plant, name):
    """The torque law ``name`` on ``plant``'s shaft, or a :class:`RigError` naming ``source``."""
    if name == "rubber" and plant.rubber_thickness == 0.0:
        raise RigError(f"{source}: model 'rubber' needs [plant] rubber_thickness > 0 (beta, rad); with beta = 0 "
                       f"the rubber law (40) is the phase plane law (23): set beta or choose 'phase-plane'")
    try:
        return make_model(name, **plant.shaft)
    except ValueError as error:
        raise RigError(f"{source}: [plant] {error}") from None


def rig_from_dict(data, source="<dict>"):
    """Build a :class:`Rig` from a dictionary shaped like the rig file.

    Raises
    ------
    RigError
        One line naming ``source`` and the offending key.
    """
    unknown = sorted(set(data) - set(_TABLES))
    if unknown:
        raise RigError(f"{source}: unknown table [{unknown[0]}]; allowed: {', '.join(_TABLES)}")
    if "plant" not in data:
        raise RigError(f"{source}: missing table [plant]")
    plant = _table(source, data, "plant", Plant)
    controller = None
    if "controller" in data:
        controller = _table(source, data, "controller", Controller)
        _check_structure(source, data["controller"])
    if isinstance(data.get("load"), dict) and "coulomb" in data["load"]:
        raise RigError(f"{source}: [load] coulomb is now [friction] coulomb_load (N m, the load side's Coulomb "
                       f"friction); move the key there")
    load = _table(source, data, "load", Load) if "load" in data else Load()
    friction = _table(source, data, "friction", Friction) if "friction" in data else Friction()
    _check_friction(source, friction)
    model = "phase-plane"
    if "model" in data:
        section = data["model"]
        if not isinstance(section, dict):
            raise RigError(f"{source}: [model] must be a table")
        unknown = sorted(set(section) - {"backlash"})
        if unknown:
            raise RigError(f"{source}: unknown key [model] {unknown[0]}; allowed: backlash")
        model = section.get("backlash", model)
        if model not in MODEL_NAMES:
            raise RigError(f"{source}: [model] backlash: unknown model {model!r}; choose one of: {', '.join(MODEL_NAMES)}")
    _check_shaft_mode(source, plant)
    _check_twist(source, plant, load)
    _model(source, plant, model)
    uncertainty = _uncertainty(source, data["uncertainty"], {"plant": plant, "friction": friction, "load": load}) \
        if "uncertainty" in data else Uncertainty()
    return Rig(plant=plant, controller=controller, load=load, model=model, source=source, friction=friction,
               uncertainty=uncertainty)


def _check_friction(source, friction):
    """A breakaway friction needs the Stribeck speed its excess decays over."""
    for side in ("motor", "load"):
        size = getattr(friction, f"breakaway_{side}")
        if size > 0.0 and friction.stribeck_speed == 0.0:
            raise RigError(f"{source}: [friction] breakaway_{side} = {size:g} N m needs stribeck_speed > 0 (rad/s, "
                           f"the speed over which the breakaway excess decays)")


def _uncertainty(source, raw, tables):
    """The ``[uncertainty]`` boxes: each a numeric key of ``tables`` (``[plant]``, ``[friction]``, ``[load]``),
    ``[low, high]`` inside the key's range and holding the rig's value."""
    if not isinstance(raw, dict):
        raise RigError(f"{source}: [uncertainty] must be a table")
    owners = {f.name: (name, table) for name, table in tables.items() for f in dataclasses.fields(table)
              if f.name in RANGES}
    boxes = {}
    for name, box in raw.items():
        where = f"{source}: [uncertainty] {name}"
        if name not in owners:
            raise RigError(f"{where}: not a numeric [plant], [friction] or [load] key; allowed: {', '.join(owners)}")
        if (not isinstance(box, (list, tuple)) or len(box) != 2
                or any(isinstance(end, bool) or not isinstance(end, (int, float)) for end in box)):
            raise RigError(f"{where} must be [low, high], two numbers, got {box!r}")
        low, high = (float(end) for end in box)
        lowest, highest, unit = RANGES[name]
        unit = f" {unit}" if unit else ""
        if not (math.isfinite(low) and math.isfinite(high)):
            raise RigError(f"{where} must be finite, got [{low!r}, {high!r}]")
        if low > high:
            raise RigError(f"{where} = [{low:g}, {high:g}]: low is above high")
        if low < lowest or high > highest:
            raise RigError(f"{where} = [{low:g}, {high:g}]{unit} reaches outside the accepted range "
                           f"[{lowest:g}, {highest:g}]{unit}")
        table, values = owners[name]
        value = getattr(values, name)
        if not low <= value <= high:
            raise RigError(f"{where} = [{low:g}, {high:g}]{unit} excludes the rig's value [{table}] {name} = "
                           f"{value:g}{unit}; the box must hold it")
        boxes[name] = (low, high)
    return Uncertainty(boxes)


def _toml_value(value):
    """A number or a word as TOML: ``repr`` of a float (``inf`` too), a JSON string (a TOML basic string)."""
    return json.dumps(value) if isinstance(value, str) else repr(float(value))


def rig_to_toml(rig, *, comments=None, header=""):
    """The rig file of ``rig``: a text :func:`load_rig` reads back to an equal :class:`Rig` (but its ``source``).

    ``[plant]`` and ``[model]`` in full, ``[controller]`` with the keys
    :meth:`Rig.to_dict` gives, ``[load]`` and ``[friction]`` where they differ from
    their defaults, ``[uncertainty]`` where the rig has boxes; every float as Python's
    ``repr`` (the shortest text that reads back to the same double).

    Parameters
    ----------
    rig : Rig
    comments : dict of str to str, optional
        A trailing comment for a key's line, by key (``"coulomb_load"``, a key of the
        value tables) or by ``"table.key"`` (``"uncertainty.load_inertia"``); one line each.
    header : str
        Comment lines put first (each line after ``#`` and a space).

    Returns
    -------
    str

    Examples
    --------
    >>> rig = rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
    ...     "half_gap": 0.05}, "friction": {"coulomb_load": 4.0}})
    >>> text = rig_to_toml(rig, comments={"coulomb_load": "measured"})
    >>> print(text[text.index("[friction]"):text.index("[model]")].strip())
    [friction]
    coulomb_motor = 0.0
    coulomb_load = 4.0  # measured
    viscous_motor = 0.0
    viscous_load = 0.0
    breakaway_motor = 0.0
    breakaway_load = 0.0
    stribeck_speed = 0.0
    >>> rig_from_dict(tomllib.loads(rig_to_toml(rig))) == rig
    True
    """
    comments = dict(comments or {})
    data = rig.to_dict()
    written = {"plant": True, "controller": rig.controller is not None, "load": rig.load != Load(),
               "friction": rig.friction != Friction(), "model": True, "uncertainty": bool(rig.uncertainty)}
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    for table in ("plant", "controller", "load", "friction", "model", "uncertainty"):
        if not written[table]:
            continue
        if lines:
            lines.append("")
        lines.append(f"[{table}]")
        for key, value in data[table].items():
            text = ("[" + ", ".join(map(_toml_value, value)) + "]" if table == "uncertainty"
                    else _toml_value(value))
            note = comments.get(f"{table}.{key}", comments.get(key) if table != "uncertainty" else None)
            lines.append(f"{key} = {text}" + (f"  # {' '.join(str(note).split())}" if note else ""))
    return "\n".join(lines) + "\n"


def write_rig(rig, path, *, comments=None, header=""):
    """Write ``rig`` as a rig file (:func:`rig_to_toml`, UTF-8) to ``path``.

    Parameters
    ----------
    rig : Rig
    path : str or Path
    comments : dict of str to str, optional
        Trailing comments by key (:func:`rig_to_toml`).
    header : str
        Comment lines put first.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> rig = rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
    ...     "half_gap": 0.05}, "uncertainty": {"load_inertia": [4.0, 8.0]}})
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "rig.toml"
    >>> write_rig(rig, path)
    >>> load_rig(path).uncertainty["load_inertia"]
    (4.0, 8.0)
    """
    Path(path).write_text(rig_to_toml(rig, comments=comments, header=header), encoding="utf-8")


def load_rig(path):
    """Read and validate a rig file.

    Parameters
    ----------
    path : str or Path
        TOML file with ``[plant]``, optional ``[controller]``, ``[load]`` and ``[model]`` tables.

    Returns
    -------
    Rig

    Raises
    ------
    RigError
        Missing file, not UTF-8, malformed TOML, unknown or missing keys, values
        negative, non-finite or outside :data:`RANGES`, ``rubber`` without
        ``rubber_thickness``: one line naming the file and the key.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "rig.toml"
    >>> _ = path.write_text('''
    ... [plant]
    ... motor_inertia = 0.4
    ... load_inertia = 5.6
    ... stiffness = 5895.0
    ... damping = 3.0
    ... half_gap = 0.05
    ... ''')
    >>> rig = load_rig(path)
    >>> rig.plant.stiffness, rig.model
    (5895.0, 'phase-plane')

    From the repository root, the bundled rigs load the same way:
    ``load_rig("examples/paper_rig.toml")``.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise RigError(f"{path}: cannot read rig file ({error.strerror})") from None
    except UnicodeDecodeError as error:
        raise RigError(f"{path}: not a UTF-8 text file (byte 0x{error.object[error.start]:02x} at offset "
                       f"{error.start}); save the rig file as UTF-8") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise RigError(f"{path}: malformed TOML: {error}") from None
    return rig_from_dict(data, source=str(path))
