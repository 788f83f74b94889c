"""What can be tested of the deployment without a Docker engine: the compose
file parses, its commands are the CLI's, its paths exist, Redis is durable."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
ARGAND = str(Path(sys.executable).with_name("argand"))


def compose() -> dict:
    return yaml.safe_load((REPO / "docker-compose.yml").read_text())


def test_compose_services_and_replicas():
    c = compose()
    assert {"redis", "api", "worker"} <= set(c["services"])
    assert c["services"]["worker"]["deploy"]["replicas"] >= 2
    for name in ("api", "worker"):
        svc = c["services"][name]
        assert svc["environment"]["ARGAND_REDIS_URL"].startswith("redis://redis:")
        assert any(v.endswith(":/data") for v in svc["volumes"])


def test_compose_commands_are_cli_commands():
    c = compose()
    for name in ("api", "worker"):
        cmd = c["services"][name]["command"]
        r = subprocess.run([ARGAND, cmd[0], "--help"], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        for option in [a for a in cmd[1:] if a.startswith("--")]:
            assert option in r.stdout, (name, option)
    assert c["services"]["api"]["build"]["dockerfile"] == "services/Dockerfile"


def test_paths_exist_and_redis_is_durable():
    c = compose()
    assert (REPO / c["services"]["api"]["build"]["dockerfile"]).exists()
    conf_mount = c["services"]["redis"]["volumes"][0].split(":")[0]
    conf = (REPO / conf_mount).read_text()
    assert "appendonly yes" in conf and "maxmemory-policy noeviction" in conf
    dockerfile = (REPO / "services/Dockerfile").read_text()
    for folder in ("core", "python", "api", "worker"):
        assert f"COPY {folder} {folder}" in dockerfile and (REPO / folder).is_dir()
    assert 'ENTRYPOINT ["argand"]' in dockerfile
