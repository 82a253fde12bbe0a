"""Recorded-file formats shared by the parts that write them and the parts that read them.

:mod:`.base` is what every reader of a recording shares (its options, its error type,
cutting samples into IMU blocks); :mod:`.imu_csv` is the firenav IMU CSV format,
written by the simulator and read by the ``recording`` source. Neither the simulator
nor the sources own them, so neither imports the other.
"""
