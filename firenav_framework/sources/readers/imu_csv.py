"""The firenav IMU CSV format (:mod:`firenav_framework.formats.imu_csv`) for ``.csv`` files."""
from __future__ import annotations

from ...formats.imu_csv import ImuCsvReader

READERS = {".csv": ImuCsvReader}
FORMATS = {"imu_csv": ImuCsvReader}
