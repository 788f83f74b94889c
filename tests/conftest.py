import sys
from pathlib import Path

import pytest

# Test helpers (the independent ground truth) live beside the tests.
sys.path.insert(0, str(Path(__file__).parent))

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def build_dir() -> Path:
    """build/ at the repository root, where the suites write their tables."""
    out = REPO / "build"
    out.mkdir(parents=True, exist_ok=True)
    return out
