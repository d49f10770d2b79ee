"""The documented, deliberate differences between Wavekeep and the real ArduSub (4.7) a ground station sees.

Each entry is a conformance item (:mod:`test_ardusub_conformance`; a key ending in ``*`` covers every item
it starts) → (topic, reason). The topic is the label under which docs/mavlink.md's "Where Wavekeep differs
from ArduSub" lists it (:func:`test_ardusub_conformance.test_every_documented_difference_is_in_the_docs`
checks that it does). Anything else that differs fails the suite; an entry that no longer differs fails too.
"""
from __future__ import annotations

_CAPS = ("Capabilities", "AUTOPILOT_VERSION claims what the link implements of ArduSub's set: no FTP (no files are "
         "served), fence or rally missions, SET_ATTITUDE_TARGET, compass calibration or flight termination")
_FIX = ("Position fix", "SITL's simulated GPS is an RTK receiver (fix type 6, 10 satellites); Wavekeep's fix is an "
        "acoustic positioning system, reported as ArduSub reports one fed to it as a GPS: a 3D fix, satellites unknown")
_PARAM_SET = ("Parameter sets", "Wavekeep range-checks a PARAM_SET and says why it refuses one (ArduSub takes any "
              "finite value and ignores NaN silently)")

DIFFERENCES: dict[str, tuple[str, str]] = {
    "autopilot_version.capabilities": _CAPS,
    "dronekit.capabilities": _CAPS,
    "banner.name": ("Banner", "the banner's first line names Wavekeep, its version and commit; AUTOPILOT_VERSION "
                              "carries the ArduSub release it follows"),
    "params.count": ("Parameter count", "ArduSub's table less ArduPilot SITL's own SIM_* simulator parameters, plus "
                                        "Wavekeep's WK_* and its simulator's SIM_*"),
    "param.BATT_CAPACITY": ("Battery", "the simulated pack is Blue Robotics' 15.6 Ah Li-ion (ArduSub's default 3300 "
                                       "mAh); the remaining charge is counted against it"),
    "param.value.BATT_CAPACITY": ("Battery", "as param.BATT_CAPACITY"),
    "sys_status.LOGGING": ("Logging", "no on-board log: ArduSub's dataflash log has no counterpart"),
    "sys_status.RC_RECEIVER": ("RC receiver", "ArduPilot SITL simulates an RC receiver from boot; a BlueROV2 has none: "
                                              "Wavekeep reports one once a joystick or RC override has been heard"),
    "named_value_float.wavekeep's own": ("NAMED_VALUE_FLOAT", "FF_* (the wave feed-forward) and TICK_* (loop timing) "
                                                              "are Wavekeep's, beside ArduSub's nine"),
    "stream.AHRS": ("Streams", "ArduPilot's DCM diagnostics: Wavekeep's estimator is an EKF, with no DCM"),
    "stream.GIMBAL_DEVICE_ATTITUDE_STATUS": ("Streams", "the camera mount's attitude is not sent: CamTilt and "
                                                        "SERVO_OUTPUT_RAW carry its tilt"),
    "stream.SCALED_IMU2": ("Streams", "SITL simulates three IMUs; Wavekeep has one (RAW_IMU)"),
    "stream.SCALED_IMU3": ("Streams", "SITL simulates three IMUs; Wavekeep has one (RAW_IMU)"),
    "stream.SIMSTATE": ("Streams", "SITL's own simulator state: Wavekeep's world is not inside the firmware"),
    "stream.TERRAIN_REPORT": ("Streams", "no terrain database"),
    "gps_raw_int.fix_type": _FIX,
    "gps_raw_int.satellites_visible": _FIX,
    "dronekit.gps fix": _FIX,
    "SET_MODE CIRCLE": ("Modes", "a circle needs sway, which this planar vehicle has not got: refused as ArduSub "
                                 "refuses a mode whose start fails"),
    "SET_MODE MOTOR_DETECT": ("Modes", "the thrusters' directions are fixed by the vehicle's configuration: refused "
                                       "as ArduSub refuses a mode whose start fails"),
    "PARAM_SET NaN": _PARAM_SET,
    "PARAM_SET out of range": _PARAM_SET,
    "PARAM_SET of one that means nothing here": ("Read-only parameters", "the parameters of ArduSub's table that mean "
                                                 "nothing on this vehicle are read-only (\"Param write denied\")"),
    "pressure calibration disarmed": ("Pressure calibration", "ArduSub blocks while it calibrates (and says "
                                      "\"Initialising ArduPilot\"); Wavekeep averages the last second of readings "
                                      "and says \"Barometer calibration complete\""),
}
