"""The drive loops of a rig: the linear part G(s) seen by the backlash, and its time-domain form.

The loop of the rig file's ``[controller]`` table (SI units; the contract page
states it too)::

    J_m dw_m/dt = T_m - T - F_m     J_l dw_l/dt = T + T_l - F_l  dtheta_d/dt = w_m - w_l
    dtheta_l/dt = w_l                                            (cascade: the load angle)
    y = w_m or w_l                  measured speed ("feedback" = "motor" or "load")
    p = theta_m or theta_l          measured position ("position_feedback"; theta_m = theta_d + theta_l)
    y_d(t) = y(t - delay)           dead time on every measured signal (p_d likewise)
    tau_f dy_f/dt = y_d - y_f       first-order speed filter (tau_f = speed_filter)
    w_ref = r                       speed loop: the speed reference
    w_ref = kv (r - p_d)            cascade: r the position reference (or P(s) of a user's LTI)
    e = w_ref - y_f
    u = kp e + (kp / ti) I,  dI/dt = e            PI speed controller (ti = inf: P; or K(s), a user's LTI)
    T_cmd = clip(u, -L, L)          torque limit L = torque_limit (0: none); dI/dt = 0 while
                                    |u| > L and e has the sign of u (clamping anti-windup)
    tau_l dT_m/dt = T_cmd - T_m     first-order torque (current) loop (tau_l = torque_lag)

with the reference ``r`` and the load torque ``T_l`` as external inputs (paper eq. 42
and Figure 3 give the two-mass part) and the friction of each side (the rig's
``[friction]``), ``F(w) = d w + (F_c + F_s exp(-(w / w_s)^2)) sign(w)``, sticking at
rest while the torque on the side stays within ``F_c + F_s``: its viscous part ``d w``
is linear and part of ``G``, its dry part a :class:`~backlash_df.system.Sticking`
of the linear part, outside ``G``.  The filter and lag states exist only when
their time constants are positive, the integrator only for a finite ``ti``.  The
backlash closes the loop through the shaft torque ``T = law(theta_d, dtheta_d)``.
With ``r`` and ``T_l`` constant, a speed loop is invariant to a common speed offset,
so a limit cycle lives around "both speeds at ``r``" with the shaft transmitting
``-T_l``; with ``T_l = 0`` it is centred in the gap (``bias = 0``).

Cutting the loop at the backlash, the linear part from ``T`` to ``-theta_d`` (the
command unsaturated) is ``G(s)``, so that ``T = N(A, w) theta_d`` gives the
harmonic-balance equation ``1 + G(jw) N(A, w) = 0``.  With the speed controller
``C(s) = K(s) e^{-s delay} / (tau_l s + 1)`` (K the PI or a user's), the filter
``F(s) = 1 / (tau_f s + 1)``, the position controller ``Kv(s)`` (kv, a user's, or 0
for a speed loop), ``P_m = 1 / (J_m s + d_m)``, ``P_l = 1 / (J_l s + d_l)`` and the measured
combination ``Kv p + F y = alpha w_m + beta w_l``:

    G = (P_m (1 + C beta P_l) / (1 + C alpha P_m) + P_l) / s

(motor feedback of a speed loop: ``alpha = F, beta = 0``, ``G = (P_m / (1 + C F P_m) +
P_l) / s``; load feedback: ``alpha = 0, beta = F``, ``G = (P_m (1 + C F P_l) + P_l) / s``).
The dead time is exact in :meth:`DriveLoop.frequency_response` and
:meth:`DriveLoop.frd`; a Pade approximation appears only in
:meth:`DriveLoop.transfer_function`, where a rational model is needed.
"""

import dataclasses

import numpy as np

from .system import Command, LinearPart, Sticking, closed_loop_matrix, closed_loop_response, frequency_response

__all__ = ["DriveLoop", "drive_loop"]


