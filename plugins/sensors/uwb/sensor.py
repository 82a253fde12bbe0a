"""The ``uwb`` sensor class: reports and ranges in, clean :class:`Range` messages out."""
from __future__ import annotations

import math

from firenav_framework import PerAgent, Range, RawFrame, Sensor, Tick
from firenav_framework.codecs import FrameError
from firenav_framework.codecs.selection import TransportCodecs
from firenav_framework.codecs.twr_report import TwrReport
from firenav_framework.contract import Context

from .link import Link, RangeTrack
from .params import UwbParams

__all__ = ["UwbSensor"]


class UwbSensor(Sensor):
    """UWB two-way ranging: decodes DW1000-style reports, calibrates bias, flags NLOS, drops outliers."""

    name = "uwb"
    inputs = (Range, RawFrame)
    outputs = {"range": Range}

    Params = UwbParams

    @classmethod
    def tick_period(cls, params: UwbParams) -> float:
        return min(1.0, params.silence_timeout / 2)

    def __init__(self, params: UwbParams, ctx: Context):
        super().__init__(params, ctx)
        self.links: PerAgent[dict[str, Link]] = PerAgent(lambda agent: {})
        self._seq: dict[str, int] = {}
        # a bad DBC or other codec option fails here, at construction, with its path
        self._codecs = TransportCodecs(params.frames, count=ctx.count, resolve=ctx.resolve)

    def reset(self, agent: str) -> None:
        self.links.reset(agent)

    def handle(self, stream: str, msg: Range | RawFrame | Tick) -> None:
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
            reports = self._codecs.decode(frame, no_codec="other_frames", other="other_frames")
        except FrameError as exc:
            self.ctx.count(exc.code)
            self.ctx.report(frame.t, f"uwb_{exc.code}", f"UWB reports that could not be "
                            f"decoded skipped; latest: {exc}", key=frame.device or "uwb link")
            return
        for rep in reports or ():
            self._report(frame, rep)

    def _report(self, frame: RawFrame, rep: TwrReport) -> None:
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
                and rep.rx_dbm - rep.fp_dbm > self.params.nlos.power_gap)
        self._measure(rep.t, agent, anchor, rep.range_m, rep.rx_dbm, rep.fp_dbm, nlos=nlos,
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
        if not p.gate.min_range <= r <= p.gate.max_range:
            self.ctx.count("out_of_range")
            return
        link = self.links[agent].setdefault(anchor, Link())
        if link.last_t is not None and t < link.last_t:
            # the link's range track filters forward in time: an older range cannot join it
            self.ctx.count("out_of_order")
            self.ctx.warn_once(t, "uwb_out_of_order", f"UWB range {anchor}-{agent} at t="
                               f"{t:.3f} s is older than the link's last ({link.last_t:.3f} "
                               "s): dropped (counted as out_of_order)", agent=agent, key=anchor)
            return
        link.last_t = t
        if link.silent:
            link.silent = False
            self.ctx.diagnose(t, "info", "uwb_silent", f"UWB ranges from {anchor} to {agent} "
                              "are back", agent=agent, active=False)
        sig = max(sigma, p.nlos.sigma if nlos else p.sigma)
        verdict = link.gate(t, r, sig, p.gate)
        if verdict == "rejected":
            self.ctx.count("outliers")
            return
        if verdict == "relocked":
            self.ctx.count("relocks")
        if link.track is None:
            link.track = RangeTrack(t, r, sig, p.gate.max_speed)
        else:
            nu, s_nu = link.track.innovation(t, r, sig, p.nlos.range_accel)
            if not nlos and p.nlos.innovation is not None and nu > p.nlos.innovation * s_nu:
                nlos, sig = True, max(sigma, p.nlos.sigma)
            link.track.update(r, sig)
        if nlos:
            self.ctx.count("nlos_suspect")
        self.ctx.publish("range", Range(t=t, agent=agent, device=f"{agent}/uwb", a=agent,
                                        b=anchor, range_m=r, sigma_m=sig, method="uwb",
                                        nlos=nlos))

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

