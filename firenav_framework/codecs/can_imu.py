"""``can_imu``: the CAN protocol of the firenav reference foot IMU (``dbc/firenav_imu.dbc``).

Node n sends three classic 8-byte frames per sample: ``IMU<n>_ACCEL``, ``IMU<n>_GYRO``
and ``IMU<n>_TIME``, tied together by the 8-bit sample counter ``Seq``. The DBC file
owns the layout: ids (the shipped file uses ``0x100 + 0x10 n`` + 0, 1, 2), the node
count (8) and the scales and ranges; ``docs/formats/can-imu.md`` documents it. A
vendor variant with the same message and signal names is one ``dbc:`` option away.
"""
from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..contract.params import Params, param
from ..messages import IMU_FLAG_BITS, ImuBlock, RawFrame
from .base import EncodedFrame, FrameError
from .can_database import DbcCodec, MessageSpec
from .imu_sample import ImuSample, check_device_times

__all__ = ["CanImuCodec"]

_NAME = re.compile(r"^IMU(\d+)_(ACCEL|GYRO|TIME)$")
_SIGNALS = {"ACCEL": ("AccX", "AccY", "AccZ", "Seq", "AccSat", "GyroSat"),
            "GYRO": ("GyroX", "GyroY", "GyroZ", "Seq"),
            "TIME": ("TimeUs", "Seq")}
_NEEDS = tuple(MessageSpec(f"IMU<n>_{kind}", rf"IMU\d+_{kind}", signals)
               for kind, signals in _SIGNALS.items())
_WRAP = 1 << 32  # TimeUs wraps at 2^32 us
_MAX_PENDING = 4  # a sample still incomplete this many samples later is dropped
_SATURATED = IMU_FLAG_BITS["saturated"]


class CanImuCodec(DbcCodec):
    """firenav reference foot IMU on CAN: ACCEL, GYRO and TIME frames per sample (DBC).

    Decoding pairs the three frames of a sample by ``Seq``, per bus and node, in any
    order; a sample still incomplete once one :data:`_MAX_PENDING` counts newer has
    arrived, or at :meth:`finish`, is dropped and counted ``incomplete_samples``.
    Device time is ``TimeUs`` unwrapped across its 71.6-minute wrap. A value at either
    end of its signal range, or ``AccSat``/``GyroSat`` set, flags the sample saturated.
    Records are named ``<bus>/node<n>``; addresses are ``node<n>``.

    Encoding sends each sample as the device does (ACCEL, GYRO, TIME), ``Seq``
    continuing per address across calls. Values beyond a signal's range are clipped and
    flag the sample saturated; quantisation is the DBC's scale (0.005 m/s^2,
    0.0005 rad/s in the shipped file) and 1 us.
    """

    name = "can_imu"
    transport = "can"
    record = ImuSample
    dbc_shipped = "firenav_imu.dbc"
    dbc_needs = _NEEDS
    dbc_doc = "docs/formats/can-imu.md"

    class Options(DbcCodec.Options):
        temperature: float = param(25.0, unit="degC", ge=-128, le=127)
        """sensor temperature sent in GYRO frames"""

    def __init__(self, options: Params | dict[str, Any] | None = None, **kw: Any):
        super().__init__(options, **kw)
        self.ids: dict[int, tuple[int, str]] = {}   # frame id -> (node, kind)
        for msg in self.db.messages:
            m = _NAME.match(msg.name)
            if m is not None:
                self.ids[msg.frame_id] = (int(m.group(1)), m.group(2))
        self.nodes = sorted({node for node, _ in self.ids.values()})
        self._limits = {fid: self._signal_limits(node, kind)
                        for fid, (node, kind) in self.ids.items() if kind != "TIME"}
        self._pending: dict[str, dict[int, dict[str, Any]]] = {}
        self._wrap: dict[str, list[int]] = {}   # device -> [last raw TimeUs, wraps]
        self._seq: dict[int, int] = {}          # node -> next Seq to send

    def _signal_limits(self, node: int, kind: str) -> tuple[float, float]:
        signal = "AccX" if kind == "ACCEL" else "GyroX"
        sig = self.db.get_message_by_name(f"IMU{node}_{kind}").get_signal_by_name(signal)
        return float(sig.minimum), float(sig.maximum)

    # -- addresses ---------------------------------------------------------------------
    def addresses(self) -> Sequence[str]:
        return [f"node{n}" for n in self.nodes]

    def channels(self, address: str) -> Sequence[int]:
        node = self._node(address)
        return sorted(fid for fid, (n, _) in self.ids.items() if n == node)

    def _node(self, address: str) -> int:
        """The node of ``address`` (``""``: the first node)."""
        if not address:
            return self.nodes[0]
        m = re.fullmatch(r"node(\d+)", address)
        if m is None or int(m.group(1)) not in self.nodes:
            raise ValueError(f"{address!r} is not a node of the DBC (addresses: "
                             f"{', '.join(self.addresses())})")
        return int(m.group(1))

    # -- decoding ----------------------------------------------------------------------
    def decode(self, frame: RawFrame) -> list[ImuSample]:
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
            lo, hi = self._limits[fid]
            entry["accel"] = (sig["AccX"], sig["AccY"], sig["AccZ"])
            saturated = sig["AccSat"] or sig["GyroSat"] or any(
                v <= lo or v >= hi for v in entry["accel"])
            entry["flags"] = entry.get("flags", 0) | (_SATURATED if saturated else 0)
        elif kind == "GYRO":
            lo, hi = self._limits[fid]
            entry["gyro"] = (sig["GyroX"], sig["GyroY"], sig["GyroZ"])
            if any(v <= lo or v >= hi for v in entry["gyro"]):
                entry["flags"] = entry.get("flags", 0) | _SATURATED
        else:
            entry["t"] = self._unwrap(device, int(sig["TimeUs"])) * 1e-6
        out = []
        if "accel" in entry and "gyro" in entry and "t" in entry:
            del pending[seq]
            out.append(ImuSample(device, entry["t"], entry["accel"], entry["gyro"], None,
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

    # -- encoding ----------------------------------------------------------------------
    def encode(self, block: ImuBlock, *, address: str = "") -> list[EncodedFrame]:
        """ACCEL, GYRO and TIME frames of every sample of ``block`` (device axes, SI,
        ``time`` the device clock [s] >= 0, sent as uint32 microseconds), sent as
        ``address`` (``""``: the first node). Each frame is stamped with its sample's time.
        """
        node = self._node(address)
        time = check_device_times(block, "CAN IMU")
        ma, mg, mt = (self.db.get_message_by_name(f"IMU{node}_{kind}") for kind in _SIGNALS)
        a_lo, a_hi = self._limits[ma.frame_id]
        g_lo, g_hi = self._limits[mg.frame_id]
        accel = np.asarray(block.accel, float)
        gyro = np.asarray(block.gyro, float)
        acc_sat = ((accel <= a_lo) | (accel >= a_hi)).any(axis=1)
        gyr_sat = ((gyro <= g_lo) | (gyro >= g_hi)).any(axis=1)
        accel = np.clip(accel, a_lo, a_hi)
        gyro = np.clip(gyro, g_lo, g_hi)
        time_us = np.round(time * 1e6).astype(np.int64) % _WRAP
        temp = int(round(self.options.temperature))
        seq0 = self._seq.get(node, 0)
        self._seq[node] = (seq0 + len(time)) & 0xFF
        frames: list[EncodedFrame] = []
        for i, t in enumerate(time.tolist()):
            seq = (seq0 + i) & 0xFF
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
