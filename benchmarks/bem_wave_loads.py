"""The independent oracle for the wave loads: a boundary-element (BEM) solution with capytaine.

Linear potential flow around a rectangular box of the vehicle's displaced volume, held at the
mission's depth in the paper's water depth, in regular waves of 4–20 s: the wave excitation force
in surge and heave (Froude–Krylov + diffraction), the Froude–Krylov part alone, and the box's
added mass and radiation damping. The table is written with its provenance (solver, version,
mesh, date) to ``benchmarks/results/bem_wave_loads.json``; ``tests/test_wave_loads.py`` compares
Wavekeep's load model with it. Two meshes are solved to show the table is converged.

capytaine is not a project dependency (it is needed only to make this table again):

    python -m venv /tmp/bem && /tmp/bem/bin/pip install capytaine==3.0.0 pyyaml
    /tmp/bem/bin/python benchmarks/bem_wave_loads.py

The script reads the vehicle config with PyYAML and imports nothing of the project, so the oracle
shares no code with what it checks.

Conventions in the table: capytaine's (z up, complex amplitudes of e^{−iωt}, per metre of wave
amplitude). Each force is also given divided by the undisturbed flow's acceleration at the box
centre in the same direction and convention, so ``ratio`` is a complex mass (kg): for a small
body, (ρ∇ + A) with zero phase.
"""
from __future__ import annotations

import datetime as _dt
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "bem_wave_loads.json"

RHO = 1025.0          # kg/m³, sea water (the vehicle config's water_density default)
G = 9.81              # m/s², the models' g
WATER_DEPTH = 54.0    # m, the paper's site (Table I)
DEPTH = 5.0           # m, the mission's station depth
PERIODS = (4.0, 5.0, 6.0, 7.0, 8.0, 10.0, 12.0, 14.0, 16.0, 20.0)   # s
MESHES = {"coarse": (8, 10, 5), "fine": (16, 20, 10)}                 # panels per side (x, y, z)


def box_of_displaced_volume(vehicle_yaml: Path) -> tuple[float, float, float, float]:
    """The box (m: length, width, height) with the vehicle's outer proportions (length 0.457 m,
    width 0.575 m, height from the config) scaled to its displaced volume B / (ρ g), and that volume (m³)."""
    cfg = yaml.safe_load(vehicle_yaml.read_text())
    mp = cfg["mass_properties"]
    volume = mp.get("displaced_volume") or mp["B"] / (RHO * G)
    outer = (float(mp["length"]), 0.575, float(mp["height"]))   # BlueROV2 Heavy frame width 0.575 m
    s = (volume / math.prod(outer)) ** (1.0 / 3.0)
    return outer[0] * s, outer[1] * s, outer[2] * s, float(volume)


def solve(size: tuple[float, float, float], resolution: tuple[int, int, int]) -> list[dict]:
    """One row per period: excitation, Froude–Krylov force and added mass/damping in surge and heave."""
    import capytaine as cpt
    from capytaine.bem.airy_waves import airy_waves_velocity, froude_krylov_force

    centre = (0.0, 0.0, -DEPTH)
    mesh = cpt.mesh_parallelepiped(size=size, center=centre, resolution=resolution)
    body = cpt.FloatingBody(mesh=mesh, dofs=cpt.rigid_body_dofs(rotation_center=centre), center_of_mass=centre)
    solver = cpt.BEMSolver()
    rows = []
    for period in PERIODS:
        common = {"body": body, "water_depth": WATER_DEPTH, "period": period, "rho": RHO, "g": G}
        diffraction = cpt.DiffractionProblem(wave_direction=0.0, **common)
        d = solver.solve(diffraction)
        fk = froude_krylov_force(diffraction)
        v = airy_waves_velocity(np.array([centre]), diffraction)[0]
        acc = -1j * diffraction.omega * v          # ∂v/∂t of Re(v e^{−iωt}): −iω v (x, y, z up)
        row = {"period_s": period, "omega_rad_s": diffraction.omega, "wavenumber_rad_m": diffraction.wavenumber,
               "k_length": diffraction.wavenumber * size[0]}
        for dof, axis in (("Surge", 0), ("Heave", 2)):
            exc = complex(d.forces[dof]) + complex(fk[dof])
            rad = solver.solve(cpt.RadiationProblem(radiating_dof=dof, **common))
            key = dof.lower()
            row[key] = {
                "excitation": [exc.real, exc.imag],
                "froude_krylov": [complex(fk[dof]).real, complex(fk[dof]).imag],
                "fluid_acceleration": [acc[axis].real, acc[axis].imag],
                "ratio_kg": [(exc / acc[axis]).real, (exc / acc[axis]).imag],
                "added_mass_kg": float(rad.added_masses[dof]),
                "radiation_damping_kg_s": float(rad.radiation_dampings[dof]),
            }
        rows.append(row)
    return rows


def main() -> None:
    import capytaine as cpt

    vehicle_yaml = ROOT / "configs" / "vehicle" / "bluerov2_heavy.yaml"
    *size, volume = box_of_displaced_volume(vehicle_yaml)
    t0 = time.perf_counter()
    tables = {name: solve(tuple(size), res) for name, res in MESHES.items()}
    worst = max(abs(complex(*f[dof]["excitation"]) / complex(*c[dof]["excitation"]) - 1.0)
                for c, f in zip(tables["coarse"], tables["fine"], strict=True) for dof in ("surge", "heave"))
    out = {
        "what": "BEM (linear potential flow) wave excitation on a box of the vehicle's displaced volume, held "
                "at the station depth, per metre of regular-wave amplitude; the independent oracle of "
                "tests/test_wave_loads.py",
        "provenance": {"solver": "capytaine", "version": cpt.__version__, "python": sys.version.split()[0],
                       "date": _dt.date.today().isoformat(), "script": "benchmarks/bem_wave_loads.py",
                       "seconds": round(time.perf_counter() - t0, 1)},
        "conventions": "capytaine's: z up, complex amplitudes of exp(-i omega t) per metre of wave amplitude; "
                       "ratio_kg = force / undisturbed fluid acceleration at the box centre (same axis)",
        "rho_kg_m3": RHO, "g_m_s2": G, "water_depth_m": WATER_DEPTH, "centre_depth_m": DEPTH,
        "box_m": size, "volume_m3": volume, "vehicle_config": str(vehicle_yaml.relative_to(ROOT)),
        "meshes": {name: {"resolution": list(res), "panels": 2 * (res[0] * res[1] + res[0] * res[2] + res[1] * res[2])}
                   for name, res in MESHES.items()},
        "mesh_convergence": {"max_rel_change_coarse_to_fine": worst},
        "table": tables["fine"],
    }
    OUT.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {OUT} (box {size[0]:.4f} x {size[1]:.4f} x {size[2]:.4f} m, {volume * 1e3:.2f} L; "
          f"coarse→fine excitation change ≤ {100 * worst:.2f} %)")
    for r in tables["fine"]:
        s, h = r["surge"], r["heave"]
        print(f"T {r['period_s']:5.1f} s  surge |F|/|a| {abs(complex(*s['ratio_kg'])):6.2f} kg "
              f"(A11 {s['added_mass_kg']:.2f})"
              f"  heave {abs(complex(*h['ratio_kg'])):6.2f} kg (A33 {h['added_mass_kg']:.2f})")


if __name__ == "__main__":
    main()