@dataclasses.dataclass(frozen=True)
class DriveLoop:
    """The loop of a rig: G(s), its frequency response and its time-domain form.

    Attributes
    ----------
    plant : Plant
        Inertias (the shaft itself is the backlash element, outside G).
    controller : Controller
        Structure (speed loop or cascade), gains or a user's LTI controllers, feedback
        choices, filter, torque lag, dead time and torque limit.
    friction : Friction, optional
        The rig's ``[friction]`` (load-side values); None: none.

    Examples
    --------
    >>> from backlash_df import Plant, Controller
    >>> loop = DriveLoop(Plant(0.4, 5.6, 5895.0, 0.05), Controller(kp=30.0, ti=0.5))
    >>> g = loop.transfer_function()
    >>> bool(abs(g(2j) - loop.frequency_response(2.0)) < 1e-12 * abs(g(2j)))
    True
    """

    plant: "object"
    controller: "object"
    friction: "object" = None

    # ------------------------------------------------------------------ blocks (python-control)

    def controller_tf(self, pade_order=None):
        """C(s) F(s): the speed controller, speed filter, torque lag and (Pade-approximated) dead time.

        Parameters
        ----------
        pade_order : int, optional
            Order of the Pade approximation of the dead time.  Required when the
            rig has a delay (a rational model cannot hold it exactly).

        Returns
        -------
        control.TransferFunction
        """
        import control as ct  # lazy: python-control takes a second to import

        return self._speed_blocks(ct.tf("s"))[0] * self._filter(ct.tf("s")) * self._pade(pade_order)

    def _pade(self, pade_order):
        """The dead time as a Pade TF (1 without one)."""
        import control as ct

        delay = self.controller.delay
        if delay == 0.0:
            return ct.tf(1.0, 1.0)
        if pade_order is None:
            raise ValueError(
                f"the loop has a dead time of {delay!r} s: pass pade_order for a rational model, "
                "or use frequency_response / frd for the exact one"
            )
        return ct.tf(*ct.pade(delay, int(pade_order)))

    def _filter(self, s):
        tau = self.controller.speed_filter
        return 1 / (tau * s + 1) if tau > 0.0 else 1 + 0 * s

    def _speed_blocks(self, s):
        """(C(s) without the dead time, Kv(s)) as TFs or FRDs of the Laplace variable ``s``."""
        ctl = self.controller
        if ctl.speed_controller is not None:
            k = _lti(ctl.speed_controller, s)
        elif np.isfinite(ctl.ti):
            k = ctl.kp * (1 + 1 / (ctl.ti * s))
        else:
            k = ctl.kp + 0 * s
        if ctl.torque_lag > 0.0:
            k = k / (ctl.torque_lag * s + 1)
        if not ctl.cascade:
            kv = 0 * s
        elif ctl.position_controller is not None:
            kv = _lti(ctl.position_controller, s)
        else:
            kv = ctl.kv + 0 * s
        return k, kv

    def _assemble(self, delay, s):
        """G from the blocks (module docs); ``delay`` is e^{-s tau} as a TF or FRD, ``s`` the Laplace variable."""
        ctl = self.controller
        c, kv = self._speed_blocks(s)
        c = c * delay
        f = self._filter(s)
        d_m, d_l = self._viscous()
        p_m = 1 / (self.plant.motor_inertia * s + d_m) if d_m else 1 / (self.plant.motor_inertia * s)
        p_l = 1 / (self.plant.load_inertia * s + d_l) if d_l else 1 / (self.plant.load_inertia * s)
        alpha = (f if ctl.feedback == "motor" else 0 * s) + (kv / s if ctl.position_feedback == "motor" else 0 * s)
        beta = (f if ctl.feedback == "load" else 0 * s) + (kv / s if ctl.position_feedback == "load" else 0 * s)
        return (p_m * (1 + c * beta * p_l) / (1 + c * alpha * p_m) + p_l) / s

    def _viscous(self):
        """The viscous friction coefficients ``(d_m, d_l)`` of the sides, N m s/rad."""
        if self.friction is None:
            return 0.0, 0.0
        return self.friction.viscous_motor, self.friction.viscous_load

    def transfer_function(self, pade_order=None):
        """G(s) from shaft torque T (N m) to -theta_d (rad) as a python-control TF, assembled from blocks.

        Parameters
        ----------
        pade_order : int, optional
            Pade order for the dead time; required only if the rig has one.

        Returns
        -------
        control.TransferFunction
            Exact without dead time; with one, G with ``e^{-s delay}`` replaced by
            its Pade approximation.  The torque command is unsaturated.
        """
        import control as ct

        return ct.minreal(self._assemble(self._pade(pade_order), ct.tf("s")), verbose=False)

    def frd(self, omega):
        """G(jw) as a python-control ``FrequencyResponseData`` assembled from blocks, dead time exact.

        Parameters
        ----------
        omega : array_like
            Frequencies, rad/s (> 0).

        Returns
        -------
        control.FrequencyResponseData
        """
        import control as ct

        omega = _frequencies(omega)
        s = ct.frd(1j * omega, omega)
        return self._assemble(ct.frd(np.exp(-1j * omega * self.controller.delay), omega), s)

    def frequency_response(self, omega):
        """G(jw), complex, from the state-space loop with the dead time exact.

        :func:`backlash_df.system.frequency_response` of :meth:`linear_part`;
        vectorised over ``omega``.

        Parameters
        ----------
        omega : array_like
            Frequencies, rad/s (> 0); any shape.

        Returns
        -------
        ndarray of complex
            Same shape as ``omega``.
        """
        return frequency_response(self.linear_part(), omega)

    # ------------------------------------------------------------------ time domain

    def linear_part(self):
        """The same loop as a :class:`~backlash_df.system.LinearPart`: the loop cut at the backlash.

        States ``theta_d`` (rad), ``motor_speed``, ``load_speed`` (rad/s), then
        ``load_angle`` (rad, cascade), ``integrator`` (rad, the integral of the
        speed error; a finite ``ti``) or ``speed_controller_1 ..`` (a user's
        controller), ``position_controller_1 ..`` (a user's position controller),
        ``filtered_speed`` (rad/s) if ``speed_filter > 0`` and ``motor_torque`` (N m,
        torque-loop output) if ``torque_lag > 0``.  Inputs ``speed_reference``
        (rad/s; ``position_reference``, rad, for a cascade) and ``load_torque`` (N m).
        A dead time delays the measured speed and, in a cascade, the measured
        position (kernel rows ``d``, entering by ``e_d``).  With a torque limit the
        part carries its :class:`~backlash_df.system.Command`.

        Returns
        -------
        LinearPart
        """
        return _Builder(self.plant, self.controller, self.friction).linear_part()

    def command_row(self):
        """The controller's output u (N m, before the torque limit and the torque lag) as a row.

        ``u = row . [z, w, u_d]`` over the states of :meth:`linear_part`, its
        inputs (reference, load torque) and, with a dead time, its delayed
        signals; with a torque limit it is :attr:`~backlash_df.system.Command.row`.

        Returns
        -------
        ndarray, shape (n + 2 + k,)
        """
        return _Builder(self.plant, self.controller).command_row()

    def reference_response(self, omega, stiffness, damping=0.0):
        """The closed loop with the gear in contact, from the reference to the load: complex, dead time exact.

        The shaft is the spring-damper ``T = k theta_d + c dtheta_d``; the
        response is from the speed reference to the load speed (a speed loop) or
        from the position reference to the load angle (a cascade): what the process
        sees, the measured motor speed of a two-mass drive having a notch at the
        anti-resonance ``sqrt(k / J_l)``.  The command unsaturated.

        Parameters
        ----------
        omega : array_like
            Frequencies, rad/s (> 0); any shape.
        stiffness, damping : float
            k (N m/rad) and c (N m s/rad).

        Returns
        -------
        ndarray of complex
            The shape of ``omega``; dimensionless (rad/s per rad/s, or rad per rad).
        """
        part = self.linear_part()
        output = part.state_names.index("load_angle" if self.controller.cascade else "load_speed")
        return closed_loop_response(part, omega, stiffness, damping, output)

    def linear_poles(self, stiffness, damping=0.0):
        """Closed-loop poles with the backlash replaced by the spring ``T = k theta_d + c dtheta_d``.

        Parameters
        ----------
        stiffness, damping : float
            k (N m/rad) and c (N m s/rad).

        Returns
        -------
        ndarray of complex
            Eigenvalues (1/s) of the delay-free loop, the command unsaturated; raises
            if the loop has a dead time.
        """
        part = self.linear_part()
        if part.delay > 0.0:
            raise ValueError("linear_poles: the loop has a dead time (infinitely many poles); use a Pade model")
        return np.linalg.eigvals(closed_loop_matrix(part, stiffness, damping))


