"""The ``foot_imu`` sensor class: inputs in, FLU blocks and reports out (see the package)."""
from __future__ import annotations

import numpy as np

from firenav_framework.codecs import Codec
from firenav_framework.codecs.imu_sample import ImuSamples
from firenav_framework.codecs.selection import TransportCodecs
from firenav_framework.contract import Context, Sensor
from firenav_framework.messages import ImuBlock, RawFrame

from .calibration import CalibrationFile, LinearCorrection, axes_matrix, load_calibration
from .params import FootImuParams
from .problems import frame_problem, screening_problems
from .routing import DeviceRoutes
from .samples import FrameBatch, Samples
from .screening import Screening
from .streams import DeviceStream

__all__ = ["FootImuSensor", "DEGRADED_BLOCKS"]

#: How many times longer frame batches are in the cheaper mode of :meth:`FootImuSensor.degrade`.
DEGRADED_BLOCKS = 4


class FootImuSensor(Sensor):
    """Decode, screen, calibrate and rotate foot-IMU data to FLU ImuBlocks."""

    name = "foot_imu"
    inputs = (ImuBlock, RawFrame)
    outputs = {"imu": ImuBlock}
    Params = FootImuParams

    def __init__(self, params: FootImuParams, ctx: Context):
        super().__init__(params, ctx)
        self._R = axes_matrix(params.axes)
        self._scales = params.units.scales()
        self._calibration: CalibrationFile | None = None
        if params.calibration:
            self._calibration = load_calibration(ctx.resolve(params.calibration))
        self._codecs = TransportCodecs(params.frames, count=self._codec_count,
                                       resolve=ctx.resolve)
        self._streams: dict[tuple[str, str], DeviceStream] = {}
        self._batches: dict[tuple[str, str], FrameBatch] = {}  # (transport, link device)
        self._routes = DeviceRoutes(params.frames, ctx, self._stream)
        self._t = 0.0  # newest input time, for reports without one of their own

    # -- inputs ---------------------------------------------------------------------
    def handle(self, stream: str, msg: ImuBlock | RawFrame) -> None:
        self._t = msg.t if np.isfinite(msg.t) else self._t
        if isinstance(msg, ImuBlock):
            self._block(msg)
        elif isinstance(msg, RawFrame):
            self._frame(msg)

    def _block(self, msg: ImuBlock) -> None:
        if msg.frame == "FLU" and not np.array_equal(self._R, np.eye(3)):
            self.ctx.warn_once(msg.t, "imu_already_flu", f"{msg.device}: input is already "
                               f"FLU but `axes` {self.params.axes} rotates it again",
                               agent=msg.agent)
        stream = self._stream(msg.agent, msg.device, msg.device)
        sa, sg, sm = self._scales
        accel = msg.accel * sa if sa != 1 else msg.accel
        gyro = msg.gyro * sg if sg != 1 else msg.gyro
        mag = None if msg.mag is None else (msg.mag * sm if sm != 1 else msg.mag)
        flags = (np.zeros(len(msg), np.uint8) if msg.flags is None
                 else np.asarray(msg.flags, np.uint8))
        self._condition(stream, msg.t, Samples(np.asarray(msg.time, float), accel, gyro, mag,
                                               flags))

    def _frame(self, frame: RawFrame) -> None:
        codec = self._codecs.get(frame.transport)
        if codec is None:
            self.ctx.count("frames_ignored")
            return
        key = (frame.transport, frame.device)
        batch = self._batches.get(key)
        if batch is None:
            batch = self._batches[key] = FrameBatch(self.params.frames.block_s)
        done = batch.add(frame)
        if done is not None:
            self._decode(codec, done, batch)

    def _decode(self, codec: Codec, frames: list[RawFrame], batch: FrameBatch | None = None,
                skip_agent: str | None = None) -> None:
        """Decode one link device's batch of frames and condition each device's samples
        (except those of ``skip_agent``, being reset)."""
        decoded = codec.decode_batch(frames)
        if decoded.ignored:
            self.ctx.count("frames_ignored", decoded.ignored)
        for i, exc in decoded.problems:
            frame = frames[i]
            frame_problem(self.ctx, frame.t, exc.code, f"latest: {exc}",
                          key=frame.device or frame.transport, every=self.params.report_interval)
        records = ImuSamples.from_records(decoded.records)
        if not len(records):
            return
        origin = np.asarray(decoded.origin, np.int64)
        frame_t = np.array([f.t for f in frames], float)[origin]
        agent = frames[0].agent
        devices = dict.fromkeys(records.device)
        for device in devices:
            mine, t_frame = records, frame_t
            if len(devices) > 1:
                of_device = np.array([d == device for d in records.device])
                mine, t_frame = records.take(of_device), frame_t[of_device]
            stream, clock = self._routes.route(device, agent, self._t)
            if stream.agent == skip_agent:
                continue
            if batch is not None:
                batch.agents.add(stream.agent)
            t = np.empty(len(mine))
            for k, (t_dev, t_fr) in enumerate(zip(mine.t.tolist(), t_frame.tolist())):
                t[k], resynced = clock.to_pipeline(t_dev, t_fr)
                if resynced:
                    frame_problem(self.ctx, self._t, "clock_resyncs", agent=stream.agent,
                                  key=stream.device, every=self.params.report_interval)
            samples = Samples(t, mine.accel, mine.gyro, mine.mag, mine.flags)
            self._condition(stream, _newest(samples, self._t), samples)

    def _codec_count(self, what: str, n: int) -> None:
        """What a codec counts that is no single frame's fault (incomplete samples)."""
        frame_problem(self.ctx, self._t, what, n=n, every=self.params.report_interval)

    def finish(self) -> None:
        for (transport, _), batch in list(self._batches.items()):
            done = batch.take()
            if done is not None:
                self._decode(self._codecs.get(transport), done)
        self._codecs.finish()
        for stream in list(self._streams.values()):
            if stream.held is not None:
                held, stream.held = stream.held, None
                self._condition(stream, self._t, held, final=True)
        self.ctx.flush_reports()

    def degrade(self, agent: str, level: int) -> str | None:
        """Backpressure (``firenav_framework.execution``): at level 1 the frames of
        ``agent``'s link devices are decoded in batches :data:`DEGRADED_BLOCKS` times
        longer (fewer, longer blocks: less work per sample, later poses); level 0
        restores ``frames.block_s``. A link device shared with others (a CAN bus) is
        coarsened for all of them."""
        block_s = self.params.frames.block_s * (DEGRADED_BLOCKS if level else 1)
        changed = [b for b in self._batches.values() if agent in b.agents]
        for batch in changed:
            batch.block_s = block_s
        if not changed:
            return None
        return f"frames decoded in blocks of {block_s:g} s"

    def reset(self, agent: str) -> None:
        for (transport, _), batch in list(self._batches.items()):
            done = batch.take()   # a link (a CAN bus) may carry other firefighters too
            if done is not None:
                self._decode(self._codecs.get(transport), done, skip_agent=agent)
        self._streams = {k: s for k, s in self._streams.items() if s.agent != agent}
        self._routes.reset(agent)

    # -- streams --------------------------------------------------------------------
    def _stream(self, agent: str, device: str, raw_id: str) -> DeviceStream:
        """The output stream of (agent, device), made on first use with the calibration
        of ``raw_id`` or ``device``."""
        stream = self._streams.get((agent, device))
        if stream is not None:
            return stream
        cal = None
        if self._calibration is not None:
            cal = self._calibration.for_device(raw_id, device)
            if cal is None:
                self.ctx.warn_once(self._t, "imu_uncalibrated", f"{device}: no entry in "
                                   f"{self.params.calibration} and no default: used "
                                   "uncalibrated", agent=agent, key=device, level="info")
        stream = DeviceStream(agent=agent, device=device,
                              accel=LinearCorrection.build(self._R, cal.accel if cal else None),
                              gyro=LinearCorrection.build(self._R, cal.gyro if cal else None),
                              mag=LinearCorrection.build(self._R, cal.mag if cal else None),
                              axes=tuple(self.params.axes))
        self._streams[(agent, device)] = stream
        return stream

    def _condition(self, stream: DeviceStream, t_msg: float, samples: Samples,
                   final: bool = False) -> None:
        """Screen, correct and publish one stream's samples; report what screening found."""
        result, block = stream.condition(samples, self.params.screening, final)
        if result is not None:
            self._report(stream, t_msg, result)
        if block is None:
            return
        self.ctx.publish("imu", block)
        if not stream.rest.done:
            for code, text in stream.rest.feed(block):
                self.ctx.diagnose(block.t, "warning", code, text, agent=stream.agent)

    def _report(self, stream: DeviceStream, t: float, result: Screening) -> None:
        for key, what, n, text in screening_problems(result):
            self.ctx.count(what, n)
            if text is not None:
                self.ctx.report(t, f"imu_{key}", text, n=n, agent=stream.agent,
                                key=stream.device, every=self.params.report_interval,
                                worst=result.longest_gap if key == "gaps" else 0.0)


def _newest(samples: Samples, default: float) -> float:
    """The newest finite sample time of ``samples`` [s], else ``default``."""
    finite = samples.time[np.isfinite(samples.time)]
    return float(finite.max()) if finite.size else default
