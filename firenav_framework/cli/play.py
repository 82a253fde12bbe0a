"""``firenav play INPUT --can ... --mavlink ...``: act as the devices on live links.

INPUT is a scenario (``.yaml``, played by the ``simulator`` source) or any recording
the ``recording`` source reads. Its IMU blocks are encoded as the reference devices
send them and sent in real time: devices of the agents named by ``--mavlink-agents``
(or all, when no ``--can`` is given) as MAVLink 2 HIGHRES_IMU from system ``N`` (the
order of first appearance, from 1) with the left/right foot as IMU id 0/1; the
others as CAN frames of the reference DBC, node = device index on the bus.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..messages import ImuBlock
from ..registry import default_registry
from ..stats import RunStats
from ..components import Context
from ..transports.mavlink_link import mavutil
from ..transports.player import Assignment, DevicePlayer
from . import UsageError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("play", help="play a scenario or recording onto CAN / MAVLink as devices would")
    p.add_argument("input", type=Path, help="scenario YAML (simulator) or a recording")
    p.add_argument("--can", metavar="INTERFACE:CHANNEL", help="python-can bus, e.g. "
                   "udp_multicast:239.74.163.2 or slcan:/dev/ttyACM0")
    p.add_argument("--can-option", action="append", default=[], metavar="KEY=VALUE",
                   help="extra can.Bus keyword (integers are converted), e.g. port=43113")
    p.add_argument("--mavlink", metavar="URL", help="pymavlink URL, e.g. udpout:127.0.0.1:14550")
    p.add_argument("--mavlink-agents", default="", help="comma-separated agents sent over "
                   "MAVLink when --can is also given")
    p.add_argument("--speed", type=float, default=1.0, help="times faster than real time "
                   "(0: as fast as possible)")
    p.add_argument("--seed", type=int, default=None, help="simulator seed (scenarios)")
    p.set_defaults(func=play)


def _source(path: Path, seed: int | None):
    reg = default_registry()
    name = "simulator" if path.suffix.lower() in (".yaml", ".yml") else "recording"
    info = reg.get("source", name)
    if info is None:
        raise UsageError(f"no '{name}' source plugin is installed to read {path}")
    params = {info.cls.input_param: str(path.resolve())}
    if seed is not None and "seed" in info.cls.Params.model_fields:
        params["seed"] = seed
    ctx = Context("play", stats=RunStats(), publish=lambda *a: None, base_dir=Path.cwd())
    return info.cls(info.cls.Params.model_validate(params), ctx)


def play(args: argparse.Namespace) -> int:
    if not (args.can or args.mavlink):
        raise UsageError("give --can and/or --mavlink")
    src = _source(args.input, args.seed)
    bus = conn = None
    if args.can:
        interface, _, channel = args.can.partition(":")
        opts = dict(o.split("=", 1) for o in args.can_option)
        opts = {k: int(v) if v.isdigit() else v for k, v in opts.items()}
        import can
        bus = can.Bus(interface=interface, channel=channel, **opts)
    if args.mavlink:
        conn = mavutil().mavlink_connection(args.mavlink, source_system=255)
    mav_agents = set(filter(None, args.mavlink_agents.split(","))) if args.can else None
    player = DevicePlayer(can_bus=bus, mavlink=conn, speed=args.speed)
    agents: list[str] = []
    try:
        for _, msg in src.messages():
            if not isinstance(msg, ImuBlock):
                continue
            if msg.device not in player.assignments:
                if msg.agent not in agents:
                    agents.append(msg.agent)
                over_mav = mav_agents is None or msg.agent in mav_agents
                same = [d for d, a in player.assignments.items()
                        if a.link == ("mavlink" if over_mav else "can")]
                if over_mav:
                    mine = sum(1 for d in same if d.startswith(msg.agent + "/"))
                    player.assignments[msg.device] = Assignment(
                        "mavlink", sysid=agents.index(msg.agent) + 1, imu_id=mine)
                else:
                    player.assignments[msg.device] = Assignment("can", node=len(same))
                a = player.assignments[msg.device]
                print(f"[play] {msg.device} -> " + (f"CAN node {a.node}" if a.link == "can"
                      else f"MAVLink sys{a.sysid} imu{a.imu_id}"), file=sys.stderr)
            player.pace(msg.t)
            player.send(msg)
    except KeyboardInterrupt:
        pass
    finally:
        if bus is not None:
            bus.shutdown()
        if conn is not None:
            conn.close()
    print(f"[play] sent {player.sent['can']} CAN frames, {player.sent['mavlink']} MAVLink packets",
          file=sys.stderr)
    return 0