def _lti(block, s):
    """A user's :class:`~backlash_df.config.LtiBlock` as a TF (``s`` a TF) or FRD (``s`` an FRD)."""
    import control as ct

    a, b, c, d = block.matrices()
    if isinstance(s, ct.FrequencyResponseData):
        return ct.frd(block.frequency_response(s.omega), s.omega)
    return ct.tf(ct.ss(a, b, c, d)) if block.order else ct.tf(d[0, 0], 1.0)


class _Builder:
    """The rows of every signal of the loop over ``[z (n), r, T_l, T, delayed (k)]`` (module docs)."""

    def __init__(self, plant, ctl, friction=None):
        self.plant, self.ctl, self.friction = plant, ctl, friction
        names = ["theta_d", "motor_speed", "load_speed"]
        if ctl.cascade:
            names.append("load_angle")
        if ctl.speed_controller is not None:
            names += [f"speed_controller_{i + 1}" for i in range(ctl.speed_controller.order)]
        elif np.isfinite(ctl.ti):
            names.append("integrator")
        if ctl.cascade and ctl.position_controller is not None:
            names += [f"position_controller_{i + 1}" for i in range(ctl.position_controller.order)]
        if ctl.speed_filter > 0.0:
            names.append("filtered_speed")
        if ctl.torque_lag > 0.0:
            names.append("motor_torque")
        self.names = names
        self.n = len(names)
        self.k = (2 if ctl.cascade else 1) if ctl.delay > 0.0 else 0
        self.width = self.n + 3 + self.k
        self.R, self.TL, self.T = self.n, self.n + 1, self.n + 2

    def unit(self, i, scale=1.0):
        row = np.zeros(self.width)
        row[i] = scale
        return row

    def state(self, name):
        return self.unit(self.names.index(name))

    def _lti_rows(self, block, prefix, signal, rates):
        """Rows of a user's block's output; its states' rates added to ``rates``."""
        a, b, c, d = block.matrices()
        states = [self.state(f"{prefix}_{i + 1}") for i in range(block.order)]
        for i in range(block.order):
            rates[f"{prefix}_{i + 1}"] = sum((a[i, j] * states[j] for j in range(block.order)), b[i, 0] * signal)
        return sum((c[0, j] * states[j] for j in range(block.order)), d[0, 0] * signal)

    def _controller(self):
        """``(u, error, integrator, measured, rates)``: the controller's output and speed error as rows, the
        clamped integrator's index (-1: none), the measured signals' rows and the controller states' rates."""
        ctl, n = self.ctl, self.n
        speed = self.state("motor_speed" if ctl.feedback == "motor" else "load_speed")
        position = None
        if ctl.cascade:
            position = self.state("load_angle") + (self.state("theta_d") if ctl.position_feedback == "motor" else 0.0)
        measured = [speed] + ([position] if ctl.cascade else [])
        delayed = [self.unit(n + 3 + j) for j in range(self.k)] or measured
        y_f = self.state("filtered_speed") if ctl.speed_filter > 0.0 else delayed[0]
        rates = {}
        if not ctl.cascade:
            reference = self.unit(self.R)
        elif ctl.position_controller is not None:
            reference = self._lti_rows(ctl.position_controller, "position_controller", self.unit(self.R) - delayed[1],
                                       rates)
        else:
            reference = ctl.kv * (self.unit(self.R) - delayed[1])
        error = reference - y_f
        integrator = -1
        if ctl.speed_controller is not None:
            u = self._lti_rows(ctl.speed_controller, "speed_controller", error, rates)
        elif np.isfinite(ctl.ti):
            integrator = self.names.index("integrator")
            u = ctl.kp * error + ctl.ki * self.state("integrator")
            rates["integrator"] = error
        else:
            u = ctl.kp * error
        if ctl.speed_filter > 0.0:
            rates["filtered_speed"] = (delayed[0] - y_f) / ctl.speed_filter
        return u, error, integrator, measured, rates

    def _over(self):
        """The columns a command row spans, ``[z, w, u_d]``: u does not depend on the shaft torque T."""
        return [*range(self.n), self.R, self.TL, *range(self.n + 3, self.n + 3 + self.k)]

    def command_row(self):
        """The controller's output u (N m) as a row over ``[z, w, u_d]``."""
        return self._controller()[0][self._over()]

    def linear_part(self):
        ctl, plant, n = self.ctl, self.plant, self.n
        u, error, integrator, measured, rates = self._controller()
        motor_torque = self.state("motor_torque") if ctl.torque_lag > 0.0 else u
        rates.update({
            "theta_d": self.state("motor_speed") - self.state("load_speed"),
            "motor_speed": (motor_torque - self.unit(self.T)) / plant.motor_inertia,
            "load_speed": (self.unit(self.T) + self.unit(self.TL)) / plant.load_inertia,
        })
        friction = self.friction
        if friction is not None:
            for side, inertia in (("motor", plant.motor_inertia), ("load", plant.load_inertia)):
                viscous = getattr(friction, f"viscous_{side}")
                if viscous:
                    rates[f"{side}_speed"] = rates[f"{side}_speed"] - viscous / inertia * self.state(f"{side}_speed")
        if ctl.cascade:
            rates["load_angle"] = self.state("load_speed")
        if ctl.torque_lag > 0.0:
            rates["motor_torque"] = (u - motor_torque) / ctl.torque_lag
        table = np.array([rates[name] for name in self.names])
        delayed_columns = list(range(n + 3, n + 3 + self.k))
        command = None
        if ctl.torque_limit > 0.0:
            column = self.state("motor_torque")[:n] / ctl.torque_lag if ctl.torque_lag > 0.0 else \
                self.state("motor_speed")[:n] / plant.motor_inertia
            over = self._over()
            command = Command(column=column, row=u[over], limit=ctl.torque_limit, integrator=integrator,
                              error=error[over])
        return LinearPart(
            A=table[:, :n],
            b=table[:, self.T],
            E=table[:, [self.R, self.TL]],
            c_x=self.state("theta_d")[:n],
            c_v=rates["theta_d"][:n],
            state_names=tuple(self.names),
            input_names=("position_reference" if ctl.cascade else "speed_reference", "load_torque"),
            delay=ctl.delay,
            d=np.array([row[:n] for row in measured]) if self.k else None,
            e_d=table[:, delayed_columns] if self.k else None,
            command=command,
            sticking=self._sticking(),
        )

    def _sticking(self):
        """The dry friction of the sides that have one (:class:`~backlash_df.system.Sticking`), None without."""
        friction, plant = self.friction, self.plant
        dry = () if friction is None else friction.dry
        sides = [side for side in ("motor", "load") if any(key.endswith(f"_{side}") for key in dry)]
        if not sides:
            return None
        inertia = {"motor": plant.motor_inertia, "load": plant.load_inertia}
        return Sticking(
            names=tuple(sides),
            index=tuple(self.names.index(f"{side}_speed") for side in sides),
            column=[self.state(f"{side}_speed")[:self.n] / inertia[side] for side in sides],
            coulomb=[getattr(friction, f"coulomb_{side}") for side in sides],
            breakaway=[getattr(friction, f"breakaway_{side}") for side in sides],
            stribeck_speed=[friction.stribeck_speed if friction.stribeck_speed > 0.0 else 1.0 for side in sides],
        )


