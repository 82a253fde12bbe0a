"""Typed messages that flow between firenav components.

Conventions used by every message (and therefore by every plugin):

* Time ``t`` is the *measurement* time in seconds on the pipeline clock (float).
  The timeline orders messages by it. Blocks of samples carry the time of their
  **last** sample, i.e. the moment the whole block exists.
* The navigation frame is local **ENU** in metres: x east, y north, z up, origin at
  the building origin (or at the start of an unaided INS). Heading (yaw) is in
  radians, counter-clockwise from the x (east) axis, wrapped to (-pi, pi].
* The body frame of a conditioned IMU is **FLU**: x forward (toe), y left, z up.
  At rest and level, specific force reads about +9.81 m/s^2 on z.
* All quantities are SI: m, s, rad, m/s^2, rad/s; RSSI in dBm; magnetic field in uT.
* ``agent`` names the firefighter a message belongs to (``""`` when it belongs to no
  one, e.g. a breadcrumb-to-breadcrumb RSSI reading); ``device`` names the physical
  device that produced it.

Messages are immutable dataclasses, and so are their arrays: every array field is made
read-only when the message is constructed (a read-only view of the array given, so
that is cheap), so a receiver that writes into one gets a ``ValueError`` (a fault of
that receiver) instead of silently changing what every other receiver sees. A
producer that keeps changing a buffer after publishing it must publish a copy. Shapes
are checked at construction too (pose and truth positions (3,), covariances (4, 4), IMU
blocks (N,) and (N, 3)), so a malformed message fails where it is made; an
:class:`Odometry` increment is judged by its consumers' one rule, :meth:`Odometry.problem`.
"""
from __future__ import annotations

import dataclasses
import hashlib
from dataclasses import dataclass
from typing import Any, ClassVar, Hashable

import numpy as np

__all__ = [
    "Message", "RawFrame", "ImuBlock", "Range", "RssiReading", "TagDetection",
    "TagDeployment", "BreadcrumbDrop", "Odometry", "PoseEstimate", "PressureHeight",
    "Diagnostic", "GroundTruth", "Tick", "MESSAGE_TYPES", "POSE_COV_AXES", "IMU_FLAG_BITS",
]

#: Order of the axes in the 4x4 covariance carried by Odometry and PoseEstimate.
POSE_COV_AXES = ("x", "y", "z", "heading")


def _readonly(msg: "Message", name: str, shape: tuple[int | None, ...] | None = None,
              what: str = "") -> np.ndarray | None:
    """Replace array field ``name`` of ``msg`` by a read-only view, checking its shape
    (``None`` in ``shape``: any length); a None value is left alone."""
    value = getattr(msg, name)
    if value is None:
        return None
    if not isinstance(value, np.ndarray):
        value = np.asarray(value, dtype=float)
    if value.flags.writeable:
        value = value.view()
        value.flags.writeable = False
    if shape is not None and (value.ndim != len(shape) or any(
            want is not None and got != want for got, want in zip(value.shape, shape))):
        expect = "(" + ", ".join("N" if w is None else str(w) for w in shape) + \
            ("," if len(shape) == 1 else "") + ")"
        raise ValueError(f"{what or type(msg).__name__} {name} has shape {value.shape}, "
                         f"expected {expect}")
    object.__setattr__(msg, name, value)
    return value


