"""A user's Lur'e loop (python-control's H and one element): prediction, exact orbits, simulation, bad input.

The exact orbits are checked against a reference written here: H realised in its
controllable canonical form from the transfer function's coefficients (not
python-control's realisation), the element's switching logic written again from its
textbook definition, scipy's DOP853 with event location (rtol 1e-12) as the
integrator, and a shooting of its own (scipy's hybrid Powell root on
``(X(T) - X0, y0)`` with a finite-difference Jacobian), whose monodromy by finite
differences gives the stability.  The reference starts 1 % away from the orbit
under test and converges on its own.
"""

import json
import math

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, root

import backlash_df as bd
from backlash_df.elements import DeadZone, Play, Relay, Saturation, ShaftLaw
from backlash_df.orbits import OrbitNotFound

#: python-control's describing-function examples (doc/descfcn.rst, examples/describing_functions.ipynb).
SATURATION_H = ct.tf(8, [1, 2, 2, 1])
BACKLASH_H = ct.tf(4, [1, 2, 2, 1]) * ct.tf(*ct.pade(5, 4))


# ------------------------------------------------------------------ the reference


def canonical(system):
    """``(A, B, C)`` of ``system``'s controllable canonical form, from its coefficients."""
    num = np.atleast_1d(np.squeeze(system.num[0][0])).astype(float)
    den = np.atleast_1d(np.squeeze(system.den[0][0])).astype(float)
    num, den = num / den[0], den / den[0]
    n = den.size - 1
    num = np.concatenate([np.zeros(n + 1 - num.size), num])
    a = np.zeros((n, n))
    a[:-1, 1:] = np.eye(n - 1)
    a[-1] = -den[:0:-1]
    b = np.zeros(n)
    b[-1] = 1.0
    return a, b, num[:0:-1].copy()


