"""Describing functions: closed forms, an independent FFT, refinement, limits, symmetry, an mpmath reference."""

import mpmath
import numpy as np
import pytest

from backlash_df import describing_function, describing_function_grid, make_model
from backlash_df.describing import phase_plane_validity
from backlash_df.describing._evaluation import evaluate
from backlash_df.models import StaticModel, theta_star

K, C, ALPHA, BETA = 5895.0, 3.0, 0.05, 0.05
STATIC = ["dead-zone", "damped-dead-zone", "revised-dead-zone", "phase-plane", "rubber", "elasto-backlash"]
ALL = STATIC + ["exact"]


def model(name, **changes):
    params = dict(stiffness=K, damping=C, half_gap=ALPHA, rubber_thickness=BETA)
    params.update(changes)
    return make_model(name, **params)


def tustin(a_over_alpha):
    """Dead-zone DF / k, written as in the textbooks (Gelb and Vander Velde)."""
    r = 1.0 / a_over_alpha
    return 1.0 - (2.0 / np.pi) * (np.arcsin(r) + r * np.sqrt(1.0 - r * r))


def fourier_by_fft(torque, amplitude):
    """N and mean from torque samples on a uniform phase grid over one period."""
    spectrum = np.fft.rfft(torque) / torque.size
    # T = a0 + b1 sin + a1 cos + ...: rfft[1] = (a1 - j b1) / 2
    b1 = -2.0 * spectrum[1].imag
    a1 = 2.0 * spectrum[1].real
    return (b1 + 1j * a1) / amplitude, spectrum[0].real


# ------------------------------------------------------------------ closed forms


@pytest.mark.parametrize("name", ["dead-zone", "damped-dead-zone", "revised-dead-zone"])
def test_harmonic_balance_matches_closed_forms_over_ten_decades_of_rate(name):
    ratio = np.geomspace(1.0001, 1e3, 41)[:, None]
    rate = np.geomspace(1e-5, 1e5, 41)[None, :]  # c w A / (k alpha)
    amplitude = ratio * ALPHA
    omega = rate * K * ALPHA / (C * amplitude)
    closed = describing_function(model(name), amplitude, omega, method="closed-form")
    balance = describing_function(model(name), amplitude, omega, method="harmonic-balance")
    np.testing.assert_allclose(balance, closed, rtol=1e-10, atol=0.0)


def test_closed_forms_are_the_textbook_formulas():
    # (26): the damper adds j c w on the same contact fraction; (27) is a dead-zone of
    # y = x + (c/k) v, amplitude A sqrt(1 + (c w / k)^2), phase-shifted by atan(c w / k)
    ratio, omega = 1.7, 400.0
    amplitude = ratio * ALPHA
    f = tustin(ratio)
    assert describing_function(model("dead-zone"), amplitude, omega) == pytest.approx(K * f, rel=1e-13)
    assert describing_function(model("damped-dead-zone"), amplitude, omega) == pytest.approx(
        (K + 1j * C * omega) * f, rel=1e-13)
    radius = amplitude * np.hypot(1.0, C * omega / K)
    assert describing_function(model("revised-dead-zone"), amplitude, omega) == pytest.approx(
        (K + 1j * C * omega) * tustin(radius / ALPHA), rel=1e-13)


def test_closed_form_keeps_precision_next_to_the_gap():
    # A = alpha (1 + e): F = (16 sqrt 2 / (3 pi)) e^(3/2) (1 + O(e))
    excess = 1e-10
    value = describing_function(model("dead-zone"), ALPHA * (1.0 + excess), 1.0).real / K
    assert value == pytest.approx(16.0 * np.sqrt(2.0) / (3.0 * np.pi) * excess**1.5, rel=1e-8)


# ------------------------------------------------------------------ independent FFT


