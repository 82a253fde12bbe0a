"""Worn barometers and the reference at the entrance: static pressure along the true walk.

The pressure a barometer reads is made, like the IMU's readings, from the truth and a
sensor model whose errors the pipeline never sees (docs/scenarios.md, "Barometer"):

* **the air**: the International Standard Atmosphere's pressure at the barometer's true
  altitude (site elevation + the body's ground height + the height it is worn at,
  lower when crawling or kneeling), with a sea-level pressure drawn per seed (weather)
  that drifts during the run: a drawn linear trend plus a random walk, the same for
  every barometer, inside and out;
* **the building** (worn barometers only; the reference stands outside the door): the
  stack effect, ``(g p / R_d) (1/T_out - 1/T_in)`` Pa per metre above the neutral plane
  with the outside temperature and the neutral plane's height drawn per seed; a
  per-floor offset (ventilation zones) drawn per seed; a slow random walk (ventilation);
  door openings, a Poisson process of steps of drawn size held for a drawn time (the
  stepwise disturbances of the building's pressure); a fire's overpressure near a fire
  zone once it burns;
* **the device** (datasheet figures of the named ``model``): a constant offset drawn per
  device, a random-walk drift (temperature changes on the body), white noise,
  quantisation to the output step, and the latency from the conversion to the receiver
  (the frame's time is the receive time: a reading describes the air ``latency_s``
  before).

Every random choice draws from a generator the engine seeds from the run's seed and a
stable name, so adding a barometer changes no other sensor's signal.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..codecs.baro_lines import BaroLinesCodec, BaroReading
from ..messages import RawFrame

__all__ = ["ISA_P0", "ISA_T0", "ISA_LAPSE", "STACK_PA_PER_M_K", "BAROMETER_MODELS",
           "BaroSpec", "isa_pressure", "Air", "Walk", "draw_air", "Interior", "draw_interior",
           "worn_height", "read_barometer", "barometer_frames", "REFERENCE_DEVICE"]

ISA_P0 = 101_325.0        # Pa, ISA sea-level pressure
ISA_T0 = 288.15           # K, ISA sea-level temperature
ISA_LAPSE = 0.0065        # K/m, ISA temperature lapse rate of the troposphere
_G0 = 9.80665             # m/s^2
_M_AIR = 0.0289644        # kg/mol
_R_GAS = 8.3144598        # J/(mol K)
_R_DRY = _R_GAS / _M_AIR  # J/(kg K)
_ISA_EXP = _G0 * _M_AIR / (_R_GAS * ISA_LAPSE)
#: g p0 / R_d [Pa K / m]: the stack effect's gradient is this times (1/T_out - 1/T_in)
STACK_PA_PER_M_K = _G0 * ISA_P0 / _R_DRY


@dataclass(frozen=True)
class BaroSpec:
    """A barometer's errors: ``noise_pa`` white noise 1-sigma per reading [Pa];
    ``resolution_pa`` output step [Pa]; ``offset_pa`` the per-device offset is drawn
    uniformly in +-offset_pa [Pa]; ``drift_pa_per_sqrt_s`` random-walk drift
    [Pa/sqrt(s)]; ``latency_s`` conversion to receipt [s]; ``max_rate_hz`` the fastest
    output rate of the part."""

    noise_pa: float
    resolution_pa: float
    offset_pa: float
    drift_pa_per_sqrt_s: float
    latency_s: float
    max_rate_hz: float


#: Named barometer parts. ``ms5611``: TE MS5611-01BA03 datasheet, OSR 4096: resolution
#: RMS 0.012 mbar (1.2 Pa), output in 0.01 mbar (1 Pa) steps, accuracy +-1.5 mbar at
#: 25 C (the offset), conversion 8.22 ms (pressure and temperature: ~20 ms with the
#: read-out), up to ~50 Hz with both conversions; the drift (the error band widens to
#: +-2.5 mbar over -20..85 C: the body warms the part) is our assumption, no recording.
BAROMETER_MODELS: dict[str, BaroSpec] = {
    "ms5611": BaroSpec(noise_pa=1.2, resolution_pa=1.0, offset_pa=150.0,
                       drift_pa_per_sqrt_s=0.05, latency_s=0.02, max_rate_hz=50.0),
}


def isa_pressure(altitude: np.ndarray | float, p0: np.ndarray | float = ISA_P0
                 ) -> np.ndarray:
    """ISA pressure [Pa] at ``altitude`` [m] above sea level, sea-level pressure ``p0``
    [Pa] (the barometric formula with the troposphere's lapse rate)."""
    return np.asarray(p0) * (1.0 - ISA_LAPSE * np.asarray(altitude) / ISA_T0) ** _ISA_EXP


@dataclass(frozen=True)
class Air:
    """The weather of one run: sea-level pressure ``p0`` [Pa] at t = 0, ``trend``
    [Pa/s], random walk ``rw`` [Pa/sqrt(s)]; outside temperature ``t_out`` [K]."""

    p0: float
    trend: float
    rw: float
    t_out: float

    def sea_level(self, t: np.ndarray, walk: np.ndarray) -> np.ndarray:
        """Sea-level pressure [Pa] at times ``t`` [s]; ``walk`` (N,) the weather's random
        walk at those times (:class:`Walk`)."""
        return self.p0 + self.trend * t + walk


class Walk:
    """One random walk of ``rw`` [Pa/sqrt(s)] from 0 at t = 0, drawn on a ``dt`` [s]
    grid up to ``t_end`` [s] and interpolated, so that every barometer sees the same."""

    def __init__(self, rw: float, t_end: float, rng: np.random.Generator, dt: float = 1.0):
        self.grid = np.arange(0.0, t_end + 2 * dt, dt)
        steps = rng.normal(0.0, rw * np.sqrt(dt), len(self.grid))
        steps[0] = 0.0
        self.values = np.cumsum(steps)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        return np.interp(t, self.grid, self.values)


def draw_air(cfg, rng: np.random.Generator) -> Air:
    """Draw the run's weather from ``cfg`` (:class:`~.scenario.Pressure`)."""
    return Air(p0=float(rng.uniform(*cfg.sea_level_pa)),
               trend=float(rng.normal(0.0, cfg.trend_pa_per_h)) / 3600.0,
               rw=cfg.weather_rw_pa_per_sqrt_s,
               t_out=float(rng.uniform(*cfg.outside_c)) + 273.15)


@dataclass(frozen=True)
class Interior:
    """The building's own pressure against the outside, drawn per run: ``stack`` [Pa/m]
    above ``neutral_z`` [m building z]; ``floor_pa`` (F,) per floor [Pa]; a random walk
    ``rw`` [Pa/sqrt(s)]; door openings ``doors`` (K, 3): start [s], end [s], step [Pa];
    fires: (floor, x, y, radius [m], start [s]) and their overpressure ``fire_pa``."""

    stack: float
    neutral_z: float
    floor_pa: np.ndarray
    rw: float
    doors: np.ndarray
    fires: tuple[tuple[int, float, float, float, float], ...]
    fire_pa: float

    def offset(self, t: np.ndarray, z: np.ndarray, floor: np.ndarray, xy: np.ndarray,
               walk: np.ndarray) -> np.ndarray:
        """Inside minus outside pressure [Pa] at times ``t`` (N,), barometer height ``z``
        (N,) [m], ``floor`` (N,), position ``xy`` (N, 2) [m]; ``walk`` (N,) the
        ventilation's random walk at those times (:class:`Walk`)."""
        out = self.stack * (z - self.neutral_z) + self.floor_pa[np.clip(floor, 0,
                                                                         len(self.floor_pa) - 1)]
        out = out + walk
        for a, b, step in self.doors:
            out = out + np.where((t >= a) & (t < b), step, 0.0)
        for f, x, y, r, t0 in self.fires:
            near = (floor == f) & (np.hypot(xy[:, 0] - x, xy[:, 1] - y) <= r + 1.0) & (t >= t0)
            out = out + np.where(near, self.fire_pa, 0.0)
        return out


def draw_interior(cfg, air: Air, n_floors: int, z_range: tuple[float, float], t_end: float,
                  fires, rng: np.random.Generator) -> Interior:
    """Draw the building's pressure for one run from ``cfg``
    (:class:`~.scenario.Pressure`); ``z_range`` [m] its lowest floor and its top,
    ``fires`` the scenario's fire zones."""
    t_in = cfg.inside_c + 273.15
    n = rng.poisson(cfg.door_rate_per_min * t_end / 60.0)
    starts = np.sort(rng.uniform(0.0, t_end, n))
    doors = np.column_stack([starts, starts + rng.exponential(cfg.door_open_s, n),
                             rng.normal(0.0, cfg.door_step_pa, n)]) if n else np.zeros((0, 3))
    return Interior(
        stack=STACK_PA_PER_M_K * (1.0 / air.t_out - 1.0 / t_in),
        neutral_z=z_range[0] + float(rng.uniform(*cfg.neutral_plane)) * (z_range[1] - z_range[0]),
        floor_pa=rng.normal(0.0, cfg.floor_sigma_pa, n_floors),
        rw=cfg.ventilation_rw_pa_per_sqrt_s, doors=doors,
        fires=tuple((f.floor, f.position[0], f.position[1], f.radius_m, f.start_s)
                    for f in fires),
        fire_pa=cfg.fire_pa)


#: How high a worn barometer is carried, per body motion label, as a share of its
#: standing height (crawling: chest height on all fours; kneeling down and up).
_POSTURE_SHARE = {"crawl": 0.4, "posture": 0.6}


def worn_height(motion: np.ndarray, height_m: float) -> np.ndarray:
    """Height [m] of a barometer worn ``height_m`` above the floor when standing, per
    body ``motion`` label (N,)."""
    share = np.ones(len(motion))
    for label, s in _POSTURE_SHARE.items():
        share[np.asarray(motion) == label] = s
    return height_m * share


def read_barometer(t: np.ndarray, true_pa: np.ndarray, spec: BaroSpec,
                   rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float]:
    """The device's readings of the true pressures ``true_pa`` (N,) [Pa] at the
    conversion times ``t`` (N,) [s]: (receive times [s], readings [Pa], the offset
    drawn [Pa])."""
    offset = float(rng.uniform(-spec.offset_pa, spec.offset_pa))
    dt = np.diff(t, prepend=t[0] if len(t) else 0.0)
    drift = np.cumsum(rng.normal(0.0, 1.0, len(t)) * spec.drift_pa_per_sqrt_s
                      * np.sqrt(np.maximum(dt, 0)))
    p = true_pa + offset + drift + rng.normal(0.0, spec.noise_pa, len(t))
    if spec.resolution_pa > 0:
        p = np.round(p / spec.resolution_pa) * spec.resolution_pa
    return t + spec.latency_s, p, offset


REFERENCE_DEVICE = "base/baro"
LINK = "baro_link"
REFERENCE_HEIGHT = 1.0   # m above the entrance's floor


def barometer_frames(b, m, bodies, t_end: float, rng_for
                     ) -> tuple[list[RawFrame], list[dict[str, float]]]:
    """Every barometer's lines (``baro_lines``, one serial link ``baro_link`` for all)
    in receive-time order, and per line its truth: ``true_pa`` the pressure without the
    device's errors [Pa], ``z`` the barometer's building z [m] (NaN: the reference).

    ``b`` the real building, ``m`` the scenario model, ``bodies`` the agents'
    :class:`~.movement.BodyTrack`, ``rng_for(*names)`` a generator per purpose.
    """
    cfg = m.environment.pressure
    elevation = cfg.site_elevation_m if cfg.site_elevation_m is not None else (
        float(b.georef.alt) if b.georef is not None else 0.0)
    air = draw_air(cfg, rng_for("baro-air"))
    top = b.floors[-1]
    interior = draw_interior(cfg, air, len(b.floors), (b.floors[0].z, top.z + top.height),
                             t_end, m.fires, rng_for("baro-building"))
    weather = Walk(air.rw, t_end, rng_for("baro-weather"))
    ventilation = Walk(interior.rw, t_end, rng_for("baro-ventilation"))
    series = []    # (device, receive t, reading, temperature or None, true_pa, z)
    for agent in m.agents:
        bc = agent.sensors.barometer
        if bc is None:
            continue
        spec = bc.spec()
        rng = rng_for("baro", agent.id)
        t = np.arange(bc.switch_on_s + rng.uniform(0, 1.0 / bc.rate_hz), t_end, 1.0 / bc.rate_hz)
        pos, _ = bodies[agent.id].at(t)
        z = pos[:, 2] + worn_height(bodies[agent.id].motion_at(t), bc.height_m)
        floor = np.asarray(b.floor_of_z(pos[:, 2]), int)
        true = isa_pressure(elevation + z, air.sea_level(t, weather(t))) + interior.offset(
            t, z, floor, pos[:, :2], ventilation(t))
        t_recv, read, _ = read_barometer(t, true, spec, rng)
        keep = t_recv <= t_end
        series.append((f"{agent.id}/baro", t_recv[keep], read[keep], None, true[keep], z[keep]))
    specs = [a.sensors.barometer.spec() for a in m.agents if a.sensors.barometer is not None]
    if cfg.reference and specs and b.entrances:
        e = b.entrances[0]
        rng = rng_for("baro", REFERENCE_DEVICE)
        t = np.arange(rng.uniform(0, 1.0 / cfg.reference_rate_hz), t_end,
                      1.0 / cfg.reference_rate_hz)
        z = b.floor(e.floor).z + REFERENCE_HEIGHT
        true = isa_pressure(elevation + z, air.sea_level(t, weather(t)))
        t_recv, read, _ = read_barometer(t, true, specs[0], rng)
        temp = air.t_out + rng.normal(0.0, 0.5, len(t))   # its own sensor, +-0.8 K class
        keep = t_recv <= t_end
        series.append((REFERENCE_DEVICE, t_recv[keep], read[keep], temp[keep], true[keep],
                       np.full(int(keep.sum()), np.nan)))
    codec = BaroLinesCodec()
    frames, truth = [], []
    for device, tr, p, temp, true, z in series:
        readings = [BaroReading(float(tr[i]), device, float(p[i]),
                                None if temp is None else float(temp[i])) for i in range(len(tr))]
        for f, r, tp, zz in zip(codec.encode(readings), readings, true, z):
            frames.append(RawFrame(t=r.t, agent="", device=LINK, transport="serial",
                                   channel=f.channel, data=f.data))
            truth.append({"true_pa": round(float(tp), 3), "z": round(float(zz), 4)})
    order = np.argsort([f.t for f in frames], kind="stable")
    return [frames[k] for k in order], [truth[k] for k in order]