class Reference:
    """The loop ``x' = A x - B F``, ``y = C x`` with the element written from its definition.

    Discrete states: the saturation's and dead zone's side (-1, 0, +1), the relay's
    branch (+-1), the play's contact (0 held, +-1 pushed) with its output ``m`` as a
    last continuous state.
    """

    def __init__(self, system, element):
        self.a, self.b, self.c = canonical(system)
        self.element = element
        self.memory = isinstance(element, Play)

    def output(self, side, y, m):
        e = self.element
        if isinstance(e, Saturation):
            return e.limit * side if side else y
        if isinstance(e, DeadZone):
            return e.slope * (y - side * e.half_width) if side else 0.0
        if isinstance(e, Relay):
            return e.level * side
        return m if side == 0 else y - side * e.width / 2

    def shaft_torque(self, side, x):
        """A shaft law's torque in contact ``side``: k (y -+ alpha) + c dy/dt, dy/dt = C A x (C B = 0)."""
        e = self.element
        return e.stiffness * (self.c @ x - side * e.half_gap) + e.damping * (self.c @ self.a @ x) if side else 0.0

    def rhs(self, side):
        def f(t, state):
            x = state[: self.a.shape[0]]
            y = self.c @ x
            force = (self.shaft_torque(side, x) if isinstance(self.element, ShaftLaw)
                     else self.output(side, y, state[-1] if self.memory else 0.0))
            dx = self.a @ x - self.b * force
            if not self.memory:
                return dx
            return np.append(dx, (self.c @ dx) if side else 0.0)
        return f

    def events(self, side):
        """``[(function, direction, next side)]`` of the discrete state ``side``."""
        e, n = self.element, self.a.shape[0]

        def y_minus(level):
            return lambda t, s: self.c @ s[:n] - level

        if isinstance(e, (Saturation, DeadZone)):
            level = e.limit if isinstance(e, Saturation) else e.half_width
            if side == 0:
                return [(y_minus(level), 1, 1), (y_minus(-level), -1, -1)]
            return [(y_minus(side * level), -side, 0)]
        if isinstance(e, Relay):
            return [(y_minus(-side * e.hysteresis), -side, -side)]
        if isinstance(e, ShaftLaw):  # contact while y beyond alpha; revised: while k y + c dy/dt beyond k alpha
            lag = e.damping / e.stiffness if e.law == "revised-dead-zone" else 0.0

            def edge(level):
                return lambda t, s: self.c @ s[:n] + lag * (self.c @ self.a @ s[:n]) - level

            if side == 0:
                return [(edge(e.half_gap), 1, 1), (edge(-e.half_gap), -1, -1)]
            return [(edge(side * e.half_gap), -side, 0)]
        if side == 0:
            return [(lambda t, s: self.c @ s[:n] - s[-1] - e.width / 2, 1, 1),
                    (lambda t, s: self.c @ s[:n] - s[-1] + e.width / 2, -1, -1)]
        return [(lambda t, s: self.rhs(side)(t, s)[-1], -side, 0)]

    def flow(self, state, side, duration, samples=None):
        """``(state, side)`` after ``duration``; with ``samples``, also y at that many equal steps."""
        t, out = 0.0, []
        grid = None if samples is None else np.linspace(0.0, duration, samples, endpoint=False)
        while True:
            found = self.events(side)
            functions = []
            for function, direction, _ in found:
                function.terminal, function.direction = True, direction
                functions.append(function)
            sol = solve_ivp(self.rhs(side), (t, duration), state, method="DOP853", rtol=1e-12, atol=1e-14,
                            events=functions, dense_output=samples is not None)
            if grid is not None:
                inside = grid[(grid >= t) & (grid < sol.t[-1])]
                out.append(self.c @ sol.sol(inside)[: self.a.shape[0]] if inside.size else np.empty(0))
            if sol.status != 1:
                state = sol.y[:, -1]
                break
            k = next(i for i, times in enumerate(sol.t_events) if times.size)
            t, state, side = sol.t_events[k][0], sol.y_events[k][0], found[k][2]
        return (state, side) if samples is None else (state, side, np.concatenate(out))

    def shoot(self, state, side, period):
        """The reference's own periodic orbit near ``(state, period)`` on the section ``y = y0``."""
        n = state.size
        level = self.c @ state[: self.a.shape[0]]

        def residual(z):
            end, _ = self.flow(z[:n], side, z[n])
            return np.append(end - z[:n], self.c @ z[: self.a.shape[0]] - level)

        start = np.append(state * 1.01, period * 1.01)
        start[: self.a.shape[0]] -= self.c * ((self.c @ start[: self.a.shape[0]] - level) / (self.c @ self.c))
        found = root(residual, start, method="hybr", options={"xtol": 1e-12})
        assert found.success, found.message
        z = found.x
        step = 1e-6 * np.abs(z[:n]).max()
        monodromy = np.column_stack([
            (self.flow(z[:n] + step * e, side, z[n])[0] - self.flow(z[:n] - step * e, side, z[n])[0]) / (2 * step)
            for e in np.eye(n)])
        _, _, y = self.flow(z[:n], side, z[n], samples=2 ** 13)
        phases = 2 * np.pi * np.arange(y.size) / y.size
        amplitude = abs(2 * np.mean(y * np.exp(-1j * phases)))
        multipliers = np.linalg.eigvals(monodromy)
        nontrivial = np.delete(multipliers, np.argmin(np.abs(multipliers - 1)))
        return z[n], amplitude, float(np.abs(nontrivial).max())


def side_of(orbit):
    """The reference's discrete state for the mode an orbit starts in."""
    names = {"linear": 0, "inside": 0, "held": 0, "free": 0, "upper": 1, "above": 1, "pushed up": 1, "high": 1,
             "right contact": 1, "lower": -1, "below": -1, "pushed down": -1, "low": -1, "left contact": -1}
    return names[orbit.loop.element.modes[orbit.mode].name]


def reference_state(orbit):
    """The orbit's start in the reference's coordinates."""
    return in_reference(orbit.loop, orbit.state)


def in_reference(loop, state):
    """An augmented state of ``loop`` in the reference's coordinates: the same output and derivatives
    (the realisations are similar; their observability matrices map one to the other)."""
    n = loop.a.shape[0]
    a_ref, b_ref, c_ref = canonical(loop.system)
    obs_pc = np.vstack([loop.c @ np.linalg.matrix_power(loop.a, k) for k in range(n)])
    obs_ref = np.vstack([c_ref @ np.linalg.matrix_power(a_ref, k) for k in range(n)])
    x = np.linalg.solve(obs_ref, obs_pc @ state[:n])
    return np.append(x, state[n:])


# ------------------------------------------------------------------ the published cases


