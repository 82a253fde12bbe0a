"""MAVLink out: every firefighter as its own system, so a ground-control station shows them.

For each :class:`PoseEstimate` the sink sends, from the firefighter's system id,
``LOCAL_POSITION_NED`` (#32) and ``ODOMETRY`` (#331, MAVLink 2) with the pose
covariance, and, when the building is georeferenced and the pose is in the building
frame, ``GLOBAL_POSITION_INT`` (#33): WGS84 latitude/longitude of the pose through the
plan's georef (``GeoRef.to_wgs84``), ``alt`` the georef's ellipsoidal height plus z
(no geoid model: MSL differs by the local geoid undulation), ``relative_alt`` z (the
height above the plan origin, i.e. above the entrance level when the plan is drawn
so), velocity in true north/east/down, ``hdg`` the compass azimuth. A GCS with a map
(QGroundControl, Mission Planner) places the firefighter there.

Frames: without a georef our ENU building frame becomes the GCS's local NED frame
with plan north as north (north = y, east = x, down = -z) and ``yaw = pi/2 -
heading``; with a georef the local frame is turned to true north (north and east from
the georef's rotation of plan x/y, yaw the azimuth), and ``GPS_GLOBAL_ORIGIN`` (#49)
gives the WGS84 position of the plan origin, the local frame's origin. Velocities are
the difference of the last two poses (NaN before).

Once per second of timeline time each known firefighter sends a ``HEARTBEAT`` of a
vehicle type a GCS lists (``vehicle_type``, a ground rover by default; autopilot
GENERIC, since GCSs ignore heartbeats of autopilot INVALID) whose ``system_status``
carries its state (ACTIVE; CRITICAL while a device is silent, the position untrusted
or contradicting the map; EMERGENCY while man-down), and ``GPS_GLOBAL_ORIGIN`` every
``origin_every`` heartbeats. Every condition change is a ``STATUSTEXT`` with the
local clock (:mod:`..timefmt`), never UNIX seconds; silence never ends a man-down
(:mod:`..liveview.status`). The alarms latched until acknowledged are the live view's.
``time_boot_ms`` is the pose time in milliseconds.
"""
from __future__ import annotations

import math
from typing import Literal

import numpy as np

from ..contract import NoBuilding, Sink, param
from ..liveview.alarms import ALARM_TITLES
from ..liveview.plan import true_turn
from ..liveview.status import StatusParams, StatusTracker
from ..messages import Diagnostic, PoseEstimate, Tick
from ..timefmt import clock_text
from ..transports.mavlink_link import mavutil

#: ODOMETRY pose_covariance is the upper triangle of the 6x6 (x, y, z, roll, pitch, yaw)
#: covariance, row by row (21 values); here the index pairs in our 4x4 (x, y, z, heading)
#: of each NED entry, or None for roll/pitch, which we do not estimate (NaN).
_NED_FROM_ENU = {0: 1, 1: 0, 2: 2, 5: 3}  # NED axis -> ENU axis (n<-y, e<-x, d<-z, yaw<-heading)
_SIGN = {0: 1.0, 1: 1.0, 2: -1.0, 5: -1.0}  # d = -z; yaw = pi/2 - heading

_VEHICLE_TYPES = {"ground_rover": "MAV_TYPE_GROUND_ROVER", "generic": "MAV_TYPE_GENERIC",
                  "surface_boat": "MAV_TYPE_SURFACE_BOAT", "quadrotor": "MAV_TYPE_QUADROTOR"}
_SEVERITY = {"man_down": "MAV_SEVERITY_EMERGENCY", "device_silent": "MAV_SEVERITY_CRITICAL",
             "untrusted": "MAV_SEVERITY_WARNING", "map_contradiction": "MAV_SEVERITY_WARNING"}


