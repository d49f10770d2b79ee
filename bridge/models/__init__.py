"""Physics shared by the firmware (nominal parameters), the SITL world (true parameters) and the shore.

* :mod:`bridge.models.waves` — dispersion and wave kinematics (linear + 2nd-order Stokes);
* :mod:`bridge.models.vehicle` — the Fossen 3-DoF vehicle model and the wave loads;
* :mod:`bridge.models.thrusters` — the T200 curve and the thruster layout.
"""
