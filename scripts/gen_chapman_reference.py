#!/usr/bin/python3
"""Generate a high-precision reference table for the Chapman function.

Definition (x = r/H > 0, chi = zenith angle, u = path length in scale
heights, no ground):

    (D)  Ch(x, chi) = int_0^inf exp( x - sqrt(x^2 + 2 x u cos(chi) + u^2) ) du

Every row is computed twice, by independent formulations, and the script
aborts unless the two agree to a relative accuracy of 1e-25 in Ch
(= absolute 1e-25 in ln Ch), and also to 25 significant digits in ln Ch:

  primary    : direct mpmath.quad of (D) over u, split at breakpoints
               (periapsis and geometric multiples of the local decay length).
  secondary  : chi <= 90 deg: Chapman's angular form (Huestis 2001, eq. (A))
                   Ch = 1 + x sin(chi) int_0^chi exp(x (1 - sin chi / sin l))
                                                 / (1 + cos l) dl
               chi >  90 deg: reflection identity (R)
                   Ch(x, chi) = 2 exp(x - x sin chi) Ch(x sin chi, 90)
                                - Ch(x, 180 - chi)
                 with Ch(p, 90) = p e^p K_1(p) (mpmath.besselk) and
                 Ch(x, 180 - chi) from the angular form (A).
               closed forms (also checked): Ch(x,0)=1, Ch(x,90)=x e^x K_1(x),
                 Ch(x,180) = 2 e^x - 1.

Inputs x and chi_deg are taken as the IEEE doubles their CSV text parses to
(mpf(float(text))); degrees -> radians and all trigonometry are done in
mpmath (sinpi/cospi of exactly formed arguments), so the table is the exact
function at the doubles a C++ program reading the same CSV text obtains.

Output CSV columns: x,chi_deg,ch,ln_ch (30 significant digits; ch is "inf"
beyond DBL_MAX).  Lines starting with '#' are comments.

Usage: scripts/gen_chapman_reference.py [--out PATH] [--procs N]
"""

import argparse
import multiprocessing
import os
import sys
import tempfile
import time

import mpmath
from mpmath import mp, mpf

DPS = 45                    # working precision (decimal digits)
OUT_DIGITS = 30             # significant digits written to the CSV
REL_TOL = mpf("1e-25")      # required agreement between formulations
# Integrands are truncated where they fall below exp(-CUTOFF) relative to
# their maximum. The omitted mass is < (length of omitted range) * e^-CUTOFF
# relative, i.e. < 1e7 * 2.7e-109 ~ 1e-101 here: far below DPS.
CUTOFF = 250

X_TEXT = ["0.01", "0.1", "0.5", "1", "2", "5", "10", "20", "50", "100",
          "200", "500", "760", "1000", "3000", "1e4", "1e5", "1e6", "1e7"]
CHI_TEXT = ["0", "5", "10", "20", "30", "45", "60", "70", "75", "80", "85",
            "87", "88", "89", "89.5", "89.9", "89.99", "89.9999999", "90",
            "90.0000001", "90.01", "90.1", "90.5", "91", "92", "93", "95",
            "100", "110", "120", "135", "150", "165", "170", "175", "179",
            "179.9", "179.99", "180"]

DBL_MAX = mpf(sys.float_info.max)   # exact binary value 1.7976931348623157e308


# --------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------
def trig(chi_deg):
    """Return (sin chi, cos chi) for chi in degrees, accurate to full relative
    precision even near 90 and 180 deg.

    cos chi = sin(pi (90 - chi)/180) and sin chi = sin(pi chi/180) or
    sin(pi (180 - chi)/180); the differences 90 - chi, 180 - chi are exact in
    mpf, so no cancellation enters."""
    c = mpmath.sinpi((90 - chi_deg) / 180)
    if chi_deg <= 90:
        s = mpmath.sinpi(chi_deg / 180)
    else:
        s = mpmath.sinpi((180 - chi_deg) / 180)
    return s, c


