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

import pytest

REPO = Path(__file__).resolve().parents[1]

#: Never imported by loading the CLI.
HEAVY = ("numpy", "rich", "pydantic", "yaml", "OpenImageIO", "flint", "PIL", "av", "matplotlib", "sqlalchemy",
         "fastapi", "starlette", "uvicorn", "celery", "redis", "argand.scene", "argand.render", "argand.media",
         "argand.farm", "argand.api", "argand.worker", "argand.serve", "argand.bench")
#: Never imported by `argand render` of one frame.
#: (typer's pydantic adapters and the scene's pydantic models: not for a
#: preset; rich: not for work that ends before its progress bar would show.)
NOT_FOR_ONE_FRAME = ("rich", "flint", "pydantic", "typer._adapters", "argand.scene.schema", "PIL", "av", "matplotlib",
                     "sqlalchemy", "fastapi", "starlette", "uvicorn", "celery",
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
    # (the progress bar's delay made long enough that a slow machine does not show it)
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"} | {"ARGAND_PROGRESS_AFTER": "60"}
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


def test_numpy_is_loaded_with_one_blas_thread_whatever_the_options(tmp_path):
    """OPENBLAS_NUM_THREADS=1 is set before numpy is loaded, not only by the
    time the command ends: an option's callback (--tile's check) imports
    numpy before the command's body runs, and OpenBLAS reads the variable
    when it is loaded (its spinning threads cost about a quarter of a
    one-frame process's CPU)."""
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    hook = ("import os, sys\nseen = {}\nclass Spy:\n"
            "    def find_spec(self, name, path=None, target=None):\n"
            "        if name == 'numpy' and 'at_numpy' not in seen:\n"
            "            seen['at_numpy'] = os.environ.get('OPENBLAS_NUM_THREADS')\n"
            "        return None\n"
            "sys.meta_path.insert(0, Spy())\n")
    for i, extra in enumerate(([], ["--tile", "16"], ["--deltas", "0:pi/9:2", "--tile", "8"])):
        _, out = loaded_after(
            hook + "from argand.cli import app\n"
            f"sys.argv = ['argand', 'render', 'whitney', '--size', '16x16', *{extra!r}, '--out', {str(tmp_path / str(i))!r}]\n"
            "try:\n    app()\nexcept SystemExit as exc:\n    assert not exc.code, exc.code\n"
            "print(seen)\nos.environ['OPENBLAS_NUM_THREADS'] = str(seen.get('at_numpy'))", env=env)
        assert out["openblas"] == "1", extra


def test_one_frame_of_a_preset_does_without_pydantic(tmp_path):
    """typer's per-parameter pydantic adapters and the scene's pydantic
    models are most of a one-frame process's CPU after numpy: a preset's
    render takes neither (argand.cli._plain_values_without_pydantic,
    argand.scene.presets.preset_scene), with options given on the command
    line too."""
    modules, _ = loaded_after(
        "import sys\nfrom argand.cli import app\n"
        "sys.argv = ['argand', 'render', 'bicube', '--size', '16x16', '--workers', '1', '--tile', '8', "
        f"'--fps', '8', '--out', {str(tmp_path / 'out')!r}]\n"
        "try:\n    app()\nexcept SystemExit as exc:\n    assert not exc.code, exc.code")
    assert found(modules, ("pydantic", "pydantic_core", "typer._adapters", "argand.scene.schema")) == []


def test_plain_values_are_what_typers_adapters_give():
    """The values argand.cli takes without typer's pydantic adapters are the
    ones those adapters give, and every other value (errors included) is
    theirs: each of `argand render`'s parameters, on values of every kind."""
    from pathlib import Path as P

    import typer.main
    from typer._click import Context
    from typer._click.exceptions import BadParameter
    from typer._coercion import build_runtime_param

    from argand.cli import app

    command = typer.main.get_command(app).commands["render"]
    ctx = Context(command)
    values = [None, "", "0", "1", "64", "064", "-1", "+3", " 5", "5 ", "1_000", "1.0", "1.5", "8.0", "1e3", "nan",
              "inf", "abc", "٣", "a/b", "~/x", ".", "-", 0, 1, 64, -1, 8.0, 1.5, float("inf"), float("nan"), True,
              False, P("render"), P("a/b"), b"x"]

    def outcome(runtime, param, value):
        try:
            got = runtime.coerce(value, param=param, ctx=ctx)
        except BadParameter as exc:
            return "error", exc.format_message()
        return type(got), repr(got)

    checked = 0
    for param in command.params:
        if param.type_descriptor.annotation not in (str, int, float, bool, P):
            continue
        param._runtime_param = None
        plain = param.get_runtime_param()
        assert type(plain).__name__ == "PlainParam", param.name
        for value in values:
            assert outcome(plain, param, value) == outcome(build_runtime_param(param.type_descriptor), param, value), \
                (param.name, value)
            checked += 1
    assert checked > 300


def test_preset_scene_is_load_scenes_typed_scene():
    """argand.scene.presets.preset_scene (a preset without the pydantic
    models, for `argand render`) gives every preset's typed scene and
    samples exactly as load_scene does."""
    from argand.render.convert import to_core_scene
    from argand.scene import PRESETS, load_scene
    from argand.scene.presets import preset_scene

    def plain(o):
        if isinstance(o, (int, float, str, bool, type(None))):
            return o
        if isinstance(o, (list, tuple)):
            return [plain(x) for x in o]
        return {k: plain(getattr(o, k)) for k in dir(o) if not k.startswith("_") and not callable(getattr(o, k))}

    for name in PRESETS:
        light, full = preset_scene(name), load_scene(name)
        assert light.samples == full.samples, name
        assert plain(to_core_scene(light)) == plain(to_core_scene(full)), name


def test_the_progress_bar_shows_once_the_work_has_taken_its_delay(tmp_path):
    """`argand render` shows its progress bar (rich) only once the work has
    run ARGAND_PROGRESS_AFTER seconds: at 0 it shows from the first tile and
    counts every tile; at 60 a short run shows none and never loads rich.
    Either way the frames and the summary are written."""
    for after, shown in (("0", True), ("60", False)):
        out = tmp_path / after
        env = dict(os.environ, ARGAND_PROGRESS_AFTER=after, COLUMNS="200")
        code = ("import sys\nfrom argand.cli import app\n"
                f"sys.argv = ['argand', 'render', 'whitney', '--size', '32x16', '--tile', '8', '--deltas', '0:pi/9:2', "
                f"'--out', {str(out)!r}]\n"
                "try:\n    app()\nexcept SystemExit as exc:\n    assert not exc.code, exc.code\n"
                "print('rich' in sys.modules)")
        run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO / "tests",
                             env=env, timeout=300)
        assert run.returncode == 0, run.stderr[-2000:]
        lines = run.stdout.strip().splitlines()
        assert lines[-1] == str(shown)
        assert lines[-2].startswith("wrote 2 frame(s) to ")
        assert sum(line.startswith("σ = 0, δ = ") for line in lines) == 2
        # 2 frames of 4x2 tiles of 8 pixels
        assert ("16/16 tiles" in run.stderr) == shown, run.stderr[-2000:]
        assert sorted(p.name for p in out.glob("frame_*.exr")) == ["frame_0000.exr", "frame_0001.exr"]


