"""MAVLink out: every firefighter as its own system, so a ground-control station shows them.

For each :class:`PoseEstimate` the sink sends, from the firefighter's system id,
``LOCAL_POSITION_NED`` (#32) and ``ODOMETRY`` (#331, MAVLink 2) with the pose
covariance. Frames: our ENU building frame becomes the GCS's local NED frame
(north = y, east = x, down = -z); heading (CCW from east) becomes yaw (clockwise
from north): ``yaw = pi/2 - heading``. Velocities are the difference of the last two
poses (NaN before). Once per second of timeline time each known firefighter sends a
``HEARTBEAT`` whose ``system_status`` carries its state (ACTIVE; CRITICAL when stale
or untrustworthy; EMERGENCY on man-down), and every state change is a ``STATUSTEXT``.
``time_boot_ms`` is the pose time in milliseconds.
"""
from __future__ import annotations

import math

import numpy as np

from ..contract import Sink, param
from ..liveview.status import StatusParams, StatusTracker
from ..messages import Diagnostic, PoseEstimate, Tick
from ..transports.mavlink_link import mavutil

#: ODOMETRY pose_covariance is the upper triangle of the 6x6 (x, y, z, roll, pitch, yaw)
#: covariance, row by row (21 values); here the index pairs in our 4x4 (x, y, z, heading)
#: of each NED entry, or None for roll/pitch, which we do not estimate (NaN).
_NED_FROM_ENU = {0: 1, 1: 0, 2: 2, 5: 3}  # NED axis -> ENU axis (n<-y, e<-x, d<-z, yaw<-heading)
_SIGN = {0: 1.0, 1: 1.0, 2: -1.0, 5: -1.0}  # d = -z; yaw = pi/2 - heading


def ned_covariance(cov4: np.ndarray) -> list[float]:
    """The 21-value ODOMETRY covariance from our 4x4 ENU (x, y, z, heading) covariance."""
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
    """Send each firefighter's pose to a ground station as its own MAVLink system (LOCAL_POSITION_NED, ODOMETRY)."""

    name = "mavlink_out"
    inputs = (PoseEstimate, Diagnostic)

    class Params(StatusParams):
        url: str = param("udpout:127.0.0.1:14550", description="pymavlink connection "
                         "string of the ground station (udpout:HOST:PORT, tcp:HOST:PORT, ...)")
        system_ids: dict[str, int] = param({}, description="firefighter id -> MAVLink system "
                                           "id; others get free ids from first_system_id on")
        first_system_id: int = param(1, ge=1, le=254, description="first id handed out "
                                     "automatically, in order of first appearance")
        component_id: int = param(1, ge=0, le=255, description="component id of the messages")
        odometry: bool = param(True, description="also send ODOMETRY with the covariance")

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
        self.sent = 0

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
            self._report(self.tracker.pose(msg))
        elif isinstance(msg, Diagnostic):
            self._report(self.tracker.diagnostic(msg))
        elif isinstance(msg, Tick):
            self._report(self.tracker.clock(msg.t))
            for agent in sorted(self.tracker.agents):
                self._heartbeat(agent)

    def _pose(self, msg: PoseEstimate) -> None:
        if not msg.agent:
            self.ctx.count("poses_without_agent")
            return
        if not (np.isfinite(msg.position).all() and math.isfinite(msg.heading)):
            self.ctx.count("non_finite_poses")
            return
        mav = self._sender(msg.agent)
        x, y, z = (float(v) for v in msg.position)
        n, e, d = y, x, -z
        vn = ve = vd = math.nan
        prev = self.last.get(msg.agent)
        if prev is not None and msg.t > prev.t:
            dt = msg.t - prev.t
            vx, vy, vz = ((np.asarray(msg.position) - np.asarray(prev.position)) / dt).tolist()
            vn, ve, vd = vy, vx, -vz
        self.last[msg.agent] = msg
        boot_ms = int(max(msg.t, 0.0) * 1000) & 0xFFFFFFFF
        mav.local_position_ned_send(boot_ms, n, e, d, vn, ve, vd)
        self.sent += 1
        if self.params.odometry:
            yaw = math.pi / 2 - float(msg.heading)
            mav.odometry_send(int(max(msg.t, 0.0) * 1e6), self.mavlink.MAV_FRAME_LOCAL_NED,
                              self.mavlink.MAV_FRAME_BODY_FRD, n, e, d, yaw_quaternion(yaw),
                              vn, ve, vd, math.nan, math.nan, math.nan,
                              ned_covariance(np.asarray(msg.cov)), [math.nan] + [0.0] * 20)
            self.sent += 1

    def _heartbeat(self, agent: str) -> None:
        mav = self._sender(agent)
        flags = self.tracker.agents[agent].flags
        ml = self.mavlink
        status = (ml.MAV_STATE_EMERGENCY if flags["man_down"] else
                  ml.MAV_STATE_CRITICAL if flags["stale"] or flags["untrusted"] else
                  ml.MAV_STATE_ACTIVE)
        mav.heartbeat_send(ml.MAV_TYPE_GENERIC, ml.MAV_AUTOPILOT_INVALID, 0, 0, status)

    def _report(self, changes: list[tuple[str, str, bool]]) -> None:
        ml = self.mavlink
        for agent, flag, on in changes:
            severity = (ml.MAV_SEVERITY_EMERGENCY if flag == "man_down" else
                        ml.MAV_SEVERITY_WARNING) if on else ml.MAV_SEVERITY_INFO
            text = f"{agent} {flag.replace('_', ' ')} {'ON' if on else 'cleared'}"
            self._sender(agent).statustext_send(severity, text[:50].encode())

    def finish(self) -> None:
        self.conn.close()