def test_the_prediction_is_python_control_s():
    saturation = bd.lure_loop(SATURATION_H, ct.saturation_nonlinearity(1)).predict()
    (cycle,) = saturation.cycles
    assert (round(cycle.amplitude, 3), round(cycle.omega, 4), cycle.stable) == (3.344, 1.4142, True)
    assert saturation.model == "saturation (L = 1)"
    response = ct.describing_function_response(BACKLASH_H, ct.friction_backlash_nonlinearity(1),
                                               np.linspace(0.6, 5, 50), np.logspace(-3, 3, 500))
    play = bd.lure_loop(BACKLASH_H, ct.friction_backlash_nonlinearity(1)).predict()
    assert len(play.cycles) == 2 and not any(c.stable for c in play.cycles)
    for cycle, (a_pc, w_pc) in zip(play.cycles, sorted(response.intersections)):
        assert (cycle.amplitude, cycle.omega) == (pytest.approx(a_pc, rel=1e-6), pytest.approx(w_pc, rel=1e-6))


@pytest.fixture(scope="module")
def published_orbits():
    loops = {"saturation": bd.lure_loop(SATURATION_H, ct.saturation_nonlinearity(1)),
             "play": bd.lure_loop(BACKLASH_H, ct.friction_backlash_nonlinearity(1))}
    return {name: loop.exact_orbits(loop.predict()) for name, loop in loops.items()}


@pytest.mark.parametrize(("name", "index", "stable"), [("saturation", 0, True), ("play", 0, False), ("play", 1, False)])
def test_exact_orbits_agree_with_the_reference(published_orbits, name, index, stable):
    cycle, orbit = published_orbits[name][index]
    assert not isinstance(orbit, str), orbit
    assert orbit.stable is stable
    assert orbit.residual < 1e-10
    period, amplitude, largest = Reference(orbit.loop.system, orbit.loop.element).shoot(
        reference_state(orbit), side_of(orbit), orbit.period)
    assert orbit.period == pytest.approx(period, rel=1e-7)
    assert orbit.amplitude == pytest.approx(amplitude, rel=1e-6)
    assert orbit.max_multiplier == pytest.approx(largest, rel=1e-4)
    assert (largest < 1) is stable


def test_the_describing_function_errs_most_on_the_flat_topped_cycle(published_orbits):
    """python-control's first backlash cycle is some 10 % off in amplitude and 15 % in frequency; the others
    within 2 % (the figures of the docs page)."""
    errors = {(name, i): (cycle.amplitude / orbit.amplitude - 1, cycle.omega / orbit.omega - 1)
              for name, pairs in published_orbits.items() for i, (cycle, orbit) in enumerate(pairs)}
    assert errors[("play", 0)][0] == pytest.approx(-0.0961, abs=2e-3)
    assert errors[("play", 0)][1] == pytest.approx(-0.132, abs=2e-3)
    assert max(abs(e) for key in [("saturation", 0), ("play", 1)] for e in errors[key]) < 0.02


def test_a_simulation_settles_on_the_stable_orbit():
    loop = bd.lure_loop(SATURATION_H, ct.saturation_nonlinearity(1))
    (_, orbit), = loop.exact_orbits(loop.predict())
    sim = loop.simulate(120.0, y0=0.5, dt=0.002)
    last = sim.y[sim.time > 100.0]
    assert orbit.peak * (1 - 3e-6) < last.max() <= orbit.peak * (1 + 1e-9)  # sampled every 2 ms
    rising = np.flatnonzero((sim.y[:-1] < 0) & (sim.y[1:] >= 0) & (sim.time[:-1] > 60.0))
    crossings = sim.time[rising] - sim.y[rising] * 0.002 / (sim.y[rising + 1] - sim.y[rising])
    assert np.diff(crossings).mean() == pytest.approx(orbit.period, rel=1e-6)


def test_the_simulation_matches_the_reference_from_a_kick():
    """From y = 0.7 with the play's output at 0 (held): beyond the unstable cycles, 20 s through its switches."""
    loop = bd.lure_loop(BACKLASH_H, Play(1.0))
    x0 = loop.c * (0.7 / (loop.c @ loop.c))
    sim = loop.simulate(20.0, x0=x0, m0=0.0, dt=0.5)
    assert sim.y[0] == pytest.approx(0.7) and sim.modes[0] == 0
    assert len(set(sim.modes)) == 3  # held, pushed up and down along the way
    end, _ = Reference(BACKLASH_H, Play(1.0)).flow(in_reference(loop, sim.states[0]), 0, 20.0)
    assert canonical(BACKLASH_H)[2] @ end[:-1] == pytest.approx(sim.y[-1], abs=1e-9)
    assert end[-1] == pytest.approx(sim.states[-1, -1], abs=1e-9)


