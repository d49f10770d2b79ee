"""The BlueOS extension as BlueOS's store and helper read it: the image's labels, the permissions (a Docker
ContainerCreate body consistent with the image and the entry point), ``/register_service``, the
Extensions-Repository's metadata.json and logo, the settings file's validation and the router endpoint's
registration against a real HTTP server. The image itself is built only where a Docker daemon answers."""
from __future__ import annotations

import json
import re
import shlex
import shutil
import subprocess
from pathlib import Path

import pytest
from blueos_rig import BlueOSStub

from blueos import __version__
from blueos.main import build_parser
from blueos.router import register_endpoint
from blueos.settings import Settings, SettingsError, SettingsStore, gain_presets
from firmware_py.params.table import load_params

ROOT = Path(__file__).resolve().parent.parent
DOCKERFILE = ROOT / "blueos" / "Dockerfile"
LABELS = ("version", "permissions", "authors", "company", "type", "tags", "readme", "links", "requirements")
CREATE_KEYS = {"Hostname", "Domainname", "User", "AttachStdin", "AttachStdout", "AttachStderr", "ExposedPorts",
               "Tty", "OpenStdin", "StdinOnce", "Env", "Cmd", "Healthcheck", "ArgsEscaped", "Image", "Volumes",
               "WorkingDir", "Entrypoint", "NetworkDisabled", "MacAddress", "OnBuild", "Labels", "StopSignal",
               "StopTimeout", "Shell", "HostConfig", "NetworkingConfig"}
"""The Docker Engine API's ContainerCreate body (ContainerConfig plus HostConfig and NetworkingConfig)."""
HOST_CONFIG_KEYS = {"Binds", "PortBindings", "ExtraHosts", "NetworkMode", "RestartPolicy", "Privileged", "Devices",
                    "CpuPeriod", "CpuQuota", "CpuShares", "NanoCpus", "Memory", "MemorySwap", "MemoryReservation",
                    "Mounts", "LogConfig", "CapAdd", "CapDrop", "Ulimits", "ShmSize", "DeviceCgroupRules"}


def dockerfile() -> list[tuple[str, str]]:
    """(instruction, arguments) of the Dockerfile, continuation lines joined as Docker joins them."""
    text = re.sub(r"\\\n", "", DOCKERFILE.read_text())
    out = []
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            word, _, rest = line.partition(" ")
            out.append((word.upper(), rest.strip()))
    return out


def labels() -> dict[str, str]:
    found: dict[str, str] = {}
    for word, rest in dockerfile():
        if word == "LABEL":
            for item in shlex.split(rest):
                key, _, value = item.partition("=")
                found[key] = value
    return found


def test_the_image_carries_every_label_blueos_store_reads():
    got = labels()
    assert set(LABELS) <= set(got), set(LABELS) - set(got)
    assert got["version"] == __version__ and re.fullmatch(r"\d+\.\d+\.\d+", got["version"])
    assert got["type"] == "device-integration"
    tags = json.loads(got["tags"])
    assert 0 < len(tags) <= 10 and all(t == t.lower() and " " not in t for t in tags)
    authors = json.loads(got["authors"])
    assert authors and all(set(a) == {"name", "email"} for a in authors)
    assert json.loads(got["company"])["name"]
    assert {"website", "support", "docs"} <= set(json.loads(got["links"]))
    assert "{tag}" in got["readme"] and got["readme"].endswith("blueos/README.md")
    assert re.fullmatch(r"core >= \d+\.\d+", got["requirements"])
    froms = [rest for word, rest in dockerfile() if word == "FROM"]
    assert froms == ["python:3.11-slim"]


def test_permissions_are_a_docker_create_body_consistent_with_the_image_and_entry_point():
    perms = json.loads(labels()["permissions"])
    assert set(perms) <= CREATE_KEYS, set(perms) - CREATE_KEYS
    host = perms["HostConfig"]
    assert set(host) <= HOST_CONFIG_KEYS, set(host) - HOST_CONFIG_KEYS
    defaults = build_parser().parse_args([])
    web = f"{defaults.port}/tcp"
    exposed = [rest for word, rest in dockerfile() if word == "EXPOSE"]
    assert exposed == [str(defaults.port)]
    assert set(perms["ExposedPorts"]) == {web} == set(host["PortBindings"])
    assert host["PortBindings"][web] == [{"HostPort": ""}]                 # BlueOS picks a free host port
    # bridge network (blueos/README.md): the router's UDP endpoint and BlueOS's API on the host's gateway
    assert "NetworkMode" not in host
    assert "host.docker.internal:host-gateway" in host["ExtraHosts"]
    assert "host.docker.internal" in defaults.mavlink and "host.docker.internal" in defaults.register_endpoint
    (bind,) = host["Binds"]
    outside, inside = bind.split(":")
    assert outside == "/usr/blueos/extensions/wavekeep" and inside == defaults.data
    assert 0 < host["CpuQuota"] <= host["CpuPeriod"]                        # at most one core
    assert host["Memory"] >= 256 * 2**20