def _digest_value(h: "hashlib._Hash", value: Any) -> None:
    if isinstance(value, np.ndarray):
        h.update(str(value.dtype).encode())
        h.update(str(value.shape).encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, (bytes, bytearray)):
        h.update(bytes(value))
    else:
        h.update(repr(value).encode())


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Message:
    """Base of all messages: measurement time, agent and device."""

    t: float
    agent: str = ""
    device: str = ""

    kind: ClassVar[str] = "message"
    #: True for data that arrive at a steady rate, where a silence means trouble (the
    #: timeline reports gaps only for these); events such as a tag read are not.
    periodic: ClassVar[bool] = False
    #: Fields naming radio nodes (anchors, breadcrumbs, firefighters' radios) that an
    #: estimator may publish poses of, besides the agents of its input.
    node_fields: ClassVar[tuple[str, ...]] = ()

    def shifted(self, dt: float) -> "Message":
        """The same message with every time field moved by ``dt`` seconds."""
        return dataclasses.replace(self, t=self.t + dt)

    def dedup_key(self) -> Hashable:
        """A key equal for exact duplicates only (time included): what the timeline
        compares for a message no newer than its channel's newest (only those can be
        duplicates). Messages made only of hashable fields override this with a plain
        tuple, which is much cheaper than :meth:`digest`."""
        return self.digest()

    def digest(self) -> bytes:
        """A content hash (time included) used to recognise exact duplicates."""
        h = hashlib.blake2b(digest_size=16)
        h.update(type(self).__name__.encode())
        for f in dataclasses.fields(self):
            _digest_value(h, getattr(self, f.name))
        return h.digest()


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class RawFrame(Message):
    """An undecoded frame as it came off a transport (CAN, serial, MAVLink, UDP).

    ``channel`` identifies the frame kind within the transport (CAN arbitration id,
    MAVLink message id, serial line prefix). ``t_recv`` is the wall-clock receive
    time (UNIX seconds) when known, used to tell device clock jumps from real gaps.
    """

    transport: str
    channel: int | str
    data: bytes
    t_recv: float | None = None
    kind: ClassVar[str] = "raw_frame"

    def dedup_key(self) -> Hashable:
        # every field is hashable: a tuple is 50x cheaper than the generic digest, and
        # live links deliver thousands of frames per second
        return (self.t, self.agent, self.device, self.transport, self.channel, self.data,
                self.t_recv)
    periodic: ClassVar[bool] = True


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class ImuBlock(Message):
    """A block of N inertial samples from one device.

    ``time`` (N,) sample times [s]; ``accel`` (N, 3) specific force [m/s^2];
    ``gyro`` (N, 3) angular rate [rad/s]; optional ``mag`` (N, 3) [uT].
    ``frame`` names the axes: ``"FLU"`` once conditioned by a sensor plugin;
    anything else means raw device axes. ``flags`` (N,) uint8 marks samples a sensor
    plugin found suspicious (see :data:`IMU_FLAG_BITS`) and kept; dropped samples
    are simply absent. ``t`` equals ``time[-1]``.
    """

    time: np.ndarray
    accel: np.ndarray
    gyro: np.ndarray
    mag: np.ndarray | None = None
    flags: np.ndarray | None = None
    frame: str = "FLU"
    kind: ClassVar[str] = "imu_block"
    periodic: ClassVar[bool] = True

    def __post_init__(self) -> None:
        n = len(_readonly(self, "time", (None,)))
        if n == 0:
            raise ValueError("an ImuBlock needs at least one sample")
        accel, gyro = _readonly(self, "accel"), _readonly(self, "gyro")
        if accel.shape != (n, 3) or gyro.shape != (n, 3):
            raise ValueError(
                f"ImuBlock arrays disagree: time has {n} samples, accel "
                f"{accel.shape}, gyro {gyro.shape}; expected ({n}, 3)")
        _readonly(self, "mag", (n, 3))
        _readonly(self, "flags", (n,))

    @classmethod
    def from_arrays(cls, time: np.ndarray, accel: np.ndarray, gyro: np.ndarray,
                    **kw: Any) -> "ImuBlock":
        """Build a block whose ``t`` is the last sample time."""
        time = np.asarray(time, dtype=float)
        return cls(t=float(time[-1]), time=time, accel=np.asarray(accel, dtype=float),
                   gyro=np.asarray(gyro, dtype=float), **kw)

    def __len__(self) -> int:
        return len(self.time)

    def shifted(self, dt: float) -> "ImuBlock":
        return dataclasses.replace(self, t=self.t + dt, time=self.time + dt)


