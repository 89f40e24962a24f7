"""Closed-form describing functions of the classical elements and python-control's objects.

Each closed form is checked against python-control's ``describing_function`` and against a
first harmonic computed here, independently: the element (python-control's own object,
with its memory) is driven along ``y = A sin(phi)`` over two periods and its output's
first harmonic over the second period is integrated piecewise, by Gauss-Legendre between
the element's switching phases, located by bisection on the element itself.  Then
python-control's two published limit cycles (its describing-function notebook) are
found with the toolbox's harmonic-balance solver, and their stability is checked against
the roots of the quasi-linear characteristic equation ``den(s) + N(A) num(s) = 0``.
"""

import copy
import math

import control as ct
import mpmath
import numpy as np
import pytest
from scipy.optimize import brentq

from backlash_df.describing import (
    dead_zone_describing_function,
    nonlinearity_describing_function,
    play_describing_function,
    relay_describing_function,
    saturation_describing_function,
)
from backlash_df.limit_cycles import solve_harmonic_balance


class DeadZone:
    """A static dead zone, written here: ``slope (y - d sign y)`` outside ``|y| <= d``."""

    def __init__(self, half_width, slope):
        self.half_width, self.slope = half_width, slope

    def __call__(self, y):
        return self.slope * math.copysign(max(abs(y) - self.half_width, 0.0), y)


# ------------------------------------------------------------------ the reference quadrature

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(12)


def first_harmonic(element, amplitude, mode, steps=400):
    """N = (b1 + j a1) / A of ``element`` along ``y = A sin(phi)``, over its second period.

    The phase grid (step pi / steps) holds the input's turning points, so between two grid
    phases the input is monotone and a rate-independent element's state at any phase is
    that of the grid point before it, fed the input there.  ``mode(y, out)`` labels the
    element's smooth pieces; where it changes between grid points the switching phase is
    located by bisection (60 halvings).  Each smooth piece is integrated by 12-point
    Gauss-Legendre.
    """
    def y(phi):
        return amplitude * math.sin(phi)

    grid = np.linspace(0.0, 4.0 * math.pi, 4 * steps + 1)
    states, outputs = [], []
    for phi in grid:  # the element's memory, stepped over two periods
        outputs.append(float(np.squeeze(element(y(phi)))))
        states.append(copy.copy(element))

    def output_from(k, phi):
        probe = copy.copy(states[k])
        return float(np.squeeze(probe(y(phi))))

    def integrate(k, lo, hi):
        half, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
        total = 0.0j
        for node, weight in zip(_NODES, _WEIGHTS):
            phi = mid + half * node
            total += weight * half * output_from(k, phi) * (math.sin(phi) + 1j * math.cos(phi))
        return total

    integral = 0.0j
    for k in range(2 * steps, 4 * steps):
        lo, hi = grid[k], grid[k + 1]
        start, end = mode(y(lo), outputs[k]), mode(y(hi), outputs[k + 1])
        if start == end:
            integral += integrate(k, lo, hi)
            continue
        a, b = lo, hi
        for _ in range(60):
            middle = 0.5 * (a + b)
            a, b = (middle, b) if mode(y(middle), output_from(k, middle)) == start else (a, middle)
        integral += integrate(k, lo, b) + integrate(k, b, hi)
    return integral / (math.pi * amplitude)


def play_mode(width):
    """The play's pieces: -1, +1 while pushed from below / above, 0 while it rests."""
    def mode(y, out):
        gap = y - out
        return int(round(gap / (0.5 * width))) if abs(abs(gap) - 0.5 * width) <= 1e-12 * max(1.0, abs(y)) else 0
    return mode


def relay_mode(y, out):
    return out


def clip_mode(threshold):
    def mode(y, out):
        return 0 if abs(y) <= threshold else int(math.copysign(1, y))
    return mode


AMPLITUDES = [0.5000001, 0.51, 0.7, 1.0, 1.7, 4.0, 30.0]


# ------------------------------------------------------------------ against python-control


@pytest.mark.parametrize("width", [1.0, 0.3])
def test_play_matches_python_control(width):
    a = np.array(AMPLITUDES) * width / 0.5
    np.testing.assert_allclose(play_describing_function(a, width),
                               ct.describing_function(ct.friction_backlash_nonlinearity(width), a), rtol=1e-8)


