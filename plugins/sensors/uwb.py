"""UWB two-way ranging between a wearable tag and fixed anchors (DW1000-style devices).

The ORCA map-matching paper (§3.1) leaves a UWB anchor at the entrance and ranges to a
DW1000 tag on the firefighter; its missed-door rule picks the door that fits that
range. This sensor turns the device reports into clean :class:`Range` messages:

* **decoding** of two link formats (``docs/formats/uwb.md``): the serial/UDP text line
  ``RANGE,<tag>,<anchor>,<range_mm>,<rx_power_dbm>,<fp_power_dbm>[,<seq>][*<xor>]`` and
  the CAN frame ``UWB_TWR_REPORT`` of ``dbc/uwb_twr.dbc`` (decoded with cantools).
  Already-decoded ``Range`` messages (the simulator's) pass through the same chain.
* **bias calibration** per anchor: ``measured = scale * true + offset + b(rx_power)``
  with ``b`` a piecewise-linear table over received power (the DW1000's range bias
  grows as the signal weakens).
* **NLOS suspicion**: a total received power more than ``nlos_power_gap`` (6 dB) above
  the first-path power means most energy arrived late, i.e. the direct path is
  blocked (the usual DW1000 rule of thumb, Decawave APS006); without power readings
  (the simulator's ranges), a range longer than the link's smoothed range track
  (constant-velocity Kalman filter) predicts by ``nlos_innovation`` sigmas is
  suspect too. Such ranges are flagged ``nlos`` and get ``nlos_sigma``.
* **outliers**: a range that moved farther from the link's last accepted range than
  walking at ``max_speed`` (plus ``gate_sigmas`` sigma) allows is dropped and counted;
  after ``relock_after`` mutually consistent rejects the link re-locks on them.
* **dropouts**: ranging failures and lost reports (sequence gaps) are counted; a link
  silent for ``silence_timeout`` raises a ``uwb_silent`` warning, cleared when it
  comes back.

Node ids: the output ``Range`` has ``a`` = the firefighter (the tag's agent id; the
tag ``n`` is mapped by ``tags``, else named ``tag<n>``), ``b`` = the anchor (mapped
by ``anchors``, else named ``anchor<n>``); ``agent`` the firefighter, ``device``
``<agent>/uwb``. Already-decoded ranges are read the same way (``a`` tag, ``b`` anchor).
"""
from __future__ import annotations

import functools
import importlib.resources
import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from firenav_framework import Params, PerAgent, Range, RawFrame, Sensor, Tick, param

from .checked_lines import NAME, LineProblem, decode_fields, encode_fields
from .imu_frames import EncodedFrame, FrameError

__all__ = ["TwrReport", "encode_uwb_line", "decode_uwb_line", "encode_uwb_can",
           "decode_uwb_can", "load_uwb_dbc", "AnchorBias", "UwbSensor", "PLUGINS"]

#: The shipped DBC of the CAN report.
DBC_PATH = importlib.resources.files(__package__).joinpath("dbc/uwb_twr.dbc")
_CAN_MESSAGE = "UWB_TWR_REPORT"
_RANGE_FAILED_MM = (1 << 24) - 1        # RangeMm value meaning "ranging failed"
_POWER_NA_RAW = 255                      # raw power byte meaning "not available"


class TwrReport(NamedTuple):
    """One decoded two-way-ranging report.

    ``tag``/``anchor`` as the device names them (numbers or names); ``range_m`` the raw
    range [m] (None: the device reports a failed exchange); ``rx_dbm``/``fp_dbm`` total
    and first-path received power [dBm] (None when not reported); ``seq`` the report
    counter (0-255, None when not reported).
    """

    tag: str
    anchor: str
    range_m: float | None
    rx_dbm: float | None = None
    fp_dbm: float | None = None
    seq: int | None = None


# -- text line -----------------------------------------------------------------------

