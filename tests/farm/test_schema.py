"""schemathesis against /openapi.json: generated requests for
every operation, a bounded number each, on a real uvicorn over a real SQLite
file and embedded Redis (no worker), through every check schemathesis has
(`--checks all`). Every answer must conform to the documented schema and
none may be a server error."""

from __future__ import annotations

import hypothesis
import pytest
import schemathesis

from pydantic import SecretStr
from schemathesis.checks import CHECKS, load_all_checks, not_a_server_error
from schemathesis.config import SchemathesisConfig

from tests.farm.test_limits import _serve
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)

EXAMPLES = 25
TOKEN = "schema-token-81c2"
# Every check, positive_data_acceptance included. A job's body is the one
# place where data the document calls valid may still be refused: the
# document cannot say everything the service checks (a scene object's
# fields and expressions, a preset's name, the band rule), and such a body
# is rightly a 422 that says why; so a 422 is an accepted answer there, and
# only there. (A 422 for data the document could have ruled out, such as a
# null it allows or 3.0 for an integer, was fixed instead.)
CONFIG = SchemathesisConfig.from_str("""
[[operations]]
include-path = "/api/jobs"
include-method = "POST"
checks.positive_data_acceptance.expected-statuses = ["2XX", "401", "403", "404", "409", "422", "429", "507"]
""")


@pytest.fixture
def api_schema(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    server, thread, url = _serve(settings.model_copy(update={"max_active_jobs": 5, "api_token": SecretStr(TOKEN)}))
    yield schemathesis.openapi.from_url(url + "/openapi.json", config=CONFIG)
    server.should_exit = True
    thread.join(10)


def test_the_api_answers_every_generated_request_as_documented(api_schema):
    """Each operation's generated cases (EXAMPLES each, derandomized so a run
    is repeatable), through schemathesis's own checks."""
    load_all_checks()
    every_check = CHECKS.get_all()
    assert len(every_check) >= 14, [c.__name__ for c in every_check]
    failures, operations = [], 0
    for result in api_schema.get_all_operations():
        operation = result.ok()
        operations += 1

        @hypothesis.given(case=operation.as_strategy())
        @hypothesis.settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                             suppress_health_check=list(hypothesis.HealthCheck))
        def check(case):
            # /healthz: its documented 503 (no worker here; test_farm_supervise has them).
            excluded = [not_a_server_error] if operation.path == "/healthz" else []
            case.call_and_validate(headers={"Authorization": f"Bearer {TOKEN}"}, checks=every_check,
                                   excluded_checks=excluded)

        try:
            check()
        except (Exception, BaseExceptionGroup) as exc:  # noqa: BLE001 - collected, then reported all at once
            failures.append(f"{operation.method.upper()} {operation.path}: {str(exc)[:600]}")
    assert operations >= 15
    assert not failures, "\n\n".join(failures)