def test_relay_matches_python_control_where_it_switches():
    level, c = 1.5, 0.4
    a = np.array([0.4000001, 0.41, 0.8, 2.0, 50.0])
    np.testing.assert_allclose(relay_describing_function(a, level, hysteresis=c),
                               ct.describing_function(ct.relay_hysteresis_nonlinearity(level, c), a), rtol=1e-8)
    # below c python-control's closed form is NaN; the relay never switches, its output has no first harmonic
    below = np.array([0.1, 0.39])
    assert np.isnan(ct.describing_function(ct.relay_hysteresis_nonlinearity(level, c), below)).all()
    assert (relay_describing_function(below, level, hysteresis=c) == 0).all()


def test_saturation_matches_python_control_closed_form_and_quadrature():
    a = np.array([0.3, 0.7, 1.0, 1.3, 3.0, 40.0])
    element = ct.saturation_nonlinearity(0.7)
    ours = saturation_describing_function(a, 0.7)
    np.testing.assert_allclose(ours, ct.describing_function(element, a), rtol=1e-12)
    # python-control's numerical quadrature (rectangle rule, error O(h^2) at the kinks): 1e-8 with 2e5 points
    numerical = ct.describing_function(element, a, num_points=200_000, try_method=False)
    np.testing.assert_allclose(ours, numerical, rtol=1e-8, atol=1e-12)


def test_dead_zone_matches_python_control_quadrature():
    element = DeadZone(0.6, 2.5)
    a = np.array([0.61, 0.9, 2.0, 25.0])
    numerical = ct.describing_function(element, a, num_points=200_000)
    np.testing.assert_allclose(dead_zone_describing_function(a, 0.6, slope=2.5), numerical, rtol=1e-8, atol=1e-12)
    assert (dead_zone_describing_function([0.2, 0.6], 0.6, slope=2.5) == 0).all()


# ------------------------------------------------------------------ against the quadrature written here


@pytest.mark.parametrize("amplitude", [0.5000001, 0.52, 0.75, 1.0, 2.3, 9.0])
def test_play_matches_its_first_harmonic(amplitude):
    width = 1.0
    element = ct.friction_backlash_nonlinearity(width)
    reference = first_harmonic(element, amplitude, play_mode(width))
    assert play_describing_function(amplitude, width) == pytest.approx(reference, rel=1e-10, abs=1e-14)
    assert reference.imag < 0  # a lag: the element has memory


@pytest.mark.parametrize("amplitude, hysteresis", [(0.41, 0.4), (1.0, 0.4), (7.0, 0.4), (0.3, 0.0), (2.0, 0.0)])
def test_relay_matches_its_first_harmonic(amplitude, hysteresis):
    level = 1.5
    element = ct.relay_hysteresis_nonlinearity(level, hysteresis)
    reference = first_harmonic(element, amplitude, relay_mode)
    assert relay_describing_function(amplitude, level, hysteresis=hysteresis) == pytest.approx(reference, rel=1e-10)


@pytest.mark.parametrize("amplitude", [0.61, 1.0, 5.0])
def test_static_elements_match_their_first_harmonic(amplitude):
    dead_zone = first_harmonic(DeadZone(0.6, 2.5), amplitude, clip_mode(0.6))
    assert dead_zone_describing_function(amplitude, 0.6, slope=2.5) == pytest.approx(dead_zone, rel=1e-10)
    saturation = first_harmonic(ct.saturation_nonlinearity(0.6), amplitude, clip_mode(0.6))
    assert saturation_describing_function(amplitude, 0.6) == pytest.approx(saturation, rel=1e-10)


def test_the_quadrature_sees_a_wrong_width():
    # the reference can fail: a play of width 1 is not the closed form of width 1.01
    reference = first_harmonic(ct.friction_backlash_nonlinearity(1.0), 0.8, play_mode(1.0))
    assert abs(play_describing_function(0.8, 1.01) - reference) > 1e-3


