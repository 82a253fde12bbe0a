"""Corrupting ideal IMU readings with a grade's errors (vectorised over samples).

Per axis, the measured value is::

    y = sat(quant( (I + M) x + k_nl x|x| + b_on + b_gm(t) + b_rw(t) + k_T dT(t)
                   [+ G f + r v(t)] + n ))

with ``M`` the scale-factor (diagonal) and cross-axis (off-diagonal) matrix, ``k_nl``
the non-linearity, ``b_on``
the turn-on bias, ``b_gm`` a first-order Gauss-Markov bias (bias instability),
``b_rw`` a bias random walk, ``k_T dT`` the thermal drift, ``G f`` the gyro's
linear-acceleration sensitivity, ``r sqrt(v(t))`` its vibration rectification (``v``:
the rms [g] of the specific force above 10 Hz over the last second, :func:`vibration_rms`;
the square root because the heading drift of the same ZUPT INS on the real walks (0.5 g
rms) and runs (0.9 g rms) grows so, ``benchmarks/bench_sim_realism.py``) and ``n`` white
noise of the stated density.
:func:`allan_model` gives the Allan deviation these processes have in theory; the
tests compare it with :func:`allan_deviation` of simulated data.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import butter, lfilter, sosfiltfilt

from .imu_grades import AccelSpec, GyroSpec, MagSpec

G0 = 9.80665
DEG = np.pi / 180.0


def _gm_allan_ratio(x: np.ndarray) -> np.ndarray:
    """Allan deviation of a unit-variance Gauss-Markov process at T = x * tau_c."""
    x = np.asarray(x, float)
    return np.sqrt(2.0 / x * (1.0 - (3.0 - 4.0 * np.exp(-x) + np.exp(-2.0 * x)) / (2.0 * x)))


_X = np.logspace(-2, 2, 4001)
#: Peak Allan deviation of a unit-variance Gauss-Markov process (about 0.62 at 1.9 tau_c).
GM_PEAK = float(_gm_allan_ratio(_X).max())


def allan_model(taus: np.ndarray, noise_density: float, bias_instability: float,
                bias_tau: float, random_walk: float = 0.0) -> np.ndarray:
    """Theoretical Allan deviation of white noise + Gauss-Markov bias + random walk.

    SI densities (``noise_density`` in units/sqrt(Hz), ``random_walk`` in
    units/sqrt(s)); ``bias_instability`` is the Gauss-Markov peak as in the grades.
    """
    taus = np.asarray(taus, float)
    sigma_gm = bias_instability / GM_PEAK
    var = (noise_density ** 2 / taus
           + (sigma_gm * _gm_allan_ratio(taus / bias_tau)) ** 2
           + random_walk ** 2 * taus / 3.0)
    return np.sqrt(var)


def allan_deviation(x: np.ndarray, fs: float, taus: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of a rate series ``x`` (N,) sampled at ``fs``.

    Returns (taus actually used, adev); each tau is rounded to whole samples and
    needs at least 2 clusters.
    """
    x = np.asarray(x, float)
    n = len(x)
    theta = np.concatenate([[0.0], np.cumsum(x)]) / fs
    m = np.unique(np.round(np.asarray(taus) * fs).astype(int))
    m = m[(m >= 1) & (2 * m < n)]
    out = np.empty(len(m))
    for i, mi in enumerate(m):  # one vectorised pass per averaging time
        d = theta[2 * mi:] - 2.0 * theta[mi:-mi] + theta[:-2 * mi]
        out[i] = np.sqrt(np.mean(d * d) / 2.0) / (mi / fs)
    return m / fs, out


@dataclass(frozen=True)
class SensorErrors:
    """The errors one run of one sensor triad drew (SI units), for the truth file."""

    turn_on_bias: np.ndarray      # (3,)
    matrix: np.ndarray            # (3, 3)  I + scale factor + cross-axis
    thermal: np.ndarray           # (3,)  per kelvin
    g_sensitivity: np.ndarray     # (3, 3) gyro only (zeros for accel) [rad/s per m/s^2]
    nonlinearity: np.ndarray      # (3,) quadratic coefficient [1 / unit]
    vibration: np.ndarray         # (3,) gyro bias at 1 g rms of vibration [rad/s]

    def as_dict(self) -> dict:
        return {k: np.asarray(v).round(9).tolist() for k, v in self.__dict__.items()}