#: Bits of ``ImuBlock.flags``.
IMU_FLAG_BITS = {"saturated": 1, "out_of_range": 2, "gap_before": 4, "repaired": 8}


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Range(Message):
    """A distance between two nodes [m] with its standard deviation [m].

    ``a`` and ``b`` are node ids (a wearable tag, an anchor, a breadcrumb, the base
    station). ``method`` says how it was measured: ``"uwb"``, ``"rssi"``, ...
    ``nlos`` marks ranges a sensor plugin suspects to be non-line-of-sight.
    """

    a: str
    b: str
    range_m: float
    sigma_m: float
    method: str = "uwb"
    nlos: bool = False
    kind: ClassVar[str] = "range"
    node_fields: ClassVar[tuple[str, ...]] = ("a", "b")


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class RssiReading(Message):
    """Received signal strength [dBm] of a packet from node ``tx`` heard at ``rx``."""

    tx: str
    rx: str
    rssi_dbm: float
    kind: ClassVar[str] = "rssi"
    node_fields: ClassVar[tuple[str, ...]] = ("tx", "rx")


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class TagDetection(Message):
    """An RFID reader on ``agent`` read tag ``tag_id`` (``reads`` times in the window)."""

    tag_id: str
    reader: str = ""
    rssi_dbm: float | None = None
    reads: int = 1
    kind: ClassVar[str] = "tag_detection"


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class TagDeployment(Message):
    """``agent`` attached tag ``tag_id`` at about its current position (door jamb, stair end)."""

    tag_id: str
    kind: ClassVar[str] = "tag_deployment"


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class BreadcrumbDrop(Message):
    """Dispenser ``device`` on ``agent`` dropped breadcrumb node ``node_id`` at time t."""

    node_id: str
    kind: ClassVar[str] = "breadcrumb_drop"
    node_fields: ClassVar[tuple[str, ...]] = ("node_id",)


