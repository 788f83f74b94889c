"""A job stored before tiles had to be multiples of 8 (its tile 20, say)
goes on after the upgrade with its own tiling: its tiles render, its frames
assemble, and its bands and on-request EXRs are decided with that tiling,
the bits its workers rendered. Only new jobs are held to the rule. The
task's body is called directly on a real Redis and SQLite (test_work.py's
farm_parts)."""

from __future__ import annotations

import pytest
from sqlalchemy import update

from argand.farm import bands, tile_work
from argand.farm.database import engine_for
from argand.farm.models import Job
from argand.farm.submission import JobRefused
from argand.media.frame_files import read_exr
from argand.render import FrameParams
from argand.render.frames import render_bands
from argand.scene import load_scene
from tests.farm.test_work import farm_parts, submit  # noqa: F401 (a fixture)


def test_a_job_stored_with_a_tile_off_the_seed_blocks_still_renders_with_its_own_tiling(farm_parts):  # noqa: F811
    settings, _redis = farm_parts
    with pytest.raises(JobRefused, match="multiple of 8"):
        submit(settings, "chmutov-octic", [0.2], 40, 40, 20)
    # Stored by an earlier version: tile 24 gives 40x40 the same four tiles a tile of 20 does.
    job_id = submit(settings, "chmutov-octic", [0.2], 40, 40, 24)
    with engine_for(settings.sqlalchemy_url).begin() as c:
        c.execute(update(Job).where(Job.id == job_id).values(tile=20))
    assert tile_work.run_tiles(settings, job_id, 0, list(range(4)), "w") == "rendered"
    scene = load_scene("chmutov-octic")
    params = FrameParams(delta=0.2, width=40, height=40)
    local = render_bands(scene, [params], tile=20, any_tile=True)[0]
    names, px = read_exr(settings.store_path / "jobs" / job_id / "frame_0000.exr")
    for k in ("Z", "arg", "re", "im", "status"):
        assert px[..., names.index(k)].tobytes() == local.aovs[k].astype("float32").tobytes(), k
    band = bands.band(settings, job_id, "0", "0.2", keep_result=True)
    for k in ("Z", "arg", "re", "im", "status"):
        assert band.result.aovs[k].tobytes() == local.aovs[k].tobytes(), k
    with pytest.raises(ValueError, match="multiple of 8"):
        render_bands(scene, [params], tile=20)  # the library itself holds new renders to the rule
