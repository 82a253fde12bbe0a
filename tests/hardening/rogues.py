"""Plugins that misbehave on purpose, for the isolation tests (registered by the tests,
never installed)."""
from __future__ import annotations

import re
import sys
import time
from pathlib import Path
from typing import Literal

import numpy as np

from firenav_framework import Odometry, PoseEstimate, param

from tests.core.toys import Integrate

MODES = Literal["none", "hang", "sleep", "exit", "interrupt", "swallow", "regex", "mutate",
                "relabel", "swap"]


class RogueEstimator(Integrate):
    """Dead-reckons odometry into poses; misbehaves as told for one agent from time ``at``."""

    name = "rogue"

    class Params(Integrate.Params):
        mode: MODES = param("none")
        """how to misbehave"""
        agent: str = param("ff1")
        """whose data trigger it"""
        at: float = param(3.0, unit="s")
        """from this time on"""
        marker: str = param("")
        """file written just before misbehaving"""

    def handle(self, stream: str, msg: Odometry) -> None:
        p = self.params
        if msg.agent == p.agent and msg.t >= p.at and p.mode != "none":
            if p.marker:
                Path(p.marker).write_text("now")
            self.misbehave(msg)
        super().handle(stream, msg)

    def misbehave(self, msg: Odometry) -> None:
        mode = self.params.mode
        if mode == "hang":
            while True:
                pass
        if mode == "sleep":
            time.sleep(3600)
        if mode == "exit":
            sys.exit("rogue wants out")
        if mode == "interrupt":
            raise KeyboardInterrupt
        if mode == "swallow":
            while True:
                try:
                    time.sleep(3600)
                except BaseException:  # noqa: BLE001 - on purpose: ignores the watchdog
                    pass
        if mode == "regex":  # minutes of backtracking in C, holding the interpreter
            re.match(r"(a+)+$", "a" * 40 + "b")
        if mode == "mutate":
            msg.delta[0] = 1000.0
        if mode == "swap":   # ff1's data published as ff2's
            self.ctx.publish("pose", PoseEstimate(t=msg.t, agent="ff2", device=msg.device,
                                                  position=np.zeros(3), heading=0.0,
                                                  cov=np.eye(4)))
        if mode == "relabel":
            self.ctx.publish("pose", PoseEstimate(t=msg.t, agent="ghost", position=np.zeros(3),
                                                  heading=0.0, cov=np.eye(4)))

