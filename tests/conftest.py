import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# The independent oracles are the package tests.helpers (tests/helpers/).
sys.path.insert(0, str(REPO))


@pytest.fixture(scope="session")
def build_dir() -> Path:
    """build/ at the repository root, where the suites write their tables."""
    out = REPO / "build"
    out.mkdir(parents=True, exist_ok=True)
    return out
