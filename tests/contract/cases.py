"""How the conformance test runs each built-in plugin that its defaults cannot run alone.

Every other registered plugin runs with its default parameters on the bundled sample
(:func:`firenav_framework.testing.sample_world`), so a newly registered plugin is
covered without an entry here.
"""
from __future__ import annotations

import socket
from collections.abc import Callable
from pathlib import Path
from typing import Any

from firenav_framework.messages import ImuBlock
from firenav_framework.formats.imu_csv import write_imu_csv
from firenav_framework.testing import sample_world


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _recording(tmp: Path) -> dict[str, Any]:
    """An IMU CSV of the sample's foot IMUs, and a damaged copy of it."""
    blocks = [m for _, m in sample_world().messages if isinstance(m, ImuBlock)][:40]
    good = write_imu_csv(tmp / "walk.csv", blocks)
    lines = good.read_text().splitlines(keepends=True)
    header = sum(1 for ln in lines if not ln[:1].isdigit())
    body = lines[header:]
    damaged = [*lines[:header], *body[:10], "0.5,1.0,two,3.0\n", "garbage line\n",
               *body[10:20], body[20][: len(body[20]) // 2] + "\n", *body[21:]]
    bad = tmp / "damaged.csv"
    bad.write_text("".join(damaged))
    return {"params": {"path": str(good)}, "faulty_params": [{"path": str(bad)}]}


def _barometer_lines() -> dict[str, Any]:
    """30 s of barometer lines (no simulated barometer yet): ff1 and ff2 worn, ff1
    climbing after the 10 s zeroing. No reference barometer, so that each firefighter's
    lines alone give heights (the reset-refeed check feeds one firefighter's)."""
    import numpy as np
    from firenav_framework.codecs import to_raw_frames
    from firenav_framework.codecs.baro_lines import BaroLinesCodec, BaroReading
    rng = np.random.default_rng(5)
    readings = []
    for k, t in enumerate(np.arange(0.0, 30.0, 0.1)):
        climb = max(0.0, t - 10.0) * 0.12 * 3.5 / 0.29  # Pa: 0.12 m/s up
        readings += [BaroReading(float(t), "ff1/baro", 101_400.0 - climb + rng.normal(0, 2)),
                     BaroReading(float(t) + 0.05, "ff2/baro", 101_250.0 + rng.normal(0, 2))]
    import dataclasses
    codec, frames = BaroLinesCodec(), []
    for r in sorted(readings):   # one serial line per barometer, mapped to its wearer
        (f,) = to_raw_frames(codec.encode([r]), transport="serial", device=r.device)
        frames.append(dataclasses.replace(f, agent=r.device.split("/")[0]))
    return {"params": {"reference": ""}, "sample_input": [("baro.raw", f) for f in frames]}


def setup(kind: str, name: str, tmp: Path) -> dict[str, Any]:
    """Keyword arguments of :func:`firenav_framework.testing.plugin_case` for a plugin."""
    if (kind, name) == ("source", "recording"):
        return _recording(tmp)
    if (kind, name) == ("sensor", "barometer"):
        return _barometer_lines()
    params: dict[str, Any] = {
        ("source", "simulator"): {"duration": 10.0},
        ("source", "can_bus"): {"interface": "virtual", "channel": f"conformance-{tmp.name}"},
        ("source", "mavlink"): {"url": f"udpin:127.0.0.1:{free_udp_port()}"},
        ("source", "udp_lines"): {"bind": f"127.0.0.1:{free_udp_port()}"},
        ("source", "serial_lines"): {"url": "loop://"},
        ("sink", "live_view"): {"port": 0},
        ("sink", "foxglove_live"): {"port": 0},
        # the wall-clock column is when a line was written: two runs differ by design
        ("sink", "diagnostics_log"): {"wall_clock": False},
        ("sink", "mavlink_out"): {"url": f"udpout:127.0.0.1:{free_udp_port()}"},
    }.get((kind, name), {})
    return {"params": params}


#: Sample input per codec name: a function giving the keyword arguments of
#: :func:`firenav_framework.testing.check_codec` (``records``: what ``encode`` takes,
#: ``address``, ``options``). Every built-in codec needs one (its round trip); a
#: vendor's codec without one is checked on foreign frames only.
CODEC_SAMPLES: dict[str, Callable[[], dict[str, Any]]] = {}


def _imu_block():
    import numpy as np
    from firenav_framework.messages import ImuBlock
    t = np.arange(1, 21) * 0.005
    return ImuBlock.from_arrays(t, np.tile([0.12, -0.2, 9.79], (20, 1)),
                                np.tile([0.01, 0.0, -0.02], (20, 1)), frame="device")


def _twr():
    from firenav_framework.codecs.twr_report import TwrReport
    return [TwrReport(1.0, "1", "1", 5.25, -80.0, -81.0, 3),
            TwrReport(1.1, "1", "2", None, None, None, 4)]


def _rfid():
    from firenav_framework.codecs.rfid_lines import RfidEvent
    return [RfidEvent(1.0, "TAG", "ff1/rfid", "E2BB01", -51.0, 3),
            RfidEvent(2.0, "DEPLOY", "ff1/rfid", "E2BB02")]


def _baro():
    from firenav_framework.codecs.baro_lines import BaroReading
    return [BaroReading(1.0, "ff1/baro", 101325.25, 294.65), BaroReading(1.1, "base/baro", 101337.5)]


def _radio():
    from firenav_framework.codecs.breadcrumb_lines import RadioEvent
    return [RadioEvent(1.0, "RSSI", "bc1", "ff3/radio", -61.0),
            RadioEvent(2.0, "DROP", "ff3/dispenser", "bc2")]


CODEC_SAMPLES.update({
    "can_imu": lambda: {"records": _imu_block(), "address": "node1"},
    "mavlink_imu": lambda: {"records": _imu_block(), "address": "sys1/comp1/imu0"},
    "imu_lines": lambda: {"records": _imu_block(), "address": "imu1"},
    "uwb_can": lambda: {"records": _twr(), "address": "1"},
    "uwb_lines": lambda: {"records": _twr(), "address": "1"},
    "rfid_lines": lambda: {"records": _rfid(), "address": "ff1/rfid"},
    "baro_lines": lambda: {"records": _baro(), "address": "ff1/baro"},
    "breadcrumb_lines": lambda: {"records": _radio(), "address": "base"},
})
