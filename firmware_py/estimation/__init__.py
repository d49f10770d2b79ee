"""Estimation: the EKF of the vehicle's pose and velocity, its tuning, and the inertial velocity from the IMU.

It reads the HAL's sensor frames and the parameter table (hal.sensors, params, numerics); it never imports the
laws, the mixer, MAVLink or the vehicle above it.
"""
