"""The RFID/MEMS PDR extended Kalman filter (rfid-mems-ekf): the ``pdr_ekf`` estimator.

Modules: :mod:`.filter` (state eq. 1, process eq. 2, position and heading updates),
:mod:`.door_heading` (eq. 3 with the 180 degree ambiguity and the adaptive covariance),
:mod:`.gait` (FW / SC / SDF / SDB stride classes from foot odometry), :mod:`.height`
(stair rise and floor levels), :mod:`.flight_tracker` (the building's stair flights),
:mod:`.history` (delayed tag events), :mod:`.params`, :mod:`.estimator` (the plugin).
"""
from .estimator import PdrEkfEstimator
from .params import PdrEkfParams

__all__ = ["PdrEkfEstimator", "PdrEkfParams"]
