"""The ``foot_imu`` sensor: any foot-IMU input to clean, calibrated FLU blocks.

Inputs are :class:`~firenav_framework.messages.ImuBlock` in a device frame (recordings,
the simulator) or :class:`~firenav_framework.messages.RawFrame` from a live link or its
log, decoded by the registered codec ``frames.codecs`` names for the frame's transport
(by default CAN frames of the reference DBC, MAVLink HIGHRES_IMU / SCALED_IMU /
RAW_IMU, text lines over serial or UDP; see ``docs/formats/codecs.md``). For each
device the sensor

1. converts units to SI (``units`` for blocks; codecs decode to SI) and, for frames,
   collects each link device's frames for ``frames.block_s`` and decodes them in one
   batch (:mod:`.samples`), maps the device id to an output stream (:mod:`.routing`)
   and the device clock onto the pipeline clock (:mod:`.clock`);
2. screens the samples (:mod:`.screening`);
3. applies the device's calibration and rotates the axes to FLU (:mod:`.calibration`);
4. publishes the block on ``imu`` and, once per device, checks that gravity points up
   and the units look right at rest (:mod:`.rest_check`).

Everything it drops or flags is counted and the serious problems are reported
(:mod:`.problems`).

Output contract (what estimators may rely on, and need not check again)
-----------------------------------------------------------------------
Every :class:`ImuBlock` on ``imu``:

* is in **FLU** (``frame == "FLU"``: x toe, y left, z up; about +9.81 m/s^2 on z at
  rest), **SI** and calibrated: ``accel`` specific force [m/s^2], ``gyro`` angular rate
  [rad/s], ``mag`` [uT] or None (NaN rows where a sample had no reading; the
  magnetometer is not screened);
* holds only samples with **finite** time, accel and gyro, within
  ``screening.accel_range`` / ``gyro_range`` per axis (judged in device axes, before
  calibration), with **strictly increasing** times [s] on the pipeline clock per
  (agent, device), across blocks too (a ``reset`` of the firefighter starts afresh):
  NaN/inf, out-of-range, corrupt-timestamp, duplicate and backwards-in-time samples
  are **dropped** (absent; counted and reported, never passed on);
* has ``flags`` (uint8, never None) with :data:`~firenav_framework.messages.IMU_FLAG_BITS`:
  ``saturated`` on samples at the device's full scale or clipped on the wire (kept),
  ``gap_before`` on the first sample after a step longer than ``screening.gap`` (kept;
  the first sample of a device has no ``gap_before``);
* has ``t == time[-1]`` and at least one sample; ``agent`` and ``device`` name the
  output stream (``<agent>/imu`` unless ``frames.agent_map`` names it).

An estimator reading this port therefore needs no screening of its own; it may still
check shapes at its edge if it also reads other producers.
"""
from .sensor import FootImuSensor

__all__ = ["FootImuSensor"]