@pytest.mark.parametrize("name", STATIC)
@pytest.mark.parametrize("ratio, omega, bias", [(1.3, 150.0, 0.0), (4.0, 900.0, 0.0), (2.0, 300.0, 0.02)])
def test_harmonic_balance_matches_fft_of_the_sampled_torque(name, ratio, omega, bias):
    law = model(name)
    amplitude = ratio * ALPHA
    phi = np.arange(2**18) * (2.0 * np.pi / 2**18)
    torque = law.torque(bias + amplitude * np.sin(phi), amplitude * omega * np.cos(phi))
    n_fft, mean_fft = fourier_by_fft(torque, amplitude)
    n, mean = evaluate(law, amplitude, omega, bias, "harmonic-balance")
    # the jumps of (23) and (26) limit the sampled sum to first order: 1/M ~ 4e-6
    assert abs(complex(n) - n_fft) <= 2e-5 * abs(n_fft)
    assert float(mean) == pytest.approx(mean_fft, abs=2e-5 * K * ALPHA)


@pytest.mark.parametrize("ratio, rate", [(1.2, 0.05), (3.0, 0.5), (2.0, 3.0)])
def test_exact_model_matches_a_time_simulation_of_14_along_the_sinusoid(ratio, rate):
    law = model("exact")
    amplitude = ratio * ALPHA
    omega = rate * K / C
    period = 2.0 * np.pi / omega
    samples = 2**14
    time = np.arange(8 * samples + 1) * (period / samples)
    torque, _ = law.torque_along(time, amplitude * np.sin(omega * time), amplitude * omega * np.cos(omega * time))
    n_sim, _ = fourier_by_fft(torque[-samples - 1:-1], amplitude)  # the 8th period: steady
    n = describing_function(law, amplitude, omega)
    assert abs(complex(n) - n_sim) <= 2e-4 * abs(n_sim)


# ------------------------------------------------------------------ refinement


@pytest.mark.parametrize("name", ["phase-plane", "rubber", "elasto-backlash"])
def test_refining_the_quadrature_changes_n_by_less_than_1e_10(name):
    amplitude = ALPHA * np.geomspace(1.01, 50.0, 15)[:, None]
    omega = np.geomspace(1.0, 2e4, 15)[None, :]
    coarse, _ = evaluate(model(name), amplitude, omega, 0.0, "harmonic-balance")
    fine, _ = evaluate(model(name), amplitude, omega, 0.0, "harmonic-balance", samples=256, gauss_order=32)
    scale = np.maximum(np.abs(fine), 1e-300)
    assert np.max(np.abs(coarse - fine) / scale) < 1e-10


def test_gauss_kronrod_rule_is_exact_to_its_degrees():
    # the 7-15 rule integrates polynomials exactly to degree 23, its Gauss part to 13
    # (odd degrees vanish by symmetry: the even ones tell)
    from backlash_df.describing._kernels import KRONROD

    pairs, kronrod, gauss = KRONROD.T  # rows +-x, the last the centre x = 0
    assert pairs[-1] == 0.0 and np.all(pairs[:-1] > 0.0)
    nodes = np.concatenate([pairs, -pairs[:-1]])
    kronrod, gauss = (np.concatenate([weights, weights[:-1]]) for weights in (kronrod, gauss))
    for degree in range(0, 26, 2):
        exact = 2.0 / (degree + 1)
        assert (abs(kronrod @ nodes**degree - exact) < 1e-15) == (degree <= 23)
        assert (abs(gauss @ nodes**degree - exact) < 1e-15) == (degree <= 13)


def boundary_distances(law, x, v):
    """|value| of every boundary of the phase plane and rubber laws at (x, v), in rad:
    (19)-(20) theta*, release k (x - alpha) + c v = 0, (28) both lines, v = 0; both sides."""
    k, c, alpha, beta = law.params
    distances = []
    for xs, vs in ((x, v), (-x, -v)):
        ts = float(theta_star(vs, k, c, alpha))
        distances += [xs - ts, xs - ts - beta / 2, xs - ts + beta / 2, xs - alpha - beta / 2,
                      xs - alpha + c * vs / k, xs - alpha + beta / 2 + 2 * c * vs / k, c * vs / k]
    return np.abs(distances)


@pytest.mark.parametrize("name, ratio, omega", [("phase-plane", 1.2, 2000.0), ("rubber", 1.2, 2000.0),
                                                ("rubber", 3.0, 800.0), ("rubber", 20.0, 100.0)])