# ------------------------------------------------------------------ the other elements


@pytest.mark.parametrize("element", [Relay(1.0, 0.2), DeadZone(0.3, 2.0), Saturation(0.5)],
                         ids=["relay with hysteresis", "dead zone", "saturation"])
def test_other_elements_orbits_agree_with_the_reference(element):
    system = ct.tf(1 if isinstance(element, Relay) else 30, [1, 3, 2, 0])
    loop = bd.lure_loop(system, element)
    prediction = loop.predict()
    assert prediction.cycles, prediction
    for cycle, orbit in loop.exact_orbits(prediction):
        assert not isinstance(orbit, str), orbit
        period, amplitude, largest = Reference(system, element).shoot(reference_state(orbit), side_of(orbit),
                                                                      orbit.period)
        assert orbit.period == pytest.approx(period, rel=1e-7)
        assert orbit.amplitude == pytest.approx(amplitude, rel=1e-6)
        assert orbit.stable is (largest < 1) is cycle.stable
        assert orbit.output_amplitude > 0


#: A third-order lag around a shaft (k = 2 N m/rad, c = 0.3 N m s/rad, alpha = 0.1 rad): one unstable cycle.
SHAFT_H = ct.tf(3, [1, 1.2, 1.5, 0.4])


@pytest.mark.parametrize("law", ["damped-dead-zone", "revised-dead-zone"])
def test_the_toolbox_s_shaft_laws_in_a_lure_loop(law):
    """A law of make_model closes the loop with y as theta_d: the DF's cycles are predict_limit_cycles' for the
    same G, and the exact orbit agrees with the reference (its own damper and release written here)."""
    rig = bd.rig_from_dict({"plant": {"motor_inertia": 1.0, "load_inertia": 1.0, "stiffness": 2.0, "damping": 0.3,
                                      "half_gap": 0.1}, "controller": {"kp": 1.0, "ti": 1.0}})
    model = rig.make_model(law)
    loop = bd.lure_loop(SHAFT_H, model)
    prediction = loop.predict(amplitude_range=(0.1001, 10.0), omega_range=(0.05, 20.0))
    toolbox = bd.predict_limit_cycles(rig, law, linear=SHAFT_H, amplitude_range=(0.1001, 10.0),
                                      omega_range=(0.05, 20.0))
    assert [(c.amplitude, c.omega, c.stable) for c in prediction.cycles] == [
        (pytest.approx(c.amplitude, rel=1e-9), pytest.approx(c.omega, rel=1e-9), c.stable) for c in toolbox.cycles]
    (cycle, orbit), = loop.exact_orbits(prediction)
    period, amplitude, largest = Reference(SHAFT_H, loop.element).shoot(reference_state(orbit), side_of(orbit),
                                                                         orbit.period)
    assert orbit.period == pytest.approx(period, rel=1e-7)
    assert orbit.amplitude == pytest.approx(amplitude, rel=1e-6)
    assert orbit.max_multiplier == pytest.approx(largest, rel=1e-4)


def test_a_damper_needs_relative_degree_two():
    model = bd.make_model("damped-dead-zone", stiffness=2.0, damping=0.3, half_gap=0.1)
    with pytest.raises(ValueError, match="depends on dy/dt: H needs a relative degree of at least 2"):
        bd.lure_loop(ct.tf([1, 1], [1, 2, 2]), model)
    assert bd.lure_loop(ct.tf([1, 1], [1, 2, 2]), bd.make_model("dead-zone", stiffness=2.0, half_gap=0.1))
    with pytest.raises(ValueError, match="piecewise-affine laws"):
        bd.lure_loop(SHAFT_H, bd.make_model("phase-plane", stiffness=2.0, damping=0.3, half_gap=0.1))


