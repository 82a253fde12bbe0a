"""ACME foot-IMU support for firenav."""
