"""Wavekeep firmware: the vehicle side (control task, estimator, controllers, HAL, MAVLink link).

``firmware_py.physics`` holds the models of the world shared with the simulator
(wave kinematics, the Fossen vehicle model, the T200 thrusters); the firmware
uses them with nominal parameters, the SITL plant with true ones.
"""
