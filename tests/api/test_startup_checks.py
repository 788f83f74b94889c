"""What `argand api` refuses at start, with the reason, and what it takes:
a blank token (every write would then be a 401) or a blank token file
(every write a 422) stop the start; an IPv6 host written as in a URL,
``[::1]``, is served. Real CLI processes on loopback."""

from __future__ import annotations

import os
import subprocess
import time

import httpx

from tests.farm.test_farm import ARGAND, free_port

#: Redis is not needed to start: a port where nothing listens.
NO_REDIS = "redis://127.0.0.1:1/0"


def api(tmp_path, *args: str, **env: str) -> list[str]:
    return [ARGAND, "api", "--port", str(free_port()), "--data", str(tmp_path / "data"), *args]


def clean_env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ARGAND_")}
    return {**env, "ARGAND_REDIS_URL": NO_REDIS, **extra}


def test_a_blank_token_or_token_file_stops_the_start_with_the_reason(tmp_path):
    r = subprocess.run(api(tmp_path, "--host", "0.0.0.0"), env=clean_env(ARGAND_API_TOKEN="  \t "),
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "ARGAND_API_TOKEN is blank" in r.stderr + r.stdout, (r.returncode, r.stderr)
    token = tmp_path / "token"
    token.write_text("   \n\n")
    r = subprocess.run(api(tmp_path), env=clean_env(ARGAND_API_TOKEN_FILE=str(token)), capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 2 and f"the API token file {token} is empty" in r.stderr + r.stdout, (r.returncode, r.stderr)


def test_an_ipv6_host_in_brackets_is_served(tmp_path):
    port = free_port()
    cmd = [ARGAND, "api", "--host", "[::1]", "--port", str(port), "--data", str(tmp_path / "data")]
    with open(tmp_path / "api.log", "w") as log:
        proc = subprocess.Popen(cmd, env=clean_env(), stdout=log, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 60
        answered = None
        while time.monotonic() < deadline and answered is None:
            assert proc.poll() is None, (proc.returncode, (tmp_path / "api.log").read_text()[-2000:])
            try:
                answered = httpx.get(f"http://[::1]:{port}/healthz", timeout=10).status_code
            except httpx.HTTPError:
                time.sleep(0.2)
        assert answered in (200, 503)  # (503: no Redis, no worker; the API answers)
    finally:
        proc.terminate()
        proc.wait(30)
