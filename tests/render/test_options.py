"""argand.render.options: the engine's modes as one checked value, read
from the environment in one place, passed to the workers, planned by C++."""

from __future__ import annotations

import itertools

import pytest

from argand.core import _core
from argand.render import FrameParams
from argand.render.convert import to_core_scene
from argand.render.frames import plan
from argand.render.options import (DECIDE_MODES, ENVIRONMENT, KERNELS, SHADE_MODES, EngineOptions, engine_environment,
                                   engine_options_from_environment)
from argand.scene import load_scene

ALL = [EngineOptions(kernel=k, cull=c, decide=d, shade=s, real=c)
       for k, c, d, s in itertools.product(KERNELS, (True, False), DECIDE_MODES, SHADE_MODES)]


def test_unset_or_empty_variables_keep_the_defaults():
    assert engine_options_from_environment({}) == EngineOptions()
    assert engine_options_from_environment({name: "" for name in ENVIRONMENT}) == EngineOptions()
    assert engine_options_from_environment({"PATH": "/bin", "ARGAND_PORT": "1"}) == EngineOptions()


@pytest.mark.parametrize("options", ALL, ids=str)
def test_the_environment_round_trips_every_combination(options):
    assert engine_options_from_environment(engine_environment(options)) == options


@pytest.mark.parametrize("name, value", [("ARGAND_KERNEL", "avx9000"), ("ARGAND_KERNEL", "AVX2"), ("ARGAND_CULL", "yes"),
                                         ("ARGAND_CULL", "true"), ("ARGAND_DECIDE", "slow"), ("ARGAND_SHADE", "pretty"),
                                         ("ARGAND_DECIDE", " fast")])
def test_a_bad_variable_is_refused_by_name(name, value):
    with pytest.raises(ValueError) as err:
        engine_options_from_environment({name: value})
    assert str(err.value).startswith(f"{name}={value}: use ")


def test_the_plan_carries_the_options_it_was_given():
    scene = to_core_scene(load_scene("whitney"))
    for options in ALL:
        if options.kernel not in ("auto", "scalar", "sse2") and options.kernel != _core.batch_kernel():
            continue  # (an instruction set this CPU may not run: below)
        p = plan(scene, FrameParams(width=4, height=4, engine=options))
        assert p.engine == {"kernel": options.kernel, "cull": options.cull, "decide": options.decide,
                            "shade": options.shade, "real": options.real}
        resolved = _core.batch_kernel() if options.kernel == "auto" else options.kernel
        assert _core.render_kernel(p) == resolved


def test_plan_frame_checks_the_names_itself():
    scene = to_core_scene(load_scene("whitney"))
    for kw, message in ((dict(kernel="avx9000"), "names no root kernel"), (dict(decide="slow"), "names no decision mode"),
                        (dict(shade="pretty"), "names no shading mode")):
        with pytest.raises(ValueError, match=message):
            _core.plan_frame(scene, 0.0, 0.0, 4, 4, **kw)


def test_the_farm_settings_pass_the_options_to_their_workers():
    from argand.farm.settings import Settings

    options = EngineOptions(kernel="scalar", cull=False, decide="full", shade="reference")
    env = Settings(engine=options).environment()
    assert engine_options_from_environment(env) == options
    assert "engine" not in Settings(engine=options).model_dump()
