"""The ``zupt_ins`` estimator: foot-IMU ImuBlocks in, step odometry and poses out.

A thin wrapper around :class:`~.engine.InsEngine` (the array core): it keeps one engine
per IMU device and turns the engine's events and full-rate states into messages. All
numerics live in the engine, so a recording gives the same output whatever its block
sizes.

Input contract: the blocks of a sensor plugin (``foot_imu``), which has screened the
samples already: FLU axes, SI units, finite values, sample times strictly increasing
per device. A block that breaks the contract is counted, reported (at most once per
``REPORT_INTERVAL`` of data time per device and problem) and skipped whole: its samples
are not screened a second time here.

Ports: ``odometry`` (:class:`Odometry` per step or rest period, INS frame), ``pose``
(:class:`PoseEstimate` at the same instants, building frame with a ``start`` of mode
``pose``), ``state`` (full-rate :class:`PoseEstimate` at ``outputs.state_rate`` Hz, off by
default) and ``diagnostics`` (alignment, IMU mounting yaw, gaps, rejected input). The
poses' covariance is the filter's plus the errors it does not model
(:mod:`.pose_uncertainty`); their protection radius comes from it and ``trusted`` from
the radius (``integrity``: :mod:`firenav_framework.integrity`).
"""
from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field

import numpy as np

from firenav_framework import Estimator, ImuBlock, Odometry, PerAgent, PoseEstimate
from firenav_framework.geometry import planar_rotation, wrap_angle
from firenav_framework.integrity import gaussian_protection_radius, trusted
from firenav_framework.messages import IMU_FLAG_BITS, Message

from . import eskf
from .clipping import ClipLog
from .engine import BlockResult, InsEngine
from .params import ZuptInsParams
from .pose_uncertainty import PoseUncertainty
from .retro import correct_positions
from .steps import Step, StepTracker

__all__ = ["ZuptInsEstimator"]

#: Sample intervals used to measure the IMU rate when ``imu.sample_rate`` is not set.
RATE_SAMPLES = 50
#: Longest swing kept back for the retrospective correction of the state output [s].
MAX_SWING = 10.0
#: Change of the mounting yaw estimate [rad] that is reported again.
YAW_REPORT_STEP = math.radians(5.0)
#: A recurring input problem of one device is reported at most once per this much data time [s].
REPORT_INTERVAL = 10.0
#: A heading that turns faster than this [rad/s] while the foot lies still gets the
#: ``ins_gyro_uncalibrated`` warning: ten times an industrial MEMS gyro's bias
#: instability, 6 deg a minute of heading.
UNCALIBRATED_YAW_RATE = math.radians(0.1)
#: Still periods at least this long [s] show the gyro bias (shorter ones are stances of a
#: walk, whose foot may still pivot) ...
BIAS_STILL_PERIOD = 1.0
#: ... and the warning needs this much still time in them [s], and this share of the
#: periods turning the same way (a bias always turns one way; pivoting feet both ways).
BIAS_EVIDENCE = 5.0
BIAS_SAME_SIGN = 0.75


@dataclass
class _Device:
    """Everything kept for one IMU device between blocks."""

    device: str
    steps: StepTracker
    uncertainty: PoseUncertainty
    pending: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    engine: InsEngine | None = None
    last_t: float = -math.inf
    aligned: bool = False
    gaps: int = 0
    zaru_rejected: int = 0
    tail: np.ndarray = field(default_factory=lambda: np.zeros((0, eskf.N_OUT)))
    state_slot: float = -math.inf
    yaw_reported: float | None = None
    still: tuple[float, float] | None = None      # (t, yaw) where the current still run began
    still_runs: list[tuple[float, float]] = field(default_factory=list)  # (duration, dyaw)
    # (step time, unmodelled pose covariance from then on) of the steps the state output
    # may still need; the oldest entry is at or before the next state row
    unmodelled: list[tuple[float, np.ndarray]] = field(default_factory=list)
    bias_judged: bool = False
    clips: ClipLog = field(default_factory=ClipLog)   # saturated samples, until their step

    @property
    def n_pending(self) -> int:
        return sum(len(p[0]) for p in self.pending)


