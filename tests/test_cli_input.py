"""Issue #17: bad input is one line ``wavekeep CMD: …`` on stderr, exit 2 — never a traceback, nothing left behind."""
from __future__ import annotations

import contextlib
import os
import socket
import subprocess
import sys

import pytest

from sitl.harness.cli import build_parser, main


def refused(capsys, argv: list[str], *words: str) -> str:
    """Run ``wavekeep argv``; assert exit 2 and one stderr line starting ``wavekeep CMD:`` naming ``words``."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"wavekeep {argv[0]}: "), err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def test_out_is_a_file(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    refused(capsys, ["run", "--duration", "5", "--out", str(f)], "--out", "is a file")
    refused(capsys, ["run", "--duration", "5", "--out", str(f / "sub")], "--out", "is a file")
    assert f.read_text() == "x" and sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_out_not_writable(capsys):
    refused(capsys, ["openloop", "--duration", "5", "--out", "/proc/wavekeep-test/x"], "--out", "cannot write")


def test_out_not_empty_needs_force(tmp_path, capsys):
    """README: ``--force`` reuses a folder, removing the previous run's files first; anything else stays."""
    stale = ["results.json", "timeseries.csv", "time_history.png", "firmware.log", "plant.log", "mission.tlog",
             "reproduce.json"]                   # a `wavekeep sim` or `reproduce` left these; openloop writes fewer
    for name in stale:
        (tmp_path / name).write_text("stale")
    (tmp_path / "ardusub" / "logs").mkdir(parents=True)           # the real ArduSub's working folder
    (tmp_path / "ardusub" / "eeprom.bin").write_text("stale")
    (tmp_path / "notes.txt").write_text("mine")
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "old.log").write_text("mine too")
    refused(capsys, ["openloop", "--duration", "1", "--out", str(tmp_path)], "not empty", "--force")
    assert all((tmp_path / name).read_text() == "stale" for name in stale)     # refused: nothing touched
    assert main(["openloop", "--duration", "1", "--out", str(tmp_path), "--force"]) == 0
    written = {"results.json", "timeseries.csv", "openloop.png", "run.json"}
    assert {p.name for p in tmp_path.iterdir()} == written | {"notes.txt", "mine"}    # no stale run file left
    assert all((tmp_path / name).read_text() != "stale" for name in written & set(stale))
    assert (tmp_path / "notes.txt").read_text() == "mine"      # not the run's: kept
    assert (tmp_path / "mine" / "old.log").read_text() == "mine too"     # nor is a sub-folder's


@pytest.mark.parametrize("value, words", [("1e9", ("--duration", "one day")), ("0.01", ("--duration", "control")),
                                          ("nan", ("--duration",)), ("-5", ("--duration",))])
def test_duration_bounds(tmp_path, capsys, value, words):
    refused(capsys, ["run", "--duration", value, "--out", str(tmp_path / "r")], *words)
    assert not (tmp_path / "r").exists()


def test_reproduce_refuses_and_leaves_no_folder(tmp_path, capsys):
    refused(capsys, ["reproduce", "--workers", "0", "--out", str(tmp_path / "r")], "--workers")
    refused(capsys, ["reproduce", "--duration", "0.01", "--out", str(tmp_path / "r")], "--duration")
    refused(capsys, ["reproduce", "--set", "NOPE=1", "--out", str(tmp_path / "r")], "--set NOPE=1")
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("argv, words", [
    (["--plant-port", "14550", "--gcs-port", "14550"], ("--plant-port", "--gcs-port")),
    (["--plant-port", "0"], ("--plant-port", "1-65535")),
    (["--gcs-port", "70000"], ("--gcs-port",)),
    (["--controller", "cpd_ff", "--forecast", "dswp", "--dswp-set", "window_s=60"],
     ("--dswp-set", "window_s", "deep_water")),
    (["--sea-set", "current.speed=9"], ("--sea-set", "current.speed")),
    (["--true-vehicle", "no_such_vehicle"], ("--true-vehicle", "no_such_vehicle")),
])
def test_sim_ports(tmp_path, capsys, argv, words):
    refused(capsys, ["sim", *argv, "--out", str(tmp_path / "s")], *words)
    assert not (tmp_path / "s").exists()


def test_sim_refuses_in_one_line_while_its_default_ports_are_held(tmp_path, monkeypatch, capsys):
    """Another run holds the default ports (here: ports this test holds, as the defaults): a refused sim still
    says one line and nothing else, since the ports are chosen only after every check has passed."""
    from sitl.harness.commands import processes

    with contextlib.ExitStack() as stack:
        for name, (_, kind, what) in list(processes.SIM_PORTS.items()):
            held = stack.enter_context(socket.socket(socket.AF_INET, kind))
            held.bind(("127.0.0.1", 0))
            if kind == socket.SOCK_STREAM:
                held.listen()
            monkeypatch.setitem(processes.SIM_PORTS, name, (held.getsockname()[1], kind, what))
        refused(capsys, ["sim", "--sea-set", "current.speed=9", "--out", str(tmp_path / "s")], "--sea-set")
        refused(capsys, ["sim", "--true-vehicle", "no_such_vehicle", "--out", str(tmp_path / "s")], "--true-vehicle")
    assert not (tmp_path / "s").exists()