def test_every_switch_is_located_to_the_last_ulp_on_a_boundary_of_the_law(name, ratio, omega):
    from backlash_df.describing._kernels import locate_switch, piece
    from backlash_df._laws import static_mode

    law = model(name)
    amplitude = ratio * ALPHA
    phases = np.pi / 2 + np.linspace(0.0, 2.0 * np.pi, 65)
    mode = static_mode(law.law, amplitude, 0.0, *law.params)
    mode, current = piece(law.law, mode, phases[0], amplitude, omega, 0.0, law.params)
    switches = 0
    for lo, hi in zip(phases[:-1], phases[1:]):
        while piece(law.law, mode, hi, amplitude, omega, 0.0, law.params)[1] != current:
            switch = locate_switch(law.law, mode, current, lo, hi, amplitude, omega, 0.0, law.params)
            # the piece changes between the float before the switch and the switch itself
            before = np.nextafter(switch, -np.inf)
            assert piece(law.law, mode, before, amplitude, omega, 0.0, law.params)[1] == current
            mode, current = piece(law.law, mode, switch, amplitude, omega, 0.0, law.params)
            x, v = amplitude * np.sin(switch), amplitude * omega * np.cos(switch)
            assert boundary_distances(law, x, v).min() < 1e-14
            lo, switches = switch, switches + 1
    assert switches >= 4


def test_exact_model_does_not_depend_on_its_search_step():
    amplitude = ALPHA * np.geomspace(1.01, 50.0, 12)[:, None]
    omega = np.geomspace(1.0, 2e4, 12)[None, :]
    coarse, _ = evaluate(model("exact"), amplitude, omega, 0.0, "auto")
    fine, _ = evaluate(model("exact"), amplitude, omega, 0.0, "auto", scan_step=0.005)
    scale = np.maximum(np.abs(fine), 1e-300)
    assert np.max(np.abs(coarse - fine) / scale) < 1e-6


# ------------------------------------------------------------------ limits (Remark 2, beta -> 0)


@pytest.mark.parametrize("name", ["phase-plane", "revised-dead-zone", "rubber", "exact", "elasto-backlash"])
def test_every_damped_law_tends_to_the_damped_dead_zone_as_c_goes_to_zero(name):
    amplitude = ALPHA * np.array([1.05, 1.5, 4.0, 30.0])[:, None]
    omega = np.array([5.0, 50.0, 500.0])[None, :]
    for damping in (1e-3, 1e-6):
        reference = describing_function(model("damped-dead-zone", damping=damping), amplitude, omega)
        # the rubber law at beta = 0 itself, built past make_model (which refuses it as a user's choice)
        law = (StaticModel("rubber", stiffness=K, damping=damping, half_gap=ALPHA) if name == "rubber"
               else model(name, damping=damping))
        n = describing_function(law, amplitude, omega)
        assert np.max(np.abs(n - reference) / np.abs(reference)) < 50.0 * damping / C


def test_rubber_tends_to_the_phase_plane_law_as_beta_goes_to_zero():
    amplitude = ALPHA * np.array([1.2, 2.0, 5.0])[:, None]
    omega = np.array([10.0, 300.0])[None, :]
    phase = describing_function(model("phase-plane"), amplitude, omega)
    errors = []
    for beta in (1e-2, 1e-3, 1e-4):
        rubber = describing_function(model("rubber", rubber_thickness=beta), amplitude, omega)
        errors.append(np.max(np.abs(rubber - phase) / np.abs(phase)))
    assert errors[0] > errors[1] > errors[2] and errors[2] < 1e-3