def tsypkin_output(theta, level):
    """y at a switch of the symmetric cycle of a relay ``+-level`` around ``H = 1/(s (s+1) (s+2))`` with
    half period ``theta`` (Tsypkin): ``H = 1/(2 s) - 1/(s+1) + 1/(2 (s+2))``, each term's periodic
    response to the square wave at the switch (``r M tanh(p theta / 2) / p``; ``r M theta / 2`` for
    the integrator)."""
    return level * (theta / 4 - math.tanh(theta / 2) + math.tanh(theta) / 4)


@pytest.mark.parametrize("hysteresis", [0.0, 0.2])
def test_relay_orbits_are_tsypkin_s(hysteresis):
    """The exact half period switches at y = h (Tsypkin's condition, solved here); the DF's frequency
    is sqrt 2 (H real there, -1/6), the exact one lower."""
    loop = bd.lure_loop(ct.tf(1, [1, 3, 2, 0]), Relay(1.0, hysteresis))
    (cycle, orbit), = loop.exact_orbits(loop.predict())
    half = brentq(lambda theta: tsypkin_output(theta, 1.0) - hysteresis, 1.0, 10.0, xtol=1e-15)
    assert orbit.period == pytest.approx(2 * half, rel=1e-9)
    assert orbit.stable
    if hysteresis == 0.0:
        assert cycle.omega == pytest.approx(math.sqrt(2), rel=1e-9)
        assert cycle.amplitude == pytest.approx(4 / (6 * math.pi), rel=1e-9)
        assert orbit.omega < cycle.omega


# ------------------------------------------------------------------ bad input


@pytest.mark.parametrize(("system", "element", "words"), [
    (ct.tf([[[1]], [[1]]], [[[1, 1]], [[1, 2]]]), Play(1.0), "SISO"),
    (ct.tf([1, 0, 0], [1, 1]), Play(1.0), "must be proper"),
    (ct.tf([1, 0], [1, 1]), Play(1.0), "strictly proper"),
    (ct.tf(1, [1, 1], 0.1), Play(1.0), "continuous time"),
    (ct.tf(1, [1, 1]), ct.DescribingFunctionNonlinearity(), "no element for a DescribingFunctionNonlinearity"),
    (ct.tf(1, [1, 1]), lambda y: y, "no element for a function"),
    ("H", Play(1.0), "python-control transfer function or state space"),
])
def test_bad_loops_are_one_line(system, element, words):
    with pytest.raises(ValueError, match=words) as caught:
        bd.lure_loop(system, element)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(("make", "words"), [
    (lambda: Play(0.0), "play's width must be finite and > 0"),
    (lambda: Saturation(-1.0), "limit must be finite and > 0"),
    (lambda: Relay(1.0, -0.1), "hysteresis must be finite and >= 0"),
    (lambda: DeadZone(0.1, slope=math.inf), "slope must be finite and > 0"),
])
def test_bad_elements_are_one_line(make, words):
    with pytest.raises(ValueError, match=words):
        make()


def test_a_seed_far_from_any_orbit_is_refused_by_name():
    loop = bd.lure_loop(BACKLASH_H, Play(1.0))
    with pytest.raises(OrbitNotFound, match="play"):
        loop.periodic_orbit((0.55, 5.0), max_iter=3)


# ------------------------------------------------------------------ the verdict

#: A conditionally stable type-1 loop: a stable rest, an unstable cycle, a stable one beyond it.
BISTABLE_H = 3 * ct.tf([1, 2, 1], 1) / (ct.tf([1, 0], 1) * ct.tf([1, 0.4, 0.04], 1) * ct.tf([0.04, 0.4, 1], 1))


@pytest.mark.parametrize(("system", "element", "word"), [
    (SATURATION_H, Saturation(1.0), "limit cycle"),
    (ct.tf(0.5, [1, 3, 2, 1]), Saturation(1.0), "no oscillation"),
    (ct.tf(1, [1, 3, 2, 0]), Relay(1.0, 0.2), "limit cycle"),
], ids=["saturation example", "small gain", "relay"])
def test_verdict_words(system, element, word):
    verdict = bd.judge_lure_loop(bd.lure_loop(system, element))
    assert verdict.verdict == word, verdict
    if word == "limit cycle":
        (orbit,) = {id(p.orbit): p.orbit for p in verdict.probes}.values()  # every probe on the one orbit
        assert orbit.stable and all(p.outcome == "cycle" for p in verdict.probes)
    else:
        assert all(p.outcome == "rest" for p in verdict.probes)
    assert json.loads(json.dumps(verdict.to_dict(), allow_nan=False))["verdict"] == word


