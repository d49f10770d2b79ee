"""``wavekeep sea`` and ``wavekeep openloop``: the world alone (the realised sea; the unpowered vehicle in it)."""
from __future__ import annotations

import argparse
import time

from . import options as o

SEA_COLUMNS = ("t_s", "eta_m", "u_m_per_s", "w_m_per_s_down")
"""``wavekeep sea`` CSV columns: time (s), elevation (m, up), horizontal and vertical particle velocity
(m/s; w positive down, as the vehicle's z)."""

ARRAY_COLUMNS = ("eta_g1_m", "eta_g2_m", "eta_g3_m")
"""``wavekeep sea --array R``: the elevations (m, up) at three gauges on a triangle of radius R around the station."""

OPENLOOP_COLUMNS = ("t", "x", "z", "theta", "u", "w", "q", "tauE_X", "tauE_Z", "tauE_M", "wave_eta")
"""``wavekeep openloop`` timeseries.csv columns: the names of the run's timeseries.csv (docs/results.md)."""


def add_parsers(sub) -> None:
    p = sub.add_parser("sea", help="write the realised sea (t, eta, u, w) at the vehicle to CSV, and its PSD",
                       description="Write the realised sea at the vehicle's station to CSV (t s, eta m, u m/s, "
                       "w m/s positive down) and FILE.png: the elevation record and its Welch PSD against the "
                       "target spectrum.")
    o.add_common(p, vehicle=False)
    p.add_argument("--duration", type=o.duration, default=600.0, help="record length (s)")
    p.add_argument("--rate", type=o.positive, default=None, help="sample rate (Hz); default: the control rate")
    p.add_argument("--x", type=float, default=None, help="north position (m); default: the mission setpoint's")
    p.add_argument("--depth", type=float, default=None, help="depth (m, positive down); default: the mission's")
    o.add_world(p, vehicle=False)
    p.add_argument("--array", type=o.positive, default=None, metavar="R",
                   help="also record a 2-D array: three gauges on a triangle of radius R (m) around the station "
                   "(columns eta_g1..eta_g3), and print the directional estimate (mean direction, cos-2s s)")
    p.add_argument("--out", default="runs/sea.csv", help="CSV file to write (and its .png beside it)")
    p.set_defaults(func=cmd_sea)

    p = sub.add_parser("openloop", help="release the unpowered vehicle at the setpoint and report its drift",
                       description="Release the unpowered vehicle (thrusters at 1500 µs) at the setpoint in the "
                       "sea; write results.json, timeseries.csv, openloop.png and run.json.")
    o.add_common(p)
    p.add_argument("--duration", type=o.duration, default=None, help="seconds; default: the mission's")
    o.add_out(p, what="run folder for results.json, timeseries.csv, openloop.png and run.json")
    p.set_defaults(func=cmd_openloop)


def cmd_sea(args: argparse.Namespace) -> int:
    """Write t, eta, u, w at the vehicle's station (x and depth from the mission) and the PSD figure."""
    import numpy as np

    from bridge.models.waves import particle_kinematics_grid
    from bridge.schemas import load_mission_config
    from sitl.sea import Sea

    out = o.check_out(args.out, kind="file")
    sea = Sea.load(args.case, seed=args.seed, overrides=o.world_options(args)["sea"])
    mission = load_mission_config(args.mission)
    x = mission["setpoint"]["x"] if args.x is None else args.x
    depth = mission["setpoint"]["depth"] if args.depth is None else args.depth
    rate = mission["control_rate"] if args.rate is None else args.rate
    n = int(round(args.duration * rate)) + 1
    if n < 16:
        raise o.UsageError(f"--duration {args.duration:g} s at {rate:g} Hz gives {n} samples; need at least 16")
    if n > 50_000_000:
        raise o.UsageError(f"--duration × --rate gives {n} samples; at most 50 million")
    t = np.arange(n) / rate
    gauges = 0 if args.array is None else 3
    rows = np.empty((n, 4 + gauges))
    for i in range(0, n, 2048):
        tt = t[i:i + 2048]
        u, wv, _, _ = particle_kinematics_grid(sea.components, [x], [depth], tt)
        rows[i:i + 2048, :4] = np.column_stack([tt, sea.elevation(x, tt), u[:, 0], wv[:, 0]])
    columns: tuple[str, ...] = SEA_COLUMNS
    if gauges:
        columns = (*SEA_COLUMNS, *ARRAY_COLUMNS)
        _array_record(sea, x, args.array, t, rows[:, 4:])
    out.parent.mkdir(parents=True, exist_ok=True)
    header = (f"# wavekeep sea: case={sea.name} seed={sea.seed} x={x} m depth={depth} m "
              f"Hs_target={sea.hs_target:.3f} m Hs_components={sea.hs():.3f} m components={sea.components.n}; "
              "t s, eta m (up), u m/s, w m/s (positive down)"
              + (f"; eta_g* m at a triangle of radius {args.array:g} m" if gauges else "") + "\n" + ",".join(columns))
    np.savetxt(out, rows, delimiter=",", header=header, comments="", fmt=("%.4f",) + ("%.6f",) * (3 + gauges))
    from ..world_plots import plot_sea
    fig = plot_sea(sea, rows[:, 0], rows[:, 1], out.with_suffix(".png"))
    hs_real = 4.0 * float(np.std(rows[:, 1]))
    print(f"wrote {out}: {n} samples at {rate:g} Hz; Hs target {sea.hs_target:.3f} m, components "
          f"{sea.hs():.3f} m, realised 4·std(η) {hs_real:.3f} m; figure {fig}")
    return 0