def drive_loop(rig, *, dry_friction=False):
    """The :class:`DriveLoop` of a rig, its ``[friction]`` included (needs its ``[controller]`` table).

    ``dry_friction`` True for a loop that holds the rig's Coulomb and breakaway friction
    (every analysis of the package builds it so); else a rig with them is refused, as a
    rig with a torque offset always is (:meth:`~backlash_df.config.Rig.require_modelled`).
    """
    rig.require_modelled(dry_friction)
    return DriveLoop(rig.plant, rig.require_controller(), rig.friction)


def frequency_response_of(linear, omega):
    """G(jw) of a :class:`DriveLoop`, a python-control LTI or a callable ``omega -> G``.

    Parameters
    ----------
    linear : DriveLoop, control.LTI or callable
    omega : array_like
        rad/s.

    Returns
    -------
    ndarray of complex, shape of ``omega``
    """
    omega = np.asarray(omega, dtype=float)
    if isinstance(linear, DriveLoop):
        return linear.frequency_response(omega)
    import control as ct  # only a user's LTI needs python-control

    if isinstance(linear, ct.LTI):
        if linear.ninputs != 1 or linear.noutputs != 1:
            raise ValueError("the linear part must be SISO (shaft torque -> -theta_d)")
        flat = omega.reshape(-1)
        if isinstance(linear, ct.FrequencyResponseData):
            values = linear.eval(flat)
        else:
            values = linear(1j * flat)
        return np.asarray(values, dtype=complex).reshape(omega.shape)
    if callable(linear):
        return np.broadcast_to(np.asarray(linear(omega), dtype=complex), omega.shape)
    raise ValueError(f"cannot take a frequency response of {type(linear).__name__}; pass a DriveLoop, an LTI or a callable")


def _frequencies(omega):
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    if omega.ndim != 1 or not np.all(np.isfinite(omega)) or np.any(omega <= 0.0):
        raise ValueError("omega must be a 1-D array of finite frequencies > 0 rad/s")
    return omega