def encode_uwb_line(r: TwrReport, checksum: bool = True) -> bytes:
    """The text line of a report (no line terminator), with its ``*HH`` checksum."""
    def power(v: float | None) -> str:
        return "" if v is None else f"{v:.1f}"
    mm = "" if r.range_m is None else str(int(round(r.range_m * 1000)))
    fields = ["RANGE", str(r.tag), str(r.anchor), mm, power(r.rx_dbm), power(r.fp_dbm)]
    if r.seq is not None:
        fields.append(str(r.seq))
    return encode_fields(fields, checksum)


def decode_uwb_line(data: bytes) -> TwrReport | None:
    """Decode one text line; None if it is not a RANGE line; FrameError if it is broken."""
    try:
        parts = decode_fields(data, ("RANGE",))
    except LineProblem as e:
        counter = "checksum_errors" if e.kind == "checksum" else "bad_frames"
        raise FrameError(counter, f"UWB {e}") from None
    if parts is None:
        return None
    text = ",".join(parts)
    if len(parts) not in (6, 7):
        raise FrameError("bad_frames", f"UWB line needs 6 or 7 fields, got {len(parts)}: {text!r}")
    _, tag, anchor, mm, rx, fp, *rest = parts
    if not (NAME.match(tag) and NAME.match(anchor)):
        raise FrameError("bad_frames", f"UWB line has a bad tag or anchor id: {text!r}")
    try:
        rng = None if mm in ("", "-1") else int(mm) / 1000.0
        rxv = float(rx) if rx else None
        fpv = float(fp) if fp else None
        seq = int(rest[0]) if rest and rest[0] else None
    except ValueError:
        raise FrameError("bad_frames", f"UWB line has a non-numeric field: {text!r}") from None
    if (rng is not None and rng < 0) or (seq is not None and not 0 <= seq <= 255):
        raise FrameError("bad_frames", f"UWB line field out of range: {text!r}")
    for v in (rxv, fpv):
        if v is not None and not math.isfinite(v):
            raise FrameError("bad_frames", f"UWB line power is not finite: {text!r}")
    return TwrReport(tag, anchor, rng, rxv, fpv, seq)


# -- CAN ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=4)
def load_uwb_dbc(path: str | None = None) -> Any:
    """The cantools database with ``UWB_TWR_REPORT`` (default: the shipped DBC)."""
    import cantools

    if path is None:
        with importlib.resources.as_file(DBC_PATH) as p:
            db = cantools.database.load_file(str(p))
    else:
        db = cantools.database.load_file(str(path))
    try:
        msg = db.get_message_by_name(_CAN_MESSAGE)
    except KeyError:
        raise ValueError(f"{path or 'uwb_twr.dbc'}: no {_CAN_MESSAGE} message "
                         "(see docs/formats/uwb.md)") from None
    missing = {"TagId", "AnchorId", "RangeMm", "RxPower", "FpPower", "Seq"} - \
        {s.name for s in msg.signals}
    if missing:
        raise ValueError(f"{path or 'uwb_twr.dbc'}: {_CAN_MESSAGE} lacks {', '.join(sorted(missing))}")
    return db


def encode_uwb_can(r: TwrReport, t: float = 0.0, dbc: str | None = None) -> EncodedFrame:
    """The CAN frame of a report (numeric tag and anchor ids 0-255)."""
    msg = load_uwb_dbc(dbc).get_message_by_name(_CAN_MESSAGE)

    def power(v: float | None) -> float:
        return -0.5 if v is None else float(np.clip(v, -128.0, -1.0))
    mm = _RANGE_FAILED_MM if r.range_m is None else int(min(round(r.range_m * 1000),
                                                            _RANGE_FAILED_MM - 1))
    data = msg.encode({"TagId": int(r.tag), "AnchorId": int(r.anchor), "RangeMm": mm,
                       "RxPower": power(r.rx_dbm), "FpPower": power(r.fp_dbm),
                       "Seq": (r.seq or 0) & 0xFF})
    return EncodedFrame(t, msg.frame_id, bytes(data))


