"""Figure 2, Figure 3 and Table I of Nordin, Galic and Gutman (1997), recomputed.

* Figure 2: torque maps over the phase plane (theta_d, dtheta_d) for alpha = 1 rad,
  k / c = 0.1 1/s, beta = 0.5 rad: (a) the release regions of the exact model (5),
  (b) the phase plane law (23), (c) the dead-zone (26) with its pull areas A1, A2,
  (d) the rubber law (40).
* Figure 3 and Table I: the two-mass drive of Section 2.4,
  ``J_m w_m' = -T - T_preload + a sin(2 pi f t)``, ``J_l w_l' = T + T_preload``
  (T_m = T_l = 0), J_m = 0.4, J_l = 5.6, k = 5895, c = 0.01 k, alpha = 0.0025,
  f = 20 Hz, started at rest with theta_b = 0.

Choices the paper leaves open (reading notes, item 9), made here and documented:

* **One simulation, driven by the phase plane law.**  The paper computes "the
  exact torque, (26) and (27)" from the theta_d, dtheta_d of the simulation, so
  the remaining law, (23), drives it.  The exact torque along that trajectory is
  the limited integrator (14) (:meth:`~backlash_df.models.ExactModel.torque_along`,
  theta_b = 0 at t = 0); (26) and (27) are evaluated as functions of the state.
  ``driver="exact"`` runs the same comparison on the exact model's own trajectory.
* **Which cycle.**  The cycle after ``warmup_cycles`` = 40 periods (2 s), by then
  periodic to the printed digits (``TorqueComparison.periodicity``).
* **Setups** (:data:`SETUPS`): the printed T_preload = a_dist = 19 N m makes the
  shaft bounce on one side of the gap; a 0.5 N m preload lets it cross the gap;
  a third keeps that crossing but with c = 0.1 k, so the shaft cannot relax
  between contacts (k / c = 10 1/s against a 0.05 s cycle) and the phase plane
  law's re-contact approximation (ii) of Remark 1 shows what it costs.

Integrals over the cycle are exact for the driving law (the load's momentum
balance, ``J_l dw_l = (T + T_preload) dt``) and, for the laws evaluated along the
trajectory, second order in the step: each jump at a mode change is located
between samples on the cubic Hermite interpolant of theta_d (:func:`integrated_torque`).
The printed numbers are not targets: in a periodic steady state any law that
drives the drive integrates to ``-T_preload x period`` (item 9).
"""

import csv
import dataclasses
import io
import math

import numpy as np

from ._json import json_ready
from ._laws import exact_step, mode_torque
from .config import Plant
from .models import make_model
from .plotting import ResultPlot, axes_or_new, legend_beside
from .render.reproduce import LAW_LABELS, TABLE_ONE_QUANTITY, table_one_text
from .simulation import simulate_two_mass

__all__ = [
    "PAPER_PLANT",
    "COMPARED_MODELS",
    "Setup",
    "SETUPS",
    "integrated_torque",
    "TorqueComparison",
    "compare_torques",
    "TableOne",
    "table1",
    "figure2_maps",
    "figure2",
    "LAW_NAMES",
]

#: The Figure 3 drive of Section 2.4 (c = 0.01 k).
PAPER_PLANT = Plant(motor_inertia=0.4, load_inertia=5.6, stiffness=5895.0, damping=58.95, half_gap=0.0025)

#: Laws compared with the exact model in Figure 3 and Table I (the paper's three, then two more).
COMPARED_MODELS = ("phase-plane", "damped-dead-zone", "revised-dead-zone", "elasto-backlash", "dead-zone")

#: Laws that can drive the Figure 3 simulation.
LAW_NAMES = ("exact",) + COMPARED_MODELS


@dataclasses.dataclass(frozen=True)
class Setup:
    """One Table I experiment on the Figure 3 drive.

    Attributes
    ----------
    name : str
    preload : float
        T_preload, N m: ``-T_preload`` on the motor, ``+T_preload`` on the load.
    amplitude : float
        a_dist, N m, of the sine disturbance on the motor.
    frequency : float
        Disturbance frequency, Hz (one cycle = ``1 / frequency`` s).
    damping_ratio : float
        c / k, s (0.01 in the paper).
    description : str
    """

    name: str
    preload: float
    amplitude: float = 19.0
    frequency: float = 20.0
    damping_ratio: float = 0.01
    description: str = ""

    @property
    def period(self):
        """Duration of one disturbance cycle, s."""
        return 1.0 / self.frequency

    def plant(self, base=PAPER_PLANT):
        """``base`` with c = damping_ratio k."""
        return dataclasses.replace(base, damping=self.damping_ratio * base.stiffness)


