"""IMU noise: ideal passthrough, seeded streams, discrete std, Allan deviation of long static runs."""
import numpy as np
import pytest

from rigs.model import Imu
from sim.allan import allan_deviation, density_at_1s, fit_white_and_walk, loglog_slope
from sim.errors import SimError
from rigs.records import ImuSamples
from sim.sensors.imu_noise import add_imu_noise
from sim.rng import stream

ADIS = dict(gyro_noise_density=1.6968e-4, accel_noise_density=2.0e-3,
            gyro_random_walk=1.9393e-5, accel_random_walk=3.0e-3)          # EuRoC ADIS16448


def static(n, rate_hz, seed=0):
    t = np.round(np.arange(n) * (1e9 / rate_hz)).astype(np.int64) + 10**9
    rng = np.random.default_rng(seed)
    return ImuSamples(t, rng.normal(size=(n, 3)) * 0.1, rng.normal(size=(n, 3)) + [0, 0, 9.81])


def noisy(clean, imu, seed_w, seed_b, **kw):
    return add_imu_noise(clean, imu, stream(seed_w, "imu_white"), stream(seed_b, "imu_bias"), **kw)


def test_ideal_imu_returns_clean_samples():
    clean = static(1000, 200.0)
    out, b = noisy(clean, Imu(), 1, 2)
    assert np.array_equal(out.gyro, clean.gyro) and np.array_equal(out.accel, clean.accel)
    assert np.array_equal(out.t_ns, clean.t_ns)
    assert not np.any(b.b_g) and not np.any(b.b_a)


def test_same_seed_same_bytes_other_seed_other_noise_streams_independent():
    clean, imu = static(2000, 200.0), Imu(**ADIS)
    a, ba = noisy(clean, imu, 1, 2)
    b, bb = noisy(clean, imu, 1, 2)
    assert a.gyro.tobytes() == b.gyro.tobytes() and a.accel.tobytes() == b.accel.tobytes()
    assert ba.b_a.tobytes() == bb.b_a.tobytes()
    c, _ = noisy(clean, imu, 3, 2)
    assert np.abs(c.gyro - a.gyro).min() > 0
    d, bd = noisy(clean, imu, 1, 4)                        # other bias stream
    white_a, white_d = a.accel - clean.accel - ba.b_a, d.accel - clean.accel - bd.b_a
    assert np.allclose(white_a, white_d, rtol=0, atol=1e-12)   # only float re-association differs
    assert np.abs(bd.b_a - ba.b_a).max() > 1e-4


def test_discrete_white_std_and_bias_steps():
    """White std = density * sqrt(rate); bias step std = rw / sqrt(rate). With 3 x 2e5 samples
    the sample std's relative std is 1/sqrt(2 * 6e5) = 0.09 %, so 1 % is > 10 sigma."""
    n, rate = 200_001, 200.0
    imu = Imu(rate_hz=rate, **ADIS)
    clean = static(n, rate)
    out, b = noisy(clean, imu, 5, 6)
    white_g = out.gyro - clean.gyro - b.b_g
    assert white_g.std() == pytest.approx(ADIS["gyro_noise_density"] * np.sqrt(rate), rel=0.01)
    steps_a = np.diff(b.b_a, axis=0)
    assert steps_a.std() == pytest.approx(ADIS["accel_random_walk"] / np.sqrt(rate), rel=0.01)
    assert not np.any(b.b_g[0]) and not np.any(b.b_a[0])      # default: biases start at 0


def test_initial_bias_std_is_used():
    """200 samples x 3 axes of N(0, 0.01^2): relative std of the RMS is 1/sqrt(2*600) ~ 3 %; 15 % is 5 sigma."""
    clean = static(2, 200.0)
    b0 = np.array([noisy(clean, Imu(), 0, s, initial_gyro_bias_std=0.01)[1].b_g[0] for s in range(200)])
    assert np.sqrt((b0**2).mean()) == pytest.approx(0.01, rel=0.15)
    with pytest.raises(SimError, match="initial_accel_bias_std"):
        noisy(clean, Imu(), 0, 0, initial_accel_bias_std=-1.0)