def test_a_rubber_band_far_thinner_than_the_amplitude_gives_the_phase_plane_law():
    # beta / A down to 1e-11, at high amplitude and rate: x - theta* + beta / 2 keeps beta / (eps A) of its
    # digits, the band torque is round-off to the quadrature's tolerance, and its adaptive rule stops at
    # _MAX_PANELS sub-intervals (before, these six points took seconds to a minute each); the band's share
    # of N is of order beta, so N is the phase plane law's
    amplitude = ALPHA * np.array([166.9213314214236, 83.45978308842672, 30.0])[:, None]
    omega = np.array([2.8770933466367272, 0.8646511722700639])[None, :] * K / C
    phase = describing_function(model("phase-plane"), amplitude, omega)
    for beta in (1e-6 * ALPHA, 1e-9 * ALPHA):
        rubber = describing_function(model("rubber", rubber_thickness=beta), amplitude, omega)
        assert np.max(np.abs(rubber - phase) / np.abs(phase)) < 1e-12


def test_exact_and_phase_plane_agree_where_the_shaft_relaxes_between_contacts():
    # reading notes item 10: agreement when c w A / (k alpha) is small
    ratio = np.geomspace(1.05, 100.0, 20)[:, None]
    amplitude = ratio * ALPHA
    omega = 0.01 * K * ALPHA / (C * amplitude) * np.array([[0.01, 0.1, 1.0]])
    exact = describing_function(model("exact"), amplitude, omega)
    phase = describing_function(model("phase-plane"), amplitude, omega)
    assert np.max(np.abs(exact - phase) / np.abs(exact)) < 0.005


def test_every_law_tends_to_the_linear_shaft_at_large_amplitude():
    # contact nearly all the time: N -> k + j c w, to O(alpha / A).  Not the
    # ElastoBacklash law: it clips the damper wherever c v > k (|x| - alpha).
    for name in set(ALL) - {"elasto-backlash"}:
        n = describing_function(model(name), 1e4 * ALPHA, 200.0)
        damper = 0.0 if name == "dead-zone" else C * 200.0
        assert abs(complex(n) - (K + 1j * damper)) < 3e-4 * K


# ------------------------------------------------------------------ no contact, bias, symmetry


@pytest.mark.parametrize("name", ["dead-zone", "damped-dead-zone", "revised-dead-zone", "elasto-backlash", "exact"])
def test_no_contact_no_torque(name):
    bias = np.array([0.0, 0.01, -0.02])
    amplitude = (ALPHA - np.abs(bias)) * 0.999
    law = model(name, damping=1e-3)  # revised (27) closes early by c v / k: keep it small
    n, mean = evaluate(law, amplitude, 50.0, bias, "auto")
    assert np.all(n == 0.0) and np.all(mean == 0.0)


def test_no_contact_no_torque_for_the_rubber_law():
    bias = np.array([0.0, 0.01])
    amplitude = (ALPHA - BETA / 2 - np.abs(bias)) * 0.999
    n, mean = evaluate(model("rubber", damping=1e-3), amplitude, 50.0, bias, "auto")
    assert np.all(n == 0.0) and np.all(mean == 0.0)


def test_phase_plane_law_closes_the_gap_below_alpha_at_high_rate():
    # theta* < alpha: approximation (ii) transmits torque for A < alpha (shown in the validity map)
    amplitude = 0.9 * ALPHA
    fast = K * ALPHA / C * 20.0 / amplitude
    assert abs(complex(describing_function(model("phase-plane"), amplitude, fast))) > 0.0
    assert complex(describing_function(model("exact"), amplitude, fast)) == 0.0
    validity = phase_plane_validity(K, C, ALPHA, [0.9, 2.0], [1e-3, 50.0])
    assert validity.early_contact[0, 1] and not validity.early_contact[1].any()


@pytest.mark.parametrize("name", ALL)
def test_odd_symmetry_makes_n_even_and_the_mean_odd_in_the_bias(name):
    amplitude, omega = np.array([0.06, 0.12]), 300.0
    n_up, mean_up = evaluate(model(name), amplitude, omega, 0.015, "auto")
    n_down, mean_down = evaluate(model(name), amplitude, omega, -0.015, "auto")
    np.testing.assert_allclose(n_down, n_up, rtol=1e-9)
    np.testing.assert_allclose(mean_down, -mean_up, rtol=1e-9)