def test_the_runaway_of_the_backlash_example_starts_at_its_smallest_unstable_orbit():
    """Both backlash cycles are unstable: the smaller exact orbit bounds the rest's basin.  The reference
    integrator, started 3 % inside and outside it, comes to rest (the play holds anywhere within its width) and
    runs away."""
    loop = bd.lure_loop(BACKLASH_H, ct.friction_backlash_nonlinearity(1))
    verdict = bd.judge_lure_loop(loop)
    assert verdict.verdict == "unstable"
    smallest = verdict.exact[0]
    assert (verdict.disturbance_to_start, verdict.disturbance_source) == (smallest.amplitude, "exact orbit")
    assert smallest.amplitude == pytest.approx(0.69255, rel=1e-4)
    reference = Reference(BACKLASH_H, Play(1.0))
    for factor, settles in ((0.97, True), (1.03, False)):
        state = in_reference(loop, smallest.state * factor)
        end, _ = reference.flow(state, side_of(smallest), 150.0)
        assert abs(reference.c @ end[:-1]) < 1.0 if settles else abs(reference.c @ end[:-1]) > 1e3


def test_a_bistable_loop_names_its_unstable_orbit_and_finds_the_stable_one_by_simulation():
    """The DF's seed for the outer cycle collapses onto the rest; the probes settle on a swing no orbit has,
    and shooting from their runs finds the stable orbit, which the reference's own shooting confirms."""
    loop = bd.lure_loop(BISTABLE_H, Saturation(1.0))
    verdict = bd.judge_lure_loop(loop)
    assert verdict.verdict == "bistable", verdict
    inner, outer = verdict.exact
    assert not inner.stable and outer.stable and outer in verdict.simulated_orbits
    assert verdict.disturbance_to_start == inner.amplitude
    assert {p.outcome for p in verdict.probes if p.size < inner.amplitude} == {"rest"}
    assert {p.outcome for p in verdict.probes if p.size > inner.amplitude} == {"cycle"}
    period, amplitude, largest = Reference(BISTABLE_H, Saturation(1.0)).shoot(reference_state(outer),
                                                                              side_of(outer), outer.period)
    assert outer.period == pytest.approx(period, rel=1e-7)
    assert outer.amplitude == pytest.approx(amplitude, rel=1e-6)
    assert largest < 1


# ------------------------------------------------------------------ continuation


def test_the_relay_branch_along_its_hysteresis_is_tsypkin_s():
    loop = bd.lure_loop(ct.tf(1, [1, 3, 2, 0]), Relay(1.0))
    branch = bd.continue_lure_orbit(loop, "hysteresis", np.linspace(0.0, 0.6, 7), (0.21, 1.4))
    assert not branch.note and branch.values.tolist() == pytest.approx(np.linspace(0.0, 0.6, 7).tolist())
    for hysteresis, orbit in zip(branch.values, branch.orbits):
        half = brentq(lambda theta: tsypkin_output(theta, 1.0) - hysteresis, 1.0, 20.0, xtol=1e-15)
        assert orbit.period == pytest.approx(2 * half, rel=1e-9)
        assert orbit.stable
    assert np.all(np.diff(branch.amplitudes) > 0) and not branch.stability_changes


def test_the_saturation_branch_shrinks_to_the_limit_where_the_linear_loop_turns_stable():
    """python-control's saturation loop with H scaled down: the cycle shrinks toward A = L as the gain
    falls to 3/8 (H(j sqrt 2) = -8 g / 3 meets -1), the DF's error vanishing with the saturation; the
    branch is lost just above 3/8, where the orbit stops touching the limit (named in the note)."""
    loop = bd.lure_loop(SATURATION_H, Saturation(1.0))
    branch = bd.continue_lure_orbit(loop, "gain", np.linspace(1.0, 0.3, 8), (3.344, 1.414))
    assert "lost" in branch.note and 0.375 < branch.values[-1] < 0.4
    assert np.all(np.diff(branch.amplitudes) < 0) and 1.0 < branch.amplitudes[-1] < 1.1
    errors = np.abs(branch.df_amplitudes / branch.amplitudes - 1)
    assert errors[-1] < 0.1 * errors[0]
    assert all(o.stable for o in branch.orbits)
    assert branch.to_dict()["points"][0]["amplitude"] == pytest.approx(3.39494, rel=1e-5)


