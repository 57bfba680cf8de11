#!/usr/bin/env python3
"""Generates src/kernels/ggem_local_table.hpp: piecewise polynomials for the GGEM local kernel, used by
ggem_local_add_tabulated (src/kernels/ggem_kernels.hpp).

With x = alpha r and t = x^2, the local kernel G_l = c1 (I + rr) - c2 (I - rr) (r unit) is
    G_l . f = a f + b (r . f) r.
Near the source (t < TSPLIT) it is written as the Stokeslet minus an entire function of t (no 1/r in the table):
    a = 1/r - alpha P(t),   b = 1/r^3 - alpha^3 Q(t),
    P(t) = erf(x)/x + (2/sqrt(pi)) exp(-t),    Q(t) = (erf(x)/x - (2/sqrt(pi)) exp(-t)) / t;
farther out the screened coefficients are tabulated directly (no cancellation, relative accuracy kept as erfc decays):
    a = alpha A(t),   b = alpha^3 B(t),   A(t) = erfc(x)/x - (2/sqrt(pi)) exp(-t),   B(t) = (erfc(x)/x + (2/sqrt(pi)) exp(-t)) / t.
Both on [0, TMAX] in NSEG equal intervals (the first NSPLIT = TSPLIT/width hold P, Q, the others -A, -B, so that the
evaluation is a = s/r - alpha p, b = s/r^3 - alpha^3 q with s = 1 or 0 for every interval: no branch), each a
polynomial of degree DEG in u in [-1, 1] (Chebyshev interpolation in 50-digit arithmetic, converted to monomials and
rounded to double).
Run: python3 tools/gen_ggem_local_table.py > src/kernels/ggem_local_table.hpp   (needs mpmath)

With --simd16 it writes the host AVX-512 table instead (src/kernels/ggem_local_table16.hpp): the same functions on
[0, 32] in 16 intervals of width 2 (P, Q on the first two), degree 17, stored coefficient-major (coefficient m of all
16 intervals contiguous, 64-byte aligned), so that an 8-lane evaluator picks each lane's coefficient from two vector
registers by one two-source permute (vpermt2pd) instead of loading and transposing table rows. Degree 17 because the
interval [4, 6) lies at distance 4 from the branch point of A, B at t = 0 (1/sqrt(t)), where A is 200x smaller than
1/x: degree 15 leaves 1.6e-13 relative there, 17 leaves 2.3e-15.
Run: python3 tools/gen_ggem_local_table.py --simd16 > src/kernels/ggem_local_table16.hpp
"""
import sys

import mpmath as mp

mp.mp.dps = 50
TMAX = 36.0  # x = alpha r <= 6: beyond, the caller uses the closed form (erfc(6) = 2e-17)
NSEG = 144
DEG = 8
TSPLIT = 4.0
NSPLIT = int(round(TSPLIT / (TMAX / NSEG)))
W = TMAX / NSEG
C = 2 / mp.sqrt(mp.pi)


def P(t):
    t = mp.mpf(t)
    if t == 0:
        return 2 * C
    x = mp.sqrt(t)
    return mp.erf(x) / x + C * mp.exp(-t)


def Q(t):
    t = mp.mpf(t)
    if t < mp.mpf("1e-6"):
        # erf(x)/x = C sum (-t)^n / (n! (2n+1));  (that - C e^-t)/t = C sum_{n>=1} (-1)^n t^(n-1)/n! (1/(2n+1) - 1)
        s = mp.mpf(0)
        for n in range(1, 30):
            s += (-1) ** n * t ** (n - 1) / mp.factorial(n) * (mp.mpf(1) / (2 * n + 1) - 1)
        return C * s
    x = mp.sqrt(t)
    return (mp.erf(x) / x - C * mp.exp(-t)) / t


def A(t):
    x = mp.sqrt(mp.mpf(t))
    return mp.erfc(x) / x - C * mp.exp(-t)


def B(t):
    t = mp.mpf(t)
    x = mp.sqrt(t)
    return (mp.erfc(x) / x + C * mp.exp(-t)) / t


