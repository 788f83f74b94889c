"""What can be tested of the deployment without a Docker engine: the compose
file against the CLI's commands, the settings and the services it names;
the worker's health check; and the image's contents: a wheel built from
exactly the files the Dockerfile copies serves the front end."""

from __future__ import annotations

import os
import shlex
import shutil
import socket
import subprocess
import sys
import sysconfig
import time
import zipfile
from pathlib import Path

import pytest
import yaml
from sqlalchemy.engine import make_url

from argand.farm.settings import Settings

REPO = Path(__file__).resolve().parents[1]
ARGAND = str(Path(sys.executable).with_name("argand"))
DOCKERFILE = REPO / "deploy" / "Dockerfile"
COMPOSE = REPO / "deploy" / "docker-compose.yml"


def compose() -> dict:
    return yaml.safe_load(COMPOSE.read_text())


def test_the_top_level_compose_file_includes_the_deployment():
    assert yaml.safe_load((REPO / "docker-compose.yml").read_text()) == {"include": ["deploy/docker-compose.yml"]}


def test_compose_runs_postgres_redis_the_api_and_two_workers_with_healthchecks():
    services = compose()["services"]
    assert set(services) == {"postgres", "redis", "api", "worker"}
    assert services["worker"]["deploy"]["replicas"] >= 2
    for name, svc in services.items():
        assert svc["healthcheck"]["test"][0] == "CMD", name
    assert services["api"]["depends_on"] == {"postgres": {"condition": "service_healthy"},
                                             "redis": {"condition": "service_healthy"}}
    # The API upgrades the schema on start: the workers wait for it.
    assert services["worker"]["depends_on"] == {"api": {"condition": "service_healthy"}}


def test_the_services_environment_is_the_settings_and_points_at_the_services():
    services = compose()["services"]
    fields = {f"ARGAND_{name.upper()}" for name in Settings.model_fields}
    pg = services["postgres"]["environment"]
    for name in ("api", "worker"):
        env = services[name]["environment"]
        assert set(env) <= fields, set(env) - fields
        db = make_url(env["ARGAND_DATABASE_URL"])
        assert db.get_backend_name() == "postgresql" and db.host == "postgres"
        assert (db.username, db.password, db.database) == (pg["POSTGRES_USER"], pg["POSTGRES_PASSWORD"], pg["POSTGRES_DB"])
        assert env["ARGAND_REDIS_URL"].startswith("redis://redis:6379/")
        settings = Settings(**{k.removeprefix("ARGAND_").lower(): v for k, v in env.items()})
        assert settings.sqlalchemy_url == env["ARGAND_DATABASE_URL"] and str(settings.data_dir) == "/data"
        # The API serves beyond its container: compose insists on a token (its ${VAR:?} form).
        assert env["ARGAND_API_TOKEN"].startswith("${ARGAND_API_TOKEN:?")
        assert settings.model_copy(update={"host": "0.0.0.0"}).exposure_problem() is None
        # The frame store is one volume, shared.
        assert f"argand-data:{env['ARGAND_DATA_DIR']}" in services[name]["volumes"]


