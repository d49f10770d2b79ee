"""Motors: the mixer (wrench → eight thruster PWM, pitch first, motor-lag compensated) and the auxiliary outputs.

As ArduPilot's AP_Motors and SRV_Channels: it imports the parameter table and the modes' result codes, never
the laws, the estimator or MAVLink.
"""
