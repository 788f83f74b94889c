"""Writes the seed corpora of the libFuzzer targets (fuzz/corpus/find_roots,
fuzz/corpus/render): small hand-picked cases in the byte layout that
find_roots_fuzz.cpp and render_fuzz.cpp read. Run from the repository root:
``python fuzz/seeds.py``. The fuzzer adds what it finds to the same folders
when `make fuzz` runs; findings worth keeping are committed there too.
"""

from __future__ import annotations

import hashlib
import struct
from pathlib import Path

HERE = Path(__file__).resolve().parent
METHODS = {"auto": 0, "paper": 1, "smith": 2, "unverified": 3}


def roots_case(coeffs: list[float], method: str = "auto", seeds: list[complex] | None = None) -> bytes:
    """Raw-double layout: control byte, count byte, 8 bytes per coefficient,
    then (if seeded) structured seeds as raw doubles (kind byte 0 + 8 bytes)."""
    control = METHODS[method] | (8 if seeds else 0)
    wide = len(coeffs) > 13
    if wide:
        control |= 16
    count = (len(coeffs) - 1) % (66 if wide else 13)
    out = bytes([control, count]) + b"".join(struct.pack("<d", c) for c in coeffs)
    for s in seeds or []:
        out += b"\x00" + struct.pack("<d", s.real) + b"\x00" + struct.pack("<d", s.imag)
    return out


def product(roots: list[float]) -> list[float]:
    c = [1.0]
    for r in roots:  # (t - r) * c, lowest degree first
        c = [-r * c[0]] + [c[k - 1] - r * c[k] for k in range(1, len(c))] + [c[-1]]
    return c


ROOTS = {
    "linear": [-1.0, 1.0],
    "circle": [-1.0, 0.0, 1.0],
    "pair": [1.0, 0.0, 1.0],
    "triple": product([1.0, 1.0, 1.0]),
    "wilkinson12": product([float(k) for k in range(1, 13)]),
    "cluster": product([1.0, 1.0 + 2**-30, 1.0 - 2**-30, 2.0]),
    "subnormal": [5e-324, 0.0, 1.0],
    "subnormal_lead": [1.0, 0.0, 5e-324],
    "huge": [1.7e308, -1.7e308, 1.0],
    "near_overflow": [1e308, 1e308, 1e308, 1e308],
    "zero_lead": [1.0, 2.0, 0.0, 0.0],
    "zero_const": [0.0, 0.0, 1.0, 1.0],
    "degree0": [3.0],
    "zero_poly": [0.0, 0.0],
    "nan": [1.0, float("nan"), 1.0],
    "inf": [float("inf"), 1.0],
    "degree64": [1.0] + [0.0] * 63 + [1.0],
    "degree65": [1.0] + [0.0] * 64 + [1.0],
}


SURFACES = [
    "x^2 + y^2 + z^2 - 1",
    "x^2*z - y^2",
    "(x+y+z+1)^12",
    "x^4 - 5*x^2 + 4 = y",
    "(1.5*x + 2e-3*y)^3*(z - 0.25)",
    "-(-(x))",
    "x^2 + (y",
]
ANGLES = ["pi/9", "-2*pi/3 + 0.125", "(1e308*10)", "1/(pi-pi)", "π/18"]
SCENES = [
    '{"objects": [{"surface": "x^2 + y^2 + z^2 - 1"}]}',
    '{"objects": [{"surface": "x^2*z - y^2", "space": "real", "clip_radius": 2}],'
    ' "camera": {"position": [4, 3, 2], "look_at": [0, 0, 0]}}',
    '{"objects": [{"surface": "x^3 - y*z", "transform": {"scale": 1e-300, "translate": [1e300, 0, 0]}}]}',
]


def write(folder: Path, name: str, data: bytes) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"seed-{name}-{hashlib.sha1(data).hexdigest()[:8]}").write_bytes(data)


def main() -> None:
    for name, coeffs in ROOTS.items():
        for method in METHODS:
            write(HERE / "corpus" / "find_roots", f"{name}-{method}", roots_case(coeffs, method))
    write(HERE / "corpus" / "find_roots", "seeded-nan", roots_case([2.0, -3.0, 1.0], "auto", [complex("nan"), 1j]))
    write(HERE / "corpus" / "find_roots", "seeded-inf", roots_case([2.0, -3.0, 1.0], "smith", [complex("inf"), 0j]))

    # render_fuzz: control byte, then objects; short inputs read as zeros,
    # so a few bytes are already a sphere-like scene.
    render = HERE / "corpus" / "render"
    write(render, "one-object", bytes([0, 0, 1, 3, 0, 2, 0, 0, 1, 0, 0]))
    write(render, "many-objects", bytes([2, 20] + [1, 2, 0, 0, 1, 8, 1] * 20))
    write(render, "camera", bytes([4 | 1, 0, 1, 2, 0, 0]) + struct.pack("<d", float("nan")) * 12)
    write(render, "sigma-delta", bytes([8 | 16 | 32, 0, 2, 1]) + struct.pack("<d", 1e308) * 6)

    # scene_fuzz.py (atheris): the text first (a leading 1 byte: ASCII), the
    # integers last (atheris reads them from the end): mode, then width and
    # height for a scene.
    scene = HERE / "corpus" / "scene"
    for text in SURFACES:
        write(scene, "surface", b"\x01" + text.encode() + bytes([0]))
    for text in ANGLES:
        write(scene, "angle", b"\x01" + text.encode() + bytes([1]))
    for text in SCENES:
        write(scene, "scene", b"\x01" + text.encode() + bytes([3, 3, 2]))


if __name__ == "__main__":
    main()
