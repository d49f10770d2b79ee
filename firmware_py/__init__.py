"""Wavekeep firmware: the vehicle side (control task, estimator, controllers, HAL, MAVLink link).

It imports only :mod:`bridge`, and uses the shared models there
(:mod:`bridge.models`: wave kinematics, the Fossen vehicle model, the T200
thrusters) with nominal parameters; the SITL world uses them with true ones.
"""