@pytest.mark.parametrize(("parameter", "values", "words"), [
    ("width", [1.0, 2.0], "unknown parameter 'width' of a saturation loop"),
    ("gain", [1.0, 1.0], "strictly monotonic"),
    ("gain", [1.0], "at least two"),
    ("limit", [1.0, -1.0], "limit must be finite and > 0"),
])
def test_bad_continuations_are_one_line(parameter, values, words):
    loop = bd.lure_loop(SATURATION_H, Saturation(1.0))
    with pytest.raises(ValueError, match=words) as caught:
        bd.continue_lure_orbit(loop, parameter, values, (3.344, 1.414))
    assert "\n" not in str(caught.value)


# ------------------------------------------------------------------ design maps


@pytest.fixture(scope="module")
def saturation_map():
    loop = bd.lure_loop(SATURATION_H, Saturation(1.0))
    return bd.lure_design_map(loop, ("gain", [0.3, 0.45, 1.0]), ("limit", [1.0, 2.0]))


def test_the_saturation_map_hunts_above_three_eighths_and_scales_with_the_limit(saturation_map):
    """H(j sqrt 2) = -8 g / 3: the loop hunts above g = 3/8 only; the loop is homogeneous in the limit, so the
    cycle's amplitude doubles with it (to round-off of the shooting)."""
    m = saturation_map
    assert m.verdicts.tolist() == [["no oscillation", "limit cycle", "limit cycle"]] * 2
    assert m.model == "saturation"
    np.testing.assert_allclose(m.amplitudes[1, 1:], 2.0 * m.amplitudes[0, 1:], rtol=1e-9)
    assert m.amplitudes[0, 2] == pytest.approx(3.39494, rel=1e-5)
    assert np.isnan(m.amplitudes[:, 0]).all()


def test_the_map_is_the_same_on_a_process_pool(saturation_map):
    import concurrent.futures

    loop = bd.lure_loop(SATURATION_H, Saturation(1.0))
    done = []
    with concurrent.futures.ProcessPoolExecutor(max_workers=2) as executor:
        pooled = bd.lure_design_map(loop, ("gain", [0.3, 0.45, 1.0]), ("limit", [1.0, 2.0]), executor=executor,
                                    progress=lambda stage, n, total: done.append((stage, n, total)))
    assert pooled.verdicts.tolist() == saturation_map.verdicts.tolist()
    np.testing.assert_array_equal(pooled.amplitudes, saturation_map.amplitudes)
    assert done[-1] == ("points", 6, 6)


@pytest.mark.parametrize(("x", "y", "words"), [
    (("gain", [1.0]), ("gain", [2.0]), "must differ"),
    (("gain", [1.0]), ("width", [1.0]), "unknown parameter 'width'"),
    (("gain", [1.0]), ("limit", [-1.0]), "limit must be finite and > 0"),
    (("gain", [np.nan]), ("limit", [1.0]), "must be finite"),
])
def test_bad_maps_are_one_line(x, y, words):
    with pytest.raises(ValueError, match=words) as caught:
        bd.lure_design_map(bd.lure_loop(SATURATION_H, Saturation(1.0)), x, y)
    assert "\n" not in str(caught.value)


def test_a_relay_cycle_the_describing_function_cannot_see_is_found_by_the_runs():
    """A relay with hysteresis around 1/(s + 1): H never reaches the third quadrant, so the DF has no cycle,
    yet the loop switches for ever with the half period ln((M + h)/(M - h)) (y climbs from -h to h along
    M - (M + h) e^-t).  The runs settle on a swing no DF cycle has, the orbit is shot from them, and the
    verdict says the DF is unreliable."""
    loop = bd.lure_loop(ct.tf(1, [1, 1]), Relay(1.0, 0.1))
    verdict = bd.judge_lure_loop(loop, t_end=20.0)
    assert not verdict.prediction.cycles
    assert verdict.verdict == "limit cycle" and not verdict.df_agrees and "DF UNRELIABLE" in verdict.reason
    (orbit,) = verdict.simulated_orbits
    assert orbit.period == pytest.approx(2 * math.log(1.1 / 0.9), rel=1e-12)
    assert orbit.peak == pytest.approx(0.1, rel=1e-12)
