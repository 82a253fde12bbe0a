"""From a firefighter's legs (routes, pauses, stairs) to foot strides and body truth.

The planner (:mod:`.planner`) turns a scenario plan into :class:`Leg` objects: routes on
one floor, pauses (standing or kneeling), stair flights. A :class:`Walker` executes
them for one person: it places the instrumented foot's footfalls along each route
(stride length, cadence, turns of at most 60 degrees per stride, on-the-spot pivots at
sharp corners, foot beside the path line with a toe-out angle, stride-to-stride
jitter), sets the stance and swing durations, and records where the body is (knots at
every footfall) so that the ground truth can be sampled at any rate.

Stairs: the foot lands on tread centres, two treads per stride (one per foot); a
path of three or more segments is read as flight - landing(s) - flight, with the steps
on the first and last segments and flat landings between (the building model itself
treats the height as linear along the path, which is what the body truth uses).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import uniform_filter1d

from ..geometry import wrap_angles
from .gait import DOWN, LEVEL, UP, StrideTable
from .gaits import (CRAWL_FLEX_DIRECTION_RIGHT, FLEX_DIRECTION_RIGHT, GAITS, POSTURE_CHANGE_S,
                    POSTURE_GAIT, POSTURE_IMU_HEIGHT, POSTURE_PITCH, STAIR_STANCE_S, Gait,
                    Person)
from .geometry import fillet, resample

#: Largest heading change of one stride of the instrumented foot (two steps) [rad];
#: sharper turns take several strides.
MAX_TURN_PER_STRIDE = np.radians(60.0)
#: Corner radius people walk [m].
CORNER_RADIUS = 0.35
#: Sweeping the floor ahead with a foot: how far it slides out to the side [m] and how
#: long each slide out or back takes [s].
SWEEP_M = 0.35
SWEEP_SWING_S = 0.6


@dataclass
class Leg:
    """One piece of a plan, on one floor (stairs: from ``floor`` to ``floor_to``).

    ``kind``: ``"move"`` (``path`` (M, 2) body route starting at the body position,
    walked with ``gait``, facing backwards if ``backwards``), ``"pause"`` (``duration``
    [s] in ``posture``, None: as the agent is), ``"sweep"`` (``duration`` [s] sweeping
    the floor with the foot), ``"turn"`` (on the spot to ``heading`` [rad]) or ``"stairs"``
    (``stair`` walked up or down, descending ``backwards`` if set). A pause may mark a
    ``checkpoint`` (its name; the true position is recorded). ``deploy`` lists
    tags (id, true position (3,)) attached during a pause. ``where`` is the plan path
    (for error messages).
    """

    kind: str
    floor: int
    path: np.ndarray | None = None
    gait: str = "walk"
    backwards: bool = False
    duration: float = 0.0
    posture: str | None = None
    stair: object = None
    up: bool = True
    deploy: list[tuple[str, np.ndarray]] = field(default_factory=list)
    heading: float = 0.0
    checkpoint: str = ""
    where: tuple = ()


@dataclass
class Deployment:
    """A tag attached at time ``t`` [s]; ``position`` (3,) its true place."""

    t: float
    tag_id: str
    position: np.ndarray


@dataclass
class CheckpointRecord:
    """A marked stop: the body stood at ``position`` (3,) from ``t_start`` to ``t_end``."""

    name: str
    t_start: float
    t_end: float
    position: np.ndarray
    heading: float

    @property
    def t(self) -> float:
        """The middle of the stop [s]: when the position is compared."""
        return 0.5 * (self.t_start + self.t_end)


@dataclass
class BodyTrack:
    """Body knots: time, position (ground under the body), heading (facing), motion."""

    t: np.ndarray
    xyz: np.ndarray
    heading: np.ndarray
    motion: np.ndarray

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(positions (N, 3), headings (N,) wrapped) at times ``t`` (linear between knots)."""
        pos = np.column_stack([np.interp(t, self.t, self.xyz[:, i]) for i in range(3)])
        hd = np.interp(t, self.t, np.unwrap(self.heading))
        return pos, wrap_angles(hd)

    def motion_at(self, t: np.ndarray) -> np.ndarray:
        i = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 1)
        return self.motion[i]