def cheb_monomial(fn, t0, t1, deg):
    """Monomial coefficients (in u in [-1, 1], t = mid + u half) of the Chebyshev interpolant at deg+1 nodes."""
    n = deg + 1
    mid, half = (t0 + t1) / 2, (t1 - t0) / 2
    nodes = [mp.cos(mp.pi * (k + mp.mpf(1) / 2) / n) for k in range(n)]
    vals = [fn(mid + half * u) for u in nodes]
    cheb = []
    for j in range(n):
        s = sum(vals[k] * mp.cos(mp.pi * j * (k + mp.mpf(1) / 2) / n) for k in range(n)) * 2 / n
        cheb.append(s / 2 if j == 0 else s)
    # T_j as monomials
    T = [[mp.mpf(1)], [mp.mpf(0), mp.mpf(1)]]
    for j in range(2, n):
        a = [mp.mpf(0)] + [2 * c for c in T[j - 1]]
        b = T[j - 2] + [mp.mpf(0)] * (len(a) - len(T[j - 2]))
        T.append([p - q for p, q in zip(a, b)])
    mono = [mp.mpf(0)] * n
    for j in range(n):
        for i, c in enumerate(T[j]):
            mono[i] += cheb[j] * c
    return [float(c) for c in mono]


def horner(c, u):
    s = mp.mpf(c[-1])
    for k in range(len(c) - 2, -1, -1):
        s = s * u + mp.mpf(c[k])
    return s


def main_simd16():
    nseg, tmax, deg, nsplit = 16, 32, 17, 2
    w = mp.mpf(tmax) / nseg
    tabA, tabB = [], []
    worst_sub, worst_dir, worst_sub_rel = 0.0, 0.0, 0.0
    for i in range(nseg):
        t0, t1 = i * w, (i + 1) * w
        fa, fb = (P, Q) if i < nsplit else (lambda t: -A(t), lambda t: -B(t))
        ca, cb = cheb_monomial(fa, t0, t1, deg), cheb_monomial(fb, t0, t1, deg)
        tabA.append(ca)
        tabB.append(cb)
        for k in range(81):
            u = mp.mpf(-1) + 2 * mp.mpf(k) / 80
            t = (t0 + t1) / 2 + u * (t1 - t0) / 2
            if t == 0:
                t = mp.mpf("1e-30")
            x = mp.sqrt(t)
            da, db = abs(horner(ca, u) - fa(t)), abs(horner(cb, u) - fb(t))
            if i < nsplit:
                worst_sub = max(worst_sub, float(da * x), float(db * x ** 3))
                worst_sub_rel = max(worst_sub_rel, float(da / abs(A(t))), float(db / abs(B(t))))
            else:
                worst_dir = max(worst_dir, float(da / abs(A(t))), float(db / abs(B(t))))
    out = sys.stdout
    out.write("#pragma once\n")
    out.write("// GENERATED by tools/gen_ggem_local_table.py --simd16 -- do not edit. The GGEM local kernel's piecewise\n")
    out.write("// polynomials (as in kernels/ggem_local_table.hpp: P, Q for t < 4, -A, -B from there; t = (alpha r)^2) for the host\n")
    out.write(f"// AVX-512 evaluator: [0, {tmax}] in {nseg} intervals of width {float(w):g}, degree {deg} in u = t - (2 i + 1) for interval i,\n")
    out.write("// coefficient-major: kGgemTab16A[16 m + i] is coefficient m (constant term first) of interval i.\n")
    out.write("// Worst error over 81 points per interval (50 digits), before double rounding in the evaluation:\n")
    out.write(f"//   P, Q relative to 1/x, 1/x^3: {worst_sub:.1e} (relative to A, B there: {worst_sub_rel:.1e}); A, B relative: {worst_dir:.1e}\n\n")
    out.write("namespace capsflow {\n\n")
    out.write(f"constexpr double kGgemTab16TMax = {float(tmax)!r};\n")
    out.write(f"constexpr int kGgemTab16Degree = {deg};\n\n")
    for name, tab in (("kGgemTab16A", tabA), ("kGgemTab16B", tabB)):
        out.write(f"alignas(64) inline constexpr double {name}[{nseg * (deg + 1)}] = {{\n")
        for m in range(deg + 1):
            out.write("    " + ", ".join(repr(tab[i][m]) for i in range(nseg)) + ",\n")
        out.write("};\n\n")
    out.write("}  // namespace capsflow\n")
    print(f"worst sub {worst_sub:.2e} (rel {worst_sub_rel:.2e}) direct {worst_dir:.2e}", file=sys.stderr)