def test_permanent_contact_gives_the_linear_shaft_and_its_mean():
    # bias beyond the gap, small amplitude: T = k (x - alpha) + c v all period
    bias, amplitude, omega = 0.2, 0.01, 40.0
    for name in ("damped-dead-zone", "phase-plane", "exact", "revised-dead-zone"):
        n, mean = evaluate(model(name), amplitude, omega, bias, "auto")
        assert complex(n) == pytest.approx(K + 1j * C * omega, rel=1e-12)
        assert float(mean) == pytest.approx(K * (bias - ALPHA), rel=1e-12)


def test_grid_result_and_plot():
    result = describing_function_grid(model("phase-plane"), ALPHA * np.array([1.2, 2.0, 5.0]), [10.0, 1000.0])
    assert result.N.shape == (3, 2)
    np.testing.assert_allclose(result.gain, np.abs(result.N))
    assert np.all(result.phase_deg > 0.0)  # the damped law leads (notes item 11)
    drawn = result.plot()
    assert len(drawn.axes[0].lines) == 2


def test_phase_plane_leads_less_than_the_damped_dead_zone():
    # reading notes item 11: the smaller lead of (23) is what lets Nyquist curves meet -1/N
    amplitude = ALPHA * np.geomspace(1.1, 20.0, 12)
    omega = 100.0
    phase = np.angle(describing_function(model("phase-plane"), amplitude, omega))
    dead = np.angle(describing_function(model("damped-dead-zone"), amplitude, omega))
    assert np.all(phase < dead)


# ------------------------------------------------------------------ bad input


