"""What the CLI's process loads: `import argand.cli` imports typer and
nothing heavy, and `argand render` of one frame only what it uses (no
python-flint while no pixel reaches the exact tier, no Pillow, PyAV or
matplotlib without an animation or atlas, never the farm). Checked on
sys.modules in a fresh interpreter, not on time: the whole process's CPU is
measured by `argand bench bands` (cli_process_cpu_s, docs/benchmarks.md)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: Never imported by loading the CLI.
HEAVY = ("numpy", "rich", "pydantic", "yaml", "OpenImageIO", "flint", "PIL", "av", "matplotlib", "sqlalchemy",
         "fastapi", "starlette", "uvicorn", "celery", "redis", "argand.scene", "argand.render", "argand.media",
         "argand.farm", "argand.api", "argand.worker", "argand.serve", "argand.bench")
#: Never imported by `argand render` of one frame.
NOT_FOR_ONE_FRAME = ("flint", "PIL", "av", "matplotlib", "sqlalchemy", "fastapi", "starlette", "uvicorn", "celery",
                     "redis", "argand.farm", "argand.api", "argand.worker", "argand.serve", "argand.bench",
                     "argand.media.gif", "argand.media.video", "argand.media.atlas", "argand.media.contact_sheet")


def loaded_after(code: str, env: dict | None = None) -> tuple[set[str], dict]:
    """The modules loaded (and the OPENBLAS_NUM_THREADS seen) after ``code`` in a fresh interpreter."""
    probe = code + "\nimport json, os, sys\nprint(json.dumps({'modules': sorted(sys.modules), " \
                   "'openblas': os.environ.get('OPENBLAS_NUM_THREADS')}))"
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=REPO / "tests",
                         env=env, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    out = json.loads(run.stdout.strip().splitlines()[-1])
    return set(out["modules"]), out


def found(modules: set[str], names: tuple[str, ...]) -> list[str]:
    return sorted(n for n in names if any(m == n or m.startswith(n + ".") for m in modules))


def test_importing_the_cli_loads_nothing_heavy():
    modules, _ = loaded_after("import argand.cli")
    assert "typer" in modules and "argand.cli" in modules
    assert found(modules, HEAVY) == []


def test_one_frame_loads_only_what_it_uses(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    modules, out = loaded_after(
        "import sys\nfrom argand.cli import app\n"
        f"sys.argv = ['argand', 'render', 'whitney', '--size', '48x32', '--out', {str(tmp_path / 'out')!r}]\n"
        "try:\n    app()\nexcept SystemExit as exc:\n    assert not exc.code, exc.code", env=env)
    assert {"numpy", "OpenImageIO", "argand.render.sweep", "argand.media.frame_files"} <= modules
    assert found(modules, NOT_FOR_ONE_FRAME) == []
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["frame_0000.exr", "frame_0000.json",
                                                                    "frame_0000.png"]
    # numpy's OpenBLAS on one thread (its threads spin for work render never gives them)
    assert out["openblas"] == "1"