@dataclass(frozen=True)
class _Placement:
    """The INS frame of one firefighter in the output frame: origin, rotation, frame name."""

    origin: np.ndarray
    heading: float
    frame: str

    def apply(self, position: np.ndarray, heading: float, cov: np.ndarray
              ) -> tuple[np.ndarray, float, np.ndarray]:
        rot = planar_rotation(self.heading, 4)
        return (self.origin + rot[:3, :3] @ position, wrap_angle(self.heading + heading),
                rot @ cov @ rot.T)


class ZuptInsEstimator(Estimator):
    """ZUPT-aided strapdown INS (error-state Kalman filter) for foot-mounted IMUs."""

    name = "zupt_ins"
    inputs = (ImuBlock,)
    outputs = {"odometry": Odometry, "pose": PoseEstimate, "state": PoseEstimate}
    Params = ZuptInsParams
    agents_independent = True   # all state per firefighter: may run on worker threads

    def __init__(self, params: ZuptInsParams, ctx):
        super().__init__(params, ctx)
        self.state: PerAgent[dict[str, _Device]] = PerAgent(lambda agent: {})
        self._placements: dict[str, _Placement] = {}

    # -- input ---------------------------------------------------------------------------
    def handle(self, stream: str, msg: Message) -> None:
        if not isinstance(msg, ImuBlock):
            self.ctx.count("ignored_messages")
            return
        dev = self._device(msg.agent, msg.device)
        if not self._meets_contract(dev, msg):
            return
        t = np.asarray(msg.time, float)
        acc = np.asarray(msg.accel, float)
        gyro = np.asarray(msg.gyro, float)
        dev.last_t = float(t[-1])
        dev.clips.add(t, None if msg.flags is None
                      else (np.asarray(msg.flags) & IMU_FLAG_BITS["saturated"]) > 0)
        if dev.engine is None:
            dev.pending.append((t, acc, gyro))
            if self.params.imu.sample_rate is None and dev.n_pending <= RATE_SAMPLES:
                return
            t, acc, gyro = (np.concatenate(a) for a in zip(*dev.pending))
            dev.pending.clear()
            dev.engine = self._new_engine(t, msg)
        self._publish(msg.agent, dev, dev.engine.process(t, acc, gyro))

    def _meets_contract(self, dev: _Device, msg: ImuBlock) -> bool:
        """Whether a block is what a sensor plugin publishes (FLU, finite, samples later
        than the device's previous ones and increasing); a block that is not is counted,
        reported and skipped: the filter must never integrate it."""
        if msg.frame != "FLU":
            problem = ("not_flu", "error", "imu_not_flu",
                       f"block(s) in frame '{msg.frame}', not FLU, skipped (put a foot_imu "
                       "sensor with the right `axes` before zupt_ins)")
        elif not (np.isfinite(msg.time).all() and np.isfinite(msg.accel).all()
                  and np.isfinite(msg.gyro).all()):
            problem = ("nonfinite", "warning", "imu_nonfinite",
                       "block(s) with NaN/inf samples skipped (a sensor plugin drops those)")
        elif not (msg.time[0] > dev.last_t and np.all(np.diff(msg.time) > 0)):
            problem = ("time_order", "warning", "imu_time_backwards",
                       "block(s) with samples not later than the previous ones skipped")
        else:
            return True
        what, level, code, text = problem
        self.ctx.count(f"rejected_blocks_{what}")
        self.ctx.report(msg.t, code, text, agent=msg.agent, key=msg.device, level=level,
                        every=REPORT_INTERVAL)
        return False

    def _device(self, agent: str, device: str) -> _Device:
        devices = self.state[agent]
        dev = devices.get(device)
        if dev is None:
            errors = self.params.odometry.errors()
            dev = devices[device] = _Device(
                device, StepTracker(self.params.gait.thresholds(), errors),
                self.params.integrity.uncertainty(errors))
        return dev

    def _new_engine(self, t: np.ndarray, msg: ImuBlock) -> InsEngine:
        rate = self.params.imu.sample_rate
        if rate is None:
            dt = float(np.median(np.diff(t[:RATE_SAMPLES + 1])))
            rate = 1.0 / dt
            self.ctx.diagnose(msg.t, "info", "imu_rate", f"{msg.device}: IMU rate "
                              f"{rate:.1f} Hz (median of the first {RATE_SAMPLES} intervals)",
                              agent=msg.agent)
        return InsEngine(self.params.detector_config(rate), self.params.filter_config(rate))

    # -- output --------------------------------------------------------------------------
    def finish(self) -> None:
        for agent, devices in self.state.items():
            for dev in devices.values():
                if dev.engine is None and dev.pending:
                    t, acc, gyro = (np.concatenate(a) for a in zip(*dev.pending))
                    dev.pending.clear()
                    dummy = ImuBlock.from_arrays(t, acc, gyro, agent=agent, device=dev.device)
                    dev.engine = self._new_engine(t, dummy) if len(t) > 1 else None
                    if dev.engine is not None:
                        self._publish(agent, dev, dev.engine.process(t, acc, gyro))
                if dev.engine is not None:
                    self._publish(agent, dev, dev.engine.finish(), final=True)

    def reset(self, agent: str) -> None:
        self.state.reset(agent)

    def _publish(self, agent: str, dev: _Device, res: BlockResult, final: bool = False) -> None:
        eng = dev.engine
        assert eng is not None
        if not dev.aligned and eng.aligned:
            dev.aligned = True
            self._report_alignment(agent, dev, res)
        if eng.gaps > dev.gaps:
            self.ctx.count("gaps", eng.gaps - dev.gaps)
            t = float(res.states[-1, eskf.O_T]) if len(res.states) else dev.last_t
            self.ctx.diagnose(t, "warning", "imu_gap", f"{dev.device}: {eng.gaps - dev.gaps} "
                              f"sample interval(s) longer than {self.params.filter.max_gap} s were "
                              "integrated as that long", agent=agent)
            dev.gaps = eng.gaps
        if eng.zaru_rejected > dev.zaru_rejected:
            self.ctx.count("zaru_rejected", eng.zaru_rejected - dev.zaru_rejected)
            dev.zaru_rejected = eng.zaru_rejected
        for ev in res.events:
            step = dev.steps.step(ev)
            self._publish_step(agent, dev, step)
        if not dev.bias_judged:
            self._judge_gyro_bias(agent, dev, res.states)
        if self.params.outputs.state_rate > 0:
            self._publish_states(agent, dev, res, final)

    def _report_alignment(self, agent: str, dev: _Device, res: BlockResult) -> None:
        aligned = np.flatnonzero(res.states[:, eskf.O_ALIGNED] > 0)
        t = float(res.states[aligned[0], eskf.O_T]) if len(aligned) else dev.last_t
        q = res.states[aligned[0], eskf.O_Q:eskf.O_Q + 4] if len(aligned) else dev.engine.nominal[6:10]
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, 1 - 2 * (q[1] ** 2 + q[2] ** 2)))))
        used = dev.engine.alignment_samples / dev.engine.filter.align_samples
        align = self.params.alignment
        short = used < 1.0
        self.ctx.diagnose(
            t, "warning" if short else "info", "ins_aligned",
            f"{dev.device}: aligned from gravity (foot tilt {tilt:.0f} deg)"
            + (f" on a still period of {used * align.duration:.2f} s, shorter "
               f"than alignment.duration {align.duration:g} s"
               if short else "") + "; navigation started", agent=agent)

    def _judge_gyro_bias(self, agent: str, dev: _Device, states: np.ndarray) -> None:
        """Warn once when the heading turns while the foot lies still.

        Without bias states (and ZARU) nothing corrects the heading at rest, so the yaw
        change over a still period is the gyro bias about the vertical. Periods of at
        least ``BIAS_STILL_PERIOD`` count; after ``BIAS_EVIDENCE`` s of them the bias is
        judged: a warning if their mean turn rate exceeds ``UNCALIBRATED_YAW_RATE`` and
        most of them turn the same way, else it is left alone for good.
        """
        rows = states[states[:, eskf.O_ALIGNED] > 0]
        if not len(rows):
            return
        still = rows[:, eskf.O_ZV] > 0
        t, yaw = rows[:, eskf.O_T], rows[:, eskf.O_YAW]
        edges = np.flatnonzero(np.diff(still.astype(np.int8))) + 1
        for a, b in zip(np.concatenate(([0], edges)), np.concatenate((edges, [len(rows)]))):
            if still[a]:
                if dev.still is None:
                    dev.still = (float(t[a]), float(yaw[a]))
                if b == len(rows):
                    continue            # the run goes on in the next block
                t0, yaw0 = dev.still
                if t[b - 1] - t0 >= BIAS_STILL_PERIOD:
                    dev.still_runs.append((float(t[b - 1] - t0), wrap_angle(float(yaw[b - 1]) - yaw0)))
            dev.still = None
        total = sum(d for d, _ in dev.still_runs)
        if total < BIAS_EVIDENCE:
            return
        dev.bias_judged = True
        rate = sum(dy for _, dy in dev.still_runs) / total
        same = sum(1 for _, dy in dev.still_runs if dy * rate > 0) / len(dev.still_runs)
        if abs(rate) <= UNCALIBRATED_YAW_RATE or same < BIAS_SAME_SIGN or self.params.zaru.enabled:
            return
        self.ctx.count("uncalibrated_gyro")
        dps = math.degrees(abs(rate))
        self.ctx.diagnose(
            float(t[-1]), "warning", "ins_gyro_uncalibrated",
            f"{dev.device}: while the foot lay still ({total:.0f} s in "
            f"{len(dev.still_runs)} still periods) the heading turned by {dps:.2f} deg/s, "
            f"the same way in {100 * same:.0f} % of them: an uncalibrated gyro, which turns "
            f"the track by about {dps * 60:.0f} deg a minute. Give the sensor the device's "
            "calibration (foot_imu `calibration`), or estimate the bias at rest (zupt_ins "
            "`filter: {bias_states: true}, zaru: {enabled: true}`)", agent=agent)

    def placement(self, agent: str) -> _Placement:
        """Where ``agent``'s INS frame lies in the output frame (``start``)."""
        placed = self._placements.get(agent)
        if placed is None:
            start = self.params.start
            if start.mode == "pose":
                position, heading = start.pose_of(agent)
                placed = _Placement(np.asarray(position or (0.0, 0.0, 0.0), float),
                                    heading or 0.0, "building")
            else:
                placed = _Placement(np.zeros(3), 0.0, "odometry")
            self._placements[agent] = placed
        return placed

    def _publish_step(self, agent: str, dev: _Device, step: Step) -> None:
        self.ctx.publish("odometry", Odometry(
            t=step.t, agent=agent, device=dev.device, t_start=step.t_start, delta=step.delta,
            dheading=step.dheading, cov=step.cov, position=step.position,
            heading=step.heading, motion=step.motion,
            yaw_drift_rate_sigma=dev.steps.unmodelled.yaw_drift_rate_sigma))
        placed = self.placement(agent)
        pos, heading, cov = placed.apply(step.position, step.heading, dev.uncertainty.step(
            step, dev.clips.share(step.t_start, step.t)))
        if self.params.outputs.state_rate > 0:
            dev.unmodelled.append((step.t, dev.uncertainty.last))
        self.ctx.publish("pose", self._pose(step.t, agent, dev.device, pos, heading, cov,
                                            placed.frame))
        yaw = dev.steps.mount_yaw
        if yaw is not None and (dev.yaw_reported is None
                                or abs(wrap_angle(yaw - dev.yaw_reported)) > YAW_REPORT_STEP):
            dev.yaw_reported = yaw
            self.ctx.diagnose(step.t, "info", "imu_mount_yaw",
                              f"{dev.device}: walking direction is {math.degrees(yaw):+.1f} deg "
                              f"from the IMU x axis (from {dev.steps.mount_yaw_steps} steps)",
                              agent=agent)

    def _publish_states(self, agent: str, dev: _Device, res: BlockResult, final: bool) -> None:
        rows = np.concatenate((dev.tail, res.states)) if len(dev.tail) else res.states
        if self.params.outputs.retrospective_correction and len(rows):
            rows = rows.copy()
            t = rows[:, eskf.O_T]
            rows[:, eskf.O_POS:eskf.O_POS + 3] = correct_positions(
                t, rows[:, eskf.O_POS:eskf.O_POS + 3], res.events)
            done = len(rows) if final else _settled(t, rows[:, eskf.O_ZV] > 0, res.events)
            done = max(done, int(np.searchsorted(t, t[-1] - MAX_SWING)))
        else:
            done = len(rows)
        out, dev.tail = rows[:done], rows[done:]
        out = out[out[:, eskf.O_ALIGNED] > 0]
        if not len(out):
            return
        slots = np.floor(out[:, eskf.O_T] * self.params.outputs.state_rate)
        placed = self.placement(agent)
        first = np.flatnonzero(np.diff(np.concatenate(([dev.state_slot], slots))) > 0)
        dev.state_slot = float(slots[-1])
        iu = np.triu_indices(4)
        # a step's event comes with the state row of its instant (the filter emits both),
        # so every step at or before a row is known here, whatever the block sizes
        step_t = [t for t, _ in dev.unmodelled]
        for row in out[first]:
            cov = np.zeros((4, 4))
            cov[iu] = row[eskf.O_COV:eskf.O_COV + 10]
            k = bisect_right(step_t, float(row[eskf.O_T])) - 1
            cov = cov + cov.T - np.diag(np.diag(cov)) + (
                dev.unmodelled[k][1] if k >= 0 else dev.uncertainty.floor)
            pos, heading, cov = placed.apply(row[eskf.O_POS:eskf.O_POS + 3],
                                             float(row[eskf.O_YAW]), cov)
            self.ctx.publish("state", self._pose(float(row[eskf.O_T]), agent, dev.device,
                                                 pos, heading, cov, placed.frame))
        keep = bisect_right(step_t, float(out[-1, eskf.O_T])) - 1
        del dev.unmodelled[:max(keep, 0)]

    def _pose(self, t: float, agent: str, device: str, position: np.ndarray, heading: float,
              cov: np.ndarray, frame: str) -> PoseEstimate:
        """A pose with its protection radius and the trusted flag derived from it."""
        integrity = self.params.integrity
        radius = gaussian_protection_radius(cov[:2, :2], integrity.containment)
        return PoseEstimate(t=t, agent=agent, device=device, position=position,
                            heading=heading, cov=cov, frame=frame, protection_radius=radius,
                            trusted=trusted(radius, integrity))


def _settled(t: np.ndarray, still: np.ndarray, events: np.ndarray) -> int:
    """Rows of the full-rate output that no later event changes: up to the end of the
    still run holding the newest event (a swing waits for the step that ends it)."""
    if not len(events):
        return 0
    i = int(np.searchsorted(t, events[:, eskf.E_T].max()))
    if i >= len(t):
        return len(t)
    after = np.flatnonzero(~still[i:])
    return i + int(after[0]) if len(after) else len(t)