def _array_record(sea, x: float, radius: float, t, out) -> None:
    """Fill ``out`` (T, 3) with the elevations at a triangle of gauges around (x, 0) and print the
    directional estimate of the peak band [0.5, 2] f_p (:mod:`sitl.harness.directional`)."""
    import numpy as np

    from bridge.models.waves import elevation_xy

    from ..directional import directional_moments, triangle_array

    gx, gy = triangle_array(x, radius)
    for i in range(0, t.size, 2048):
        out[i:i + 2048] = elevation_xy(sea.components, gx[None, :], gy[None, :], t[i:i + 2048, None])
    fp = sea.omega_peak / (2.0 * np.pi)
    m = directional_moments(out, gx, gy, float(t[1] - t[0]), (0.5 * fp, 2.0 * fp))
    print(f"array of radius {radius:g} m, band {0.5 * fp:.3f}-{2.0 * fp:.3f} Hz: mean direction "
          f"{m['mean_direction_deg']:.1f} deg, r1 {m['r1']:.3f}, cos-2s s = {m['s']:.1f}")


def cmd_openloop(args: argparse.Namespace) -> int:
    """The passive vehicle (all thrusters at 1500 µs) released at the setpoint in the sea."""
    import json

    import numpy as np

    from bridge.schemas import load_mission_config
    from sitl.plant import Plant
    from sitl.sea import Sea

    from ..metrics import format_table, station_keeping_metrics
    from ..progress import ProgressBar
    from ..provenance import configs_record, write_run_record
    from ..world_plots import plot_openloop

    o.check_duration(args.duration, args.mission)
    out = o.check_out(args.out, force=args.force)
    sea = Sea.load(args.case, seed=args.seed)
    mission = load_mission_config(args.mission)
    plant = Plant.from_configs(sea, args.vehicle, args.mission)
    sp = mission["setpoint"]
    setpoint = np.array([sp["x"], sp["depth"], sp["pitch"]])
    rate = mission["control_rate"]
    duration = mission["duration"] if args.duration is None else args.duration
    n = int(round(duration * rate))
    pwm = np.full(8, plant.curve.pwm_neutral)
    log = np.empty((n + 1, len(OPENLOOP_COLUMNS)))

    def record(i):
        s = plant.state
        log[i] = [s.t, *s.eta, *s.nu, *plant.tau_E, sea.elevation(s.eta[0], s.t)]

    record(0)
    wall0 = time.perf_counter()
    with ProgressBar(n, f"openloop {sea.name}", unit="tick") as bar:
        for i in range(1, n + 1):
            plant.step(pwm, 1.0 / rate)
            record(i)
            bar.update(i)
    wall = time.perf_counter() - wall0
    metrics = station_keeping_metrics(log[:, 0], log[:, 1:4], setpoint, np.zeros((n + 1, 3)))
    results = {
        "kind": "openloop", "case": sea.name, "seed": sea.seed, "controller": "none",
        "duration_s": duration, "rate_hz": rate, "hs_target_m": sea.hs_target, "hs_components_m": sea.hs(),
        "setpoint": setpoint.tolist(), **metrics,
        "wall_time_s": wall, "speed_x_realtime": duration / wall if wall > 0 else None,
    }
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(results, indent=2))
    np.savetxt(out / "timeseries.csv", log, delimiter=",", header=",".join(OPENLOOP_COLUMNS), comments="",
               fmt="%.6f")
    plot_openloop(log, OPENLOOP_COLUMNS, setpoint, results, out / "openloop.png")
    write_run_record(out, args.argv, seed=sea.seed, case=sea.name, mission=args.mission, vehicle=args.vehicle,
                     duration_s=duration, configs=configs_record(args.case, args.mission, args.vehicle))
    print(f"Open loop (thrusters neutral) in {sea.name}, seed {sea.seed}, {duration:g} s at {rate:g} Hz: "
          f"{wall:.2f} s wall ({results['speed_x_realtime']:.0f}x real time)")
    print(format_table({f"{sea.name} passive": metrics}))
    print(f"wrote {out}: results.json, timeseries.csv, openloop.png, run.json")
    return 0