def test_register_service_answers_blueos_required_fields(tmp_path):
    from fastapi.testclient import TestClient

    from blueos.service import CompanionService, ServiceOptions
    from blueos.web import create_app
    service = CompanionService(ServiceOptions(data=tmp_path), SettingsStore(tmp_path))
    with TestClient(create_app(service)) as client:
        doc = client.get("/register_service").json()
    for key in ("name", "description", "icon", "company", "version", "webpage", "api"):
        assert isinstance(doc[key], str) and doc[key], key
    assert doc["works_in_relative_paths"] is True
    assert doc["icon"].startswith("mdi-") and doc["version"] == __version__


def test_metadata_json_and_logo_for_the_extensions_repository():
    meta = json.loads((ROOT / "blueos" / "metadata.json").read_text())
    assert set(meta) == {"name", "website", "docker", "description"}
    tagged = re.search(r"-t (\S+):" + re.escape(__version__), DOCKERFILE.read_text())
    assert tagged and tagged.group(1) == meta["docker"]
    assert json.loads(labels()["links"])["website"] == meta["website"]
    assert (ROOT / "blueos" / "extension_logo.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_settings_file_is_validated_on_load(tmp_path):
    store = SettingsStore(tmp_path)
    assert store.load() == (Settings(), None)                           # no file yet: defaults, no error
    store.save(Settings(law="cpd_ff", method="servo"))
    assert store.load() == (Settings(law="cpd_ff", method="servo"), None)
    for text, why in (("{not json", "not JSON"), ('{"law": "pid"}', "law 'pid'"), ('{"colour": "red"}', "unknown"),
                      ('{"gains": 3}', "expected a string"), ('["cpd"]', "JSON object"),
                      ('{"forecast_endpoint": "localhost"}', "PROTO/HOST:PORT"), ('{"site": "a/b"}', "site")):
        store.path.write_text(text)
        settings, error = store.load()
        assert settings == Settings() and error and why in error and str(store.path) in error, (text, error)
    with pytest.raises(SettingsError, match="method"):
        Settings(method="pwm").checked()


def test_every_gain_preset_is_a_valid_parameter_set():
    presets = gain_presets()
    assert "default" in presets and Settings().gains in presets
    for name, params in presets.items():
        table = load_params("params", params)                               # ConfigError names a bad one
        assert all(table[k] == v for k, v in params.items()), name


def test_router_endpoint_is_registered_once_through_the_ardupilot_manager():
    blueos = BlueOSStub()
    try:
        assert "registered" in register_endpoint(blueos.url, 14771)
        (ep,) = blueos.endpoints
        assert (ep["connection_type"], ep["place"], ep["argument"], ep["persistent"]) == ("udpin", "0.0.0.0", 14771,
                                                                                          True)
        assert 3 <= len(ep["name"]) <= 50 and 3 <= len(ep["owner"]) <= 50
        assert "present" in register_endpoint(blueos.url, 14771) and len(blueos.endpoints) == 1    # not twice
    finally:
        blueos.close()
    assert "not reachable" in register_endpoint(blueos.url, 14771)


def test_the_image_builds_where_a_docker_daemon_answers():
    docker = shutil.which("docker")
    if docker is None or subprocess.run([docker, "info"], capture_output=True, timeout=30).returncode != 0:
        pytest.skip("no Docker daemon answers `docker info` here: the image is built where one does (CI with Docker)")
    tag = f"wavekeep/blueos-wavekeep:test-{__version__}"
    r = subprocess.run([docker, "build", "-f", str(DOCKERFILE), "-t", tag, str(ROOT)], capture_output=True,
                       text=True, timeout=1800)
    assert r.returncode == 0, r.stderr[-3000:]
    inspect = json.loads(subprocess.run([docker, "image", "inspect", tag], capture_output=True, text=True,
                                        check=True).stdout)
    assert inspect[0]["Config"]["Labels"]["permissions"].strip().startswith("{")
    assert json.loads(inspect[0]["Config"]["Labels"]["permissions"]) == json.loads(labels()["permissions"])


def test_the_readme_gives_the_owner_the_image_s_own_permissions_and_build_commands():
    readme = (ROOT / "blueos" / "README.md").read_text()
    block = re.search(r"Original settings.*?```json\n(.*?)```", readme, re.S)
    assert block and json.loads(block.group(1)) == json.loads(labels()["permissions"])
    assert "docker build -f blueos/Dockerfile -t wavekeep/blueos-wavekeep:" + __version__ in readme
    assert "--platform linux/arm/v7,linux/arm64/v8,linux/amd64" in readme
    assert "metadata.json" in readme and "extension_logo.png" in readme
