"""The preset scenes of the paper (Table 1 and Figure 7). The YAML files
ship inside the package; scenes/ in the repository holds identical copies
(a test keeps them equal)."""

from __future__ import annotations

from pathlib import Path

PRESET_DIR = Path(__file__).with_name("presets")
PRESETS: tuple[str, ...] = ("whitney", "plucker", "bicube", "mitchell", "steiner", "whitney-in-sphere")


def preset_path(name: str) -> Path:
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; presets: {', '.join(PRESETS)}")
    return PRESET_DIR / f"{name}.yaml"
