"""The fuzzers' inputs replayed through the binding against the exact truth.

* fuzz/corpus/find_roots: the hand-made seeds (seed-*) and the inputs that
  fuzzing kept for their coverage (libFuzzer -merge=1): every case makes no
  false claim (tests/helpers/truth.py) and returns (about 750 cases, ~10 s of CPU).
* fuzz/findings/find_roots: what fuzzing found (see docs/reliability.md);
  each runs in its own process with a time limit, since some hung: each must
  return within FINDING_SECONDS and make no false claim. A finding stays here
  as a regression case once fixed.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers.fuzz_input import decode_roots_case, replay
from tests.test_properties import watchdog

FUZZ = Path(__file__).resolve().parents[1] / "fuzz"
CORPUS = sorted((FUZZ / "corpus" / "find_roots").iterdir())
FINDINGS = sorted((FUZZ / "findings" / "find_roots").iterdir())
#: A finding's replay takes well under a second when find_roots is right.
FINDING_SECONDS = 20


def test_the_corpus_is_there():
    assert len(CORPUS) >= 70 and FINDINGS


def test_seed_corpus_makes_no_false_claim():
    problems = []
    for path in CORPUS:
        case = decode_roots_case(path.read_bytes())
        if not case.valid:
            continue
        with watchdog():
            problems += [f"{path.name}: {p}" for p in replay(case)]
    assert not problems, problems


@pytest.mark.parametrize("path", FINDINGS, ids=[p.name for p in FINDINGS])
def test_fuzz_finding_returns_and_makes_no_false_claim(path):
    try:
        out = subprocess.run(
            [sys.executable, str(Path(__file__).parent / "helpers" / "fuzz_input.py"), str(path)],
            capture_output=True, text=True, timeout=FINDING_SECONDS, check=False,
        )
    except subprocess.TimeoutExpired:
        case = decode_roots_case(path.read_bytes())
        pytest.fail(f"find_roots did not return within {FINDING_SECONDS} s: {case}")
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert not result["problems"], result
