"""``firenav play INPUT --can ... --mavlink ... --lines ...``: act as the devices on live links.

INPUT is a scenario (a ``.yaml`` file or a bundled scenario name, simulated with
``--seed``) or any recording the ``recording`` source reads. Its foot-IMU blocks are
encoded as the reference devices send them and sent in real time (``--speed``
times faster), in the team layout of ``pipelines/field-live.yaml``
(:mod:`firenav_framework.transports.player`): the firefighter at position N of the
scenario (order of first appearance in a recording) is MAVLink system N with
HIGHRES_IMU id 0/1 for the left/right foot, or CAN nodes 2(N-1) (left) and
2(N-1)+1 (right). Agents named by ``--mavlink-agents`` go over MAVLink, the others
over CAN; without ``--can`` everyone goes over MAVLink. Frames are made by the
registered IMU codecs ``can_imu`` and ``mavlink_imu`` unless ``--codec LINK=NAME``
names another (a vendor's). The assignment of every device is printed on stderr as it
starts.

Every other sensor goes on the link its codec uses
(:mod:`firenav_framework.transports.radio_frames`): UWB ranges as ``UWB_TWR_REPORT``
frames on the CAN bus (tag N = the firefighter at position N, anchors numbered in the
plan's order, each number printed), RFID reads and deployments, barometer lines and
the breadcrumb radio's readings and drops as text lines on ``--lines`` (a serial port
or pty, a pyserial URL, or ``udp:HOST:PORT``). A message whose link is not given is
counted and skipped. ``--write-plan FILE`` writes the plan the scenario gives, with
its anchors, as GeoJSON for the live pipeline's ``building:``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..codecs import UnknownCodec, get_codec
from ..codecs.imu_sample import ImuSample
from ..contract import Context
from ..registry import default_registry
from ..stats import RunStats
from ..transports.line_links import open_line_output
from ..transports.mavlink_link import mavutil
from ..transports.player import DEFAULT_CODECS, DevicePlayer, Roster
from ..transports.radio_frames import RadioEncoder, plan_anchors
from . import UsageError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("play", help="play a scenario or recording onto CAN / MAVLink / "
                       "serial lines as devices would")
    p.add_argument("input", help="scenario YAML or bundled scenario name (simulated), or a recording")
    p.add_argument("--can", metavar="INTERFACE:CHANNEL", help="python-can bus, e.g. "
                   "udp_multicast:239.74.163.2, virtual:x or slcan:/dev/ttyACM0")
    p.add_argument("--can-option", action="append", default=[], metavar="KEY=VALUE",
                   help="extra can.Bus keyword (integers are converted), e.g. port=43113")
    p.add_argument("--mavlink", metavar="URL", help="pymavlink URL, e.g. udpout:127.0.0.1:14550")
    p.add_argument("--mavlink-agents", default="", help="comma-separated agents sent over "
                   "MAVLink when --can is also given (the others go over CAN)")
    p.add_argument("--lines", metavar="PORT|URL", help="the text-line link of the RFID "
                   "readers, barometers and breadcrumb radios: a serial port or pty "
                   "(/dev/pts/3), a pyserial URL, or udp:HOST:PORT")
    p.add_argument("--write-plan", metavar="FILE", help="write the scenario's plan with its "
                   "anchors (GeoJSON) for the live pipeline's building:")
    p.add_argument("--speed", type=float, default=1.0, help="times faster than real time "
                   "(0: as fast as possible; the radios carry no clock: other than 1, their "
                   "receive times no longer match the IMUs' device clocks)")
    p.add_argument("--seed", type=int, default=None, help="simulator seed (scenarios)")
    p.add_argument("--duration", type=float, default=None, help="play only the first this "
                   "many seconds of a scenario")
    p.add_argument("--block-s", type=float, default=0.01, help="samples are sent in blocks "
                   "of this many seconds (default 0.01: close to a device's own pace)")
    p.add_argument("--codec", action="append", default=[], metavar="LINK=NAME",
                   help="the registered IMU codec encoding for a link, e.g. "
                   "can=acme_can_imu (default: can=can_imu, mavlink=mavlink_imu)")
    p.set_defaults(func=play)


def imu_source(name: str, *, seed: int | None = None, duration: float | None = None,
               block_s: float = 0.01):
    """The ``simulator`` (scenario) or ``recording`` source that reads ``name``."""
    from ..simulator.scenario import SCENARIO_DIR
    path = Path(name)
    scenario = path.suffix.lower() in (".yaml", ".yml") or (
        not path.exists() and (SCENARIO_DIR / f"{name}.yaml").is_file())
    if not scenario and not path.is_file():
        raise UsageError(f"{name}: no such file or bundled scenario")
    plugin = "simulator" if scenario else "recording"
    info = default_registry().get("source", plugin)
    if info is None:
        raise UsageError(f"no '{plugin}' source plugin is installed to read {name}")
    params: dict = {info.cls.input_param: str(path.resolve()) if path.exists() else name,
                    "block_s": block_s}
    if scenario:
        params["seed"] = 0 if seed is None else seed
        if duration is not None:
            params["duration"] = duration
    ctx = Context("play", stats=RunStats(), publish=lambda *a: None, base_dir=Path.cwd())
    try:
        return info.cls(info.cls.Params.model_validate(params), ctx)
    except ValueError as exc:
        raise UsageError(f"{name}: {exc}") from None


def _codecs(specs: list[str]) -> dict[str, str]:
    """``--codec LINK=NAME`` values as {link: codec name}, each checked to exist."""
    out = {}
    for spec in specs:
        link, sep, name = spec.partition("=")
        if not sep or link not in DEFAULT_CODECS:
            raise UsageError(f"--codec {spec}: expected can=NAME or mavlink=NAME")
        try:
            codec = get_codec(name)
        except UnknownCodec as exc:
            raise UsageError(f"--codec {spec}: {exc}") from None
        if not codec.serves(link) or not issubclass(codec.record, ImuSample):
            raise UsageError(f"--codec {spec}: codec {name!r} is not an IMU codec of "
                             f"{link!r} frames ({codec.transport}, {codec.record.__name__})")
        out[link] = name
    return out


def _say(text: str) -> None:
    print(f"[play] {text}", file=sys.stderr, flush=True)


def play(args: argparse.Namespace) -> int:
    if not (args.can or args.mavlink):
        raise UsageError("give --can and/or --mavlink")
    src = imu_source(args.input, seed=args.seed, duration=args.duration, block_s=args.block_s)
    building = src.building() if hasattr(src, "building") else None
    if args.write_plan:
        if building is None:
            raise UsageError(f"--write-plan: {args.input} gives no plan")
        from ..building.geojson_format import write_geojson
        try:
            write_geojson(building, args.write_plan)
        except OSError as exc:
            raise UsageError(f"--write-plan {args.write_plan}: {exc}") from None
        _say(f"wrote the plan with its anchors to {args.write_plan}")
    mav_agents = set(filter(None, args.mavlink_agents.split(","))) if args.can else None
    if args.mavlink is None and mav_agents:
        raise UsageError("--mavlink-agents needs --mavlink")
    codecs = _codecs(args.codec)
    scenario = getattr(src, "scenario", None)
    roster = (Roster.of_scenario(scenario, mav_agents) if scenario is not None
              else Roster(mavlink_agents=mav_agents))
    bus = conn = lines = None
    if args.lines:      # first: a wrong port fails before any other link is open
        try:
            lines = open_line_output(args.lines)
        except (OSError, ValueError) as exc:
            raise UsageError(f"--lines {args.lines}: {exc}") from None
    if args.can:
        interface, _, channel = args.can.partition(":")
        opts = dict(o.split("=", 1) for o in args.can_option)
        opts = {k: int(v) if v.isdigit() else v for k, v in opts.items()}
        import can
        bus = can.Bus(interface=interface, channel=channel, **opts)
    if args.mavlink:
        conn = mavutil().mavlink_connection(args.mavlink, source_system=255)
    radio = RadioEncoder(team=lambda: roster.order, anchors=list(plan_anchors(building)),
                         announce=_say)
    player = DevicePlayer(can_bus=bus, mavlink=conn, lines=lines, speed=args.speed,
                          codecs=codecs, radio=radio)
    if args.speed != 1:
        _say(f"--speed {args.speed:g}: UWB, RFID, barometer and radio frames are stamped "
             "with their receive time, which now runs at another pace than the IMUs' clocks")

    def announce(device: str, a) -> None:
        _say(f"{device} -> {a}")
        if a.link == "can" and bus is None:
            raise UsageError(f"{device} goes over CAN: give --can, or name its agent in "
                             "--mavlink-agents")

    try:
        player.play((m for _, m in src.messages()), roster, on_assign=announce)
    except KeyboardInterrupt:
        pass
    except ValueError as exc:  # a layout without room for a device
        raise UsageError(str(exc)) from None
    except OSError as exc:     # a link went away: the serial port, a socket
        raise UsageError(f"sending failed: {exc}") from None
    finally:
        if bus is not None:
            bus.shutdown()
        if conn is not None:
            conn.close()
        if lines is not None:
            lines.close()
    kinds = ", ".join(f"{n} {k}" for k, n in sorted(radio.sent.items())) or "none"
    _say(f"sent {player.sent['can']} CAN frames, {player.sent['mavlink']} MAVLink packets, "
         f"{player.sent['lines']} lines (other sensors' messages: {kinds})")
    for link, n in sorted(player.skipped.items()):
        _say(f"skipped {n} {link} frames: no --{link} link given")
    return 0
