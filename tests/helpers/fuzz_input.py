"""The byte layout of fuzz/find_roots_fuzz.cpp (fuzz/fuzz_input.h), read in
Python, so that the fuzzer's corpus and findings can be replayed through the
binding and checked against the exact truth (tests/helpers/truth.py), which the C++
target cannot do.

    python tests/helpers/fuzz_input.py FILE   # prints the case and its violations as JSON
"""

from __future__ import annotations

import json
import math
import struct
import sys
from dataclasses import dataclass
from pathlib import Path

METHODS = ("auto", "paper", "smith", "unverified")  # the C++ Method enum's order
MAX_DEGREE = 64


class _Bytes:
    def __init__(self, data: bytes) -> None:
        self.data, self.pos = data, 0

    def byte(self) -> int:
        if self.pos < len(self.data):
            self.pos += 1
            return self.data[self.pos - 1]
        return 0

    def in_range(self, lo: int, hi: int) -> int:
        span = hi - lo + 1
        raw = (self.byte() << 8 | self.byte()) if span > 256 else self.byte()
        return lo + raw % span

    def raw_double(self) -> float:
        return struct.unpack("<d", bytes(self.byte() for _ in range(8)))[0]

    def structured_double(self) -> float:
        kind = self.byte()
        if kind & 7 == 0:
            return self.raw_double()
        mantissa = struct.unpack("b", bytes([self.byte()]))[0]
        exponent = [lambda: 0, lambda: self.in_range(-8, 8), lambda: self.in_range(-60, 60),
                    lambda: self.in_range(-1100, 1100)][(kind >> 3) & 3]()
        value = float(mantissa)
        # One step at a time, as the C++ does (the rounding of a subnormal
        # result is the same as the C++'s).
        while exponent > 0:
            value *= 2.0
            exponent -= 1
        while exponent < 0:
            value *= 0.5
            exponent += 1
        return value


@dataclass
class RootsCase:
    method: str
    coeffs: list[float]
    seeds: list[complex] | None
    radii: list[float] | None = None

    @property
    def valid(self) -> bool:
        """find_roots accepts it (finite, not all zero, degree <= 64)."""
        return (
            all(math.isfinite(c) for c in self.coeffs)
            and any(c != 0.0 for c in self.coeffs)
            and len(self.coeffs) - 1 <= MAX_DEGREE
            and (self.radii is None or all(math.isfinite(r) for r in self.radii))
        )


def decode_roots_case(data: bytes) -> RootsCase:
    """The case LLVMFuzzerTestOneInput in find_roots_fuzz.cpp builds."""
    b = _Bytes(data)
    control = b.byte()
    method = METHODS[control & 3]
    structured, seeded = bool(control & 4), bool(control & 8)
    n_coeffs = b.in_range(1, MAX_DEGREE + 2) if control & 16 else b.in_range(1, 13)
    coeffs = [b.structured_double() if structured else b.raw_double() for _ in range(n_coeffs)]
    seeds = None
    if seeded:
        seeds = []
        for _ in range(min(n_coeffs - 1, MAX_DEGREE + 1)):
            re = b.structured_double()
            seeds.append(complex(re, b.structured_double()))
    radii = [abs(b.structured_double()) for _ in range(n_coeffs)] if control & 32 else None
    return RootsCase(method, coeffs, seeds, radii)


def replay(case: RootsCase) -> list[str]:
    """The contract's violations by find_roots on the case (empty: none).
    With coefficient radii the claims must hold for every polynomial within
    them, so in particular for the centre one, which is what is checked."""
    import numpy as np

    from argand.core import find_roots
    from tests.helpers.truth import check_roots

    initial = None if not case.seeds or len(case.seeds) != len(case.coeffs) - 1 else np.array(case.seeds)
    roots = find_roots(case.coeffs, method=case.method, initial=initial, radius=case.radii)
    if case.method == "unverified":
        return ["the unverified method claimed a proof"] if roots.verified.any() else []
    return check_roots(case.coeffs, roots)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root, for tests.helpers
    found = decode_roots_case(Path(sys.argv[1]).read_bytes())
    problems = replay(found) if found.valid else []
    print(json.dumps({"method": found.method, "coeffs": [c.hex() for c in found.coeffs],
                      "seeded": found.seeds is not None, "radii": found.radii, "problems": problems}))
