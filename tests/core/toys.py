"""Small plugins for testing the core: a scripted source, a live source, a dead-reckoner."""
from __future__ import annotations

import threading
import time

import numpy as np

from firenav_framework import (Diagnostic, Estimator, GroundTruth, Odometry, Params,
                               PerAgent, PoseEstimate, Sink, Source, Tick, param)
from firenav_framework.messages import Message
from firenav_framework.registry import Registry, load_registry


def step(t: float, agent: str, dx: float = 1.0, device: str = "") -> Odometry:
    return Odometry(t=t, agent=agent, device=device or f"{agent}/imu", t_start=t - 1.0,
                    delta=np.array([dx, 0.0, 0.0]), dheading=0.0, cov=np.eye(4) * 0.01,
                    position=np.zeros(3), heading=0.0)


class ScriptSource(Source):
    """Replays a list of odometry steps given as (t, agent, dx) triples."""

    name = "script"
    outputs = {"odo": Odometry, "truth": GroundTruth}
    input_param = "path"

    class Params(Params):
        steps: list[tuple[float, str, float]] = param([])
        """(t, agent, dx) rows"""
        path: str = param("")
        """unused file path, for --input tests"""
        truth_frame: str = param("building")
        """frame named by the truth messages"""

    def messages(self):
        for t, agent, dx in self.params.steps:
            yield "odo", step(t, agent, dx)
            yield "truth", GroundTruth(t=t, agent=agent, position=np.array([t, 0.0, 0.0]),
                                       frame=self.params.truth_frame)


class LiveSource(Source):
    """Emits steps from a thread with small wall-clock delays, like a live link."""

    name = "live_script"
    outputs = {"odo": Odometry}
    live = True

    class Params(Params):
        steps: list[tuple[float, str, float]] = param([])
        """(t, agent, dx) rows"""
        delay: float = param(0.001, unit="s")
        """pause between messages"""

    def messages(self):
        self._stop = threading.Event()
        for t, agent, dx in self.params.steps:
            if self._stop.is_set():
                return
            time.sleep(self.params.delay)
            yield "odo", step(t, agent, dx)

    def stop(self) -> None:
        getattr(self, "_stop", threading.Event()).set()


class Integrate(Estimator):
    """Sums odometry increments into a pose; optionally raises for one agent at one time."""

    name = "integrate"
    inputs = (Odometry,)
    outputs = {"pose": PoseEstimate}

    class Params(Params):
        fail_agent: str = param("")
        """agent whose step at fail_t raises"""
        fail_t: float = param(-1.0, unit="s")
        """time of the failing step"""
        gain: float = param(1.0, gt=0)
        """scale of each increment"""
        frame: str = param("building")
        """frame its poses are in"""

    def __init__(self, params, ctx):
        super().__init__(params, ctx)
        self.pos = PerAgent(lambda agent: np.zeros(3))
        self.resets: list[str] = []

    def handle(self, stream: str, msg: Odometry) -> None:
        if msg.agent == self.params.fail_agent and msg.t == self.params.fail_t:
            raise ValueError("scripted failure")
        self.pos[msg.agent] = self.pos[msg.agent] + self.params.gain * msg.delta
        self.ctx.publish("pose", PoseEstimate(t=msg.t, agent=msg.agent,
                                              position=self.pos[msg.agent], heading=0.0,
                                              cov=np.eye(4) * 0.1, frame=self.params.frame))

    def reset(self, agent: str) -> None:
        self.resets.append(agent)
        self.pos.reset(agent)


class Collect(Sink):
    """Keeps every message it receives (stream, message) in order."""

    name = "collect"
    inputs = (Message,)

    class Params(Params):
        pass

    def start(self) -> None:
        self.got: list[tuple[str, Message]] = []

    def handle(self, stream: str, msg: Message) -> None:
        self.got.append((stream, msg))


class TickCounter(Sink):
    """Records the times of the ticks it gets every `period` seconds."""

    name = "tick_counter"
    inputs = (Diagnostic,)

    class Params(Params):
        period: float = param(1.0, unit="s", gt=0)
        """tick period"""

    @classmethod
    def tick_period(cls, params) -> float:
        return params.period

    def start(self) -> None:
        self.ticks: list[float] = []

    def handle(self, stream: str, msg: Message) -> None:
        if isinstance(msg, Tick):
            self.ticks.append(msg.t)


TOYS = [ScriptSource, LiveSource, Integrate, Collect, TickCounter]


def toy_registry() -> Registry:
    """The installed plugins plus the toys."""
    reg = load_registry()
    for cls in TOYS:
        reg.add(cls, package="toys")
    return reg


class FlakySource(ScriptSource):
    """Like `script`, but raises after `fail_after` messages (a device driver crashing)."""

    name = "flaky_script"

    class Params(ScriptSource.Params):
        fail_after: int = param(3, ge=0)
        """messages before the failure"""

    def messages(self):
        for i, item in enumerate(super().messages()):
            if i == self.params.fail_after:
                raise OSError("device vanished")
            yield item

    def duration(self):
        return (1.0, 10.0)


TOYS.append(FlakySource)