def decode_uwb_can(frame_id: int, data: bytes, dbc: str | None = None) -> TwrReport | None:
    """Decode a CAN frame; None if it is not a UWB report; FrameError if it is broken."""
    db = load_uwb_dbc(dbc)
    msg = db.get_message_by_name(_CAN_MESSAGE)
    if frame_id != msg.frame_id:
        return None
    try:
        sig = msg.decode(bytes(data), decode_choices=False, scaling=False)
    except Exception as exc:  # cantools DecodeError: wrong length
        raise FrameError("bad_frames", f"CAN id 0x{frame_id:X}: {exc}") from None

    def power(raw: int) -> float | None:
        return None if raw == _POWER_NA_RAW else raw * 0.5 - 128.0
    mm = int(sig["RangeMm"])
    return TwrReport(str(int(sig["TagId"])), str(int(sig["AnchorId"])),
                     None if mm == _RANGE_FAILED_MM else mm / 1000.0,
                     power(int(sig["RxPower"])), power(int(sig["FpPower"])), int(sig["Seq"]))


# -- calibration -------------------------------------------------------------------

class AnchorBias(Params):
    """Range bias model of one anchor: ``measured = scale * true + offset_m + b(rx)``."""

    offset_m: float = param(0.0, unit="m", description="constant bias (antenna delay residue)")
    scale: float = param(1.0, gt=0.5, lt=1.5, description="scale factor (clock/propagation)")
    power_table: list[tuple[float, float]] = param(
        [], description="(rx_power_dbm, bias_m) points of the power-dependent bias, "
        "interpolated linearly (held constant beyond the ends)")

    def correct(self, range_m: float, rx_dbm: float | None) -> float:
        """The bias-corrected range [m]."""
        b = 0.0
        if self.power_table and rx_dbm is not None:
            pts = sorted(self.power_table)
            b = float(np.interp(rx_dbm, [p[0] for p in pts], [p[1] for p in pts]))
        return (range_m - self.offset_m - b) / self.scale


@dataclass
class _Link:
    """One tag-anchor pair."""

    last_t: float | None = None           # time of the last report, accepted or not
    accepted: tuple[float, float] | None = None   # (t, range) of the last accepted range
    rejects: list = field(default_factory=list)   # consecutive rejected (t, range)
    silent: bool = False
    track: "_RangeTrack | None" = None    # smoothed range and range rate


class _RangeTrack:
    """Constant-velocity Kalman filter on one link's range: state (range [m], rate [m/s]).

    Walking changes a range smoothly; a range that jumps *longer* than the track allows
    is the signature of a blocked direct path (NLOS adds delay, never removes it).
    """

    def __init__(self, t: float, r: float, sigma: float, max_rate: float):
        self.t = t
        self.x = np.array([r, 0.0])
        self.P = np.diag([sigma ** 2, max_rate ** 2])

    def innovation(self, t: float, r: float, sigma: float, accel: float) -> tuple[float, float]:
        """Predict to ``t``; (innovation [m], its standard deviation [m])."""
        dt = max(t - self.t, 0.0)
        f = np.array([[1.0, dt], [0.0, 1.0]])
        g = np.array([0.5 * dt * dt, dt])
        self.x = f @ self.x
        self.P = f @ self.P @ f.T + np.outer(g, g) * accel ** 2
        self.t = t
        return r - self.x[0], math.sqrt(self.P[0, 0] + sigma ** 2)

    def update(self, r: float, sigma: float) -> None:
        s = self.P[0, 0] + sigma ** 2
        k = self.P[:, 0] / s
        self.x = self.x + k * (r - self.x[0])
        self.P = self.P - np.outer(k, self.P[0, :])