def geometric_points(start, step0, direction, limit, logf):
    """Breakpoints start + direction*step0*2^k (k = 0, 1, ...) until the log
    integrand logf(point) drops below -CUTOFF or the point passes `limit`
    (which is then included).  Used to split the quadrature interval in
    pieces whose widths grow like the distance from the peak, so that each
    piece is resolved by tanh-sinh quadrature."""
    pts = []
    d = step0
    while True:
        p = start + direction * d
        if (direction > 0 and p >= limit) or (direction < 0 and p <= limit):
            pts.append(limit)
            break
        pts.append(p)
        if logf(p) < -CUTOFF:
            break
        d *= 2
    return pts


# --------------------------------------------------------------------------
# Primary: direct integral (D) over path length u
# --------------------------------------------------------------------------
def ln_ch_direct(x, s, c):
    """ln Ch from (D) by mpmath.quad.

    With s^2 = x^2 + 2xu cos chi + u^2 = (u + x cos chi)^2 + (x sin chi)^2 the
    exponent of (D) is written without cancellation:
      cos chi >= 0 (peak at u = 0, E = 0):
          x - S = -(2 x u cos chi + u^2) / (x + S)
      cos chi <  0 (peak at periapsis u0 = -x cos chi, impact p = x sin chi;
                    integration variable w = u - u0 in [-u0, inf)):
          x - S = E - w^2 / (p + S),
          E = x (1 - sin chi) = x cos^2 chi / (1 + sin chi)
    and ln Ch = E + ln int exp(exponent - E) du, so e^(1e7)-sized values never
    appear."""
    if c >= 0:
        E = mpf(0)
        u0 = mpf(0)

        def logf(u):
            S = mpmath.sqrt(x * x + 2 * x * u * c + u * u)
            return -(2 * x * u * c + u * u) / (x + S)

        # local decay length: 1/cos chi (linear term) or sqrt(2x) (curvature)
        ell = mpmath.sqrt(2 * x)
        if c > 0:
            ell = min(ell, 1 / c)
        ell = min(ell, mpf(1))  # for u >> x the decay length is <= 1
        pts = [u0] + geometric_points(u0, ell / 16, +1, mpmath.inf, logf)
    else:
        p = x * s
        u0 = -x * c
        E = x * c * c / (1 + s)

        # integrate in w = u - u0 (not u) so that quadrature nodes close to
        # the periapsis keep full relative precision
        def logf(w):
            S = mpmath.sqrt(w * w + p * p)
            if S == 0:
                return mpf(0)
            return -(w * w) / (p + S)

        # around periapsis: Gaussian width sqrt(2p) or exponential width 1
        ell = min(mpmath.sqrt(2 * p), mpf(1)) if p > 0 else mpf(1)
        left = geometric_points(mpf(0), ell / 16, -1, -u0, logf)
        right = geometric_points(mpf(0), ell / 16, +1, mpmath.inf, logf)
        pts = left[::-1] + [mpf(0)] + right

    def f(u):
        return mpmath.exp(logf(u))

    integral = mpmath.quad(f, pts)
    return E + mpmath.log(integral)


