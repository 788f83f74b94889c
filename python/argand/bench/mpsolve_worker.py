"""Runs under Debian's /usr/bin/python3 (where python3-mpsolve lives; its
libmps cannot be loaded into the project's interpreter). Reads JSON
{"polys": [[c0..cn], ...], "repeats": k} on stdin; writes
{"seconds": median, "roots": [[[re, im]...]...], "radii": [[...]...]}."""

import json
import sys
import time

import mpsolve


def main() -> None:
    job = json.load(sys.stdin)
    ctx = mpsolve.Context()
    polys = job["polys"]
    times = []
    roots = radii = None
    for _ in range(job.get("repeats", 1)):
        out_roots, out_radii = [], []
        t = time.perf_counter()
        for coeffs in polys:
            poly = mpsolve.MonomialPoly(ctx, len(coeffs) - 1)
            for k, c in enumerate(coeffs):
                poly.set_coefficient(k, float(c))
            r = ctx.solve(poly)
            out_roots.append([[complex(z).real, complex(z).imag] for z in r])
            out_radii.append(list(ctx.get_inclusion_radii()))
        times.append(time.perf_counter() - t)
        roots, radii = out_roots, out_radii
    times.sort()
    json.dump({"seconds": times[len(times) // 2], "roots": roots, "radii": radii}, sys.stdout)


if __name__ == "__main__":
    main()