def test_sim_default_port_is_not_one_given_for_another_process(monkeypatch, capsys):
    """`--plant-port 14550` with the GCS port left out: the GCS gets a free port, not the plant's."""
    import argparse

    from sitl.harness.commands import processes
    from sitl.harness.ports import free_port

    spare = free_port()
    monkeypatch.setitem(processes.SIM_PORTS, "--gcs-port", (spare, socket.SOCK_DGRAM, "GCS"))
    ports = processes._sim_ports(argparse.Namespace(plant_port=spare, gcs_port=None, zenoh_port=7000))
    assert ports["--plant-port"] == spare and ports["--gcs-port"] not in (spare, 7000)
    assert f"port {spare} (GCS) is taken; using {ports['--gcs-port']}" in capsys.readouterr().err


def test_live_udpin_port_in_use(capsys):
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        refused(capsys, ["live", "--mavlink", f"udpin:127.0.0.1:{port}", "--duration", "1"], "--mavlink", "port")


def test_thrust_inputs(tmp_path, capsys):
    refused(capsys, ["thrust", "--csv", str(tmp_path / "missing.csv"), "--mavlink", "udpin:127.0.0.1:0"],
            "--csv", "no such file")
    refused(capsys, ["thrust", "--mavlink", "bogus"], "--mavlink", "udpout:HOST:PORT")
    refused(capsys, ["thrust", "--amplitude", "5", "--mavlink", "udpin:127.0.0.1:0"], "--amplitude", "[-1, 1]")
    bad = tmp_path / "bad.csv"
    bad.write_text("t,surge,heave,pitch\n0,0,0,0\n1,x,0,0\n")
    refused(capsys, ["thrust", "--csv", str(bad), "--mavlink", "udpin:127.0.0.1:0"], "--csv")


@pytest.mark.parametrize("argv, words", [
    (["--seed", "-1"], ("--seed",)),
    (["--seed", "12345678901234567890123"], ("--seed", "2^63")),
    (["--forecast-snr-db", "-100"], ("--forecast-snr-db",)),
    (["--forecast-snr-db", "nan"], ("--forecast-snr-db",)),
    (["--controller", "cpd", "--forecast-snr-db", "15"], ("--forecast-snr-db", "--controller")),
    (["--forecast", "dswp", "--forecast-snr-db", "15"], ("--forecast-snr-db", "--forecast")),
    (["--set", "WK_PD_KP_X=-5"], ("--set WK_PD_KP_X=-5",)),
    (["--set", "WK_PD_KP_X"], ("--set", "NAME=VALUE")),
])
def test_run_options(tmp_path, capsys, argv, words):
    line = refused(capsys, ["run", "--duration", "5", *argv, "--out", str(tmp_path / "r")], *words)
    assert "params.yaml" not in line
    assert not (tmp_path / "r").exists()


def test_params_file_is_blamed(tmp_path, capsys):
    p = tmp_path / "p.yaml"
    p.write_text("WK_NOT_A_PARAM: 1\n")
    refused(capsys, ["run", "--params", str(p), "--out", str(tmp_path / "r")], "--params", "WK_NOT_A_PARAM")


def test_spectrum_csv_error_is_a_config_error(tmp_path, capsys):
    (tmp_path / "bad.csv").write_text("f,d\n0.1,1\nx,y\n")
    (tmp_path / "sea.yaml").write_text("spectrum: {type: measured, csv: bad.csv}\n")
    refused(capsys, ["sea", "--case", str(tmp_path / "sea.yaml"), "--out", str(tmp_path / "o.csv")], "config error",
            "spectrum.csv")
    assert not (tmp_path / "o.csv").exists()


def test_minimal_measured_sea_yaml(tmp_path, capsys):
    """README: a sea YAML needs only what differs from the defaults."""
    (tmp_path / "buoy.csv").write_text("0.05,0.1\n0.1,2.0\n0.15,1.0\n0.2,0.3\n0.3,0.05\n")
    (tmp_path / "sea.yaml").write_text("spectrum: {type: measured, csv: buoy.csv}\n")
    argv = ["sea", "--case", str(tmp_path / "sea.yaml"), "--duration", "60", "--out", str(tmp_path / "o.csv")]
    assert main(argv) == 0
    assert (tmp_path / "o.png").is_file()
    assert (tmp_path / "o.csv").read_text().splitlines()[1] == "t_s,eta_m,u_m_per_s,w_m_per_s_down"


def test_every_option_has_help_and_its_default_shown():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, p in sub.choices.items():
        if name in ("plant", "firmware"):
            continue
        text = p.format_help()
        for a in p._actions:
            if a.help == "==SUPPRESS==" or a.dest == "help":
                continue
            assert a.help, f"{name} {a.option_strings or a.dest} has no help"
            if a.option_strings and a.default not in (None, False) and a.default != "==SUPPRESS==":
                assert f"(default: {a.default})" in " ".join(text.split()), (name, a.option_strings)


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("wavekeep ")


