"""The 3-D view's recording: written by a real run, read back with Rerun's own reader, checked against the
run's timeseries.csv and the plant; the thrust replay against the plant's motors; the view without Rerun."""
from __future__ import annotations

import sys

import numpy as np
import pytest

rr = pytest.importorskip("rerun", reason="the view extra (pip install 'wavekeep[view]') is not installed")

from bridge.models.waves import elevation, elevation_grid  # noqa: E402
from sitl.harness.cli import main  # noqa: E402
from sitl.harness.recording import replay_thrust  # noqa: E402
from sitl.harness.run import build_mission, take_off  # noqa: E402
from sitl.harness.spec import RunSpec  # noqa: E402
from sitl.harness.view_layout import SEA_PERIOD_S, SceneGeometry  # noqa: E402
from sitl.harness.view_sources import read_timeseries  # noqa: E402


def read_rrd(path) -> dict[str, dict[str, list]]:
    """Every temporal chunk of a .rrd, with Rerun's own reader: entity → {"t": ns..., component: values...}."""
    import pyarrow as pa
    from rerun.chunk import RrdReader

    out: dict[str, dict[str, list]] = {}
    for chunk in RrdReader(path).stream():
        batch = chunk.to_record_batch()
        if "sim_time" not in batch.schema.names:
            continue
        e = out.setdefault(chunk.entity_path, {"t": []})
        e["t"] += batch.column("sim_time").cast(pa.int64()).to_pylist()
        for name in batch.schema.names:
            if ":" in name:
                e.setdefault(name, []).extend(batch.column(name).to_pylist())
    return out


def at(entity: dict[str, list], t: float) -> int:
    """The row of ``entity`` logged at time t (s; the CSV's 6 digits)."""
    i = int(np.argmin(np.abs(np.array(entity["t"]) / 1e9 - t)))
    assert abs(entity["t"][i] / 1e9 - t) < 1e-5
    return i


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("view") / "run"
    assert main(["run", "--case", "W1", "--duration", "8", "--no-plots", "--out", str(out)]) == 0
    return out


ENTITIES = ("/world/sea/true", "/world/sea/forecast", "/world/vehicle/true", "/world/vehicle/estimate",
            "/world/vehicle/true/thrusters", "/world/target/station", "/world/target/preview",
            "/plots/error/x/true", "/plots/error/z/plus_2sigma", "/plots/error/theta/minus_2sigma",
            "/plots/wave/true", "/plots/wave/forecast", "/plots/wrench/X/cpd", "/plots/wrench/Z/ff",
            "/plots/wrench/M/total", "/plots/ff/weight_X", "/plots/ff/skill_M", "/plots/nis/nis", "/events")


def test_recording_read_back_covers_the_mission_and_equals_the_timeseries(short_run):
    rec = read_rrd(short_run / "recording.rrd")
    missing = [e for e in ENTITIES if e not in rec]
    assert not missing, f"entities missing from the recording: {missing}"
    ts = read_timeseries(short_run / "timeseries.csv")
    t0, t1 = ts["t"][0], ts["t"][-1]
    for e in ENTITIES:
        if e == "/events":
            continue
        t = np.array(rec[e]["t"]) / 1e9
        slack = SEA_PERIOD_S if e.startswith("/world/sea") else 1e-6
        assert t.min() <= t0 + 1e-6 and t.max() >= t1 - slack, f"{e} covers {t.min():.2f}..{t.max():.2f} s"
    texts = [row[0] for row in rec["/events"]["TextLog:text"]]
    assert any(s == "Arming motors" for s in texts) and any("GUIDED" in s for s in texts), texts   # ArduSub's words
    # One tick, the recording against timeseries.csv (written with 6 significant digits)
    k = 77
    vehicle = rec["/world/vehicle/true"]
    i = at(vehicle, ts["t"][k])
    x, y, z = vehicle["Transform3D:translation"][i][0]
    assert (x, y, z) == pytest.approx((ts["x"][k], 0.0, ts["z"][k]), rel=1e-5, abs=1e-6)
    qx, qy, qz, qw = vehicle["Transform3D:quaternion"][i][0]
    assert (qx, qz) == (0.0, 0.0)                      # a pitch about the body's y axis only
    assert 2 * np.arctan2(qy, qw) == pytest.approx(ts["theta"][k], rel=1e-5, abs=1e-7)
    err = rec["/plots/error/x/true"]
    j = at(err, ts["t"][k])
    assert err["Scalars:scalars"][j][0] == pytest.approx(ts["x"][k] - ts["sp_x"][k], rel=1e-4, abs=1e-6)
    band = rec["/plots/error/z/plus_2sigma"]
    j = at(band, ts["t"][k])
    assert band["Scalars:scalars"][j][0] == pytest.approx(ts["z_hat"][k] - ts["sp_z"][k] + 2 * ts["sigma_z"][k],
                                                          abs=3e-5)   # 6 digits of z ≈ 5 m
    arrows = rec["/world/vehicle/true/thrusters"]
    assert len(arrows["Arrows3D:vectors"][0]) == 8