class Walker:
    """Executes legs for one person; collects swings, body knots and tag deployments."""

    def __init__(self, person: Person, gaits: dict[str, Gait], rng: np.random.Generator, *,
                 t0: float, xy: np.ndarray, floor: int, z: float, heading: float,
                 emit_deployments: bool = True, rockers: bool = True):
        self.person = person
        self.gaits = {**GAITS, **gaits}
        self.rng = rng
        self.emit_deployments = emit_deployments
        self.rockers = rockers             # False: the foot lifts off and lands flat
        self.side = -1.0 if person.foot == "right" else 1.0  # left-normal multiplier
        self.t = float(t0)                 # the foot is at rest since this time
        self.floor = floor
        self.z_ground = float(z)
        self.xy = np.asarray(xy, float)
        self.heading = float(heading)
        self.posture = "stand"
        self.foot_p = self._foot_point(self.xy, heading, z)
        self.foot_yaw = heading + self._toe_out()
        self.foot_pitch = 0.0
        self.swings: list[tuple] = []
        self.knots: list[tuple] = []
        self.deployments: list[Deployment] = []
        self.checkpoints: list[CheckpointRecord] = []
        self._knot(self.t, "still")

    # -- helpers -------------------------------------------------------------------
    def _toe_out(self) -> float:
        """Toe-out yaw offset: outwards, i.e. clockwise for the right foot [rad]."""
        return self.side * np.radians(self.person.toe_out_deg)

    def _imu_height(self, posture: str) -> float:
        return POSTURE_IMU_HEIGHT.get(posture, self.person.imu_height)

    def _foot_point(self, xy: np.ndarray, heading: float, z_ground: float,
                    posture: str = "stand") -> np.ndarray:
        left = np.array([-np.sin(heading), np.cos(heading)])
        p = xy + self.side * self.person.foot_offset * left
        return np.array([p[0], p[1], z_ground + self._imu_height(posture)])

    def _knot(self, t: float, motion: str) -> None:
        self.knots.append((t, self.xy[0], self.xy[1], self.z_ground, self.heading, motion))

    def _gait(self, name: str) -> Gait:
        return self.gaits[name]

    def _stride_length(self, gait: Gait) -> float:
        return gait.stride * self.person.stride_scale * np.sqrt(self.person.speed_scale)

    def _swing(self, t0: float, t1: float, p1: np.ndarray, yaw1: float, pitch1: float,
               gait: Gait, vstyle: int, motion: str) -> None:
        # rockers scale with this swing's duration; inversion and the boot's flex are
        # mirrored between the feet (self.side is -1 for the right foot)
        scale = (t1 - t0) / gait.swing_s if self.rockers else 0.0
        cap = 0.4 * (t1 - t0)
        mirror = np.array([-self.side, 1.0, -self.side])
        if motion == "posture" or "kneel" in (self.posture, gait.posture):
            flex = np.zeros(3)
        elif "crawl" in (self.posture, gait.posture):
            flex = CRAWL_FLEX_DIRECTION_RIGHT * mirror * gait.flex_scale
        else:
            flex = FLEX_DIRECTION_RIGHT * mirror * gait.flex_scale
        self.swings.append((t0, t1, self.foot_p.copy(), p1.copy(), self.foot_yaw, yaw1,
                            self.foot_pitch, pitch1, gait.clearance,
                            np.radians(gait.toe_off_deg), np.radians(gait.heel_strike_deg),
                            -self.side * np.radians(gait.roll_deg), gait.sway, vstyle, motion,
                            gait.impact_mm / 1000.0, min(gait.toe_rocker_s * scale, cap),
                            min(gait.heel_rocker_s * scale, cap), flex))
        self.foot_p = p1.copy()
        self.foot_yaw = yaw1
        self.foot_pitch = pitch1
        self.t = t1

    # -- legs ------------------------------------------------------------------------
    def run(self, legs: list[Leg]) -> None:
        for leg in legs:
            if leg.kind == "pause":
                self.pause(leg)
            elif leg.kind == "move":
                self.move(leg)
            elif leg.kind == "stairs":
                self.stairs(leg)
            elif leg.kind == "turn":
                self.turn(leg.heading)
            elif leg.kind == "sweep":
                self.sweep(leg)
            else:  # pragma: no cover - the planner only makes these kinds
                raise ValueError(f"unknown leg kind {leg.kind!r}")

    def set_posture(self, posture: str) -> None:
        """Get down on the knees or on all fours, or stand up: one slow in-place swing of
        the foot."""
        if posture == self.posture:
            return
        t0 = self.t + 0.3
        pitch = POSTURE_PITCH[posture]
        p1 = self.foot_p.copy()
        p1[2] = self.z_ground + self._imu_height(posture)
        g = Gait(clearance=0.03, toe_off_deg=0, heel_strike_deg=0, roll_deg=2, sway=0.0,
                 impact_mm=0.0, toe_rocker_s=0.0, heel_rocker_s=0.0)
        self._swing(t0, t0 + POSTURE_CHANGE_S, p1, self.foot_yaw, pitch, g, LEVEL, "posture")
        self.posture = posture
        self._knot(self.t, "posture")

    def pause(self, leg: Leg) -> None:
        if leg.posture is not None and leg.posture != self.posture:
            self.set_posture(leg.posture)
        t_start = self.t
        self._knot(t_start, "still")
        if self.emit_deployments:
            for i, (tag, pos) in enumerate(leg.deploy):
                self.deployments.append(Deployment(t_start + min(1.0 + i, leg.duration),
                                                   tag, np.asarray(pos, float)))
        self.t = t_start + leg.duration
        self._knot(self.t, "still")
        if leg.checkpoint:
            self.checkpoints.append(CheckpointRecord(
                leg.checkpoint, t_start, self.t,
                np.array([self.xy[0], self.xy[1], self.z_ground]), self.heading))

    def sweep(self, leg: Leg) -> None:
        """Stand and sweep the floor ahead with the instrumented foot for ``duration``:
        the foot slides out to the side (``SWEEP_M``) and back, again and again, and ends
        where it started. On the knees or on all fours it is a pause (the hands sweep)."""
        if self.posture != "stand":
            self.pause(leg)
            return
        t_start = self.t
        self._knot(t_start, "sweep")
        home = self.foot_p.copy()
        left = np.array([-np.sin(self.heading), np.cos(self.heading), 0.0])
        out = home + self.side * SWEEP_M * left          # to the side of the foot
        g = Gait(clearance=0.02, toe_off_deg=5, heel_strike_deg=3, roll_deg=3, sway=0.0,
                 impact_mm=0.5, toe_rocker_s=0.0, heel_rocker_s=0.0)
        while self.t + 2 * (0.3 + SWEEP_SWING_S) <= t_start + max(leg.duration, 1.5):
            for p1 in (out, home):
                t0 = self.t + 0.3
                self._swing(t0, t0 + SWEEP_SWING_S, p1, self.foot_yaw, self.foot_pitch, g,
                            LEVEL, "sweep")
        self.t = max(self.t, t_start + leg.duration)
        self._knot(self.t, "sweep")

    def move(self, leg: Leg) -> None:
        gait = self._gait(leg.gait)
        if gait.posture != self.posture:
            self.set_posture(gait.posture)
        path = np.asarray(leg.path, float)
        if len(path) < 2 or np.linalg.norm(path[-1] - path[0]) < 1e-6 and len(path) == 2:
            return
        smooth, sharp = fillet(path, CORNER_RADIUS)
        dense, s = resample(smooth, 0.05)
        travel = np.unwrap(np.arctan2(np.diff(dense[:, 1]), np.diff(dense[:, 0])))
        travel = np.concatenate([travel, travel[-1:]])
        facing = travel + (np.pi if leg.backwards else 0.0)
        # turn from the current heading to the first facing direction on the spot
        facing0 = self.heading + wrap_angles(facing[0] - self.heading)
        facing += facing0 - facing[0]
        s = np.concatenate([[0.0], s])
        dense = np.vstack([dense[:1], dense])
        facing = np.concatenate([[self.heading], facing])
        L = self._stride_length(gait)
        # Turning costs time as if it were distance: a turn of MAX_TURN_PER_STRIDE takes
        # the nominal stride time of the gait, whoever walks it (partners stay together);
        # a curve of up to the gait's ``free_turn_deg`` per nominal stride (the facing
        # smoothed over a stride) costs nothing.
        kappa = gait.stride / MAX_TURN_PER_STRIDE
        turning = np.abs(np.diff(facing))
        if gait.free_turn_deg > 0:
            along = uniform_filter1d(facing[1:], max(1, int(round(gait.stride / 0.05))),
                                     mode="nearest")
            free = np.radians(gait.free_turn_deg) / gait.stride
            turning[1:] = np.maximum(np.abs(np.diff(along)) - free * np.diff(s[1:]), 0.0)
        q = s + kappa * np.concatenate([[0.0], np.cumsum(turning)])
        total = q[-1]
        if total < 0.05:
            return
        n = max(1, int(round(total / L)))
        w = np.clip(1.0 + self.person.jitter * self.rng.standard_normal(n), 0.7, 1.3)
        qi = total * np.cumsum(w) / w.sum()
        si = np.interp(qi, q, s)
        hi = np.interp(qi, q, facing)
        xy = np.column_stack([np.interp(si, s[1:], dense[1:, 0]),
                              np.interp(si, s[1:], dense[1:, 1])])
        dq = np.diff(np.concatenate([[0.0], qi]))
        period = dq / (gait.speed * self.person.speed_scale)
        swing = np.minimum(gait.swing_s * (1 + self.person.jitter * self.rng.standard_normal(n)),
                           period - gait.min_flat_s)
        swing = np.maximum(swing, 0.35)
        stance = np.maximum(period - swing, gait.min_flat_s)
        z = np.full(n, self.z_ground)
        self._footfalls(xy, hi, z, stance, swing, np.full(n, LEVEL), gait, leg.gait)

    def turn(self, heading: float) -> None:
        """Turn on the spot to ``heading`` [rad], at most 60 degrees per stride."""
        delta = wrap_angles(heading - self.heading)
        n = int(np.ceil(abs(delta) / MAX_TURN_PER_STRIDE))
        if n == 0:
            return
        gait = self._gait(POSTURE_GAIT[self.posture])
        hi = self.heading + delta * np.arange(1, n + 1) / n
        swing = np.full(n, 0.6)
        self._footfalls(np.repeat(self.xy[None], n, 0), hi, np.full(n, self.z_ground),
                        np.full(n, 0.3), swing, np.full(n, LEVEL),
                        gait.model_copy(update={"clearance": 0.04, "toe_off_deg": 10.0,
                                                "heel_strike_deg": 5.0, "impact_mm": 1.0}),
                        "turn")

    def _footfalls(self, xy: np.ndarray, heading: np.ndarray, z: np.ndarray,
                   stance: np.ndarray, swing: np.ndarray, vstyle: np.ndarray, gait: Gait,
                   motion: str) -> None:
        pitch = POSTURE_PITCH[self.posture]
        jitter = np.radians(self.person.heading_jitter_deg) * self.rng.standard_normal(len(xy))
        for i in range(len(xy)):
            t0 = self.t + stance[i]
            t1 = t0 + swing[i]
            p1 = self._foot_point(xy[i], heading[i], z[i], self.posture)
            yaw1 = heading[i] + self._toe_out() + jitter[i]
            yaw1 = self.foot_yaw + wrap_angles(yaw1 - self.foot_yaw)
            self._swing(t0, t1, p1, yaw1, pitch, gait, int(vstyle[i]), motion)
            self.xy = xy[i]
            self.heading = float(heading[i])
            self.z_ground = float(z[i])
            self._knot(t1 + 0.5 * min(stance[min(i + 1, len(xy) - 1)], 0.4), motion)

    def stairs(self, leg: Leg) -> None:
        if self.posture != "stand":
            self.set_posture("stand")
        st, up = leg.stair, leg.up
        name = "stairs_up" if up else ("stairs_down_backward" if leg.backwards else "stairs_down")
        gait = self._gait(name)
        s_tread, z_tread, s_land, z_land, length = stair_geometry(st)
        # The instrumented foot lands on every other tread (right foot: the 1st, 3rd...
        # in the walking direction), walks the landings flat, and steps off 0.35 m
        # beyond the last tread.
        n = len(s_tread)
        order = np.arange(n) if up else np.arange(n)[::-1]
        first = 0 if self.person.foot == "right" else 1
        pick = order[first::2]
        fs = np.concatenate([s_tread[pick], s_land])
        fz = np.concatenate([z_tread[pick], z_land])
        srt = np.argsort(fs if up else -fs)
        fs, fz = fs[srt], fz[srt]
        fs = np.concatenate([fs, [length + 0.35 if up else -0.35]])
        fz = np.concatenate([fz, [st.z_to if up else st.z_from]])
        path = np.asarray(st.path, float)
        ext = np.vstack([path[0] - 0.35 * _unit(path[1] - path[0]), path,
                         path[-1] + 0.35 * _unit(path[-1] - path[-2])])
        s_ext = np.concatenate([[-0.35], np.concatenate([[0.0], np.cumsum(
            np.linalg.norm(np.diff(path, axis=0), axis=1))]), [length + 0.35]])
        xy = np.column_stack([np.interp(fs, s_ext, ext[:, 0]), np.interp(fs, s_ext, ext[:, 1])])
        seg_i = np.clip(np.searchsorted(s_ext, fs, side="right") - 1, 0, len(ext) - 2)
        d = np.diff(ext, axis=0)[seg_i]
        climb = np.arctan2(d[:, 1], d[:, 0])               # bottom-to-top direction
        facing = climb if (up or leg.backwards) else climb + np.pi
        heading = self.heading + np.cumsum(np.concatenate(
            [[wrap_angles(facing[0] - self.heading)], wrap_angles(np.diff(facing))]))
        dz = np.diff(np.concatenate([[self.z_ground], fz]))
        vstyle = np.where(dz > 0.05, UP, np.where(dz < -0.05, DOWN, LEVEL))
        m = len(fs)
        stance = np.full(m, STAIR_STANCE_S[name])
        swing = gait.swing_s * np.clip(1 + self.person.jitter * self.rng.standard_normal(m),
                                       0.8, 1.2) / self.person.speed_scale
        self._footfalls(xy, heading, fz, stance, swing, vstyle, gait, name)
        self.floor = st.floor_to if up else st.floor_from

    # -- results ---------------------------------------------------------------------
    def stride_table(self) -> StrideTable | None:
        if not self.swings:
            return None
        cols = list(zip(*self.swings))
        p0, p1 = np.array(cols[2]), np.array(cols[3])
        yaw0, yaw1 = np.array(cols[4], float), np.array(cols[5], float)
        pitch0, pitch1 = np.array(cols[6], float), np.array(cols[7], float)
        k = len(self.swings)
        return StrideTable(t0=np.array(cols[0], float), t1=np.array(cols[1], float), p0=p0, p1=p1,
                           yaw0=yaw0, yaw1=yaw1, pitch0=pitch0, pitch1=pitch1,
                           roll0=np.zeros(k), roll1=np.zeros(k),
                           clearance=np.array(cols[8], float), toe_off=np.array(cols[9], float),
                           heel_strike=np.array(cols[10], float),
                           roll_amp=np.array(cols[11], float), sway=np.array(cols[12], float),
                           vstyle=np.array(cols[13], int), motion=np.array(cols[14], dtype=object),
                           impact=np.array(cols[15], float), toe_rocker=np.array(cols[16], float),
                           heel_rocker=np.array(cols[17], float), flex=np.array(cols[18], float),
                           heel_arm=np.array([-self.person.imu_from_heel, 0.0,
                                              -self.person.imu_height]),
                           toe_arm=np.array([self.person.imu_to_ball, 0.0,
                                             -self.person.imu_height]))

    def body_track(self) -> BodyTrack:
        k = sorted(self.knots, key=lambda r: r[0])
        t = np.array([r[0] for r in k])
        # keep time strictly increasing for interpolation
        t = np.maximum.accumulate(t + np.arange(len(t)) * 1e-9)
        return BodyTrack(t=t, xyz=np.array([[r[1], r[2], r[3]] for r in k]),
                         heading=np.array([r[4] for r in k]),
                         motion=np.array([r[5] for r in k], dtype=object))