def _check_cov4(msg: "Message", what: str) -> None:
    cov = _readonly(msg, "cov")
    if cov.shape != (4, 4):
        raise ValueError(f"{what} covariance must be 4x4 over (x, y, z, heading), got {cov.shape}")


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Odometry(Message):
    """A dead-reckoning increment between two instants (typically two stances).

    ``delta`` (3,) displacement [m] from ``t_start`` to ``t`` expressed in the
    odometry's own ENU frame (the INS frame, whose yaw is arbitrary);
    ``dheading`` heading change [rad] over the interval; ``cov`` (4, 4) covariance
    of (dx, dy, dz, dheading). ``position`` (3,) and ``heading`` are the odometry's
    absolute pose at ``t`` in its own frame, for consumers that want it.
    ``motion`` labels the gait when known (``"walk"``, ``"stairs_up"``,
    ``"stairs_down"``, ``"stairs_down_backward"``, ``"crawl"``, ``"still"``).
    ``yaw_drift_rate_sigma`` [rad/s] is the spread (one sigma) of a heading drift rate
    about the vertical (ENU z) that lasts the mission: a constant per source, so it is
    not in ``cov`` (the increments' covariance is step-to-step only) and a consumer
    with a heading-drift state takes it as that state's prior; 0 when the source does
    not say.
    """

    t_start: float
    delta: np.ndarray
    dheading: float
    cov: np.ndarray
    position: np.ndarray
    heading: float
    motion: str = ""
    yaw_drift_rate_sigma: float = 0.0
    kind: ClassVar[str] = "odometry"

    def __post_init__(self) -> None:
        _check_cov4(self, "Odometry")
        _readonly(self, "delta")      # shapes: judged by problem(), the one rule
        _readonly(self, "position")

    def shifted(self, dt: float) -> "Odometry":
        return dataclasses.replace(self, t=self.t + dt, t_start=self.t_start + dt)

    def problem(self) -> str:
        """Why this increment cannot be dead-reckoned with, or ``""`` when it can.

        The one rule every odometry consumer applies: ``delta`` three finite numbers,
        ``dheading`` finite, ``t_start <= t`` both finite, the absolute ``position``
        (3,) and ``heading`` finite, and ``cov`` finite with no negative variance.
        """
        delta = np.asarray(self.delta, float)
        if delta.shape != (3,) or not np.all(np.isfinite(delta)) \
                or not np.isfinite(self.dheading):
            return f"increment (delta {np.round(delta, 3).tolist()}, dheading " \
                   f"{self.dheading}) is not finite or not 3-D"
        if not (np.isfinite(self.t_start) and np.isfinite(self.t) and self.t_start <= self.t):
            return f"interval from {self.t_start} to {self.t} s is not a finite forward interval"
        position = np.asarray(self.position, float)
        if position.shape != (3,) or not np.all(np.isfinite(position)) \
                or not np.isfinite(self.heading):
            return "absolute pose (position, heading) is not finite or not 3-D"
        cov = np.asarray(self.cov, float)
        if not np.all(np.isfinite(cov)) or np.any(np.diag(cov) < 0):
            return "covariance is not finite or has a negative variance"
        return ""


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class PoseEstimate(Message):
    """An estimated pose of ``agent`` with its uncertainty.

    ``position`` (3,) ENU [m]; ``heading`` [rad]; ``cov`` (4, 4) over
    (x, y, z, heading); ``floor`` the floor index (0 = ground floor) or None when
    unknown. ``protection_radius`` [m] bounds the horizontal error at 99 % containment
    (``inf``: no bound is promised); ``trusted`` is True only while that bound is within
    the estimator's alert limit and nothing contradicts the estimate
    (:mod:`firenav_framework.integrity`). ``frame`` is ``"building"`` when the pose is
    placed in the building; an estimator that only knows its own start (an unaided INS)
    names its own frame, e.g. ``"odometry"``.
    """

    position: np.ndarray
    heading: float
    cov: np.ndarray
    floor: int | None = None
    trusted: bool = True
    frame: str = "building"
    protection_radius: float = float("inf")
    kind: ClassVar[str] = "pose"

    def __post_init__(self) -> None:
        _check_cov4(self, "PoseEstimate")
        _readonly(self, "position", (3,))


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class PressureHeight(Message):
    """The height of ``agent``'s barometer from static pressure, in the building's z.

    ``height`` [m] is a z of the building frame (the ``position[2]`` of a building-frame
    :class:`PoseEstimate`, the levels of ``Floor.z``): the height above the level where
    the barometer was zeroed (``zero_level``, the entrance floor's z) plus that level.
    ``sigma`` [m] is its 1-sigma uncertainty: reading noise, the zeroing, the reference's
    noise and its drift since it was last heard, and the pressure difference between
    inside and the reference that the zeroing cannot remove (fire, doors, ventilation).
    ``pressure`` [Pa] is the firefighter's static pressure (mean over the report's
    interval, ``t - interval`` to ``t``); ``reference_pressure`` [Pa] the pressure at
    the zeroing level it was compared with (the reference barometer at the entrance or
    base station, corrected by the zeroing offset; without a reference, the pressure
    at zeroing), ``reference_age`` [s] how old that reference is (0: heard within the
    interval). Heights are only published once the barometer is zeroed.
    """

    height: float
    sigma: float
    pressure: float
    reference_pressure: float
    reference_age: float = 0.0
    interval: float = 0.0
    zero_level: float = 0.0
    kind: ClassVar[str] = "pressure_height"
    periodic: ClassVar[bool] = True


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Diagnostic(Message):
    """Something a component wants the operator to know.

    ``level`` is ``"info"``, ``"warning"`` or ``"error"``; ``code`` a stable
    machine-readable name (``"device_silent"``, ``"map_error"``, ``"plugin_fault"``,
    ...); ``active`` False announces that a condition has cleared.
    """

    component: str
    level: str
    code: str
    text: str
    active: bool = True
    kind: ClassVar[str] = "diagnostic"


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class GroundTruth(Message):
    """The true pose of ``agent`` (simulator or surveyed checkpoint).

    ``frame`` names the frame of ``position``: ``"building"`` (the ENU building frame
    the estimates use) or another name (``"vicon"``, ``"survey"``) for truth that can
    only be compared with an estimate after aligning the two frames.
    """

    position: np.ndarray
    heading: float = float("nan")
    floor: int | None = None
    frame: str = "building"
    kind: ClassVar[str] = "ground_truth"
    periodic: ClassVar[bool] = True

    def __post_init__(self) -> None:
        _readonly(self, "position", (3,))


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Tick(Message):
    """A periodic tick at a fixed rate, for estimators that run synchronously."""

    period: float
    kind: ClassVar[str] = "tick"


MESSAGE_TYPES: dict[str, type[Message]] = {
    cls.kind: cls for cls in (RawFrame, ImuBlock, Range, RssiReading, TagDetection,
                              TagDeployment, BreadcrumbDrop, Odometry, PoseEstimate,
                              PressureHeight, Diagnostic, GroundTruth, Tick)
}
