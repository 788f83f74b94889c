"""The preset scenes: the paper's Table 1 surfaces and its Figure 7, and
classic surfaces of degree 5 to 8 (each file cites its equation's source).

The YAML files in ``argand/scene/presets/`` are the single source and ship
inside the package; ``scenes/`` at the repository root holds byte-identical
copies for people browsing the repository (tests/scene/test_model.py keeps
them equal).
"""

from __future__ import annotations

from pathlib import Path

#: Where the preset files live (inside the installed package).
PRESET_DIR = Path(__file__).with_name("presets")

#: The paper's presets, in its order (Table 1, then Figure 7).
PAPER_PRESETS: tuple[str, ...] = ("whitney", "plucker", "bicube", "mitchell", "steiner", "whitney-in-sphere")

#: Classic surfaces of degree 5 to 8 with many nodes, by degree.
CLASSIC_PRESETS: tuple[str, ...] = ("togliatti", "barth-sextic", "chmutov-septic", "chmutov-octic", "endrass-octic")

#: Every preset name: the paper's, then the classic ones.
PRESETS: tuple[str, ...] = PAPER_PRESETS + CLASSIC_PRESETS


def preset_path(name: str) -> Path:
    """The YAML file of a preset; ValueError for an unknown name."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; presets: {', '.join(PRESETS)}")
    return PRESET_DIR / f"{name}.yaml"