def ned_covariance(cov4: np.ndarray, turn: np.ndarray | None = None) -> list[float]:
    """The 21-value ODOMETRY covariance from our 4x4 ENU (x, y, z, heading) covariance;
    ``turn`` (2, 2) takes plan (x, y) to true (east, north) when georeferenced."""
    cov4 = np.asarray(cov4, float)
    if turn is not None:
        t = np.eye(4)
        t[:2, :2] = turn
        cov4 = t @ cov4 @ t.T
    out = []
    for i in range(6):
        for j in range(i, 6):
            if i in _NED_FROM_ENU and j in _NED_FROM_ENU:
                out.append(float(_SIGN[i] * _SIGN[j] * cov4[_NED_FROM_ENU[i], _NED_FROM_ENU[j]]))
            else:
                out.append(math.nan)
    return out


def yaw_quaternion(yaw: float) -> list[float]:
    """(w, x, y, z) of a rotation by ``yaw`` about the down axis."""
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


class MavlinkOutSink(Sink):
    """Send each firefighter to a ground station as its own MAVLink system (local and WGS84 position, state)."""

    name = "mavlink_out"
    inputs = (PoseEstimate, Diagnostic)

    class Params(StatusParams):
        url: str = param("udpout:127.0.0.1:14550")
        """pymavlink connection string of the ground station (udpout:HOST:PORT, tcp:HOST:PORT, ...)"""
        system_ids: dict[str, int] = param({})
        """firefighter id -> MAVLink system id; others get free ids from first_system_id on"""
        first_system_id: int = param(1, ge=1, le=254)
        """first id handed out automatically, in order of first appearance"""
        component_id: int = param(1, ge=0, le=255)
        """component id of the messages"""
        odometry: bool = param(True)
        """also send ODOMETRY with the covariance"""
        vehicle_type: Literal["ground_rover", "generic", "surface_boat", "quadrotor"] = param(
            "ground_rover", description="HEARTBEAT type the GCS shows each firefighter as")
        origin_every: int = param(10, ge=1)
        """send GPS_GLOBAL_ORIGIN every this many heartbeats (georeferenced plans)"""

    @classmethod
    def tick_period(cls, params) -> float:
        return 1.0  # heartbeats and the status clock

    def start(self) -> None:
        mu = mavutil()
        self.mavlink = mu.mavlink
        self.conn = mu.mavlink_connection(self.params.url, source_system=255, input=False)
        self.tracker = StatusTracker.from_params(self.params)
        self.sysids: dict[str, int] = dict(self.params.system_ids)
        self.senders: dict[str, object] = {}
        self.last: dict[str, PoseEstimate] = {}
        self.beats: dict[str, int] = {}
        self.sent = 0
        self.georef = None
        if self.ctx.has_building:
            try:
                self.georef = self.ctx.building.georef
            except NoBuilding:
                self.georef = None
        self.turn = None if self.georef is None else true_turn(self.georef)
        self.origin = None if self.georef is None else self.georef.to_wgs84(np.zeros((1, 3)))[0]

    def _sender(self, agent: str):
        mav = self.senders.get(agent)
        if mav is None:
            if agent not in self.sysids:
                used = set(self.sysids.values())
                sid = self.params.first_system_id
                while sid in used:
                    sid += 1
                if sid > 254:
                    raise ValueError("no MAVLink system id left for firefighter " + agent)
                self.sysids[agent] = sid
                self.ctx.log.info("firefighter %s is MAVLink system %d", agent, sid)
            mav = self.mavlink.MAVLink(self.conn, srcSystem=self.sysids[agent],
                                       srcComponent=self.params.component_id)
            self.senders[agent] = mav
        return mav

    def handle(self, stream: str, msg) -> None:
        if isinstance(msg, PoseEstimate):
            self._pose(msg)
            self._report(self.tracker.pose(msg), msg.t)
        elif isinstance(msg, Diagnostic):
            self._report(self.tracker.diagnostic(msg), msg.t)
        elif isinstance(msg, Tick):
            self._report(self.tracker.clock(msg.t), msg.t)
            for agent in sorted(self.tracker.agents):
                self._heartbeat(agent)

    def _to_ned(self, v: np.ndarray) -> tuple[float, float, float]:
        """A plan vector (x, y, z) as (north, east, down)."""
        e, n = (self.turn @ v[:2]) if self.turn is not None else (v[0], v[1])
        return float(n), float(e), float(-v[2])

    def _yaw(self, heading: float) -> float:
        """Plan heading (CCW from +x) -> yaw clockwise from (true or plan) north."""
        if self.georef is not None:
            return float(self.georef.heading_to_azimuth(heading))
        return math.pi / 2 - float(heading)

    def _pose(self, msg: PoseEstimate) -> None:
        if not msg.agent:
            self.ctx.count("poses_without_agent")
            return
        if not (np.isfinite(msg.position).all() and math.isfinite(msg.heading)):
            self.ctx.count("non_finite_poses")
            return
        mav = self._sender(msg.agent)
        pos = np.asarray(msg.position, float)
        n, e, d = self._to_ned(pos)
        vn = ve = vd = math.nan
        prev = self.last.get(msg.agent)
        if prev is not None and msg.t > prev.t:
            vn, ve, vd = self._to_ned((pos - np.asarray(prev.position, float)) / (msg.t - prev.t))
        self.last[msg.agent] = msg
        boot_ms = int(max(msg.t, 0.0) * 1000) & 0xFFFFFFFF
        mav.local_position_ned_send(boot_ms, n, e, d, vn, ve, vd)
        self.sent += 1
        yaw = self._yaw(msg.heading)
        if self.params.odometry:
            mav.odometry_send(int(max(msg.t, 0.0) * 1e6), self.mavlink.MAV_FRAME_LOCAL_NED,
                              self.mavlink.MAV_FRAME_BODY_FRD, n, e, d, yaw_quaternion(yaw),
                              vn, ve, vd, math.nan, math.nan, math.nan,
                              ned_covariance(np.asarray(msg.cov), self.turn),
                              [math.nan] + [0.0] * 20)
            self.sent += 1
        if self.georef is not None and msg.frame == "building":
            lon, lat, h = self.georef.to_wgs84(pos[None, :])[0]
            cms = [0 if not math.isfinite(v) else int(round(100 * v)) for v in (vn, ve, vd)]
            cms = [max(-32768, min(32767, v)) for v in cms]
            hdg = int(round(math.degrees(yaw) * 100)) % 36000
            mav.global_position_int_send(boot_ms, int(round(lat * 1e7)), int(round(lon * 1e7)),
                                         int(round(h * 1000)), int(round(pos[2] * 1000)),
                                         cms[0], cms[1], cms[2], hdg)
            self.sent += 1
        elif self.georef is not None:
            self.ctx.count("poses_not_in_building_frame")

    def _heartbeat(self, agent: str) -> None:
        mav = self._sender(agent)
        cond = self.tracker.agents[agent].conditions
        ml = self.mavlink
        status = (ml.MAV_STATE_EMERGENCY if cond["man_down"] else
                  ml.MAV_STATE_CRITICAL if any(cond.values()) else ml.MAV_STATE_ACTIVE)
        mav.heartbeat_send(getattr(ml, _VEHICLE_TYPES[self.params.vehicle_type]),
                           ml.MAV_AUTOPILOT_GENERIC, 0, 0, status)
        beats = self.beats[agent] = self.beats.get(agent, 0) + 1
        if self.origin is not None and (beats - 1) % self.params.origin_every == 0:
            lon, lat, h = self.origin
            mav.gps_global_origin_send(int(round(lat * 1e7)), int(round(lon * 1e7)),
                                       int(round(h * 1000)))

    def _report(self, changes: list[tuple[str, str, bool]], t: float) -> None:
        ml = self.mavlink
        when = clock_text(t)
        for agent, cond, on in changes:
            if on:
                severity = getattr(ml, _SEVERITY[cond])
                text = f"{agent} {ALARM_TITLES[cond]} since {when}"
            else:
                severity = ml.MAV_SEVERITY_NOTICE
                text = f"{agent} {ALARM_TITLES[cond].lower()} over at {when}"
            self._sender(agent).statustext_send(severity, text[:50].encode())

    def finish(self) -> None:
        self.conn.close()
