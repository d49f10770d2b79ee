"""The extension's web app through its test client (no vehicle): the page works under a relative path, engage
is refused with its reason when there is no link, settings persist across a restart of the app, bad settings
(a bad form value, a bad file) give a clear error and change nothing; and the entry point's bad options."""
from __future__ import annotations

import json
import re
import socket
import subprocess
import sys
from types import SimpleNamespace

import pytest
from fastapi.testclient import TestClient

from blueos.service import CompanionService, ServiceOptions
from blueos.settings import Settings, SettingsStore
from blueos.web import create_app
from sitl.harness.ports import free_port

NEW = {"law": "cpd_ff", "gains": "half", "method": "servo", "forecast_endpoint": "tcp/192.168.2.1:7447",
       "site": "harbour"}


def client(folder) -> tuple[TestClient, CompanionService]:
    service = CompanionService(ServiceOptions(data=folder), SettingsStore(folder), log=lambda _t: None)
    return TestClient(create_app(service)), service


def test_the_page_has_a_title_and_uses_relative_urls_only(tmp_path):
    c, _ = client(tmp_path)
    r = c.get("/")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    assert "<title>Wavekeep</title>" in r.text
    # under /extensionv2/wavekeep/ an absolute URL would leave the extension's prefix
    assert not re.search(r"""(fetch\(\s*[`'"]/|href=["']/|src=["']/|action=["']/)""", r.text)
    assert 'fetch("v1/status")' in r.text
    ids = re.findall(r'\bid="([^"]+)"', r.text)
    assert len(ids) == len(set(ids)), sorted(i for i in ids if ids.count(i) > 1)      # the script finds each one


def test_engage_without_a_link_is_refused_with_the_reason(tmp_path):
    c, _ = client(tmp_path)
    r = c.post("/v1/engage")
    assert r.status_code == 409 and r.json()["message"].startswith("not engaged: starting")
    assert c.post("/v1/release").json() == {"ok": True, "message": "not engaged"}
    s = c.get("/v1/status").json()
    assert not s["link"]["ok"] and not s["control"]["engaged"] and s["control"]["errors"] is None


def test_a_setting_persists_across_a_restart_of_the_app(tmp_path):
    c, _ = client(tmp_path)
    assert c.get("/v1/settings").json()["settings"] == Settings().as_dict()
    r = c.put("/v1/settings", json=NEW)
    assert r.status_code == 200 and r.json()["settings"] == NEW
    c2, service = client(tmp_path)                                 # a new process on the same data folder
    doc = c2.get("/v1/settings").json()
    assert doc["settings"] == NEW and doc["error"] is None
    assert set(doc["choices"]["law"]) == {"cpd", "cpd_ff", "mpc"} and "half" in doc["choices"]["gains"]
    assert json.loads((tmp_path / "settings.json").read_text()) == NEW
    argv = service.companion_argv(service.settings)                # what the companion then flies
    assert argv[argv.index("--method") + 1] == "servo" and argv[argv.index("--forecast") + 1] == "zenoh"
    assert "WK_PD_KP_X=0.6" in argv and "harbour" in (tmp_path / "network.yaml").read_text()


@pytest.mark.parametrize("body, why", [(b"{law: cpd}", "not JSON"), (b'{"law": "pid"}', "law 'pid'"),
                                       (b'{"gains": 1}', "expected a string"), (b'{"colour": "red"}', "unknown"),
                                       (b'{"method": "pwm"}', "method"), (b'{"site": "x/y"}', "site"),
                                       (b'{"forecast_endpoint": "7447"}', "PROTO/HOST:PORT")])
def test_a_bad_setting_is_refused_with_the_reason_and_changes_nothing(tmp_path, body, why):
    c, _ = client(tmp_path)
    c.put("/v1/settings", json=NEW)
    r = c.put("/v1/settings", content=body, headers={"Content-Type": "application/json"})
    assert r.status_code == 400 and why in r.json()["error"], r.json()
    assert c.get("/v1/settings").json()["settings"] == NEW
    assert json.loads((tmp_path / "settings.json").read_text()) == NEW


def test_settings_do_not_change_while_engaged(tmp_path):
    c, service = client(tmp_path)
    service.commander = SimpleNamespace(engaged=True, depth_only=False, events=[])
    r = c.put("/v1/settings", json=NEW)
    assert r.status_code == 400 and "release" in r.json()["error"]
    assert not (tmp_path / "settings.json").exists()


def test_a_bad_settings_file_gives_the_defaults_and_says_why(tmp_path):
    (tmp_path / "settings.json").write_text('{"law": "cpd_ff", "gains": "turbo"}')
    c, _ = client(tmp_path)
    s = c.get("/v1/status").json()
    assert s["settings"] == Settings().as_dict()
    assert "gains 'turbo'" in s["settings_error"] and "settings.json" in s["settings_error"]
    assert c.put("/v1/settings", json=NEW).status_code == 200                # the pilot fixes it from the page
    assert c.get("/v1/status").json()["settings_error"] is None


@pytest.mark.parametrize("args, why", [(["--port", "99999"], "--port 99999: must be in [1, 65535]"),
                                       (["--stale", "soon"], "--stale soon: not a number"),
                                       (["--mavlink", "tcp:127.0.0.1:5777"], "needs udpout:HOST:PORT")])
def test_bad_options_are_one_line_and_exit_2(tmp_path, args, why):
    r = subprocess.run([sys.executable, "-m", "blueos.main", "--data", str(tmp_path), *args], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and why in r.stderr, r.stderr


def test_a_web_port_in_use_exits_1(tmp_path):
    with socket.socket() as s:
        port = free_port(socket.SOCK_STREAM)
        s.bind(("127.0.0.1", port))
        s.listen()
        r = subprocess.run([sys.executable, "-m", "blueos.main", "--host", "127.0.0.1", "--port", str(port), "--data",
                            str(tmp_path), "--register-endpoint", "none"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 1 and "did not start" in r.stderr, r.stderr