def test_allan_white_density_two_hours_adis():
    """2 h static at 200 Hz with ADIS16448 densities. Gyro ADEV at tau = 1 s equals the white density:
    the estimate's relative std is ~1/sqrt(2 (T/tau - 1)) = 0.8 % and the gyro random walk adds only
    sqrt(1 + K^2/(3 N^2)) - 1 = 0.2 %, so 10 % is far outside chance. For the accelerometer the random
    walk (3e-3) dominates already at 1 s (raw ADEV ~ 1.33 N), so the white density is read from the
    fit adev^2 = N^2/tau + K^2 tau/3 (within 10 %) and K within 30 % (few long-tau samples)."""
    n, rate = 7200 * 200 + 1, 200.0
    z = np.zeros((n, 3))
    out, _ = noisy(ImuSamples(np.arange(n, dtype=np.int64) * 5_000_000, z, z), Imu(**ADIS), 11, 12)
    taus = [0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0]
    tg, ag = allan_deviation(out.gyro, rate, taus)
    ta, aa = allan_deviation(out.accel, rate, taus)
    for c in range(3):
        assert density_at_1s(tg, ag[:, c]) == pytest.approx(ADIS["gyro_noise_density"], rel=0.10)
        N_g, _ = fit_white_and_walk(tg, ag[:, c])
        N_a, K_a = fit_white_and_walk(ta, aa[:, c])
        assert N_g == pytest.approx(ADIS["gyro_noise_density"], rel=0.10)
        assert N_a == pytest.approx(ADIS["accel_noise_density"], rel=0.10)
        assert K_a == pytest.approx(ADIS["accel_random_walk"], rel=0.30)


def test_allan_random_walk_slope():
    """20 h at 10 Hz, gyro random walk 10x ADIS (white/walk crossing at tau = 3 N / K = 2.6 s):
    the log-log slope over 50..3000 s is +1/2. Over 12 seeds x 6 axes the fitted slope had mean 0.49
    and std 0.035, so the 0.5 +- 0.15 band is > 4 sigma."""
    n, rate = 20 * 3600 * 10 + 1, 10.0
    imu = Imu(rate_hz=rate, **{**ADIS, "gyro_random_walk": 1.9393e-4})
    z = np.zeros((n, 3))
    out, _ = noisy(ImuSamples(np.arange(n, dtype=np.int64) * 100_000_000, z, z), imu, 21, 22)
    taus, adev = allan_deviation(np.hstack([out.gyro, out.accel]), rate, np.logspace(0, np.log10(5000), 15))
    for c in range(6):
        assert loglog_slope(taus, adev[:, c], 50, 3000) == pytest.approx(0.5, abs=0.15)
    # and the white region below the crossing has slope -1/2 (gyro, 0.1..1 s is white-dominated at 10 Hz)
    t2, a2 = allan_deviation(out.gyro, rate, [0.1, 0.2, 0.4, 0.8])
    assert loglog_slope(t2, a2[:, 0], 0.1, 0.8) == pytest.approx(-0.5, abs=0.1)


def test_allan_estimator_on_deterministic_signals():
    """Deterministic check of the estimator: a constant rate has zero ADEV; a linear ramp x = c t has
    ADEV c tau / sqrt(2) (IEEE 952 rate-ramp term, exact for the overlapping estimator)."""
    rate, c = 100.0, 0.01
    t = np.arange(100_000) / rate
    taus, adev = allan_deviation(np.full_like(t, 3.0), rate, [0.1, 1.0, 10.0])
    assert np.abs(adev).max() < 1e-9
    taus, adev = allan_deviation(c * t, rate, [0.1, 1.0, 10.0])
    assert np.allclose(adev, c * taus / np.sqrt(2), rtol=1e-6)
