"""CAN codec of the firenav reference foot IMU (``dbc/firenav_imu.dbc``).

Node n sends three classic 8-byte frames per sample at base id ``0x100 + 0x10 n``:
``IMU<n>_ACCEL`` (+0), ``IMU<n>_GYRO`` (+1) and ``IMU<n>_TIME`` (+2), tied together
by the 8-bit sample counter ``Seq``. The layout is documented in the DBC file and
``docs/formats/can-imu.md``; the DBC is the single source of truth for ids, scales
and ranges (cantools reads it for both directions).
"""
from __future__ import annotations

import functools
import importlib.resources
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from firenav_framework.messages import IMU_FLAG_BITS, RawFrame

from .imu_frames import DecodedSample, EncodedFrame, FrameError

__all__ = ["DBC_PATH", "load_imu_dbc", "encode_can_imu", "CanImuDecoder", "can_ids"]

#: The shipped DBC file (inside the installed package).
DBC_PATH = importlib.resources.files(__package__).joinpath("dbc/firenav_imu.dbc")

_NAME = re.compile(r"^IMU(\d+)_(ACCEL|GYRO|TIME)$")
_SIGNALS = {"ACCEL": ("AccX", "AccY", "AccZ", "Seq", "AccSat", "GyroSat"),
            "GYRO": ("GyroX", "GyroY", "GyroZ", "Seq"),
            "TIME": ("TimeUs", "Seq")}
_WRAP = 1 << 32  # TimeUs wraps at 2^32 us
_MAX_PENDING = 4  # a sample still incomplete this many samples later is dropped
_SATURATED = IMU_FLAG_BITS["saturated"]


def _no_count(what: str, n: int = 1) -> None:
    """Default counter: nothing is recorded."""


@functools.lru_cache(maxsize=8)
def load_imu_dbc(path: str | None = None) -> Any:
    """The cantools database of ``path`` (default: the shipped DBC), checked for our layout.

    Raises ``ValueError`` when a message named ``IMU<n>_ACCEL|GYRO|TIME`` lacks the
    signals the codec needs, or when no such message exists.
    """
    import cantools

    if path is None:
        with importlib.resources.as_file(DBC_PATH) as p:
            db = cantools.database.load_file(str(p))
        where = "the shipped firenav_imu.dbc"
    else:
        db = cantools.database.load_file(str(path))
        where = str(path)
    found = 0
    for msg in db.messages:
        m = _NAME.match(msg.name)
        if m is None:
            continue
        found += 1
        names = {s.name for s in msg.signals}
        missing = [s for s in _SIGNALS[m.group(2)] if s not in names]
        if missing:
            raise ValueError(f"{where}: message {msg.name} lacks signals {', '.join(missing)}")
    if not found:
        raise ValueError(f"{where}: no IMU<n>_ACCEL/GYRO/TIME messages (see docs/formats/can-imu.md)")
    return db


def can_ids(db: Any) -> dict[int, tuple[int, str]]:
    """``{frame id: (node, "ACCEL"|"GYRO"|"TIME")}`` of the IMU messages in ``db``."""
    out = {}
    for msg in db.messages:
        m = _NAME.match(msg.name)
        if m is not None:
            out[msg.frame_id] = (int(m.group(1)), m.group(2))
    return out


def _limits(db: Any, name: str, signal: str) -> tuple[float, float]:
    sig = db.get_message_by_name(name).get_signal_by_name(signal)
    return float(sig.minimum), float(sig.maximum)


def encode_can_imu(time: np.ndarray, accel: np.ndarray, gyro: np.ndarray, *, node: int = 0,
                   seq_start: int = 0, temperature: float = 25.0,
                   dbc: str | Path | None = None) -> list[EncodedFrame]:
    """Encode samples as the reference device sends them: ACCEL, GYRO, TIME per sample.

    ``time`` (N,) device clock [s] (>= 0; sent as uint32 microseconds, wrapping),
    ``accel`` (N, 3) [m/s^2] and ``gyro`` (N, 3) [rad/s] in the device axes. Values
    beyond the signal range are clipped to it and the sample's AccSat/GyroSat bit is
    set, as a saturating sensor would. Quantisation: 0.005 m/s^2 and 0.0005 rad/s.
    Each frame is stamped with its sample's time.
    """
    db = load_imu_dbc(None if dbc is None else str(dbc))
    nodes = sorted({n for n, _ in can_ids(db).values()})
    if node not in nodes:
        raise ValueError(f"node {node} is not in the DBC (nodes: {nodes})")
    time = np.asarray(time, float)
    if len(time) and (not np.all(np.isfinite(time)) or time.min() < 0):
        raise ValueError("CAN IMU times must be finite and non-negative (device clock)")
    a_lo, a_hi = _limits(db, f"IMU{node}_ACCEL", "AccX")
    g_lo, g_hi = _limits(db, f"IMU{node}_GYRO", "GyroX")
    accel = np.asarray(accel, float)
    gyro = np.asarray(gyro, float)
    acc_sat = ((accel <= a_lo) | (accel >= a_hi)).any(axis=1)
    gyr_sat = ((gyro <= g_lo) | (gyro >= g_hi)).any(axis=1)
    accel = np.clip(accel, a_lo, a_hi)
    gyro = np.clip(gyro, g_lo, g_hi)
    time_us = np.round(time * 1e6).astype(np.int64) % _WRAP
    temp = int(np.clip(round(temperature), -128, 127))
    frames: list[EncodedFrame] = []
    ma, mg, mt = (db.get_message_by_name(f"IMU{node}_{kind}") for kind in _SIGNALS)
    for i, t in enumerate(time.tolist()):
        seq = (seq_start + i) & 0xFF
        ax, ay, az = accel[i].tolist()
        gx, gy, gz = gyro[i].tolist()
        frames.append(EncodedFrame(t, ma.frame_id, ma.encode(
            {"AccX": ax, "AccY": ay, "AccZ": az, "Seq": seq,
             "AccSat": int(acc_sat[i]), "GyroSat": int(gyr_sat[i])})))
        frames.append(EncodedFrame(t, mg.frame_id, mg.encode(
            {"GyroX": gx, "GyroY": gy, "GyroZ": gz, "Seq": seq, "Temp": temp})))
        frames.append(EncodedFrame(t, mt.frame_id, mt.encode(
            {"TimeUs": int(time_us[i]), "Seq": seq})))
    return frames


