"""The ACME IMU reports specific force in g and angular rate in deg/s on FRD axes
(x forward, y right, z down). This sensor converts its blocks to firenav's FLU, SI."""
from __future__ import annotations

import numpy as np

from firenav_framework import ImuBlock, Params, Sensor, hookimpl, param

G = 9.80665
FRD_TO_FLU = np.diag([1.0, -1.0, -1.0])


class AcmeImu(Sensor):
    """ACME AX-1 foot IMU: g and deg/s on FRD axes to SI on FLU."""

    name = "acme_imu"
    inputs = (ImuBlock,)
    outputs = {"imu": ImuBlock}

    class Params(Params):
        gyro_bias_dps: tuple[float, float, float] = param(
            (0.0, 0.0, 0.0), unit="deg/s", description="factory gyro bias, FRD axes")

    def handle(self, stream: str, msg: ImuBlock) -> None:
        accel = msg.accel * G @ FRD_TO_FLU
        gyro = np.radians(msg.gyro - np.asarray(self.params.gyro_bias_dps)) @ FRD_TO_FLU
        self.ctx.count("samples", len(msg))
        self.ctx.publish("imu", ImuBlock.from_arrays(msg.time, accel, gyro, agent=msg.agent,
                                                     device=msg.device, frame="FLU"))


@hookimpl
def firenav_plugins():
    return [AcmeImu]
