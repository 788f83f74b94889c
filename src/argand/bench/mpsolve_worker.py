"""Runs under Debian's /usr/bin/python3, where Debian's python3-mpsolve
module lives (it is not on the project's venv path). Reads JSON
{"polys": [[c0..cn], ...], "repeats": k} on stdin; solves every polynomial
once untimed (warm-up), then k timed times; writes
{"seconds": median over the k runs of the whole list, "roots": [[[re, im]...]...],
"radii": [[...]...]}. Only the solving loop is timed: process start, imports
and JSON are not."""

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
    repeats = int(job.get("repeats", 1))
    for run in range(repeats + 1):  # run 0: warm-up, not timed
        out_roots, out_radii = [], []
        t = time.perf_counter()
        for coeffs in polys:
            poly = mpsolve.MonomialPoly(ctx, len(coeffs) - 1)
            for k, c in enumerate(coeffs):
                poly.set_coefficient(k, float(c))
            r = ctx.solve(poly)
            out_roots.append([[complex(z).real, complex(z).imag] for z in r])
            out_radii.append(list(ctx.get_inclusion_radii()))
        if run > 0:
            times.append(time.perf_counter() - t)
        roots, radii = out_roots, out_radii
    times.sort()
    json.dump({"seconds": times[len(times) // 2], "roots": roots, "radii": radii}, sys.stdout)


if __name__ == "__main__":
    main()
