"""The preset scenes: the paper's Table 1 surfaces and its Figure 7.

The YAML files in ``argand/scene/presets/`` are the single source and ship
inside the package; ``scenes/`` at the repository root holds byte-identical
copies for people browsing the repository (tests/test_scene_model.py keeps
them equal).
"""

from __future__ import annotations

from pathlib import Path

#: Where the preset files live (inside the installed package).
PRESET_DIR = Path(__file__).with_name("presets")

#: Preset names, in the paper's order (Table 1, then Figure 7).
PRESETS: tuple[str, ...] = ("whitney", "plucker", "bicube", "mitchell", "steiner", "whitney-in-sphere")


def preset_path(name: str) -> Path:
    """The YAML file of a preset; ValueError for an unknown name."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; presets: {', '.join(PRESETS)}")
    return PRESET_DIR / f"{name}.yaml"
