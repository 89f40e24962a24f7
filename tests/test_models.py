"""The torque laws are the paper's: symmetry, Lemma 1, theta*, limits, continuity.

Every expected value is computed here from the paper's equations or a property
the paper states, never copied from the package's output.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from backlash_df import MODEL_NAMES, make_model, theta_star
from backlash_df.models import StaticModel

STATIC = [name for name in MODEL_NAMES if name != "exact"]

# ---------------------------------------------------------------- strategies

stiffness = st.floats(1.0, 1e4)
ratio = st.floats(1e-4, 10.0)  # c / k, s
half_gap = st.floats(1e-3, 1.0)
unit = st.floats(-4.0, 4.0)  # x / alpha, and c v / (k alpha)


@st.composite
def shafts(draw, rubber=True):
    k = draw(stiffness)
    alpha = draw(half_gap)
    params = dict(stiffness=k, damping=draw(ratio) * k, half_gap=alpha)
    if rubber:
        params["rubber_thickness"] = draw(st.floats(1e-6, 2.0)) * alpha  # beta = 0, the phase plane law: see law()
    return params


def law(name, **params):
    """:func:`make_model`, but the rubber law without rubber built as itself (make_model refuses it as a
    user's choice: with beta = 0 it is the phase plane law (23)), for the laws' limits at beta = 0."""
    if name == "rubber" and not params.get("rubber_thickness"):
        return StaticModel(name, **params)
    return make_model(name, **params)


def scaled_point(params, xs, vs):
    """(x, v) from x / alpha and c v / (k alpha)."""
    k, c, alpha = params["stiffness"], params["damping"], params["half_gap"]
    return xs * alpha, vs * k * alpha / c


def dead_zone(x, k, alpha):
    """(24)-(25): k D_alpha(x)."""
    return k * (np.clip(np.abs(x) - alpha, 0.0, None) * np.sign(x))


# ---------------------------------------------------------------- odd symmetry


@pytest.mark.parametrize("name", STATIC)
@settings(max_examples=150, deadline=None)
@given(params=shafts(), xs=unit, vs=unit)
def test_static_laws_are_odd(name, params, xs, vs):
    model = make_model(name, **params)
    x, v = scaled_point(params, xs, vs)
    assert model.torque(-x, -v) == -model.torque(x, v)


@settings(max_examples=150, deadline=None)
@given(params=shafts(rubber=False), xs=unit, vs=unit, bs=st.floats(-1.0, 1.0))
def test_exact_torque_is_odd_in_the_mirrored_state(params, xs, vs, bs):
    model = make_model("exact", **params)
    x, v = scaled_point(params, xs, vs)
    theta_b = bs * params["half_gap"]
    assert model.torque(-x, -v, -theta_b) == -model.torque(x, v, theta_b)


def test_exact_torque_along_a_mirrored_trajectory_is_mirrored():
    params = dict(stiffness=100.0, damping=3.0, half_gap=0.1)
    model = make_model("exact", **params)
    t = np.linspace(0.0, 2.0, 4001)
    x = 0.3 * np.sin(5 * t) + 0.05 * np.sin(17 * t)
    v = 1.5 * np.cos(5 * t) + 0.85 * np.cos(17 * t)
    torque, theta_b = model.torque_along(t, x, v, theta_b0=0.02)
    mirrored, theta_m = model.torque_along(t, -x, -v, theta_b0=-0.02)
    np.testing.assert_array_equal(mirrored, -torque)
    np.testing.assert_array_equal(theta_m, -theta_b)


# ---------------------------------------------------------------- Lemma 1 (no pull)


@pytest.mark.parametrize("name", ["phase-plane", "revised-dead-zone", "elasto-backlash", "rubber"])
@settings(max_examples=300, deadline=None)
@given(params=shafts(), xs=unit, vs=unit)
def test_lemma_1_no_pull(name, params, xs, vs):
    """T > 0 only where k x + c v >= k alpha_e, T < 0 only where k x + c v <= -k alpha_e.

    alpha_e = alpha for the steel laws.  The rubber fills the gap from
    alpha - beta/2 on (Section 3: contact at theta* - beta/2), so for the rubber
    law the no-pull border moves in by beta/2: alpha_e = alpha - beta/2.
    """
    model = make_model(name, **params)
    k, c, alpha = params["stiffness"], params["damping"], params["half_gap"]
    edge = alpha - 0.5 * params["rubber_thickness"] if name == "rubber" else alpha
    x, v = scaled_point(params, xs, vs)
    torque = float(model.torque(x, v))
    slack = 1e-12 * (abs(k * x) + abs(c * v) + k * alpha)
    if torque > 0.0:
        assert k * x + c * v >= k * edge - slack
    if torque < 0.0:
        assert k * x + c * v <= -k * edge + slack


def test_rubber_pushes_inside_the_steel_gap():
    """Why the rubber's border is alpha - beta/2: it transmits torque before steel contact."""
    model = make_model("rubber", stiffness=1.0, damping=10.0, half_gap=1.0, rubber_thickness=0.5)
    x = 0.9  # inside |x| < alpha, inside the rubber band alpha - beta/2 < x
    assert model.torque(x, 0.0) == pytest.approx(0.5 * (x - 0.75) ** 2 / 0.5)  # (38)
    assert 1.0 * x + 0.0 < 1.0  # k x + c v < k alpha: not steel contact


def allowed_by_5(x, v, torque, k, c, alpha):
    """True where ``torque`` is one of the values (5) allows at (x, v)."""
    y = x + c * v / k
    right = np.isclose(torque, k * (x - alpha) + c * v, rtol=1e-12, atol=1e-12)
    left = np.isclose(torque, k * (x + alpha) + c * v, rtol=1e-12, atol=1e-12)
    return (torque == 0.0) | ((y >= alpha) & right) | ((y <= -alpha) & left)


def test_dead_zone_26_pulls_exactly_in_areas_a1_a2():
    """(26) gives T != 0 with the wrong sign in A1, A2 (Figure 2(c)), violating (5).

    A2 = {x > alpha, k x + c v < k alpha}: right side of the gap, but the damper
    pulls (T < 0) with the right-contact formula, a value (5) does not allow
    there (inside A_r (5) says T = 0; in A_- only T = 0 or left contact).  A1 is
    its mirror image.  Everywhere else (26) is one of the values (5) allows,
    and the phase plane law (23) is one of them everywhere.
    """
    k, c, alpha = 2.0, 3.0, 0.5
    damped = make_model("damped-dead-zone", stiffness=k, damping=c, half_gap=alpha)
    phase = make_model("phase-plane", stiffness=k, damping=c, half_gap=alpha)
    x, v = np.meshgrid(np.linspace(-3, 3, 401), np.linspace(-2, 2, 401))
    torque = damped.torque(x, v)
    a2 = (x > alpha) & (k * x + c * v < k * alpha)
    a1 = (x < -alpha) & (k * x + c * v > -k * alpha)
    pull = ((x > alpha) & (torque < 0)) | ((x < -alpha) & (torque > 0))
    np.testing.assert_array_equal(pull, a1 | a2)
    assert a1.sum() > 1000 and a2.sum() > 1000  # areas, not a boundary line
    np.testing.assert_array_equal(~allowed_by_5(x, v, torque, k, c, alpha), a1 | a2)
    assert np.all(allowed_by_5(x, v, phase.torque(x, v), k, c, alpha))
    # inside the release set A_r the physics transmits nothing; (26) pulls there
    release = np.abs(k * x + c * v) < k * alpha
    assert np.all(phase.torque(x[release], v[release]) == 0.0)
    assert np.all(torque[release & a2] < 0.0) and np.all(torque[release & a1] > 0.0)


@pytest.mark.parametrize("name", ["phase-plane", "revised-dead-zone"])
@settings(max_examples=200, deadline=None)
@given(params=shafts(rubber=False), xs=unit, vs=unit)
def test_phase_plane_and_revised_laws_give_a_torque_that_5_allows(name, params, xs, vs):
    k, c, alpha = params["stiffness"], params["damping"], params["half_gap"]
    x, v = scaled_point(params, xs, vs)
    torque = make_model(name, **params).torque(x, v)
    assert allowed_by_5(x, v, torque, k, c, alpha)


# ---------------------------------------------------------------- theta*


def _theta_star_bracketed(v, k, c, alpha):
    """Root of (19): f(theta + alpha, v) = 2 alpha, bracketed in [alpha - c v / k, alpha]."""
    s = c * v / k

    def f_minus_2alpha(theta):
        y = theta + alpha
        return y + s * math.exp(-y / s - 1.0) - 2.0 * alpha

    return brentq(f_minus_2alpha, alpha - s, alpha, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500)


def _gap_distance_bracketed(v, k, c, alpha):
    """alpha - theta* as a root of (19) with theta = alpha - d (conditioned in d)."""
    s = c * v / k
    return brentq(lambda d: d - s * math.exp(d / s - 1.0 - 2.0 * alpha / s), 0.0, s,
                  xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500)


@pytest.mark.parametrize("alpha, k, c", [(1.0, 1.0, 10.0), (0.0025, 5895.0, 58.95), (0.05, 5895.0, 3.0)])
def test_theta_star_closed_form_equals_root_of_19_over_ten_decades(alpha, k, c):
    ratios = np.logspace(-2, 8, 201)  # c v / (k alpha): ten decades
    v = ratios * k * alpha / c
    closed = theta_star(v, k, c, alpha)
    bracketed = np.array([_theta_star_bracketed(vi, k, c, alpha) for vi in v])
    np.testing.assert_allclose(closed, bracketed, rtol=1e-12, atol=0.0)
    # and the part that is not trivially alpha or alpha - c v / k, where it is resolvable
    nontrivial = ratios < 1e6
    distance = np.array([_gap_distance_bracketed(vi, k, c, alpha) for vi in v[nontrivial]])
    np.testing.assert_allclose(alpha - closed[nontrivial], distance, rtol=2e-12,
                               atol=4 * np.finfo(float).eps * alpha)
    s = c * v / k
    assert np.all(closed <= alpha) and np.all(closed >= alpha - s)


def test_theta_star_limits():
    k, c, alpha = 1.0, 10.0, 1.0
    assert theta_star(0.0, k, c, alpha) == alpha
    assert theta_star(-3.0, k, c, alpha) == alpha  # defined for v > 0 only
    assert theta_star(1e-6, k, c, alpha) == pytest.approx(alpha, abs=1e-15)
    v = 1e6
    assert (theta_star(v, k, c, alpha) - (alpha - c * v / k)) / (c * v / k) == pytest.approx(0.0, abs=1e-2)


# ---------------------------------------------------------------- rubber law


RUBBER = dict(stiffness=1.0, damping=10.0, half_gap=1.0, rubber_thickness=0.5)  # Figure 2(d)


def _largest_jump(model, n):
    x = np.linspace(-3.0, 3.0, n)
    v = np.linspace(-0.4, 0.4, n)
    torque = model.torque(x[None, :], v[:, None])
    return max(np.abs(np.diff(torque, axis=0)).max(), np.abs(np.diff(torque, axis=1)).max())


def test_rubber_is_continuous_in_x_and_v_everywhere():
    """The largest jump between grid neighbours halves with the grid step (local slope x step).

    A jump anywhere would not shrink; the phase plane law's jump at theta* shows
    the test can tell the difference.  The region holds every border: theta* -+ beta/2,
    the v <= 0 band, the release lines and v = 0, on both sides.
    """
    rubber = make_model("rubber", **RUBBER)
    coarse, fine = _largest_jump(rubber, 801), _largest_jump(rubber, 1601)
    assert fine < 0.55 * coarse
    phase = make_model("phase-plane", **RUBBER)
    assert _largest_jump(phase, 1601) > 0.9 * _largest_jump(phase, 801)


def _rubber_c0(x, k, alpha, beta):
    """(41): the smoothed dead-zone, fourth line's domain as in reading notes item 6."""
    x = np.asarray(x, dtype=float)
    band = 0.5 * k * (np.abs(x) - alpha + 0.5 * beta) ** 2 / beta
    out = np.where(np.abs(x) >= alpha + 0.5 * beta, k * (np.abs(x) - alpha), band)
    out = np.where(np.abs(x) <= alpha - 0.5 * beta, 0.0, out)
    return np.sign(x) * out


@settings(max_examples=100, deadline=None)
@given(k=stiffness, alpha=half_gap, b=st.floats(0.01, 2.0), xs=unit, v=st.floats(-1e3, 1e3))
def test_rubber_reduces_to_41_without_damping(k, alpha, b, xs, v):
    beta = b * alpha
    model = make_model("rubber", stiffness=k, damping=0.0, half_gap=alpha, rubber_thickness=beta)
    x = xs * alpha
    assert float(model.torque(x, v)) == pytest.approx(float(_rubber_c0(x, k, alpha, beta)), rel=1e-12, abs=1e-12 * k * alpha)


def test_rubber_tends_to_phase_plane_as_beta_vanishes():
    """Mean |T_rubber - T_phase| over a region of the phase plane -> 0 like beta."""
    x, v = np.meshgrid(np.linspace(-3, 3, 601), np.linspace(-0.4, 0.4, 401))
    phase = make_model("phase-plane", **RUBBER).torque(x, v)
    means = []
    for beta in (0.1, 0.01, 0.001):
        rubber = make_model("rubber", **{**RUBBER, "rubber_thickness": beta}).torque(x, v)
        means.append(np.mean(np.abs(rubber - phase)))
    assert means[1] < 0.2 * means[0] and means[2] < 0.2 * means[1]
    assert means[2] < 1e-3 * np.mean(np.abs(phase))


# ---------------------------------------------------------------- Remark 2: c -> 0


@pytest.mark.parametrize("name", ["phase-plane", "revised-dead-zone", "damped-dead-zone", "elasto-backlash", "rubber"])
def test_laws_tend_to_classical_dead_zone_as_damping_vanishes(name):
    """sup |T - k D_alpha(x)| over a region is O(c): the areas A1, A2 and the c v term vanish."""
    k, alpha = 1.0, 1.0
    x, v = np.meshgrid(np.linspace(-3, 3, 301), np.linspace(-2, 2, 201))
    reference = dead_zone(x, k, alpha)
    errors = []
    for c in (1e-1, 1e-2, 1e-3, 1e-4):
        model = law(name, stiffness=k, damping=c, half_gap=alpha)
        errors.append(np.abs(model.torque(x, v) - reference).max())
        assert errors[-1] <= 2.0 * c * 2.0 + 1e-15  # |T - k D| <= 2 c |v|max
    assert errors[-1] < 2e-3 * errors[0]


# ---------------------------------------------------------------- elasto-backlash


def _elasto_backlash(x, v, k, c, alpha):
    """Modelica ElastoBacklash as written in the issue, both sides written out."""
    right_c, left_c = k * (x - alpha), k * (x + alpha)
    tau_d = c * v
    right = np.where(right_c + tau_d <= 0.0, 0.0, right_c + np.minimum(right_c, tau_d))
    left = np.where(left_c + tau_d >= 0.0, 0.0, left_c + np.maximum(left_c, tau_d))
    return np.where(x > alpha, right, np.where(x < -alpha, left, 0.0))


@settings(max_examples=200, deadline=None)
@given(params=shafts(rubber=False), xs=unit, vs=unit)
def test_elasto_backlash_follows_its_definition(params, xs, vs):
    model = make_model("elasto-backlash", **params)
    x, v = scaled_point(params, xs, vs)
    expected = _elasto_backlash(x, v, params["stiffness"], params["damping"], params["half_gap"])
    assert float(model.torque(x, v)) == pytest.approx(float(expected), rel=1e-13, abs=1e-300)


def test_elasto_backlash_closes_at_alpha_whatever_the_speed_and_is_continuous():
    model = make_model("elasto-backlash", **{**RUBBER, "rubber_thickness": 0.0})
    v = np.linspace(0.01, 10.0, 50)
    assert np.all(model.torque(1.0 - 1e-9, v) == 0.0)  # the phase plane law would push here
    assert np.all(make_model("phase-plane", **RUBBER).torque(1.0 - 1e-9, v[v > 0.2]) > 0.0)
    assert _largest_jump(model, 1601) < 0.55 * _largest_jump(model, 801)


# ---------------------------------------------------------------- exact model


def test_exact_model_without_damping_is_the_dead_zone_along_a_trajectory():
    k, alpha = 50.0, 0.1
    t = np.linspace(0.0, 3.0, 3001)
    x = 0.25 * np.sin(4.0 * t) + 0.1 * np.sin(11.0 * t)
    v = 1.0 * np.cos(4.0 * t) + 1.1 * np.cos(11.0 * t)
    for c in (0.0, 1e-9 * k):
        torque, _ = make_model("exact", stiffness=k, damping=c, half_gap=alpha).torque_along(t, x, v)
        np.testing.assert_allclose(torque, dead_zone(x, k, alpha), atol=1e-6 * k * alpha)


def test_exact_model_free_motion_follows_13():
    """Off contact theta_b - theta_d decays as exp(-k t / c), eq. (13), whatever theta_d does."""
    k, c, alpha = 100.0, 5.0, 1.0
    t = np.linspace(0.0, 0.5, 501)
    x = 0.2 + 0.3 * t  # stays well inside the gap
    v = np.full_like(t, 0.3)
    torque, theta_b = make_model("exact", stiffness=k, damping=c, half_gap=alpha).torque_along(t, x, v, theta_b0=-0.1)
    np.testing.assert_allclose(theta_b, x + (-0.1 - 0.2) * np.exp(-k * t / c), rtol=1e-12, atol=1e-14)
    assert np.all(torque == 0.0)


@settings(max_examples=40, deadline=None)
@given(params=shafts(rubber=False), amplitude=st.floats(0.5, 5.0), omega=st.floats(0.1, 50.0),
       bias=st.floats(-2.0, 2.0), b0=st.floats(-1.0, 1.0))
def test_exact_model_contact_invariants(params, amplitude, omega, bias, b0):
    """|theta_b| <= alpha; T > 0 only in right contact, with T = k (x - alpha) + c v; mirror on the left."""
    k, c, alpha = params["stiffness"], params["damping"], params["half_gap"]
    model = make_model("exact", **params)
    t = np.linspace(0.0, 4 * np.pi / omega, 2001)
    x = alpha * (bias + amplitude * np.sin(omega * t))
    v = alpha * amplitude * omega * np.cos(omega * t)
    torque, theta_b = model.torque_along(t, x, v, theta_b0=b0 * alpha)
    assert np.all(np.abs(theta_b) <= alpha)
    right, left = torque > 0, torque < 0
    np.testing.assert_array_equal(theta_b[right], alpha)
    np.testing.assert_array_equal(theta_b[left], -alpha)
    np.testing.assert_allclose(torque[right], k * (x[right] - alpha) + c * v[right], rtol=1e-12)
    np.testing.assert_allclose(torque[left], k * (x[left] + alpha) + c * v[left], rtol=1e-12)
    # Lemma 1 holds for the exact model too (up to the round-off of a contact that just begins:
    # T = 3e-17 N m where k x + c v rounds to k alpha)
    slack = 4 * np.finfo(float).eps * k * alpha
    assert np.all(k * x[right] + c * v[right] > k * alpha - slack)
    assert np.all(k * x[left] + c * v[left] < -k * alpha + slack)


def test_exact_model_agrees_with_phase_plane_when_the_shaft_relaxes_between_contacts():
    """Remark 1 / notes item 10: with c w A / (k alpha) small, approximation (ii) is exact."""
    k, c, alpha = 100.0, 0.01, 1.0
    t = np.linspace(0.0, 20.0, 40001)
    x, v = 2.0 * np.sin(t), 2.0 * np.cos(t)
    exact, _ = make_model("exact", stiffness=k, damping=c, half_gap=alpha).torque_along(t, x, v)
    phase = make_model("phase-plane", stiffness=k, damping=c, half_gap=alpha).torque(x, v)
    assert np.abs(exact - phase).max() < 1e-3 * np.abs(phase).max()


# ---------------------------------------------------------------- broadcasting and bad input


def test_torque_broadcasts_like_a_ufunc():
    model = make_model("phase-plane", stiffness=1.0, damping=10.0, half_gap=1.0)
    x = np.linspace(-2, 2, 3)[:, None]
    v = np.linspace(-1, 1, 4)[None, :]
    torque = model.torque(x, v)
    assert torque.shape == (3, 4)
    assert torque[2, 0] == model.torque(2.0, -1.0)


@pytest.mark.parametrize(
    "params, match",
    [
        (dict(stiffness=-1.0, half_gap=0.1), "stiffness must be > 0"),
        (dict(stiffness=float("nan"), half_gap=0.1), "stiffness must be finite"),
        (dict(stiffness=float("inf"), half_gap=0.1), "stiffness must be finite"),
        (dict(stiffness=1.0, half_gap=0.0), "half_gap must be > 0"),
        (dict(stiffness=1.0, half_gap=-0.1), "half_gap must be > 0"),
        (dict(stiffness=1.0, half_gap=0.1, damping=-1.0), "damping must be >= 0"),
        (dict(stiffness=1.0, half_gap=0.1, rubber_thickness=0.3), "rubber_thickness must be <="),
        (dict(stiffness="stiff", half_gap=0.1), "stiffness must be a number"),
        (dict(half_gap=0.1), "missing shaft parameter.*stiffness"),
    ],
)
@pytest.mark.parametrize("name", ["phase-plane", "exact"])
def test_bad_parameters_raise_value_error_naming_them(name, params, match):
    with pytest.raises(ValueError, match=match):
        make_model(name, **params)


def test_unknown_model_name():
    with pytest.raises(ValueError, match="unknown model 'hysteresis'"):
        make_model("hysteresis", stiffness=1.0, half_gap=0.1)


def test_non_finite_state_is_rejected():
    model = make_model("dead-zone", stiffness=1.0, half_gap=0.1)
    with pytest.raises(ValueError, match="theta_d must be finite"):
        model.torque([0.0, np.nan], 0.0)


def test_rubber_without_rubber_is_refused_as_the_rig_loader_refuses_it():
    """With beta = 0 the rubber law (40) is the phase plane law (23): a result labelled rubber would be that."""
    with pytest.raises(ValueError, match=r"model 'rubber' needs rubber_thickness > 0"):
        make_model("rubber", stiffness=5895.0, damping=3.0, half_gap=0.05)
    with pytest.raises(ValueError, match=r"model 'rubber' needs rubber_thickness > 0"):
        make_model("rubber", stiffness=5895.0, damping=3.0, half_gap=0.05, rubber_thickness=0.0)
    law = StaticModel("rubber", stiffness=5895.0, damping=3.0, half_gap=0.05)
    x, v = np.meshgrid(np.linspace(-0.2, 0.2, 41), np.linspace(-5.0, 5.0, 21))
    phase = make_model("phase-plane", stiffness=5895.0, damping=3.0, half_gap=0.05)
    assert np.array_equal(law.torque(x, v), phase.torque(x, v))