def stair_geometry(st) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    """Treads and landings of a stair, along its walking line from the bottom.

    Returns (tread centre s (n,), tread surface z (n,), landing footfall s, landing z,
    path length). The steps are split between flights as :meth:`Stair.flights
    <firenav_framework.building.model.Stair.flights>` splits them (three or more path
    segments: the first and last are flights, the ones between flat landings); otherwise
    the steps spread over the whole path in proportion to its segments' lengths.
    """
    path = np.asarray(st.path, float)
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s_nodes = np.concatenate([[0.0], np.cumsum(seg)])
    n = int(st.n_steps)
    flights = [0, len(seg) - 1] if len(seg) >= 3 else list(range(len(seg)))
    if len(seg) >= 3 and n >= 2:
        per = np.array([f.n_steps for f in st.flights()], int)   # lowest first
        if st.z_to < st.z_from:                                   # line from the top
            per = per[::-1]
    else:
        per = np.floor(n * seg[flights] / seg[flights].sum()).astype(int)
        per[-1] = n - per[:-1].sum()
    rise = st.rise / n
    s_tread: list[float] = []
    for f, k in zip(flights, per):
        tread = seg[f] / max(k, 1)
        s_tread.extend(s_nodes[f] + (np.arange(k) + 0.5) * tread)
    z_tread = st.z_from + rise * np.arange(1, n + 1)
    s_land, z_land = [], []
    if len(seg) >= 3:
        z_mid = st.z_from + rise * per[0]
        for f in range(1, len(seg) - 1):
            k = max(1, int(round(seg[f] / 0.6)))
            s_land.extend(s_nodes[f] + seg[f] * np.arange(1, k + 1) / (k + 1))
            z_land.extend([z_mid] * k)
    return (np.array(s_tread), z_tread, np.array(s_land), np.array(z_land, float),
            float(s_nodes[-1]))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / max(np.linalg.norm(v), 1e-12)
