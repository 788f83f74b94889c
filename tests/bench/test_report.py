"""The benchmark page (argand.bench.report) assembled from the sections'
last JSON files, as `argand bench all --reuse ...` does: nothing is run
again, and the page says which machine wrote it and when each section was
measured."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from argand.bench.report import SECTIONS, bench_all

REPO = Path(__file__).resolve().parents[2]


def test_a_page_of_reused_sections_dates_each_and_does_not_claim_the_machine(tmp_path):
    out = tmp_path / "bench"
    out.mkdir()
    for name in SECTIONS:
        shutil.copy(REPO / "docs" / "bench" / f"{name}.json", out / f"{name}.json")
    page = tmp_path / "benchmarks.md"
    bench_all(out_dir=out, page=page, reuse=SECTIONS)
    text = page.read_text()
    assert "**Page assembled on:**" in text and "**Machine:**" not in text
    assert f"Taken from their last run (not run again for this page): {', '.join(SECTIONS)}" in text
    for name in SECTIONS:
        date = json.loads((out / f"{name}.json").read_text())["machine"]["date"]
        assert f"*measured {date}" in text, name
    # The charts are linked relative to the page, and nothing else was written.
    assert "](bench/roots.png)" in text
    assert sorted(p.name for p in out.iterdir()) == sorted(f"{n}.json" for n in SECTIONS)
