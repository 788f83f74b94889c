"""The cluster harness runs what deploy/docker-compose.yml runs: the same
commands, the same variables (pointing at the harness's hosts), the same
health checks and the same Redis configuration, so that what the cluster
tests prove holds for the compose file. (No namespace is needed to check
this; it runs wherever the cluster tests do.)"""

from __future__ import annotations

from pathlib import Path

import yaml

from tests.cluster import harness

COMPOSE = Path(__file__).resolve().parents[2] / "deploy" / "docker-compose.yml"


def services() -> dict:
    return yaml.safe_load(COMPOSE.read_text())["services"]


def test_the_harness_runs_the_compose_files_commands_and_health_checks():
    s = services()
    assert s["api"]["command"] == harness.API_COMMAND
    assert s["worker"]["command"] == harness.WORKER_COMMAND
    assert s["worker"]["healthcheck"]["test"][1:] == harness.WORKER_HEALTH
    assert f"127.0.0.1:{harness.API_PORT}/readyz" in " ".join(s["api"]["healthcheck"]["test"])
    assert s["postgres"]["healthcheck"]["test"][1] == "pg_isready"
    assert s["redis"]["healthcheck"]["test"][1:] == ["redis-cli", "ping"]
    # Redis: the same configuration file, its folder given with --dir.
    redis = s["redis"]
    assert redis["command"] == ["redis-server", redis["volumes"][0].split(":")[1], "--dir"] + redis["command"][3:]
    assert harness.REDIS_COMMAND[1:] == [str(harness.REDIS_CONF), "--dir"]
    assert (COMPOSE.parent / redis["volumes"][0].split(":")[0]).resolve() == harness.REDIS_CONF


def test_the_harness_gives_every_farm_process_the_compose_files_variables():
    s = services()
    cluster = harness.Cluster.__new__(harness.Cluster)  # the addresses only: no namespace is made
    cluster.env, cluster.prefix, cluster.data = {}, "169.254.1", Path("/data")
    env = cluster.farm_env()
    for name in ("api", "worker"):
        compose_env = s[name]["environment"]
        assert set(compose_env) <= set(env), set(compose_env) - set(env)
        # The same URLs but for the host names: the database's user, password and name, Redis's port and db.
        pg = s["postgres"]["environment"]
        assert compose_env["ARGAND_DATABASE_URL"].replace("@postgres:", f"@{cluster.ip('db')}:") == env["ARGAND_DATABASE_URL"]
        assert compose_env["ARGAND_REDIS_URL"].replace("//redis:", f"//{cluster.ip('db')}:") == env["ARGAND_REDIS_URL"]
        assert f"{pg['POSTGRES_USER']}:{pg['POSTGRES_PASSWORD']}@" in env["ARGAND_DATABASE_URL"]
        assert compose_env["ARGAND_DATA_DIR"] == env["ARGAND_DATA_DIR"] == "/data"
        assert env["ARGAND_API_TOKEN"].strip()