def test_the_thrust_replayed_from_the_logged_pwm_is_the_plants(tmp_path):
    """The arrows' thrust: the T200 curve and motor lag replayed on the PWM, against the plant's own motors."""
    spec = RunSpec(case="W1", duration=4.0)
    m = build_mission(spec)
    take_off(m)
    pwm, t, truth = [], [], []
    for _ in range(60):
        truth.append(m.plant.state.thrust.copy())
        t.append(m.plant.state.t)
        m.firmware.scheduler.run_tick()
        m.hal.step_world()
        pwm.append(list(m.firmware.last.mix.pwm))
    g = SceneGeometry.from_configs(spec.vehicle, None, 0.0)
    f, saturated, _ = replay_thrust(g, np.array(pwm), np.array(t), f0=truth[0])
    assert np.abs(np.array(truth)).max() > 5.0                      # the thrusters work: not a trivial check
    np.testing.assert_allclose(f, np.array(truth), rtol=1e-9, atol=1e-9)
    assert saturated.shape == (60, 8)


def test_elevation_grid_is_elevation_at_every_point():
    from sitl.sea import Sea
    c = Sea.load("W2").components
    x, t = np.linspace(-60.0, 60.0, 13), np.linspace(0.0, 30.0, 7)
    np.testing.assert_allclose(elevation_grid(c, x, t), elevation(c, x[None, :], t[:, None]), atol=1e-12)


def test_the_view_options_without_rerun_say_how_to_install_it(short_run, monkeypatch, capsys, tmp_path):
    monkeypatch.setitem(sys.modules, "rerun", None)        # import rerun now fails, as without the extra
    assert main(["view", str(short_run)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["wavekeep view: wavekeep view needs Rerun: pip install 'wavekeep[view]'"]
    assert main(["run", "--case", "W1", "--duration", "2", "--no-plots", "--out", str(tmp_path / "r")]) == 0
    assert "pip install 'wavekeep[view]'" in capsys.readouterr().err      # the run is fine, the recording skipped
    assert not (tmp_path / "r" / "recording.rrd").exists()


def test_view_converts_a_run_folder_and_refuses_what_it_cannot_read(short_run, tmp_path, capsys):
    assert main(["view", str(short_run), "--out", str(tmp_path / "a.rrd")]) == 0
    assert (tmp_path / "a.rrd").stat().st_size > 10_000
    (tmp_path / "junk.tlog").write_bytes(b"\x00" * 64)
    assert main(["view", str(tmp_path / "junk.tlog"), "--out", str(tmp_path / "b.rrd")]) == 2
    assert main(["view", str(tmp_path / "nowhere")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 2 and all(s.startswith("wavekeep view: ") for s in lines), lines