def _si(spec: GyroSpec | AccelSpec) -> dict[str, float]:
    if isinstance(spec, GyroSpec):
        return dict(range=spec.range_dps * DEG, noise=spec.noise_density_dps_rthz * DEG,
                    bi=spec.bias_instability_dph * DEG / 3600.0, tau=spec.bias_tau_s,
                    rw=spec.rate_random_walk_dps_rts * DEG, on=spec.turn_on_bias_dps * DEG,
                    thermal=spec.thermal_drift_dps_per_k * DEG, sf=spec.scale_factor_pct / 100,
                    mis=spec.misalignment_deg * DEG,
                    gsens=spec.g_sensitivity_dps_per_g * DEG / G0,
                    vib=spec.vibration_bias_dps * DEG,
                    res=spec.resolution_dps * DEG, nl=spec.nonlinearity_pct / 100)
    return dict(range=spec.range_g * G0, noise=spec.noise_density_ug_rthz * 1e-6 * G0,
                bi=spec.bias_instability_ug * 1e-6 * G0, tau=spec.bias_tau_s,
                rw=spec.random_walk_ug_rts * 1e-6 * G0, on=spec.turn_on_bias_mg * 1e-3 * G0,
                thermal=spec.thermal_drift_mg_per_k * 1e-3 * G0, sf=spec.scale_factor_pct / 100,
                mis=spec.misalignment_deg * DEG, gsens=0.0, vib=0.0,
                res=spec.resolution_mg * 1e-3 * G0, nl=spec.nonlinearity_pct / 100)


def draw_errors(spec: GyroSpec | AccelSpec, rng: np.random.Generator) -> SensorErrors:
    """Draw the constant errors of one triad (turn-on bias, matrix, thermal, g-sens,
    vibration rectification; the last only when the spec has it, so that specs without
    it draw exactly what they drew before it existed)."""
    p = _si(spec)
    matrix = np.eye(3) + np.diag(rng.normal(0.0, p["sf"], 3))
    off = rng.normal(0.0, p["mis"], (3, 3))
    np.fill_diagonal(off, 0.0)
    drawn = dict(turn_on_bias=rng.normal(0.0, p["on"], 3), matrix=matrix + off,
                 thermal=rng.normal(0.0, p["thermal"], 3),
                 g_sensitivity=rng.normal(0.0, p["gsens"], (3, 3)),
                 nonlinearity=rng.normal(0.0, p["nl"], 3) / p["range"])
    vib = rng.normal(0.0, p["vib"], 3) if p["vib"] > 0 else np.zeros(3)
    return SensorErrors(**drawn, vibration=vib)


#: Vibration is the specific force above this frequency [Hz], its rms taken over
#: ``VIBRATION_WINDOW_S`` [s].
VIBRATION_HZ = 10.0
VIBRATION_WINDOW_S = 1.0


def vibration_rms(specific_force: np.ndarray, fs: float) -> np.ndarray:
    """(N,) rms [g] of the specific force (N, 3) [m/s^2] above ``VIBRATION_HZ`` over the
    last ``VIBRATION_WINDOW_S`` (centred): impacts, the strap's ringing, running."""
    f = np.asarray(specific_force, float)
    if len(f) < 16 or fs <= 2.5 * VIBRATION_HZ:
        return np.zeros(len(f))
    sos = butter(2, VIBRATION_HZ, "highpass", fs=fs, output="sos")
    hp = sosfiltfilt(sos, f, axis=0)
    ms = uniform_filter1d(np.sum(hp * hp, axis=1), max(1, int(round(VIBRATION_WINDOW_S * fs))))
    return np.sqrt(np.maximum(ms, 0.0)) / G0


def gauss_markov(n: int, fs: float, sigma: float, tau: float, rng: np.random.Generator,
                 axes: int = 3) -> np.ndarray:
    """(n, axes) stationary first-order Gauss-Markov process, std ``sigma``, time ``tau``."""
    if sigma == 0.0 or n == 0:
        return np.zeros((n, axes))
    phi = np.exp(-1.0 / (fs * tau))
    w = rng.normal(0.0, sigma * np.sqrt(1.0 - phi * phi), (n, axes))
    x0 = rng.normal(0.0, sigma, axes)
    return lfilter([1.0], [1.0, -phi], w, axis=0, zi=(phi * x0)[None, :])[0]