def test_play_keeps_its_precision_at_the_threshold():
    # (1 + f(1 - r)) / 2 in 50 digits: the printed form cancels as A -> b / 2
    mpmath.mp.dps = 50
    for excess in (1e-6, 1e-9, 1e-12):
        a = mpmath.mpf(0.5) * (1 + mpmath.mpf(excess))
        x = 1 - 1 / a
        real = (1 + 2 / mpmath.pi * (mpmath.asin(x) + x * mpmath.sqrt(1 - x * x))) / 2
        imag = -(2 / a - 1 / a ** 2) / mpmath.pi
        ours = play_describing_function(float(a), 1.0)
        assert ours.real == pytest.approx(float(real), rel=1e-9)
        assert ours.imag == pytest.approx(float(imag), rel=1e-9)


def test_limits():
    a = np.array([0.2, 1.0, 8.0])
    np.testing.assert_allclose(play_describing_function(a, 0.0), 1.0, rtol=1e-15)
    np.testing.assert_allclose(relay_describing_function(a, 2.0), 8.0 / (np.pi * a), rtol=1e-15)
    np.testing.assert_allclose(dead_zone_describing_function(a, 0.0, slope=3.0), 3.0, rtol=1e-15)
    assert (play_describing_function([0.1, 0.25], 0.5) == 0).all()
    # far past the play, it passes the input with a lag of b / A
    n = play_describing_function(1e4, 1.0)
    assert n.real == pytest.approx(1.0, abs=2e-4) and n.imag == pytest.approx(-2e-4 / np.pi, rel=1e-4)


# ------------------------------------------------------------------ python-control's objects, bad input


def test_objects_map_to_their_closed_forms():
    a = np.array([0.6, 1.0, 3.0])
    np.testing.assert_array_equal(nonlinearity_describing_function(ct.friction_backlash_nonlinearity(0.8))(a),
                                  play_describing_function(a, 0.8))
    np.testing.assert_array_equal(nonlinearity_describing_function(ct.relay_hysteresis_nonlinearity(2.0, 0.5))(a),
                                  relay_describing_function(a, 2.0, hysteresis=0.5))
    np.testing.assert_array_equal(nonlinearity_describing_function(ct.saturation_nonlinearity(0.9))(a),
                                  saturation_describing_function(a, 0.9))


@pytest.mark.parametrize("thing, message", [
    (lambda y: y, "function"),
    (ct.DescribingFunctionNonlinearity(), "DescribingFunctionNonlinearity"),
    (ct.tf([1], [1, 1]), "TransferFunction"),
])
def test_other_objects_are_refused_by_type(thing, message):
    with pytest.raises(ValueError, match=f"a {message} object") as caught:
        nonlinearity_describing_function(thing)
    assert "\n" not in str(caught.value)


def test_asymmetric_saturation_is_refused():
    with pytest.warns(UserWarning):
        element = ct.saturation_nonlinearity(1.0, -0.5)
    with pytest.raises(ValueError, match="asymmetric saturation"):
        nonlinearity_describing_function(element)


@pytest.mark.parametrize("call, message", [
    (lambda: play_describing_function(1.0, -0.1), "width must be >= 0"),
    (lambda: play_describing_function(0.0, 0.1), "amplitude must be > 0"),
    (lambda: play_describing_function([1.0, np.nan], 0.1), "amplitude must be finite"),
    (lambda: relay_describing_function(1.0, 0.0), "level must be > 0"),
    (lambda: relay_describing_function(1.0, 1.0, hysteresis=-1.0), "hysteresis must be >= 0"),
    (lambda: relay_describing_function(-1.0, 1.0), "amplitude must be > 0"),
    (lambda: dead_zone_describing_function(1.0, -0.5), "half_width must be >= 0"),
    (lambda: dead_zone_describing_function(1.0, 0.5, slope=0.0), "slope must be > 0"),
    (lambda: dead_zone_describing_function(1.0, [0.5, 0.6]), "half_width must be a number"),
    (lambda: nonlinearity_describing_function(ct.friction_backlash_nonlinearity(-1.0)), "b must be >= 0"),
])
def test_bad_input_is_one_line(call, message):
    with pytest.raises(ValueError, match=message) as caught:
        call()
    assert "\n" not in str(caught.value)


# ------------------------------------------------------------------ python-control's published limit cycles

