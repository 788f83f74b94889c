"""A job keeps the engine options it was submitted with (Job.engine): the
worker hosts render its tiles with them and the API decides its bands and
on-request EXRs with them, whatever each process's own environment says.
Hosts started with different ARGAND_KERNEL values (one says scalar) would
otherwise mix two algorithms' bits in one frame, and a band or EXR asked of
the API would differ from the PNG the workers made. The task's body is
called directly on a real Redis and SQLite (test_work.py's farm_parts)."""

from __future__ import annotations

import numpy as np

from argand.farm import bands, tile_work
from argand.farm.database import session_scope
from argand.farm.models import Job
from argand.media.frame_files import read_exr
from argand.render import FrameParams, render_frame
from argand.render.options import EngineOptions
from argand.scene import load_scene
from tests.farm.test_work import farm_parts, submit  # noqa: F401 (a fixture)

SCALAR = EngineOptions(kernel="scalar")


def test_workers_and_the_api_render_a_job_with_the_options_it_was_submitted_with(farm_parts):  # noqa: F811
    settings, _redis = farm_parts
    api = settings.model_copy(update={"engine": SCALAR})  # the submitting process ran ARGAND_KERNEL=scalar
    worker = settings  # a worker host with the defaults (kernel auto)
    job_id = submit(api, "endrass-octic", [0.0, 0.3], 48, 40, 16)
    with session_scope(settings.sqlalchemy_url) as s:
        assert EngineOptions.from_stored(s.get(Job, job_id).engine) == SCALAR
    for frame in (0, 1):
        assert tile_work.run_tiles(worker, job_id, frame, list(range(9)), "w") == "rendered"
    scene = load_scene("endrass-octic")
    for frame, delta in ((0, 0.0), (1, 0.3)):
        scalar = render_frame(scene, FrameParams(delta=delta, width=48, height=40, engine=SCALAR), tile=16, workers=1)
        batched = render_frame(scene, FrameParams(delta=delta, width=48, height=40), tile=16, workers=1)
        names, px = read_exr(settings.store_path / "jobs" / job_id / f"frame_{frame:04d}.exr")
        for k in ("Z", "arg", "re", "im", "escalation"):
            assert px[..., names.index(k)].tobytes() == scalar.aovs[k].astype(np.float32).tobytes(), (frame, k)
        # (The test can fail: the two kernels are different algorithms. They
        # show the same values (Tracer::show_root), but climb the ladder
        # differently: level 2, the unseeded retry, is the scalar path's.)
        assert scalar.aovs["escalation"].tobytes() != batched.aovs["escalation"].tobytes()
    # The API's own options are the defaults; the band it answers is the job's scalar render.
    band = bands.band(worker, job_id, "0", "0.3", keep_result=True)
    scalar = render_frame(scene, FrameParams(delta=0.3, width=48, height=40, engine=SCALAR), tile=16, workers=1)
    for k in ("Z", "arg", "re", "im", "status", "escalation"):
        assert band.result.aovs[k].tobytes() == scalar.aovs[k].tobytes(), k


def test_stored_options_read_back_and_refuse_what_they_do_not_know():
    import pytest

    for options in (EngineOptions(), SCALAR, EngineOptions(kernel="sse2", cull=False, decide="full", shade="reference")):
        assert EngineOptions.from_stored(options.stored()) == options
    assert EngineOptions.from_stored(None) == EngineOptions()  # a job stored before jobs kept them
    with pytest.raises(ValueError, match="unknown field"):
        EngineOptions.from_stored({"kernel": "auto", "threads": 4})
    with pytest.raises(ValueError, match="kernel"):
        EngineOptions.from_stored({"kernel": "gpu"})