# --------------------------------------------------------------------------
# Secondary: Chapman's angular form (A), reflection (R), closed forms
# --------------------------------------------------------------------------
def ch_angular(x, s, c, chi_rad):
    """Ch from Chapman's angular form (A) (Huestis 2001), valid for
    0 <= chi <= 90 deg (c >= 0):
        Ch = 1 + x sin chi int_0^chi exp(x (1 - sin chi/sin l)) / (1 + cos l) dl
    Substituting l = chi - m, the exponent is evaluated without cancellation:
        1 - sin chi / sin l = -2 sin(m/2) (cos chi cos(m/2) + sin chi sin(m/2))
                              / sin l,
        sin l = sin chi cos m - cos chi sin m,
        cos l = cos chi cos m + sin chi sin m."""
    assert c >= 0
    if s == 0:
        return mpf(1)

    def logf(m):
        sl = s * mpmath.cos(m) - c * mpmath.sin(m)
        if sl <= 0:
            return -mpmath.inf
        h = m / 2
        return -x * 2 * mpmath.sin(h) * (c * mpmath.cos(h) + s * mpmath.sin(h)) / sl

    def f(m):
        lf = logf(m)
        if lf == -mpmath.inf:
            return mpf(0)
        cl = c * mpmath.cos(m) + s * mpmath.sin(m)
        return mpmath.exp(lf) / (1 + cl)

    # scale near m = 0 (l = chi): linear s/(x c) or curvature sqrt(2/x)
    ell = mpmath.sqrt(2 / x)
    if c > 0:
        ell = min(ell, s / (x * c))
    ell = min(ell, chi_rad / 4)
    pts = set([mpf(0), chi_rad])
    for q in geometric_points(mpf(0), ell / 16, +1, chi_rad, logf):
        pts.add(q)
    # near l -> 0 the factor exp(-x sin chi / l) switches on at l ~ x s/CUTOFF
    lam = chi_rad / 2
    while lam > 0 and x * s / lam < CUTOFF and lam > chi_rad * mpf(2) ** -200:
        pts.add(chi_rad - lam)
        lam /= 2
    pts = sorted(q for q in pts if 0 <= q <= chi_rad)
    integral = mpmath.quad(f, pts)
    return 1 + x * s * integral


def ch90_closed(p):
    """Ch(p, 90 deg) = p e^p K_1(p) (closed form); limit 1 at p = 0."""
    if p == 0:
        return mpf(1)
    return p * mpmath.exp(p) * mpmath.besselk(1, p)


def ln_ch_second(x, chi_deg, s, c):
    """Independent ln Ch: angular form (A) for chi <= 90, reflection (R) for
    chi > 90 (R written as ln Ch = E + ln(2 Ch(p,90) - e^-E Ch(x,180-chi)),
    E = x (1 - sin chi), p = x sin chi).  Returns (ln_ch, extra) where extra
    is a list of further (name, ln_ch) values from closed forms."""
    extra = []
    if c >= 0:
        chi_rad = chi_deg * mpmath.pi / 180
        ln2 = mpmath.log(ch_angular(x, s, c, chi_rad))
        if chi_deg == 0:
            extra.append(("closed Ch(x,0)=1", mpf(0)))
        if chi_deg == 90:
            extra.append(("closed x e^x K1(x)", mpmath.log(ch90_closed(x))))
        return ln2, extra
    p = x * s
    E = x * c * c / (1 + s)
    sup_rad = (180 - chi_deg) * mpmath.pi / 180        # 180 - chi exact
    ch_sup = ch_angular(x, s, -c, sup_rad)             # Ch(x, 180 - chi)
    ln2 = E + mpmath.log(2 * ch90_closed(p) - mpmath.exp(-E) * ch_sup)
    if chi_deg == 180:
        # Ch = 2 e^x - 1  ->  ln Ch = x + ln(2 - e^-x)
        extra.append(("closed 2e^x-1", x + mpmath.log(2 - mpmath.exp(-x))))
    return ln2, extra


# --------------------------------------------------------------------------
# Driver
# --------------------------------------------------------------------------
def compute_row(args):
    """Compute one table row; return (x_text, chi_text, ln_ch, worst, secs)
    where worst = (abs diff in ln Ch, name of the formulation compared)."""
    x_text, chi_text = args
    mp.dps = DPS
    t0 = time.time()
    x = mpf(float(x_text))
    chi = mpf(float(chi_text))
    s, c = trig(chi)
    ln1 = ln_ch_direct(x, s, c)
    ln2, extra = ln_ch_second(x, chi, s, c)
    name2 = "angular (A)" if c >= 0 else "reflection (R)"
    checks = [(name2, ln2)] + extra
    worst = (mpf(0), "")
    for name, other in checks:
        d = abs(ln1 - other)
        tol = max(REL_TOL * min(1, abs(ln1)), mpf("1e-35"))
        if not d <= tol:
            raise AssertionError(
                "Chapman reference MISMATCH at x=%s chi=%s: direct ln Ch=%s, "
                "%s ln Ch=%s, |diff|=%s > tol %s" % (
                    x_text, chi_text, mpmath.nstr(ln1, 40), name,
                    mpmath.nstr(other, 40), mpmath.nstr(d, 5),
                    mpmath.nstr(tol, 5)))
        if d >= worst[0]:
            worst = (d, name)
    return (x_text, chi_text, ln1, worst, time.time() - t0)