#: Documented Table I setups (see the module notes).
SETUPS = {
    "one-sided": Setup(
        "one-sided", preload=19.0,
        description="printed T_preload = a_dist = 19 N m: bounces on one side, never crosses the gap",
    ),
    "crossing": Setup(
        "crossing", preload=0.5,
        description="T_preload = 0.5 N m: crosses the gap twice a cycle, relaxes between contacts",
    ),
    "crossing-slow-relaxation": Setup(
        "crossing-slow-relaxation", preload=0.5, damping_ratio=0.1,
        description="as crossing with c = 0.1 k: the shaft cannot relax between contacts",
    ),
}

DEFAULT_DT = 2e-5


# --------------------------------------------------------------------------- integrals


def _hermite(x0, x1, v0, v1, h, s):
    """theta_d and its rate at fraction s of a step, cubic Hermite from end values."""
    s2, s3 = s * s, s * s * s
    x = (2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * h * v0 + (3 * s2 - 2 * s3) * x1 + (s3 - s2) * h * v1
    v = ((6 * s2 - 6 * s) * x0 + (6 * s - 6 * s2) * x1) / h + (3 * s2 - 4 * s + 1) * v0 + (3 * s2 - 2 * s) * v1
    return x, v


_GAUSS_S, _GAUSS_W = np.polynomial.legendre.leggauss(4)


def _piece(torque_in_mode, mode, ends, a, b):
    """Gauss-Legendre integral of a frozen mode's torque over fractions [a, b] of a step."""
    x0, x1, v0, v1, h = ends
    s = a + (b - a) * 0.5 * (_GAUSS_S + 1.0)
    x, v = _hermite(x0, x1, v0, v1, h, s)
    values = [torque_in_mode(mode, xi, vi) for xi, vi in zip(x, v)]
    return 0.5 * (b - a) * h * float(np.dot(_GAUSS_W, values))


def _switching_integral(torque_in_mode, mode_at, mode0, mode1, ends):
    """Integral over one step in which the mode changes: bisect for the switch, integrate both sides."""
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if mode_at(mid) == mode0:
            lo = mid
        else:
            hi = mid
    return _piece(torque_in_mode, mode0, ends, 0.0, hi) + _piece(torque_in_mode, mode1, ends, hi, 1.0)


def integrated_torque(model, time, theta_d, dtheta_d, *, theta_b0=0.0, start=0):
    """Integral of a law's torque along a sampled trajectory, jumps located between samples.

    Steps without a change of contact mode use the trapezoid rule; in a step
    where the mode changes, the switch is found by bisection on the cubic Hermite
    interpolant of theta_d (its derivative interpolates dtheta_d) and each side
    is integrated with its own frozen-mode torque.  Second order in the step.

    Parameters
    ----------
    model : BacklashModel
        A static law (evaluated as a function of the state) or the exact model
        (theta_b integrated by the limited integrator (14) from ``theta_b0``).
    time, theta_d, dtheta_d : array_like
        Uniform samples: s, rad, rad/s.
    theta_b0 : float
        Exact model only: theta_b at ``time[0]``, rad.
    start : int
        Integrate from ``time[start]`` to ``time[-1]`` (the exact model's state is
        still integrated from ``time[0]``).

    Returns
    -------
    float
        N m s.

    Examples
    --------
    >>> model = make_model("dead-zone", stiffness=2.0, half_gap=1.0)
    >>> t = np.linspace(0.0, 3.0, 31)   # theta_d = t: T = 2 (t - 1) after t = 1
    >>> round(float(integrated_torque(model, t, t, np.ones_like(t))), 12)   # = (3 - 1)^2
    4.0
    """
    time = np.asarray(time, dtype=float)
    x = np.asarray(theta_d, dtype=float)
    v = np.asarray(dtheta_d, dtype=float)
    h = float(time[1] - time[0])
    if model.is_static:
        k, c, alpha, beta = model.params
        law = model.law
        modes = model.mode(x, v)
        torque = model.torque(x, v)

        def torque_in_mode(mode, xi, vi):
            return mode_torque(law, int(mode), xi, vi, k, c, alpha, beta)

        def mode_at_factory(i, ends):
            return lambda s: int(model.mode(*_hermite(*ends, s)))
    else:
        k, c, alpha, _ = model.params
        torque, theta_b = model.torque_along(time, x, v, theta_b0=theta_b0)
        modes = np.sign(torque).astype(int)

        def torque_in_mode(mode, xi, vi):
            return 0.0 if mode == 0 else k * (xi - mode * alpha) + c * vi

        def mode_at_factory(i, ends):
            if modes[i] != 0:  # in contact until the release condition fails
                return lambda s: modes[i] if modes[i] * torque_in_mode(modes[i], *_hermite(*ends, s)) > 0 else 0

            def free(s):  # free until theta_b, by (14), reaches a side
                xs, vs = _hermite(*ends, s)
                theta = exact_step(theta_b[i], x[i], v[i], xs, vs, s * h, k, c, alpha)
                return 0 if abs(theta) < alpha else int(math.copysign(1.0, theta))

            return free

    total = 0.0
    for i in range(start, len(time) - 1):
        if modes[i] == modes[i + 1]:
            total += 0.5 * h * (torque[i] + torque[i + 1])
            continue
        ends = (x[i], x[i + 1], v[i], v[i + 1], h)
        total += _switching_integral(torque_in_mode, mode_at_factory(i, ends), modes[i], modes[i + 1], ends)
    return float(total)


# --------------------------------------------------------------------------- Figure 3 / Table I


@dataclasses.dataclass(frozen=True)
class TorqueComparison:
    """Torques of several laws along one simulated cycle (Figure 3, one column of Table I).

    Attributes
    ----------
    setup : Setup
    driver : str
        The law that drives the simulation; the others are evaluated along it.
    time, theta_d, dtheta_d : ndarray
        The compared cycle: s, rad, rad/s.
    torque : dict of str to ndarray
        Shaft torque of each law on that cycle, N m (``"exact"`` included).
    integral : dict of str to float
        Integral of each torque over the cycle, N m s.
    periodicity : float
        Largest change of the state over the cycle before, relative to its range
        (0 for an exactly periodic response).
    dt : float
        Simulation step, s.
    """

    setup: Setup
    driver: str
    time: np.ndarray
    theta_d: np.ndarray
    dtheta_d: np.ndarray
    torque: dict
    integral: dict
    periodicity: float
    dt: float

    def error_percent(self, name):
        """Integral of ``name`` against the exact one, per cent (None if the exact one is 0)."""
        exact = self.integral["exact"]
        return None if exact == 0.0 else 100.0 * (self.integral[name] / exact - 1.0)

    def rms_error(self, name):
        """RMS of ``T_name - T_exact`` over the cycle, N m."""
        difference = self.torque[name][:-1] - self.torque["exact"][:-1]
        return float(np.sqrt(np.mean(difference**2)))

    def rms_error_percent(self, name):
        """:meth:`rms_error` relative to the RMS of the exact torque, per cent (None if that is 0)."""
        scale = float(np.sqrt(np.mean(self.torque["exact"][:-1] ** 2)))
        return None if scale == 0.0 else 100.0 * self.rms_error(name) / scale

    def __repr__(self):
        errors = ", ".join(f"{name} {self.error_percent(name):+.2f} %" for name in self.torque
                           if name != "exact" and self.error_percent(name) is not None)
        return f"<TorqueComparison {self.setup.name}, driven by {self.driver}: integral errors {errors or 'n/a'}>"

    def to_dict(self):
        """JSON-ready: setup, driver, the cycle (s, rad, rad/s), each law's torque (N m) and integral (N m s)."""
        return json_ready({"setup": dataclasses.asdict(self.setup), "driver": self.driver, "dt": self.dt,
                           "periodicity": self.periodicity, "time": self.time, "theta_d": self.theta_d,
                           "dtheta_d": self.dtheta_d, "torque": self.torque, "integral": self.integral})

    def plot(self, ax=None, names=("exact", "phase-plane", "damped-dead-zone", "revised-dead-zone")):
        """Figure 3: the torques of ``names`` over the cycle.

        Returns
        -------
        ResultPlot
            One panel; the legend beside it.
        """
        figure, axes = axes_or_new(ax, figsize=(9.5, 4), layout="constrained")
        ax = axes[0]
        t_ms = 1e3 * (self.time - self.time[0])
        styles = {"exact": dict(color="k", lw=2.5, alpha=0.5)}
        for name in names:
            ax.plot(t_ms, self.torque[name], label=LAW_LABELS[name], **styles.get(name, dict(lw=1.2)))
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_xlabel("time in cycle (ms)")
        ax.set_ylabel("shaft torque T (N m)")
        ax.set_title(f"{self.setup.name}: simulated with the {self.driver} law", fontsize="medium")
        legend = legend_beside(ax, fontsize=8)
        return ResultPlot(figure, axes, legend)


def compare_torques(setup="one-sided", *, driver="phase-plane", dt=DEFAULT_DT, warmup_cycles=40,
                    models=COMPARED_MODELS, plant=PAPER_PLANT):
    """Simulate a :class:`Setup` with ``driver`` and evaluate every law along its last cycle.

    Parameters
    ----------
    setup : str or Setup
        A key of :data:`SETUPS` or a setup.
    driver : str
        Law that drives the simulation (default ``"phase-plane"``, as in the paper).
    dt : float
        Simulation step, s.
    warmup_cycles : int
        Disturbance cycles simulated before the compared one.
    models : sequence of str
        Static laws evaluated along the trajectory (the exact model always is).
    plant : Plant
        Inertias, k and alpha (c comes from the setup's damping ratio).

    Returns
    -------
    TorqueComparison
    """
    setup = _setup(setup)
    if driver not in LAW_NAMES:
        raise ValueError(f"unknown driver model {driver!r}; choose one of: {', '.join(LAW_NAMES)}")
    plant = setup.plant(plant)
    n_cycle = int(round(setup.period / dt))
    if n_cycle < 20 or not math.isclose(n_cycle * dt, setup.period, rel_tol=1e-9):
        raise ValueError(f"dt = {dt!r} s must divide the cycle of {setup.period!r} s into at least 20 steps")
    result = simulate_two_mass(
        plant, driver, (warmup_cycles + 1) * setup.period, dt,
        motor_torque=lambda t: -setup.preload + setup.amplitude * np.sin(2 * np.pi * setup.frequency * t),
        load_torque=setup.preload,
    )
    first = warmup_cycles * n_cycle
    window = slice(first, first + n_cycle + 1)
    x, v, time = result.theta_d, result.dtheta_d, result.time
    torque, integral = {}, {}
    for name in dict.fromkeys(("exact", driver, *models)):
        model = make_model(name, **plant.shaft)
        if name == driver:
            torque[name] = result.torque[window]
            w_l = result.state("load_speed")  # J_l dw_l/dt = T + T_preload
            integral[name] = plant.load_inertia * (w_l[first + n_cycle] - w_l[first]) - setup.preload * setup.period
        elif model.is_static:
            torque[name] = model.torque(x[window], v[window])
            integral[name] = integrated_torque(model, time[window], x[window], v[window])
        else:
            torque[name] = model.torque_along(time, x, v)[0][window]
            integral[name] = integrated_torque(model, time, x, v, start=first)
    previous = result.states[first - n_cycle:first + 1]
    current = result.states[window]
    spread = np.ptp(current, axis=0)
    periodicity = float(np.max(np.abs(current - previous).max(axis=0) / np.where(spread > 0, spread, 1.0)))
    return TorqueComparison(
        setup=setup, driver=driver, time=time[window], theta_d=x[window], dtheta_d=v[window],
        torque=torque, integral=integral, periodicity=periodicity, dt=dt,
    )


def _setup(setup):
    if isinstance(setup, Setup):
        return setup
    if setup not in SETUPS:
        raise ValueError(f"unknown setup {setup!r}; choose one of: {', '.join(SETUPS)}")
    return SETUPS[setup]


@dataclasses.dataclass(frozen=True)
class TableOne:
    """Table I recomputed: one :class:`TorqueComparison` per setup.

    ``rows`` are dictionaries with keys ``setup``, ``model``, ``integral``
    (N m s), ``error_percent`` (integral against the exact one),
    ``rms_error`` (N m) and ``rms_error_percent`` (of the exact torque's RMS).
    """

    comparisons: tuple

    @property
    def rows(self):
        """Table rows, the exact model first in each setup."""
        rows = []
        for comparison in self.comparisons:
            for name in comparison.torque:
                exact = name == "exact"
                rows.append(dict(
                    setup=comparison.setup.name,
                    model=name,
                    integral=comparison.integral[name],
                    error_percent=None if exact else comparison.error_percent(name),
                    rms_error=None if exact else comparison.rms_error(name),
                    rms_error_percent=None if exact else comparison.rms_error_percent(name),
                ))
        return rows

    def to_text(self):
        """The table as aligned text, one block per setup, after a line saying what is integrated
        (:func:`~backlash_df.render.reproduce.table_one_text`)."""
        return table_one_text(self)

    def to_csv(self):
        """The rows as CSV text; each numeric column's name ends with its unit
        (``integral_N_m_s``, ``error_percent``, ``rms_error_N_m``, ``rms_error_percent``)."""
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow([f"{key}_{_CSV_UNITS[key]}" if _CSV_UNITS.get(key) else key for key in self.rows[0]])
        writer.writerows([["" if value is None else value for value in row.values()] for row in self.rows])
        return buffer.getvalue()

    def to_dict(self):
        """Setups and rows, JSON-ready (SI units, listed under ``units``): ``reproduce table1 --out x.json``."""
        setups = [dict(dataclasses.asdict(c.setup), driver=c.driver, dt=c.dt, periodicity=c.periodicity)
                  for c in self.comparisons]
        units = {"integral": "N m s", "error_percent": "%", "rms_error": "N m", "rms_error_percent": "%"}
        return dict(quantity=TABLE_ONE_QUANTITY, units=units, setups=setups, rows=self.rows)

    def __repr__(self):
        return f"<TableOne: {len(self.comparisons)} setups ({', '.join(c.setup.name for c in self.comparisons)})>"

    def __str__(self):
        return self.to_text()

    def plot(self, ax=None):
        """Bars of each law's error against the exact model, grouped by setup.

        Top: error of the cycle integral of T (the printed Table I column), per
        cent; bottom: RMS of T - T_exact over the cycle, per cent of the exact
        torque's RMS.  A bar is missing where the exact integral is zero.

        Returns
        -------
        ResultPlot
            Axes ``[integral error, RMS error]``; the legend beside the first.
        """
        figure, axes = axes_or_new(ax, (2, 1), sharex=True, figsize=(9.5, 6), layout="constrained")
        setups = [comparison.setup.name for comparison in self.comparisons]
        names = list(dict.fromkeys(row["model"] for row in self.rows if row["model"] != "exact"))
        width = 0.8 / max(len(names), 1)
        for ax, key, label in ((axes[0], "error_percent", "integral error (%)"),
                               (axes[1], "rms_error_percent", "RMS error (% of exact)")):
            for j, name in enumerate(names):
                values = [next((row[key] for row in self.rows if row["setup"] == setup and row["model"] == name),
                               None) for setup in setups]
                heights = [np.nan if value is None else value for value in values]
                ax.bar(np.arange(len(setups)) + (j - 0.5 * (len(names) - 1)) * width, heights, width,
                       label=LAW_LABELS[name])
            ax.axhline(0.0, color="0.4", lw=0.6)
            ax.set_ylabel(label)
            ax.grid(True, axis="y", alpha=0.3)
        axes[1].set_xticks(np.arange(len(setups)), setups)
        axes[0].set_title("Table I: each law along the simulated cycle against the exact model (1), (14)",
                          fontsize="medium")
        legend = legend_beside(axes[0], fontsize=8)
        return ResultPlot(figure, axes, legend)


_CSV_UNITS = {"integral": "N_m_s", "rms_error": "N_m"}  # the other numeric columns name their unit (percent)


def table1(setups=tuple(SETUPS), *, driver="phase-plane", dt=DEFAULT_DT, **kwargs):
    """Table I on each setup: integrated torque and error of every law against the exact one.

    Parameters
    ----------
    setups : sequence of str or Setup
    driver, dt, **kwargs
        Passed to :func:`compare_torques`.

    Returns
    -------
    TableOne
    """
    return TableOne(tuple(compare_torques(setup, driver=driver, dt=dt, **kwargs) for setup in setups))


# --------------------------------------------------------------------------- Figure 2


FIGURE2_SHAFT = dict(stiffness=1.0, damping=10.0, half_gap=1.0, rubber_thickness=0.5)  # k / c = 0.1 1/s


def figure2_maps(n=301, x_max=4.0, v_max=0.4, shaft=FIGURE2_SHAFT):
    """The data of Figure 2 on an ``n`` x ``n`` grid of the phase plane.

    Returns
    -------
    dict
        ``x``, ``v`` (grids, rad and rad/s); ``regions``: (5) as +1 on ``A_+``
        (T = 0 or right contact), 0 on the release set ``A_r`` (T = 0), -1 on ``A_-``;
        ``torque``: the phase plane (23), dead-zone (26) and rubber (40) maps,
        N m; ``pull``: where (26) pulls (areas A1, A2).
    """
    x, v = np.meshgrid(np.linspace(-x_max, x_max, n), np.linspace(-v_max, v_max, n))
    k, c, alpha = shaft["stiffness"], shaft["damping"], shaft["half_gap"]
    y = k * x + c * v
    regions = np.where(y >= k * alpha, 1, np.where(y <= -k * alpha, -1, 0))
    torque = {name: make_model(name, **shaft).torque(x, v) for name in ("phase-plane", "damped-dead-zone", "rubber")}
    dead = torque["damped-dead-zone"]
    pull = ((x > alpha) & (dead < 0)) | ((x < -alpha) & (dead > 0))
    return dict(x=x, v=v, regions=regions, torque=torque, pull=pull, shaft=dict(shaft))


def figure2(n=301, maps=None):
    """Figure 2 (a)-(d) as a matplotlib figure; returns ``(fig, axes)``."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap, TwoSlopeNorm

    maps = figure2_maps(n) if maps is None else maps
    x, v = maps["x"], maps["v"]
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5), sharex=True, sharey=True, constrained_layout=True)
    regions = ListedColormap(["#9ecae1", "#eeeeee", "#fdae6b"])
    axes[0, 0].pcolormesh(x, v, maps["regions"], cmap=regions, vmin=-1.5, vmax=1.5, shading="auto")
    axes[0, 0].set_title("(a) exact model (5): A_- | A_r (T = 0) | A_+")
    for label, xy in (("A_r", (0.0, 0.0)), ("A_+", (2.5, 0.2)), ("A_-", (-2.5, -0.2))):
        axes[0, 0].annotate(label, xy, ha="center")
    limit = max(np.abs(t).max() for t in maps["torque"].values())
    norm = TwoSlopeNorm(0.0, -limit, limit)
    panels = (("phase-plane", axes[0, 1], "(b) phase plane (23)"),
              ("damped-dead-zone", axes[1, 0], "(c) dead-zone (26): hatched A1, A2 pull"),
              ("rubber", axes[1, 1], "(d) rubber (40)"))
    for name, ax, title in panels:
        mesh = ax.pcolormesh(x, v, maps["torque"][name], cmap="RdBu_r", norm=norm, shading="auto")
        ax.contour(x, v, (maps["torque"][name] != 0).astype(float), levels=[0.5], colors="k", linewidths=0.6)
        ax.set_title(title)
    axes[1, 0].contourf(x, v, maps["pull"].astype(float), levels=[0.5, 1.5], hatches=["//"], colors="none")
    fig.colorbar(mesh, ax=axes, label="T (N m)", shrink=0.8)
    for ax in axes[1]:
        ax.set_xlabel("theta_d (rad)")
    for ax in axes[:, 0]:
        ax.set_ylabel("dtheta_d/dt (rad/s)")
    shaft = maps["shaft"]
    fig.suptitle(f"Figure 2: alpha = {shaft['half_gap']:g} rad, k/c = {shaft['stiffness'] / shaft['damping']:g} 1/s, "
                 f"beta = {shaft['rubber_thickness']:g} rad")
    return fig, axes