class UwbSensor(Sensor):
    """UWB two-way ranging: decodes DW1000-style reports, calibrates bias, flags NLOS, drops outliers."""

    name = "uwb"
    inputs = (Range, RawFrame)
    outputs = {"range": Range}

    class Params(Params):
        tags: dict[str, str] = param({}, description="tag number/name in the frames -> "
                                     "firefighter id (default 'tag<n>')")
        anchors: dict[str, str] = param({}, description="anchor number/name in the frames -> "
                                        "building anchor id (default 'anchor<n>')")
        bias: dict[str, AnchorBias] = param({}, description="bias model per anchor id "
                                            "('*' for every anchor without its own)")
        sigma: float = param(0.10, unit="m", gt=0, description="1-sigma of a line-of-sight "
                             "range (DW1000 TWR: about 0.1 m)")
        nlos_sigma: float = param(0.5, unit="m", gt=0, description="1-sigma of an "
                                  "NLOS-suspect range")
        nlos_power_gap: float = param(6.0, unit="dB", gt=0, description="total minus "
                                      "first-path power above which a range is NLOS-suspect")
        nlos_innovation: float | None = param(3.0, gt=0, description="a range longer than "
                                              "its link's smoothed track predicts by this "
                                              "many sigmas is NLOS-suspect (null: off)")
        range_accel: float = param(0.5, unit="m/s^2", gt=0, description="range acceleration "
                                   "the track allows (walking, turning)")
        min_range: float = param(0.0, unit="m", ge=0, description="ranges below this are dropped")
        max_range: float = param(150.0, unit="m", gt=0, description="ranges above this are dropped")
        max_speed: float = param(3.0, unit="m/s", gt=0, description="fastest a firefighter "
                                 "moves, bounding how fast a range can change")
        gate_sigmas: float = param(5.0, gt=0, description="outlier gate beyond the "
                                   "motion bound, in range sigmas")
        relock_after: int = param(3, ge=1, description="mutually consistent rejected ranges "
                                  "after which the link accepts them (re-locks)")
        silence_timeout: float = param(3.0, unit="s", gt=0, description="a link with no "
                                       "range for this long raises a uwb_silent warning")
        dbc: str | None = param(None, description="alternative DBC file for the CAN report "
                                "(default: the shipped uwb_twr.dbc)")

    @classmethod
    def tick_period(cls, params: Params) -> float:
        return min(1.0, params.silence_timeout / 2)

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        self.links: PerAgent[dict[str, _Link]] = PerAgent(lambda agent: {})
        self._seq: dict[str, int] = {}
        self._dbc = None if params.dbc is None else str(ctx.resolve(params.dbc))
        load_uwb_dbc(self._dbc)   # a bad DBC fails at construction, with its path

    def reset(self, agent: str) -> None:
        self.links.reset(agent)

    def handle(self, stream: str, msg) -> None:
        if isinstance(msg, Tick):
            self._check_silence(msg.t)
        elif isinstance(msg, RawFrame):
            self._raw(msg)
        elif isinstance(msg, Range):
            if msg.method not in ("uwb", ""):
                self.ctx.count("not_uwb")
                return
            self._measure(msg.t, msg.agent or msg.a, msg.b, msg.range_m, None, None,
                          nlos=msg.nlos, sigma=msg.sigma_m)

    # -- decoding ------------------------------------------------------------------
    def _raw(self, frame: RawFrame) -> None:
        try:
            if frame.transport == "can":
                if not isinstance(frame.channel, int):
                    raise FrameError("bad_frames", f"CAN channel {frame.channel!r} is not an id")
                rep = decode_uwb_can(frame.channel, frame.data, self._dbc)
            elif frame.transport in ("serial", "udp"):
                rep = decode_uwb_line(frame.data)
            else:
                rep = None
        except FrameError as exc:
            self.ctx.count(exc.code)
            self.ctx.log.debug("%s", exc)
            return
        if rep is None:
            self.ctx.count("other_frames")
            return
        agent = self.params.tags.get(rep.tag) or self._default_name("tag", rep.tag)
        anchor = self.params.anchors.get(rep.anchor) or self._default_name("anchor", rep.anchor)
        if rep.seq is not None:
            key = f"{frame.device}/{rep.tag}"
            last = self._seq.get(key)
            if last is not None:
                lost = (rep.seq - last - 1) % 256
                if lost < 128:            # a larger gap is a restart, not 128+ losses
                    self.ctx.count("lost_reports", lost)
            self._seq[key] = rep.seq
        if rep.range_m is None:
            self.ctx.count("ranging_failed")
            return
        nlos = (rep.rx_dbm is not None and rep.fp_dbm is not None
                and rep.rx_dbm - rep.fp_dbm > self.params.nlos_power_gap)
        self._measure(frame.t, agent, anchor, rep.range_m, rep.rx_dbm, rep.fp_dbm, nlos=nlos,
                      sigma=0.0)

    @staticmethod
    def _default_name(kind: str, ident: str) -> str:
        return f"{kind}{ident}" if ident.isdigit() else ident

    # -- conditioning -----------------------------------------------------------------
    def _measure(self, t: float, agent: str, anchor: str, raw: float, rx: float | None,
                 fp: float | None, *, nlos: bool, sigma: float) -> None:
        p = self.params
        if not (math.isfinite(raw) and math.isfinite(t)):
            self.ctx.count("non_finite")
            return
        model = p.bias.get(anchor) or p.bias.get("*")
        r = model.correct(raw, rx) if model is not None else raw
        if not p.min_range <= r <= p.max_range:
            self.ctx.count("out_of_range")
            return
        link = self.links[agent].setdefault(anchor, _Link())
        link.last_t = t
        if link.silent:
            link.silent = False
            self.ctx.diagnose(t, "info", "uwb_silent", f"UWB ranges from {anchor} to {agent} "
                              "are back", agent=agent, active=False)
        sig = max(sigma, p.nlos_sigma if nlos else p.sigma)
        if not self._gate(link, t, r, sig):
            self.ctx.count("outliers")
            return
        if link.track is None:
            link.track = _RangeTrack(t, r, sig, p.max_speed)
        else:
            nu, s_nu = link.track.innovation(t, r, sig, p.range_accel)
            if not nlos and p.nlos_innovation is not None and nu > p.nlos_innovation * s_nu:
                nlos, sig = True, max(sigma, p.nlos_sigma)
            link.track.update(r, sig)
        if nlos:
            self.ctx.count("nlos_suspect")
        self.ctx.publish("range", Range(t=t, agent=agent, device=f"{agent}/uwb", a=agent,
                                        b=anchor, range_m=r, sigma_m=sig, method="uwb",
                                        nlos=nlos))

    def _gate(self, link: _Link, t: float, r: float, sigma: float) -> bool:
        """Motion-bounded outlier test; re-locks after consistent rejects."""
        p = self.params

        def fits(t0: float, r0: float) -> bool:
            return abs(r - r0) <= p.max_speed * abs(t - t0) + p.gate_sigmas * sigma * math.sqrt(2)

        if link.accepted is None or fits(*link.accepted):
            link.accepted, link.rejects = (t, r), []
            return True
        if link.rejects and not fits(*link.rejects[-1]):
            link.rejects = []
        link.rejects.append((t, r))
        if len(link.rejects) >= p.relock_after:
            self.ctx.count("relocks")
            link.accepted, link.rejects, link.track = (t, r), [], None
            return True
        return False

    def _check_silence(self, now: float) -> None:
        for agent, links in self.links.items():
            for anchor, link in sorted(links.items()):
                if (not link.silent and link.last_t is not None
                        and now - link.last_t > self.params.silence_timeout):
                    link.silent = True
                    self.ctx.count("silences")
                    self.ctx.diagnose(now, "warning", "uwb_silent",
                                      f"no UWB range from {anchor} to {agent} for "
                                      f"{now - link.last_t:.1f} s", agent=agent)


PLUGINS = [UwbSensor]
