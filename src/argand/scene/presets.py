"""The preset scenes: the paper's Table 1 surfaces and its Figure 7, and
classic surfaces of degree 5 to 8 (each file cites its equation's source).

The YAML files in ``argand/scene/presets/`` are the single source and ship
inside the package; ``scenes/`` at the repository root holds byte-identical
copies for people browsing the repository (tests/scene/test_model.py keeps
them equal).
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

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


#: What a preset may say for the light path below to read it (anything else,
#: and it is read by argand.scene.load_scene, the pydantic models).
_PLAIN_OBJECT_KEYS = frozenset({"surface", "space", "clip_radius", "material"})
_PLAIN_MATERIAL_KEYS = frozenset({"color", "diffuse", "specular", "shininess", "reflectivity", "transparency", "ior"})


def preset_scene(name: str) -> Any:
    """The preset ``name`` for rendering: what argand.render.convert.to_core_scene
    and the CLI read of ``load_scene(name)`` (objects with their polynomial,
    space, clip radius and material; background, lights, the default camera,
    samples), the same values, without the pydantic models: the presets are
    files of this package, validated by ``load_scene`` in the tests
    (tests/scene/test_model.py), which check that both give the same typed
    scene for every preset (tests/test_startup.py). A preset that
    says more than a surface with its space, clip radius and material is
    ``load_scene(name)`` itself. ValueError for an unknown name."""
    import yaml

    from argand.core import _core
    from argand.scene import model
    from argand.scene.expression import parse_surface

    data = yaml.load(preset_path(name).read_text(encoding="utf-8"), Loader=model._yaml_loader())  # noqa: S506
    objects = data.get("objects") if isinstance(data, dict) and set(data) == {"objects"} else None
    if not (isinstance(objects, list) and 1 <= len(objects) <= _core.MAX_OBJECTS and all(
            isinstance(o, dict) and "surface" in o and set(o) <= _PLAIN_OBJECT_KEYS
            and set(o.get("material", {})) <= _PLAIN_MATERIAL_KEYS for o in objects)):
        return model.load_scene(name)
    defaults = model._MATERIAL
    color = model._color_of("Material.color")
    plain = []
    for o in objects:
        m = o.get("material", {})
        material = SimpleNamespace(color=color(m["color"]) if "color" in m else defaults.color, **{
            k: float(m[k]) if k in m else getattr(defaults, k) for k in _PLAIN_MATERIAL_KEYS - {"color"}})
        clip = o.get("clip_radius")
        polynomial = parse_surface(o["surface"])
        plain.append(SimpleNamespace(
            surface=o["surface"], polynomial=polynomial, space=o.get("space", "complex"), transform=None,
            clip_radius=None if clip is None else float(clip), material=material,
            extent=float(clip) if clip is not None else model.surface_extent(polynomial)))
    centre, radius = model._enclose([((0.0, 0.0, 0.0), o.extent) for o in plain])
    camera = SimpleNamespace(position=model.framing_position(centre, radius), look_at=centre, up=(0.0, 0.0, 1.0),
                             fov=model.DEFAULT_FOV)
    return SimpleNamespace(objects=plain, camera=None, lights=None, background=model._SCENE.background,
                           samples=1, resolved_camera=lambda: camera)
