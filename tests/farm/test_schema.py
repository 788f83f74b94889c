"""schemathesis against /openapi.json: generated requests for
every operation, a bounded number each, on a real uvicorn over a real SQLite
file and embedded Redis (no worker). Every answer must conform to the
documented schema and none may be a server error."""

from __future__ import annotations

import hypothesis
import pytest
import schemathesis

from pydantic import SecretStr
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import positive_data_acceptance

from tests.farm.test_limits import _serve
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)

EXAMPLES = 25
TOKEN = "schema-token-81c2"
# positive_data_acceptance is left out: the schema cannot say everything the
# service checks (a preset's name, a scene's expression, the band rule), and
# such a request is rightly a 422 with the reason.


@pytest.fixture
def api_schema(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    server, thread, url = _serve(settings.model_copy(update={"max_active_jobs": 5, "api_token": SecretStr(TOKEN)}))
    yield schemathesis.openapi.from_url(url + "/openapi.json")
    server.should_exit = True
    thread.join(10)


def test_the_api_answers_every_generated_request_as_documented(api_schema):
    """Each operation's generated cases (EXAMPLES each, derandomized so a run
    is repeatable), through schemathesis's own checks."""
    failures, operations = [], 0
    for result in api_schema.get_all_operations():
        operation = result.ok()
        operations += 1

        @hypothesis.given(case=operation.as_strategy())
        @hypothesis.settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                             suppress_health_check=list(hypothesis.HealthCheck))
        def check(case):
            excluded = [positive_data_acceptance]
            if operation.path == "/healthz":  # its documented 503: no worker here (test_farm_supervise has them)
                excluded.append(not_a_server_error)
            case.call_and_validate(headers={"Authorization": f"Bearer {TOKEN}"}, excluded_checks=excluded)

        try:
            check()
        except (Exception, BaseExceptionGroup) as exc:  # noqa: BLE001 - collected, then reported all at once
            failures.append(f"{operation.method.upper()} {operation.path}: {str(exc)[:600]}")
    assert operations >= 15
    assert not failures, "\n\n".join(failures)