@pytest.mark.parametrize(
    "amplitude, omega, bias, match",
    [
        (0.0, 10.0, 0.0, "amplitude must be > 0"),
        (-0.1, 10.0, 0.0, "amplitude must be > 0"),
        (np.nan, 10.0, 0.0, "amplitude must be finite"),
        (0.1, -1.0, 0.0, "omega must be >= 0"),
        (0.1, np.inf, 0.0, "omega must be finite"),
        (0.1, 10.0, np.nan, "bias must be finite"),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(amplitude, omega, bias, match):
    with pytest.raises(ValueError, match=match):
        describing_function(model("phase-plane"), amplitude, omega, bias=bias)


def test_closed_form_request_for_a_law_without_one():
    with pytest.raises(ValueError, match="no closed-form"):
        describing_function(model("phase-plane"), 0.1, 10.0, method="closed-form")


def test_phase_plane_contact_is_held_until_release_as_in_the_simulation():
    # Just above the gap at high rate, (23) read as a memoryless function would drop
    # contact for an instant before the peak (x < theta*(v) while v decays); the
    # simulation holds contact until release (_laws.held_mode) and so does the DF.
    from backlash_df._laws import held_mode, mode_torque, static_mode

    law = model("phase-plane")
    amplitude, omega = 1.001 * ALPHA, 11595.0
    k, c, alpha, beta = law.params
    samples = 2**16
    phi = 0.5 * np.pi + np.arange(2 * samples) * (2.0 * np.pi / samples)
    x = amplitude * np.sin(phi)
    v = amplitude * omega * np.cos(phi)
    mode = static_mode(law.law, x[0], 0.0, k, c, alpha, beta)
    torque = np.empty(phi.size)
    for i in range(phi.size):  # march the held mode sample by sample, two periods
        mode = held_mode(law.law, mode, x[i], v[i], k, c, alpha, beta)
        torque[i] = mode_torque(law.law, mode, x[i], v[i], k, c, alpha, beta)
    spectrum = np.fft.rfft(torque[samples:]) / samples
    # the samples start at phi0 = phi[samples]: refer the harmonic back to phi = 0
    first = 2.0 * spectrum[1] * np.exp(-1j * phi[samples])  # = a1 - j b1
    n_marched = (-first.imag + 1j * first.real) / amplitude
    n = complex(describing_function(law, amplitude, omega))
    assert abs(n - n_marched) <= 1e-3 * abs(n_marched)


# ------------------------------------------------------------------ switch-exact kernels


def reference_points(size, seed):
    """A seeded sample of the validity map's regions: A / alpha in [1.001, 100], c w / k in
    [1e-3, 10] (log-uniform), half the points without bias, half with bias / alpha in [-2, 2]."""
    rng = np.random.default_rng(seed)
    ratio = np.exp(rng.uniform(np.log(1.001), np.log(100.0), size))
    rate = np.exp(rng.uniform(np.log(1e-3), np.log(10.0), size))
    bias = np.where(np.arange(size) < size // 2, 0.0, rng.uniform(-2.0, 2.0, size)) * ALPHA
    return ratio * ALPHA, rate * K / C, bias


@pytest.mark.parametrize("name", STATIC)
def test_switch_exact_kernels_agree_with_the_sampled_walk_on_10000_points(name):
    # the walk of earlier releases (64 samples, switches settled by bisection on the mode),
    # here with 256 samples: at 64 it misses a narrow band of the rubber law at 1 point in 10^4
    amplitude, omega, bias = reference_points(10_000, seed=2024)
    law = model(name)
    n_walk, mean_walk = evaluate(law, amplitude, omega, bias, "harmonic-balance", samples=256)
    n, mean = evaluate(law, amplitude, omega, bias, "harmonic-balance")
    scale = np.abs(n_walk)
    assert np.all(scale > 0.0)
    assert np.max(np.abs(n - n_walk) / scale) < 1e-12
    assert np.max(np.abs(mean - mean_walk) / (scale * amplitude)) < 1e-12


def mp_describing_function(name, amplitude, omega, bias, damping=C, scan=360):
    """N and the mean torque of a static law at 30 digits, from the paper's equations alone.

    Every boundary of the law's regions is sampled at ``scan`` phases over a period, each sign
    change refined by mpmath.findroot (Anderson-Bjorck, bracketing); the mode is decided at
    the middle of each piece (contact of (23) held from theta* until the release, Theorem 1),
    and each piece integrated by mpmath.quad.  Left contact by odd symmetry T(-x, -v) = -T(x, v).
    """
    with mpmath.workdps(30):
        k, c, alpha, beta = (mpmath.mpf(value) for value in (K, damping, ALPHA, BETA))
        amp, w, b = (mpmath.mpf(value) for value in (amplitude, omega, bias))

        def state(phi):
            return b + amp * mpmath.sin(phi), amp * w * mpmath.cos(phi)

        def closing(x, v, offset):
            """(19) as f(x - offset + alpha, v) - 2 alpha: zero where x = theta*(v) + offset (v > 0);
            where y - offset < alpha (f not monotone there, x below theta* + offset), y - offset - alpha."""
            s = c * v / k
            z = x - offset + alpha
            if s <= 0 or z + s < 2 * alpha:
                return z + max(s, 0) - 2 * alpha
            return z - 2 * alpha + s * mpmath.exp(-z / s - 1)

        def theta_star(v):
            s = c * v / k
            return mpmath.findroot(lambda t: closing(t, v, 0), (alpha - s, alpha), solver="anderson")

        def boundaries(x, v):
            """Right-side boundary functions, each continuous along the sinusoid."""
            release = k * (x - alpha) + c * v
            if name in ("dead-zone", "damped-dead-zone"):
                return [x - alpha]
            if name == "revised-dead-zone":
                return [release]
            if name == "elasto-backlash":
                return [x - alpha, release, k * (x - alpha) - c * v]
            if name == "phase-plane":
                return [release, closing(x, v, 0)]
            # rubber: (28) both lines, x = alpha + beta / 2, release
            return [closing(x, v, beta / 2), closing(x, v, -beta / 2), x - alpha - beta / 2,
                    x - alpha + beta / 2 + 2 * c * v / k, release]

        def right_mode(x, v, before):
            """0 free, 1 rubber band, 2 contact, right side; ``before`` the mode held until here."""
            release = k * (x - alpha) + c * v
            if name in ("dead-zone", "damped-dead-zone"):
                return 2 if x > alpha else 0
            if name == "revised-dead-zone":
                return 2 if release > 0 else 0
            if name == "elasto-backlash":
                return 2 if x > alpha and release > 0 else 0
            if name == "phase-plane":  # (20): both lines; contact held until release
                closed = release >= 0 and (v <= 0 or closing(x, v, 0) >= 0)
                return 2 if closed or (before == 2 and release >= 0) else 0
            if v > 0:  # (28) first line, (29)
                ts = theta_star(v)
                return 2 if x >= ts + beta / 2 else (1 if x > ts - beta / 2 else 0)
            if x >= alpha + beta / 2:
                return 2 if release >= 0 else 0
            return 1 if x > alpha - beta / 2 - 2 * c * v / k else 0  # (28) second line, notes item 5

        def right_torque(mode, x, v):
            if mode == 0:
                return mpmath.mpf(0)
            if name == "dead-zone":
                return k * (x - alpha)
            if name == "elasto-backlash":
                return k * (x - alpha) + min(k * (x - alpha), c * v)
            if mode == 2:
                return k * (x - alpha) + c * v  # (23), (26), (27), (33)
            if v > 0:  # (36) first line
                ts = theta_star(v)
                return (k * (x - ts + beta / 2) / 2 + k * (ts - alpha) + c * v) * (x - ts + beta / 2) / beta
            # (36) second line with the denominator beta + 2 c v / k (notes item 5)
            return (k * (x - alpha + beta / 2) / 2 + c * v) * (x - alpha + beta / 2 + 2 * c * v / k) / (
                beta + 2 * c * v / k)

        start = mpmath.pi / 2
        grid = [start + 2 * mpmath.pi * i / scan for i in range(scan + 1)]
        switches = [start, start + mpmath.pi, start + 2 * mpmath.pi]  # v = 0: (36) changes line
        for side in (1, -1):
            values = [boundaries(*(side * q for q in state(phi))) for phi in grid]
            for i in range(len(values[0])):
                for j in range(scan):
                    if (values[j][i] > 0) != (values[j + 1][i] > 0):
                        def boundary(phi, i=i, side=side):
                            return boundaries(*(side * q for q in state(phi)))[i]
                        switches.append(mpmath.findroot(boundary, (grid[j], grid[j + 1]), solver="anderson"))
        switches.sort()
        integrals = [mpmath.mpf(0)] * 3
        modes = [0, 0]  # held modes, right and left
        for a, e in zip(switches[:-1], switches[1:]):
            if e - a < mpmath.mpf(10) ** -25:
                continue
            x, v = state((a + e) / 2)
            modes = [right_mode(x, v, modes[0]), right_mode(-x, -v, modes[1])]
            if modes[0] and modes[1]:
                raise AssertionError("right and left contact at once")
            side = 1 if modes[0] else -1
            mode = max(modes)

            def torque(phi, side=side, mode=mode):
                x, v = state(phi)
                return side * right_torque(mode, side * x, side * v)

            for i, weight in enumerate((mpmath.sin, mpmath.cos, lambda phi: 1)):
                integrals[i] += mpmath.quad(lambda phi: torque(phi) * weight(phi), [a, e])
        n = (integrals[0] + 1j * integrals[1]) / (mpmath.pi * amp)
        return complex(n), float(integrals[2] / (2 * mpmath.pi))


# (A / alpha, c w / k, bias / alpha): low, middle and high rate; just above the gap at high rate,
# where (23) read as a function would drop contact before the peak; below the gap (theta* < alpha
# closes it early); with bias; and the rubber point where a 64-sample walk misses the band
MP_POINTS = [(1.3, 0.15, 0.0), (4.0, 0.9, 0.0), (30.0, 0.02, 0.0), (1.001, 5.9, 0.0), (0.9, 22.0, 0.0),
             (2.0, 0.3, 0.4), (3.0, 5.0, -0.7), (1.50101280768794, 4.050261330690965, 0.0)]


@pytest.mark.parametrize("name", STATIC)
@pytest.mark.parametrize("ratio, rate, bias", MP_POINTS)
def test_switch_exact_kernels_match_an_mpmath_reference_with_its_own_switches(name, ratio, rate, bias):
    amplitude, omega, bias = ratio * ALPHA, rate * K / C, bias * ALPHA
    n_mp, mean_mp = mp_describing_function(name, amplitude, omega, bias)
    n, mean = evaluate(model(name), amplitude, omega, bias, "harmonic-balance")
    if n_mp == 0.0:
        assert complex(n) == 0.0 and float(mean) == 0.0
        return
    assert abs(complex(n) - n_mp) <= 1e-13 * abs(n_mp)
    assert abs(float(mean) - mean_mp) <= 1e-13 * abs(n_mp) * amplitude


@pytest.mark.parametrize("rate", [0.05, 0.3, 1.1095969687283675, 3.0, 10.0, 100.0])
def test_critical_points_of_x_minus_theta_star_match_a_dense_sampling(rate):
    # on v > 0, phi in (0, pi/2), x - theta*(v) rises, or rises, falls and rises again: the
    # kernels bracket the theta* crossings between its critical points.  Checked against the
    # sign changes of its slope on 2^16 phases (theta* from models.theta_star); 4.53 at
    # c w / k = 1.1096 lies just above the floor of the criticality level with no critical point
    from backlash_df.describing._kernels import critical_points

    phi = np.linspace(0.0, np.pi / 2, 2**16 + 1)
    for ratio in (0.3, 1.001, 2.0, 4.533105131932044, 20.0, 100.0):
        amplitude, omega = ratio * ALPHA, rate * K / C
        gamma = amplitude * np.sin(phi) - theta_star(amplitude * omega * np.cos(phi), K, C, ALPHA)
        turns = np.nonzero(np.diff(np.sign(np.diff(gamma))) != 0)[0] + 1
        crit = np.full(5, -1.0)
        found = critical_points(amplitude, rate, ALPHA, crit, True)
        if not found:
            # a turn within a few samples of pi/2 is below the resolution of theta* (D ~ 1e-17)
            assert turns.size == 0 or phi[turns[0]] > np.pi / 2 - 1e-3
            continue
        step = phi[1]
        if crit[3] > np.pi / 2 - 2 * step:  # the minimum within two samples of pi/2: not resolved
            turns = np.append(turns, phi.size - 1)
        assert turns.size == 2
        for turn, (phase, value) in zip(turns, [crit[1:3], crit[3:5]]):
            assert abs(phase - phi[turn]) < 2 * step
            # the sampled extremum is off the true one by about |gamma''| step^2 / 8
            if turn < phi.size - 1:
                curvature = abs(gamma[turn + 1] - 2 * gamma[turn] + gamma[turn - 1])
            else:  # gamma ~ A - alpha - A t^2 / 2 within 2 steps t of pi/2
                curvature = 2.0 * amplitude * step**2
            assert value == pytest.approx(gamma[turn], abs=curvature + 1e-12 * amplitude)


def test_contact_fraction_of_the_band_torque_matches_lambert_w():
    # theta* = alpha - s u, u - ln u = 1 + K (K = 2 alpha k / (c v)), u = -W0(-exp(-1 - K));
    # ln u ~ -1 - K carries an ulp of 1.1e-16 (1 + K)
    from backlash_df.describing._kernels import contact_fraction

    for big_k in np.concatenate([np.geomspace(1e-10, 40.0, 400), np.linspace(0.01, 40.0, 400)]):
        with mpmath.workdps(30):
            u = -mpmath.lambertw(-mpmath.exp(-1 - mpmath.mpf(big_k)))
            assert abs(contact_fraction(big_k) - u) <= 1e-15 * (1.0 + big_k) * u


def test_grid_on_threads_equals_the_serial_kernel():
    amplitude = ALPHA * np.geomspace(1.01, 50.0, 40)
    omega = np.geomspace(1.0, 2e4, 30)
    for name in ("phase-plane", "rubber"):
        for bias in (0.0, 0.02):
            result = describing_function_grid(model(name), amplitude, omega, bias=bias)
            n, mean = evaluate(model(name), amplitude[:, None], omega[None, :], bias, "auto")
            np.testing.assert_array_equal(result.N, n)
            np.testing.assert_array_equal(result.mean_torque, mean)
