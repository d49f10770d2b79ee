"""The columns of the firmware's tick log: one row per control tick (``Firmware.on_tick`` → ``tick_row``).

Apart from :mod:`firmware_py.firmware` so that a reader of the log (the launcher merging the
firmware's CSV, the results schema) need not import the firmware itself (numba, scipy: ~0.5 s).
"""
from __future__ import annotations

from enum import IntEnum

__all__ = ["TICK_COLUMNS", "SolveStatus"]


class SolveStatus(IntEnum):
    """What a controller's solver did this tick (the ``ctrl_status`` column; 0 for a law with no solver)."""

    NONE = 0          # no solver (C-PD and its FF/DOB terms)
    SOLVED = 1        # the optimiser's command was flown
    TIMEOUT = 2       # out of its budget (iterations, or milliseconds on a wall clock): the fallback flew
    INFEASIBLE = 3    # no command within the limits: the fallback flew
    NONFINITE = 4     # a non-finite model or result: the fallback flew
    FAILED = 5        # any other solver failure: the fallback flew


TICK_COLUMNS = (
    ["x_hat", "z_hat", "theta_hat", "u_hat", "w_hat", "q_hat", "sigma_x", "sigma_z", "sigma_theta"]
    + ["sp_x", "sp_z", "sp_theta"]
    + ["tau_X", "tau_Z", "tau_M", "tau_ff_X", "tau_ff_Z", "tau_ff_M", "tauE_hat_X", "tauE_hat_Z", "tauE_hat_M"]
    + [f"pwm{i}" for i in range(1, 9)]
    + ["ff_active", "ff_w_X", "ff_w_Z", "ff_w_M", "saturated"]
    + ["sigma_u", "sigma_w", "sigma_q", "dhat_X", "dhat_Z", "dhat_M", "tau_dob_X", "tau_dob_Z", "tau_dob_M"]
    + ["nis", "nis_dof", "prv_x", "prv_z", "ff_skill_X", "ff_skill_Z", "ff_skill_M"]
    + ["ctrl_status", "ctrl_iter", "ctrl_ms"]     # the law's solver: SolveStatus, iterations, compute (ms)
    # the lateral-directional plane (six-DoF vehicle; NaN while it is not estimated): estimate, target, commands
    + ["y_hat", "phi_hat", "psi_hat", "v_hat", "p_hat", "r_hat", "sp_y", "sp_psi"]
    + ["tau_Y", "tau_K", "tau_N", "tau_ff_Y", "tau_ff_K", "tau_ff_N"]
)
"""What one tick's record holds, flattened (:func:`tick_row`): estimate, setpoint, commands, PWM."""