S = ct.tf("s")
CUBIC = S ** 3 + 2 * S ** 2 + 2 * S + 1
SATURATION_LOOP = 8 / CUBIC
BACKLASH_LOOP = 4 / CUBIC * ct.tf(*ct.pade(5, 4))


def response_of(system):
    """``omega -> H(j omega)`` over arrays of any shape."""
    return lambda w: system(1j * np.ravel(w)).reshape(np.shape(w))


def quasi_linear_root(system, n, omega):
    """The root near ``j omega`` of ``den(s) + N num(s)``: the loop closed through the gain N."""
    num, den = system.num[0][0], system.den[0][0]
    size = max(len(num), len(den))
    roots = np.roots(np.pad(den, (size - len(den), 0)) + n * np.pad(num, (size - len(num), 0)))
    return roots[np.argmin(np.abs(roots - 1j * omega))]


def settles(system, n_of, cycle):
    """The textbook criterion: a slightly larger amplitude decays (its root in the left half plane)
    and a slightly smaller one grows."""
    above = quasi_linear_root(system, complex(n_of(cycle.amplitude * 1.001)), cycle.omega).real
    below = quasi_linear_root(system, complex(n_of(cycle.amplitude * 0.999)), cycle.omega).real
    assert above * below < 0
    return bool(above < 0)


def test_saturation_cycle_of_python_control():
    element = ct.saturation_nonlinearity(1)
    n = nonlinearity_describing_function(element)
    cycles, _ = solve_harmonic_balance(response_of(SATURATION_LOOP), lambda a, w: n(a) + 0 * w,
                                       0.0, (0.5, 20.0), (0.1, 10.0))
    assert len(cycles) == 1
    cycle = cycles[0]
    # H(j sqrt 2) = -8 / 3 is real: the cycle solves N(A) = 3 / 8 at w = sqrt 2
    exact_amplitude = brentq(lambda a: saturation_describing_function(a, 1.0) - 3 / 8, 1.0, 10.0, xtol=1e-15)
    assert cycle.omega == pytest.approx(math.sqrt(2), rel=1e-10)
    assert cycle.amplitude == pytest.approx(exact_amplitude, rel=1e-10)
    assert (round(cycle.amplitude, 3), round(cycle.omega, 4)) == (3.344, 1.4142)  # python-control's figures
    response = ct.describing_function_response(SATURATION_LOOP, element, np.linspace(0, 5, 50),
                                               np.logspace(-3, 3, 500))
    (a_pc, w_pc), = response.intersections
    # python-control refines with scipy.optimize.minimize at its default tolerance: 1e-4 relative
    assert (a_pc, w_pc) == (pytest.approx(cycle.amplitude, rel=1e-4), pytest.approx(cycle.omega, rel=1e-4))
    assert cycle.residual < abs(1 + SATURATION_LOOP(1j * w_pc) * n(a_pc))
    assert cycle.stable is True
    assert settles(SATURATION_LOOP, n, cycle) is True


def test_backlash_cycles_of_python_control():
    element = ct.friction_backlash_nonlinearity(1)
    n = nonlinearity_describing_function(element)
    cycles, _ = solve_harmonic_balance(response_of(BACKLASH_LOOP), lambda a, w: n(a) + 0 * w,
                                       0.5, (0.501, 20.0), (0.05, 10.0))
    response = ct.describing_function_response(BACKLASH_LOOP, element, np.linspace(0.6, 5, 50),
                                               np.logspace(-3, 3, 500))
    published = sorted(response.intersections)
    assert len(cycles) == len(published) == 2
    for cycle, (a_pc, w_pc), figures in zip(cycles, published, [(0.626, 0.3103), (0.874, 1.2156)]):
        assert cycle.amplitude == pytest.approx(a_pc, rel=1e-6)
        assert cycle.omega == pytest.approx(w_pc, rel=1e-6)
        assert (round(cycle.amplitude, 3), round(cycle.omega, 4)) == figures
        assert abs(1 + BACKLASH_LOOP(1j * cycle.omega) * n(cycle.amplitude)) < 1e-10
        # both unstable: a larger amplitude grows (Loeb's criterion and the quasi-linear roots agree)
        assert cycle.stable is False
        assert settles(BACKLASH_LOOP, n, cycle) is False
