"""Physics shared by the firmware (nominal parameters), the SITL world (true parameters) and the shore.

* :mod:`bridge.models.waves` — dispersion and wave kinematics (linear + 2nd-order Stokes);
* :mod:`bridge.models.vehicle` — the Fossen 3-DoF vehicle model and the wave loads;
* :mod:`bridge.models.thrusters` — the T200 curve and the thruster layout;
* six degrees of freedom (the six-DoF world's plant and the firmware's lateral-directional plane):
  :mod:`bridge.models.rigid_body6`
  (Fossen's 6-DoF rigid body, added mass, damping, restoring, kinematics), :mod:`bridge.models.strip_load6`
  (the wave load on strips over the length and beam), :mod:`bridge.models.motion6` (rates, RK4, the
  planar and lateral parts), :mod:`bridge.models.body6` (a body cut into strips: its flow, RK4 step, load and
  rates through the compiled kernels), :mod:`bridge.models.directional_sea` (cos-2s spreading, 3-D
  kinematics) and :mod:`bridge.models.vehicle6_config` (the 6-DoF vehicle config).
"""