@pytest.mark.parametrize("value", ["soon", "-1", "nan"])
def test_a_bad_progress_delay_is_refused_before_any_frame_is_written(tmp_path, value):
    """ARGAND_PROGRESS_AFTER that is not a number of seconds >= 0 stops
    `argand render` with an error naming it and the value, and writes no
    frame (an unset or "inf" value is fine: the default, or never)."""
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "argand.cli", "render", "whitney", "--size", "16x16", "--out", str(out)],
                         capture_output=True, text=True, cwd=REPO / "tests",
                         env=dict(os.environ, ARGAND_PROGRESS_AFTER=value, COLUMNS="200"), timeout=300)
    assert run.returncode == 2, run.stderr[-2000:]
    assert "ARGAND_PROGRESS_AFTER" in run.stderr and repr(value) in run.stderr, run.stderr[-2000:]
    assert not list(out.glob("frame_*"))
    ok = subprocess.run([sys.executable, "-m", "argand.cli", "render", "whitney", "--size", "16x16", "--out",
                         str(tmp_path / "ok")], capture_output=True, text=True, cwd=REPO / "tests",
                        env=dict(os.environ, ARGAND_PROGRESS_AFTER="inf"), timeout=300)
    assert ok.returncode == 0, ok.stderr[-2000:]