class CanImuDecoder:
    """Pairs ACCEL, GYRO and TIME frames by ``Seq`` into samples, per bus and node.

    ``count(what, n)`` receives ``incomplete_samples`` when a sample's frames never
    all arrive: it is dropped once a sample :data:`_MAX_PENDING` counts newer has
    been seen, or by :meth:`finish` at the end of the input.
    Device time is TimeUs unwrapped across its 71.6-minute wrap.
    """

    def __init__(self, dbc: str | Path | None = None,
                 count: Callable[[str, int], None] = _no_count):
        self.db = load_imu_dbc(None if dbc is None else str(dbc))
        self.ids = can_ids(self.db)
        self.count = count
        self._acc_limits = {fid: _limits(self.db, f"IMU{node}_ACCEL", "AccX")
                            for fid, (node, kind) in self.ids.items() if kind == "ACCEL"}
        self._gyro_limits = {fid: _limits(self.db, f"IMU{node}_GYRO", "GyroX")
                             for fid, (node, kind) in self.ids.items() if kind == "GYRO"}
        self._pending: dict[str, dict[int, dict[str, Any]]] = {}
        self._wrap: dict[str, list[int]] = {}  # device -> [last raw TimeUs, wraps]

    def decode(self, frame: RawFrame) -> list[DecodedSample] | None:
        fid = frame.channel
        if not isinstance(fid, int):
            raise FrameError("bad_frames", f"CAN frame channel {fid!r} is not an arbitration id")
        try:
            sig = self.db.decode_message(fid, bytes(frame.data), decode_choices=False)
            node, kind = self.ids[fid]
        except KeyError:
            raise FrameError("unknown_can_ids", f"CAN id 0x{fid:X} is not an IMU frame of the "
                             "DBC") from None
        except Exception as exc:  # cantools DecodeError (wrong length) or a malformed payload
            raise FrameError("bad_frames", f"CAN id 0x{fid:X}: {exc}") from None
        device = f"{frame.device or 'can'}/node{node}"
        pending = self._pending.setdefault(device, {})
        seq = int(sig["Seq"])
        entry = pending.setdefault(seq, {})
        if kind == "ACCEL":
            lo, hi = self._acc_limits[fid]
            entry["accel"] = (sig["AccX"], sig["AccY"], sig["AccZ"])
            saturated = sig["AccSat"] or sig["GyroSat"] or any(
                v <= lo or v >= hi for v in entry["accel"])
            entry["flags"] = entry.get("flags", 0) | (_SATURATED if saturated else 0)
        elif kind == "GYRO":
            lo, hi = self._gyro_limits[fid]
            entry["gyro"] = (sig["GyroX"], sig["GyroY"], sig["GyroZ"])
            if any(v <= lo or v >= hi for v in entry["gyro"]):
                entry["flags"] = entry.get("flags", 0) | _SATURATED
        else:
            entry["t"] = self._unwrap(device, int(sig["TimeUs"])) * 1e-6
        out = []
        if "accel" in entry and "gyro" in entry and "t" in entry:
            del pending[seq]
            out.append(DecodedSample(device, entry["t"], entry["accel"], entry["gyro"], None,
                                     entry.get("flags", 0)))
        stale = [old for old in pending if _MAX_PENDING < (seq - old) % 256 < 128]
        for old in stale:
            del pending[old]
        if stale:
            self.count("incomplete_samples", len(stale))
        return out

    def finish(self) -> None:
        """Count the samples still waiting for frames at the end of the input."""
        n = sum(len(p) for p in self._pending.values())
        self._pending.clear()
        if n:
            self.count("incomplete_samples", n)

    def _unwrap(self, device: str, raw: int) -> int:
        state = self._wrap.get(device)
        if state is None:
            self._wrap[device] = [raw, 0]
            return raw
        last, wraps = state
        if raw < last - _WRAP // 2:      # counter wrapped
            wraps += 1
        elif raw > last + _WRAP // 2:    # a late frame from before the wrap
            return raw + (wraps - 1) * _WRAP
        self._wrap[device] = [raw, wraps]
        return raw + wraps * _WRAP
