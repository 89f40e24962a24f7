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

    [controller]               # PI speed loop (optional unless a loop is analysed)
    feedback = "load"          # "motor" or "load"
    kp = 30.0                  # N m s / rad
    ti = 0.5                   # s
    speed_filter = 0.002       # s
    torque_lag = 0.0           # s
    delay = 0.0                # s

    [load]                     # optional
    torque = 0.0               # N m, constant torque applied to the load
    coulomb = 0.0              # N m, Coulomb friction of the driven machine

    [model]
    backlash = "phase-plane"

Every problem is reported as one line naming the file and the key, raised as
:class:`RigError` (a ``ValueError``).
"""

import dataclasses
import math
import tomllib
from pathlib import Path

from .models import MODEL_NAMES, make_model

__all__ = ["Plant", "Controller", "Load", "Rig", "RigError", "load_rig", "rig_from_dict"]


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
class Controller:
    """PI speed controller and the loop's linear elements (SI units)."""

    kp: float  #: proportional gain, N m s/rad
    ti: float  #: integral time, s (Ki = kp / ti)
    feedback: str = "load"  #: "motor" or "load": which speed is measured
    speed_filter: float = 0.0  #: time constant of the first-order speed filter, s
    torque_lag: float = 0.0  #: time constant of the torque (current) loop, s
    delay: float = 0.0  #: dead time in the loop, s

    @property
    def ki(self):
        """Integral gain kp / ti, N m / rad."""
        return self.kp / self.ti


@dataclasses.dataclass(frozen=True)
class Load:
    """What the driven machine applies to the load (SI units, load side)."""

    torque: float = 0.0  #: constant torque applied to the load, N m (gravity, process load)
    coulomb: float = 0.0  #: Coulomb friction of the driven machine, N m


@dataclasses.dataclass(frozen=True)
class Rig:
    """A parsed rig file: plant, optional controller, default backlash model."""

    plant: Plant
    controller: Controller | None = None
    load: Load = Load()
    model: str = "phase-plane"
    source: str = "<dict>"

    def make_model(self, name=None):
        """The rig's shaft as a torque law (default: the ``[model] backlash`` name)."""
        return make_model(name or self.model, **self.plant.shaft)

    def require_controller(self):
        """The controller, or a :class:`RigError` saying the rig has none."""
        if self.controller is None:
            raise RigError(f"{self.source}: no [controller] table; this analysis needs the PI speed loop")
        return self.controller


_POSITIVE = {"motor_inertia", "load_inertia", "stiffness", "half_gap", "kp", "ti", "gear_ratio"}
_SIGNED = {"torque"}  # may be negative: a load torque acts in either direction
_TABLES = {"plant": Plant, "controller": Controller, "load": Load, "model": None}


def _number(source, table, key, value):
    where = f"{source}: [{table}] {key}"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RigError(f"{where} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise RigError(f"{where} must be finite, got {value!r}")
    if key in _POSITIVE and value <= 0.0:
        raise RigError(f"{where} must be > 0, got {value!r}")
    if value < 0.0 and key not in _SIGNED:
        raise RigError(f"{where} must be >= 0, got {value!r}")
    return value


def _table(source, data, name, cls):
    raw = data.get(name)
    if not isinstance(raw, dict):
        raise RigError(f"{source}: [{name}] must be a table")
    fields = {field.name: field for field in dataclasses.fields(cls)}
    unknown = sorted(set(raw) - set(fields))
    if unknown:
        raise RigError(f"{source}: unknown key [{name}] {unknown[0]}; allowed: {', '.join(fields)}")
    missing = [key for key, field in fields.items() if field.default is dataclasses.MISSING and key not in raw]
    if missing:
        raise RigError(f"{source}: missing key [{name}] {missing[0]}")
    values = {}
    for key, value in raw.items():
        if key == "feedback":
            if value not in ("motor", "load"):
                raise RigError(f"{source}: [{name}] feedback must be \"motor\" or \"load\", got {value!r}")
            values[key] = value
        else:
            values[key] = _number(source, name, key, value)
    return cls(**values)


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
    controller = _table(source, data, "controller", Controller) if "controller" in data else None
    load = _table(source, data, "load", Load) if "load" in data else Load()
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
    try:
        make_model(model, **plant.shaft)
    except ValueError as error:
        raise RigError(f"{source}: [plant] {error}") from None
    return Rig(plant=plant, controller=controller, load=load, model=model, source=source)


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
        Missing file, malformed TOML, unknown or missing keys, values negative or
        non-finite: one line naming the file and the key.

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
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise RigError(f"{path}: malformed TOML: {error}") from None
    return rig_from_dict(data, source=str(path))
