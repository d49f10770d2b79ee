"""HAL: the hardware layer — the HAL interface and its SITL backends, sensor frames, clocks and the scheduler.

The bottom of the vehicle, as ArduPilot's AP_HAL: it imports only the parameter table and bridge, never the
laws, the estimator, the mixer, the forecast or MAVLink.
"""