def test_compose_commands_are_cli_commands():
    services = compose()["services"]
    for name in ("api", "worker"):
        cmd = services[name]["command"]
        r = subprocess.run([ARGAND, cmd[0], "--help"], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        for option in [a for a in cmd[1:] if a.startswith("--")]:
            assert option in r.stdout, (name, option)
        build = services[name]["build"]
        assert (COMPOSE.parent / build["context"] / build["dockerfile"]).resolve() == DOCKERFILE
    api = services["api"]
    port = api["command"][api["command"].index("--port") + 1]
    assert api["ports"] == [f"{port}:{port}"] and f"127.0.0.1:{port}/readyz" in " ".join(api["healthcheck"]["test"])
    assert services["worker"]["healthcheck"]["test"][1:] == ["python", "-m", "argand.worker.health"]


def test_redis_runs_the_one_redis_conf_durably():
    redis = compose()["services"]["redis"]
    mount, target = redis["volumes"][0].split(":")[:2]
    assert redis["command"][:2] == ["redis-server", target]
    assert (COMPOSE.parent / mount).resolve() == REPO / "src" / "argand" / "serve" / "redis.conf"
    conf = (COMPOSE.parent / mount).read_text()
    assert "appendonly yes" in conf and "maxmemory-policy noeviction" in conf


def test_the_worker_health_check_sees_this_hosts_heartbeat(tmp_path):
    from argand.farm.database import upgrade
    from argand.farm.workers import heartbeat
    from argand.worker.health import healthy

    settings = Settings(data_dir=tmp_path, heartbeat_timeout_s=2)
    upgrade(settings.sqlalchemy_url)
    assert not healthy(settings, socket.gethostname())
    heartbeat(settings, "w1", os.getpid())
    assert healthy(settings, socket.gethostname()) and not healthy(settings, "another-host")
    time.sleep(2.1)
    assert not healthy(settings, socket.gethostname())  # silent too long


def dockerfile_copies() -> list[str]:
    """The sources of the build stage's COPY lines (the files the wheel is built from)."""
    stage = DOCKERFILE.read_text().split("\nFROM ")[1]
    out = []
    for line in stage.splitlines():
        if line.startswith("COPY ") and "--from" not in line:
            out += shlex.split(line)[1:-1]
    return out


def test_the_dockerfile_copies_every_folder_of_the_package():
    import tomllib

    packages = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["scikit-build"]["wheel"]["packages"]
    copies = dockerfile_copies()
    assert packages == ["src/argand"]
    assert {"src", "core"} <= set(copies)
    assert {"pyproject.toml", "CMakeLists.txt", "README.md"} <= set(copies)
    assert 'ENTRYPOINT ["argand"]' in DOCKERFILE.read_text()


@pytest.mark.slow
def test_a_wheel_built_from_the_dockerfiles_files_serves_the_front_end(tmp_path):
    """The image's build, without Docker: the files the Dockerfile copies, a
    wheel built from them alone, and the app from that wheel (not from this
    checkout) serving / and /static/app.js."""
    src = tmp_path / "src"
    src.mkdir()
    for name in dockerfile_copies():
        copy = shutil.copytree if (REPO / name).is_dir() else shutil.copy2
        copy(REPO / name, src / name, **({"ignore": shutil.ignore_patterns("__pycache__")} if copy is shutil.copytree else {}))
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-build-isolation", "--no-deps", "-q", "-w",
                        str(tmp_path / "dist"), str(src)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    (wheel,) = (tmp_path / "dist").glob("argand-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {"argand/web/index.html", "argand/web/app.js", "argand/api/app.py",
            "argand/farm/migrations/versions/0001_initial.py",
            "argand/farm/migrations/versions/0002_outbox.py", "argand/farm/migrations/versions/0003_frame_grid.py",
            "argand/serve/redis.conf", "argand/core/_core.pyi"} <= names
    assert not [n for n in names if n.endswith((".cpp", ".h"))]
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    # -S: no site-packages hooks (this checkout's editable install stays out); the dependencies come after the wheel.
    path = os.pathsep.join([str(site), sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]])
    check = f"""
import socket, threading, time, urllib.request
import uvicorn
import argand.api.app as a
from argand.farm.settings import Settings
assert a.__file__.startswith({str(site)!r}), a.__file__
with socket.socket() as s:
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
server = uvicorn.Server(uvicorn.Config(a.create_app(Settings(data_dir={str(tmp_path / 'data')!r})), port=port, log_level="warning"))
threading.Thread(target=server.run, daemon=True).start()
while not server.started:
    time.sleep(0.05)
page = urllib.request.urlopen(f"http://127.0.0.1:{{port}}/").read().decode()
assert '<script type="module" src="/static/app.js">' in page, page[:200]
assert urllib.request.urlopen(f"http://127.0.0.1:{{port}}/static/app.js").status == 200
server.should_exit = True
"""
    r = subprocess.run([sys.executable, "-S", "-c", check], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=path), cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
