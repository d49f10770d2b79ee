"""Config files: every shipped file loads; every bad value is named with its file, key and allowed range."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from bridge.configfile import ConfigError, configs_dir
from bridge.schemas import load_mission_config, load_vehicle_config
from sitl.harness.cli import main as wavekeep
from sitl.sea import Sea, load_sea_config

CONFIGS = configs_dir()


def write_variant(tmp_path: Path, src: Path, edit) -> Path:
    data = yaml.safe_load(src.read_text())
    edit(data)
    out = tmp_path / src.name
    out.write_text(yaml.safe_dump(data))
    return out


def test_shipped_configs_load_with_the_paper_values():
    v = load_vehicle_config("bluerov2_heavy")
    assert v["mass_properties"]["W"] == 112.8 and v["mass_properties"]["B"] == 114.8
    assert v["thrusters"]["thrust_max"] == 35.0
    for name, tp, hs in (("W1", 7.1, 2.78), ("W2", 9.5, 3.47), ("W3", 11.1, 3.24)):
        s = load_sea_config(name)
        assert (s["spectrum"]["tp"], s["spectrum"]["hs"], s["water_depth"]) == (tp, hs, 54.0)
        assert s["components"] >= 200
    m = load_mission_config("station_keeping")
    assert (m["setpoint"]["depth"], m["duration"], m["control_rate"]) == (5.0, 600.0, 20.0)


@pytest.mark.parametrize("loader, src, edit, key, allowed", [
    (load_sea_config, "sea/W1.yaml", lambda d: d["spectrum"].__setitem__("hs", -1.0), "spectrum.hs", "(0, 30]"),
    (load_sea_config, "sea/W1.yaml", lambda d: d.__setitem__("components", 3), "components", "[8, 4096]"),
    (load_sea_config, "sea/W1.yaml", lambda d: d.__setitem__("water_depth", ".nan"), "water_depth", "finite"),
    (load_sea_config, "sea/W1.yaml", lambda d: d["spectrum"].__setitem__("type", "bretschneider"),
     "spectrum.type", "'jonswap', 'measured'"),
    (load_sea_config, "sea/W1.yaml", lambda d: d.__setitem__("omega_band", [0.5]), "omega_band", "2"),
    (load_sea_config, "sea/W1.yaml", lambda d: d.__setitem__("seeed", 3), "seeed", "allowed keys"),
    (load_sea_config, "sea/W1.yaml", lambda d: d["spectrum"].pop("tp"), "spectrum.tp", "required"),
    (load_vehicle_config, "vehicle/bluerov2_heavy.yaml", lambda d: d["damping"].__setitem__("X_u", "13.7 kg/s"),
     "damping.X_u", "[0, 10000]"),
    (load_vehicle_config, "vehicle/bluerov2_heavy.yaml", lambda d: d["mass_properties"].pop("W"),
     "mass_properties.W", "missing"),
    (load_vehicle_config, "vehicle/bluerov2_heavy.yaml", lambda d: d["thrusters"]["layout"].pop(),
     "thrusters.layout", "exactly 8"),
    (load_vehicle_config, "vehicle/bluerov2_heavy.yaml",
     lambda d: d["thrusters"]["layout"][2].__setitem__("direction", [0, 0, 0]),
     "thrusters.layout[2].direction", "non-zero"),
    (load_mission_config, "mission/station_keeping.yaml", lambda d: d.__setitem__("control_rate", 0),
     "control_rate", "[1, 1000]"),
    (load_mission_config, "mission/station_keeping.yaml", lambda d: d["plant"].__setitem__("substeps", 1.5),
     "plant.substeps", "integer"),
])
def test_bad_values_name_file_key_and_allowed_range(tmp_path, loader, src, edit, key, allowed):
    path = write_variant(tmp_path, CONFIGS / src, edit)
    with pytest.raises(ConfigError) as info:
        loader(path)
    msg = str(info.value)
    assert str(path) in msg and f"'{key}'" in msg and allowed in msg, msg


def test_unreadable_and_malformed_files(tmp_path):
    bad = tmp_path / "broken.yaml"
    bad.write_text("name: W1\nspectrum: [unclosed\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_sea_config(bad)
    with pytest.raises(ConfigError, match="no such file"):
        load_sea_config(tmp_path / "missing.yaml")
    with pytest.raises(ConfigError, match=r"known: W1, W2, (W2F, )?W3"):
        load_sea_config("W9")


def test_case_accepts_a_path_and_a_measured_spectrum(tmp_path):
    csv = tmp_path / "buoy.csv"
    csv.write_text("frequency_hz,density_m2_per_hz\n0.05,0.0\n0.1,2.0\n0.14,6.0\n0.2,1.0\n0.4,0.05\n")
    path = write_variant(tmp_path, CONFIGS / "sea/W2.yaml", lambda d: d.__setitem__(
        "spectrum", {"type": "measured", "csv": "buoy.csv"}))
    sea = Sea.load(path)
    # Peak picked from the data (0.14 Hz); the band kept is [0.5, 5] × f_p = [0.07, 0.7] Hz
    assert sea.omega_peak == pytest.approx(2 * np.pi * 0.14)
    f = np.linspace(0.07, 0.4, 100001)
    m0 = np.trapezoid(np.interp(f, [0.05, 0.1, 0.14, 0.2, 0.4], [0.0, 2.0, 6.0, 1.0, 0.05]), f)
    assert sea.hs() == pytest.approx(4 * np.sqrt(m0), rel=0.02)


def test_cli_reports_a_bad_case_and_exits_2(tmp_path, capsys):
    assert wavekeep(["sea", "--case", "W9", "--out", str(tmp_path / "x.csv")]) == 2
    assert "W9" in capsys.readouterr().err
    bad = write_variant(tmp_path, CONFIGS / "sea/W1.yaml", lambda d: d.__setitem__("seed", -4))
    assert wavekeep(["sea", "--case", str(bad), "--out", str(tmp_path / "x.csv")]) == 2
    assert "'seed'" in capsys.readouterr().err


@pytest.mark.processes
def test_console_script_writes_the_sea_csv(tmp_path):
    out = tmp_path / "sea.csv"
    exe = Path(sys.executable).with_name("wavekeep")
    proc = subprocess.run([str(exe), "sea", "--case", "W1", "--duration", "60", "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = out.read_text().splitlines()
    assert lines[1] == "t_s,eta_m,u_m_per_s,w_m_per_s_down"
    assert len(lines) == 2 + 60 * 20 + 1
