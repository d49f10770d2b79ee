"""Station-keeping figures of merit, as the paper reports them (§V): RMSE, maximum error, power.

Errors are truth minus setpoint per DoF: surge x (m), heave z (m, depth), pitch θ
(rad; the table shows degrees). Power per DoF is the paper's T200 polynomial on
|τ| (W), averaged over the run; energy is its time integral (J).
"""
from __future__ import annotations

import numpy as np

from bridge.models.thrusters import power_per_dof

__all__ = ["DOF", "DOF6", "format_six_dof", "format_table", "six_dof_metrics", "station_keeping_metrics"]

DOF = ("surge", "heave", "pitch")
DOF6 = ("x", "y", "z", "roll", "pitch", "yaw")
"""The six-DoF pose's names in results.json's ``six_dof`` (m for x, y, z; rad for the angles)."""


def station_keeping_metrics(t: np.ndarray, eta: np.ndarray, setpoint: np.ndarray, tau: np.ndarray) -> dict:
    """RMSE, max |error|, mean power and energy per DoF.

    t (K,) s; eta (K, 3) truth [x, z, θ]; setpoint (3,) or (K, 3); tau (K, 3) the
    control wrench [X, Z, M] the controller commanded — the paper's "power
    consumed by the control actions" (§V-C).
    """
    t = np.asarray(t, dtype=float)
    err = np.asarray(eta, dtype=float) - np.asarray(setpoint, dtype=float)
    power = power_per_dof(tau)
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0] if t.size > 1 else 0.0))
    rmse = np.sqrt(np.mean(err**2, axis=0))
    max_err = np.max(np.abs(err), axis=0)
    return {
        "rmse": dict(zip(DOF, rmse.tolist(), strict=False)),
        "max_abs_error": dict(zip(DOF, max_err.tolist(), strict=False)),
        "mean_power_w": dict(zip(DOF, np.mean(power, axis=0).tolist(), strict=False)),
        "energy_j": dict(zip(DOF, (power * dt[:, None]).sum(axis=0).tolist(), strict=False)),
    }


def six_dof_metrics(eta6: np.ndarray, setpoint6: np.ndarray, dof: str) -> dict:
    """RMSE and max |error| of the six-DoF pose, and the horizontal error √(Δx² + Δy²) (m).

    eta6 (K, 6) truth [x, y, z, φ, θ, ψ] (NED m, rad); setpoint6 (6,) the station and its attitude (the
    vehicle's start heading). ``dof`` is the world's ("planar": y, roll, yaw are zero by construction).
    """
    err = np.asarray(eta6, dtype=float) - np.asarray(setpoint6, dtype=float)
    horizontal = np.hypot(err[:, 0], err[:, 1])
    return {
        "world_dof": dof,
        "rmse": dict(zip(DOF6, np.sqrt(np.mean(err**2, axis=0)).tolist(), strict=True)),
        "max_abs_error": dict(zip(DOF6, np.max(np.abs(err), axis=0).tolist(), strict=True)),
        "horizontal_error_m": {"rmse": float(np.sqrt(np.mean(horizontal**2))), "max": float(np.max(horizontal))},
    }


def format_six_dof(m: dict) -> str:
    """Two lines of a results document's ``six_dof`` metrics: RMSE and max per DoF (m; angles in degrees)."""
    def row(d: dict) -> str:
        return "  ".join(f"{k} {d[k] * (1.0 if k in ('x', 'y', 'z') else float(np.degrees(1.0))):.3g}"
                         f"{' m' if k in ('x', 'y', 'z') else '°'}" for k in DOF6)
    h = m["horizontal_error_m"]
    return (f"six DoF ({m['world_dof']} world) RMSE: {row(m['rmse'])}; horizontal {h['rmse']:.3g} m\n"
            f"six DoF max |error|: {row(m['max_abs_error'])}; horizontal {h['max']:.3g} m")


def format_table(rows: dict[str, dict]) -> str:
    """A plain-text table of RMSE / max error / mean power per DoF, one row per run label.

    Each row is a ``results.json``-style mapping (``rmse``, ``max_abs_error``,
    ``mean_power_w``; pitch in rad, shown in degrees)."""
    w = max([16, *(len(label) + 1 for label in rows)])
    head = f"{'run':<{w}}{'RMSE x (m)':>11}{'z (m)':>9}{'θ (deg)':>9}{'max x (m)':>11}{'z (m)':>9}" \
           f"{'θ (deg)':>9}{'P x (W)':>9}{'z (W)':>8}{'θ (W)':>8}"
    lines = [head, "-" * len(head)]
    for label, m in rows.items():
        r, mx, p = m["rmse"], m["max_abs_error"], m["mean_power_w"]
        lines.append(f"{label:<{w}}{r['surge']:>11.3f}{r['heave']:>9.3f}{np.degrees(r['pitch']):>9.2f}"
                     f"{mx['surge']:>11.3f}{mx['heave']:>9.3f}{np.degrees(mx['pitch']):>9.2f}"
                     f"{p['surge']:>9.2f}{p['heave']:>8.2f}{p['pitch']:>8.2f}")
    return "\n".join(lines)