def format_row(x_text, chi_text, ln_ch):
    ch = mpmath.exp(ln_ch)
    ch_str = "inf" if ch > DBL_MAX else mpmath.nstr(ch, OUT_DIGITS)
    return "%s,%s,%s,%s" % (x_text, chi_text, ch_str,
                             mpmath.nstr(ln_ch, OUT_DIGITS))


def main():
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(
        repo, "tests", "data", "chapman_reference.csv"))
    ap.add_argument("--procs", type=int, default=2)
    opts = ap.parse_args()

    mp.dps = DPS
    tasks = [(xt, ct) for xt in X_TEXT for ct in CHI_TEXT]
    t_start = time.time()
    results = {}
    worst_all = (mpf(0), None)
    slowest = []
    with multiprocessing.Pool(opts.procs) as pool:
        for i, r in enumerate(pool.imap_unordered(compute_row, tasks), 1):
            xt, ct, ln1, worst, secs = r
            results[(xt, ct)] = ln1
            slowest.append((secs, xt, ct))
            if worst[0] >= worst_all[0]:
                worst_all = (worst[0], (xt, ct, worst[1]))
            if i % 20 == 0 or i == len(tasks):
                print("[%4d/%d] %6.1fs  last x=%s chi=%s (%.2fs)" % (
                    i, len(tasks), time.time() - t_start, xt, ct, secs),
                    file=sys.stderr, flush=True)

    lines = [
        "# Chapman function reference table: Ch(x, chi) = int_0^inf "
        "exp(x - sqrt(x^2 + 2 x u cos chi + u^2)) du",
        "# generated by scripts/gen_chapman_reference.py with mpmath %s, "
        "mp.dps=%d" % (mpmath.__version__, DPS),
        "# value: direct mpmath.quad of the u-integral (exponent written "
        "cancellation-free, split at periapsis and geometric breakpoints)",
        "# cross-checked per row to rel. 1e-25 in Ch and 25 sig. digits in "
        "ln Ch against: Chapman angular form (chi<=90), reflection identity "
        "with besselk (chi>90), closed forms at 0/90/180 deg",
        "# x and chi_deg are taken as the IEEE doubles their text parses to; "
        "ch, ln_ch to %d significant digits; ch=inf beyond DBL_MAX"
        % OUT_DIGITS,
        "# max |diff ln Ch| between formulations: %s"
        % mpmath.nstr(worst_all[0], 3),
        "x,chi_deg,ch,ln_ch",
    ]
    for xt, ct in tasks:
        lines.append(format_row(xt, ct, results[(xt, ct)]))

    out = os.path.abspath(opts.out)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(out), prefix=".chapman_",
                               suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write("\n".join(lines) + "\n")
        os.replace(tmp, out)
    except BaseException:
        os.unlink(tmp)
        raise

    slowest.sort(reverse=True)
    print("wrote %d rows to %s in %.1fs" % (len(tasks), out,
                                           time.time() - t_start),
          file=sys.stderr)
    print("max |diff ln Ch| = %s at x=%s chi=%s (vs %s)" % (
        mpmath.nstr(worst_all[0], 5), *worst_all[1]), file=sys.stderr)
    print("slowest rows: " + ", ".join(
        "x=%s chi=%s %.1fs" % (xt, ct, t) for t, xt, ct in slowest[:5]),
        file=sys.stderr)


if __name__ == "__main__":
    main()