def main():
    tabA, tabB = [], []
    worst_sub, worst_dir, worst_sub_rel = 0.0, 0.0, 0.0
    for i in range(NSEG):
        t0, t1 = mp.mpf(i) * W, mp.mpf(i + 1) * W
        fa, fb = (P, Q) if i < NSPLIT else (lambda t: -A(t), lambda t: -B(t))
        ca = cheb_monomial(fa, t0, t1, DEG)
        cb = cheb_monomial(fb, t0, t1, DEG)
        tabA.append(ca)
        tabB.append(cb)
        for k in range(41):
            u = mp.mpf(-1) + 2 * mp.mpf(k) / 40
            t = (t0 + t1) / 2 + u * (t1 - t0) / 2
            if t == 0:
                t = mp.mpf("1e-30")
            x = mp.sqrt(t)
            da, db = abs(horner(ca, u) - fa(t)), abs(horner(cb, u) - fb(t))
            if i < NSPLIT:
                # relative to the Stokeslet coefficients 1/x and 1/x^3 (alpha = 1) and to the screened ones
                worst_sub = max(worst_sub, float(da * x), float(db * x ** 3))
                worst_sub_rel = max(worst_sub_rel, float(da / abs(A(t))), float(db / abs(B(t))))
            else:
                worst_dir = max(worst_dir, float(da / abs(A(t))), float(db / abs(B(t))))  # fa = -A: same modulus
    out = sys.stdout
    out.write("#pragma once\n")
    out.write("// GENERATED by tools/gen_ggem_local_table.py -- do not edit. Piecewise polynomials for the GGEM local\n")
    out.write("// kernel (see ggem_local_add_tabulated in kernels/ggem_kernels.hpp and the generator's docstring), t = (alpha r)^2:\n")
    out.write(f"//   t < {TSPLIT:g}: smooth part  P(t) = erf(x)/x + (2/sqrt(pi)) exp(-t),  Q(t) = (erf(x)/x - (2/sqrt(pi)) exp(-t)) / t\n")
    out.write(f"//   t >= {TSPLIT:g}: screened, negated: -A, -B, A(t) = erfc(x)/x - (2/sqrt(pi)) exp(-t), B(t) = (erfc(x)/x + (2/sqrt(pi)) exp(-t)) / t\n")
    out.write(f"// on [0, {TMAX:g}] in {NSEG} intervals of width {W:g}, degree {DEG} in u = 2 (t - t_mid) / width, constant term first.\n")
    out.write(f"// Worst error over 41 points per interval (50 digits), before double rounding in the evaluation:\n")
    out.write(f"//   P, Q relative to 1/x, 1/x^3: {worst_sub:.1e} (relative to A, B there: {worst_sub_rel:.1e}); A, B relative: {worst_dir:.1e}\n")
    out.write("#include \"kernels/device_macros.hpp\"\n\nnamespace capsflow {\n\nCAPSFLOW_DEVICE_BEGIN\n\n")
    out.write(f"constexpr double kGgemTabTMax = {TMAX!r};\n")
    out.write(f"constexpr int kGgemTabSegments = {NSEG};\n")
    out.write(f"constexpr int kGgemTabDirectFrom = {NSPLIT};  // first interval holding A, B (t >= {TSPLIT:g})\n")
    out.write(f"constexpr double kGgemTabInvWidth = {NSEG / TMAX!r};\n")
    out.write(f"constexpr int kGgemTabStride = {DEG + 1};  // coefficients per interval\n\n")
    for name, tab in (("kGgemTabA", tabA), ("kGgemTabB", tabB)):
        out.write(f"inline constexpr double {name}[{NSEG * (DEG + 1)}] = {{\n")
        for c in tab:
            out.write("    " + ", ".join(repr(v) for v in c) + ",\n")
        out.write("};\n\n")
    out.write("CAPSFLOW_DEVICE_END\n\n}  // namespace capsflow\n")
    print(f"worst sub {worst_sub:.2e} (rel {worst_sub_rel:.2e}) direct {worst_dir:.2e}", file=sys.stderr)


if __name__ == "__main__":
    main_simd16() if "--simd16" in sys.argv[1:] else main()