@pytest.mark.processes
def test_a_subprocess_error_is_one_line(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "sitl.harness.cli", "run", "--seed", "-1", "--out",
                           str(tmp_path / "r")], capture_output=True, text=True, timeout=120)
    assert (proc.returncode == 2 and proc.stderr.count("\n") == 1 and proc.stderr.startswith("wavekeep run: --seed")) \
        or proc.stderr.startswith("wavekeep run: argument --seed"), proc.stderr


@pytest.mark.parametrize("cmd", ["sea", "forecast"])
def test_vehicle_is_not_an_option_where_no_vehicle_flies(tmp_path, capsys, cmd):
    refused(capsys, [cmd, "--vehicle", "bluerov2_heavy", "--out", str(tmp_path / "x.csv")] if cmd == "sea"
            else [cmd, "--vehicle", "bluerov2_heavy"], "--vehicle")
    assert not (tmp_path / "x.csv").exists()


def test_sim_takes_a_free_port_when_a_default_is_held(monkeypatch, capsys):
    """`make run` while QGroundControl (or another sim) holds a default port: a free port, said so."""
    import argparse

    from sitl.harness.commands import processes
    from sitl.harness.ports import free_port

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as held:
        held.bind(("127.0.0.1", 0))
        taken = held.getsockname()[1]
        spare = free_port()
        monkeypatch.setitem(processes.SIM_PORTS, "--gcs-port", (taken, socket.SOCK_DGRAM, "GCS"))
        monkeypatch.setitem(processes.SIM_PORTS, "--plant-port", (spare, socket.SOCK_DGRAM, "plant"))
        ports = processes._sim_ports(argparse.Namespace(plant_port=None, gcs_port=None, zenoh_port=7000))
    assert ports["--gcs-port"] != taken and ports["--plant-port"] == spare and ports["--zenoh-port"] == 7000
    err = capsys.readouterr().err
    assert f"port {taken} (GCS) is taken; using {ports['--gcs-port']}" in err


def test_plant_refuses_bad_world_options(capsys):
    from sitl.physics_server import main as plant_main

    for argv, word in ((["--sea-set", "current.speed=9"], "current.speed"), (["--sea-set", "oops"], "KEY=VALUE"),
                       (["--true-vehicle", "no_such_vehicle"], "no_such_vehicle")):
        assert plant_main(["--port", "0", *argv]) == 2
        err = capsys.readouterr().err
        assert err.startswith("wavekeep plant: ") and word in err and "Traceback" not in err


def test_wavekeep_runs_with_one_blas_thread_unless_told_otherwise():
    """The CLI sets one BLAS thread before numpy is imported (sitl/harness/blas.py), and leaves a choice alone."""
    code = ("import os, sys; from sitl.harness.cli import main; main(['--version']); "
            "print(os.environ['OPENBLAS_NUM_THREADS'], 'numpy' in sys.modules)")
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.split()[-2:] == ["1", "False"]
    out = subprocess.run([sys.executable, "-c", code], env={**env, "OPENBLAS_NUM_THREADS": "2"},
                         capture_output=True, text=True, check=True).stdout
    assert out.split()[-2] == "2"


def test_sim_refuses_an_autopilot_it_cannot_run(tmp_path, capsys):
    """--autopilot takes ardusub:PATH to an executable file; anything else is one line before anything starts."""
    script = tmp_path / "ardusub"
    script.write_text("#!/bin/sh\n")
    cases = (("px4:/bin/true", ("expected ardusub:PATH",)), ("ardusub:", ("expected ardusub:PATH",)),
             (f"ardusub:{tmp_path / 'none'}", ("no such file",)), (f"ardusub:{script}", ("not executable",)))
    for spec, words in cases:
        refused(capsys, ["sim", "--autopilot", spec, "--out", str(tmp_path / "run")], *words)
    assert not (tmp_path / "run").exists()


def test_plant_refuses_bad_foreign_world_options(capsys):
    from sitl.physics_server import main as plant_main

    for argv, word in ((["--sea-start", "-1"], "sea_start"), (["--physics-rate", "0"], "physics rate"),
                       (["--start", "orbit"], "invalid choice")):
        try:
            status = plant_main(["--port", "0", *argv])
        except SystemExit as exc:                        # argparse's own refusal (a choice)
            status = exc.code
        assert status == 2
        err = capsys.readouterr().err
        assert word in err and "Traceback" not in err, err


def test_ardusub_set_needs_the_autopilot_and_numbers(tmp_path, capsys):
    refused(capsys, ["sim", "--ardusub-set", "SIM_BAR2_RND=0.01", "--out", str(tmp_path / "a")], "--autopilot")
    refused(capsys, ["sim", "--autopilot", "ardusub:/bin/true", "--ardusub-set", "SIM_BAR2_RND", "--out",
                     str(tmp_path / "b")], "NAME=NUMBER")
