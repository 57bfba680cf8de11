#!/usr/bin/env python3
"""Derives the 16-point degree-8 fully symmetric triangle rule used for the far-mid band of the local single layer
(kSym16* in src/kernels/element_quadrature.hpp) by solving its moment equations, and checks it.

Orbit structure: the centroid, three (a, a, 1 - 2a) orbits (3 points each), one (a, b, 1 - a - b) orbit (6 points):
10 unknowns. Equations: the rule integrates exactly the 10 S3-invariant polynomials p2^i p3^j (2i + 3j <= 8) of the
barycentric power sums p2 = sum l_k^2, p3 = sum l_k^3 (every polynomial of degree <= 8 is integrated exactly by a
symmetric rule once these are). Exact integrals from int l0^i l1^j l2^k dA = 2 A i! j! k! / (i + j + k + 2)!.
Newton (mpmath.findroot, 40 digits) from pseudo-random starts (fixed seed) until a solution has all points inside and
all weights positive; then every monomial x^i y^j of degree <= 8 is checked against its exact integral.
Run: python3 tools/gen_symmetric_triangle_rule.py   (needs mpmath; prints the constants, weights per unit area)
"""
import random
from fractions import Fraction
from math import factorial

import mpmath as mp

mp.mp.dps = 40
INV = [(0, 0), (1, 0), (2, 0), (3, 0), (4, 0), (0, 1), (1, 1), (2, 1), (0, 2), (1, 2)]


def pmul(P, Q):
    R = {}
    for k1, c1 in P.items():
        for k2, c2 in Q.items():
            k = tuple(x + y for x, y in zip(k1, k2))
            R[k] = R.get(k, 0) + c1 * c2
    return R


def exact_invariants():
    """Integrals of p2^i p3^j over the triangle of area 1/2."""
    p2 = {(2, 0, 0): 1, (0, 2, 0): 1, (0, 0, 2): 1}
    p3 = {(3, 0, 0): 1, (0, 3, 0): 1, (0, 0, 3): 1}
    out = []
    for a, b in INV:
        P = {(0, 0, 0): 1}
        for _ in range(a):
            P = pmul(P, p2)
        for _ in range(b):
            P = pmul(P, p3)
        s = sum(Fraction(c * factorial(i) * factorial(j) * factorial(k), factorial(i + j + k + 2))
                for (i, j, k), c in P.items())
        out.append(mp.mpf(s.numerator) / s.denominator)
    return out


EX = exact_invariants()


def invariants(l0, l1, l2):
    p2 = l0 * l0 + l1 * l1 + l2 * l2
    p3 = l0 ** 3 + l1 ** 3 + l2 ** 3
    return [p2 ** a * p3 ** b for a, b in INV]


def orbits(p):
    """(barycentric representative, orbit size, weight per point) for parameters p."""
    third = mp.mpf(1) / 3
    out = [((third, third, third), 1, p[0])]
    for k in range(3):
        a, w = p[1 + 2 * k], p[2 + 2 * k]
        out.append(((a, a, 1 - 2 * a), 3, w))
    out.append(((p[7], p[8], 1 - p[7] - p[8]), 6, p[9]))
    return out


def equations(*p):
    s = [mp.mpf(0)] * len(INV)
    for l, n, w in orbits(p):
        v = invariants(*l)
        for k in range(len(INV)):
            s[k] += n * w * v[k]
    return [s[k] - EX[k] for k in range(len(INV))]


def points(p):
    pts = []
    for (l0, l1, l2), n, w in orbits(p):
        perms = [(l0, l1, l2)] if n == 1 else ([(l0, l1, l2), (l1, l2, l0), (l2, l0, l1)] if n == 3 else
                                               [(l0, l1, l2), (l1, l0, l2), (l0, l2, l1), (l2, l0, l1),
                                                (l1, l2, l0), (l2, l1, l0)])
        pts += [(q, w) for q in perms]
    return pts


def main():
    random.seed(3)
    for _ in range(1000):
        p0 = [random.uniform(0.02, 0.1)]
        for _k in range(3):
            p0 += [random.uniform(0.02, 0.49), random.uniform(0.005, 0.05)]
        p0 += [random.uniform(0.0, 0.3), random.uniform(0.1, 0.7), random.uniform(0.003, 0.03)]
        try:
            r = mp.findroot(equations, [mp.mpf(v) for v in p0], tol=mp.mpf("1e-35"), maxsteps=60)
        except (ZeroDivisionError, ValueError):
            continue
        p = [r[k] for k in range(10)]
        if max(abs(v) for v in equations(*p)) > 1e-30:
            continue
        pts = points(p)
        if all(min(l) > 0 for l, _ in pts) and all(w > 0 for _, w in pts):
            break
    else:
        raise SystemExit("no rule found")
    # Check: every monomial x^i y^j (x = l1, y = l2) of degree <= 8, exact integral i! j! / (i + j + 2)!.
    worst = max(abs(sum(w * l[1] ** i * l[2] ** j for l, w in pts) * (factorial(i + j + 2)) /
                    (factorial(i) * factorial(j)) - 1) for i in range(9) for j in range(9 - i))
    print(f"// 16 points, degree 8, worst relative monomial error {mp.nstr(worst, 3)}; weights per unit area")
    for (l0, l1, l2), w in pts:
        print(f"    {{{mp.nstr(l0, 17)}, {mp.nstr(l1, 17)}, {mp.nstr(l2, 17)}, {mp.nstr(2 * w, 17)}}},")


if __name__ == "__main__":
    main()