def corrupt(ideal: np.ndarray, spec: GyroSpec | AccelSpec, fs: float,
            rng: np.random.Generator, *, errors: SensorErrors | None = None,
            temperature_delta: np.ndarray | None = None,
            specific_force: np.ndarray | None = None
            ) -> tuple[np.ndarray, np.ndarray, SensorErrors]:
    """Measured (N, 3) readings from ideal ones, the per-sample saturation mask, the errors.

    ``temperature_delta`` (N,) [K] drives the thermal drift; ``specific_force`` (N, 3)
    [m/s^2] drives the gyro g-sensitivity and vibration rectification.
    """
    p = _si(spec)
    n = len(ideal)
    if errors is None:
        errors = draw_errors(spec, rng)
    y = ideal @ errors.matrix.T + errors.turn_on_bias
    if np.any(errors.nonlinearity):
        y += errors.nonlinearity * ideal * np.abs(ideal)
    y += gauss_markov(n, fs, p["bi"] / GM_PEAK, p["tau"], rng)
    if p["rw"] > 0:
        y += np.cumsum(rng.normal(0.0, p["rw"] / np.sqrt(fs), (n, 3)), axis=0)
    if temperature_delta is not None:
        y += np.asarray(temperature_delta, float)[:, None] * errors.thermal
    if specific_force is not None and np.any(errors.g_sensitivity):
        y += specific_force @ errors.g_sensitivity.T
    if specific_force is not None and np.any(errors.vibration):
        y += np.sqrt(vibration_rms(specific_force, fs))[:, None] * errors.vibration
    if p["noise"] > 0:
        y += rng.normal(0.0, p["noise"] * np.sqrt(fs), (n, 3))
    if p["res"] > 0:
        y = np.round(y / p["res"]) * p["res"]
    saturated = np.any(np.abs(y) > p["range"], axis=1)
    np.clip(y, -p["range"], p["range"], out=y)
    return y, saturated, errors


# -- magnetometer ------------------------------------------------------------------

def earth_field_enu(intensity_ut: float, inclination_deg: float, declination_deg: float
                    ) -> np.ndarray:
    """The geomagnetic field in ENU [uT] (inclination positive downward)."""
    inc, dec = np.radians(inclination_deg), np.radians(declination_deg)
    return intensity_ut * np.array([np.cos(inc) * np.sin(dec), np.cos(inc) * np.cos(dec),
                                    -np.sin(inc)])


@dataclass(frozen=True)
class IndoorField:
    """A smooth random magnetic disturbance over the building (steel, wiring, radiators).

    Sum of ``K`` plane waves with random directions and wavelengths: a cheap stationary
    random field whose rms is ``rms_ut`` per axis. Evaluated at positions (N, 3) [m].
    """

    k: np.ndarray       # (K, 3) wave vectors [rad/m]
    phase: np.ndarray   # (K,)
    amp: np.ndarray     # (K, 3) [uT]

    @classmethod
    def random(cls, rng: np.random.Generator, rms_ut: float, wavelength_m: tuple[float, float]
               = (1.5, 8.0), waves: int = 24) -> "IndoorField":
        direction = rng.normal(size=(waves, 3))
        direction[:, 2] *= 0.5
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        lam = rng.uniform(*wavelength_m, waves)
        amp = rng.normal(0.0, rms_ut * np.sqrt(2.0 / waves), (waves, 3))
        return cls(k=direction * (2 * np.pi / lam)[:, None],
                   phase=rng.uniform(0, 2 * np.pi, waves), amp=amp)

    def __call__(self, position: np.ndarray) -> np.ndarray:
        return np.cos(position @ self.k.T + self.phase) @ self.amp


def magnetometer(b_device_true: np.ndarray, spec: MagSpec, rng: np.random.Generator
                 ) -> np.ndarray:
    """Measured field (N, 3) [uT]: residual hard/soft iron, noise and saturation."""
    soft = np.eye(3) + rng.normal(0.0, spec.soft_iron_pct / 100, (3, 3))
    hard = rng.normal(0.0, spec.hard_iron_ut, 3)
    y = b_device_true @ soft.T + hard + rng.normal(0.0, spec.noise_ut, b_device_true.shape)
    return np.clip(y, -spec.range_ut, spec.range_ut)
