#!/usr/bin/python3
"""Reference masses (∫ rho ds, metres at density 1) along rays of an Earth-like
atmosphere, by mpmath quadrature at 30 digits, for tests/test_optical_depth.cpp.

The atmosphere (the same as earth_like() in the test): planet radius 6360 km, top at
60 km altitude (densities are zero above it), Rayleigh exp(-h/8000 m), Mie
exp(-h/1200 m), ozone tent 0 at 10 km -> 1 at 25 km -> 0 at 40 km.

Independent of the C++ code: the geometry is r(t)^2 = r0^2 + 2 r0 cos(zenith) t + t^2
in mpmath, the integrals are split at the periapsis, the top and the tent's knots.

Usage: /usr/bin/python3 scripts/gen_optical_depth_reference.py > tests/data/optical_depth_reference.csv
"""
import mpmath as mp

mp.mp.dps = 30
R = mp.mpf(6360e3)
TOP = mp.mpf(60e3)


def rho_rayleigh(h):
    return mp.e ** (-h / 8000)


def rho_mie(h):
    return mp.e ** (-h / 1200)


def rho_ozone(h):
    if h <= 10e3 or h >= 40e3:
        return mp.mpf(0)
    return (h - 10e3) / 15e3 if h <= 25e3 else (40e3 - h) / 15e3


def crossings(r0, mu, a):
    """t where the line reaches altitude a (both roots), or []"""
    rr = R + a
    b = r0 * mu
    D = b * b - (r0 - rr) * (r0 + rr)
    if D < 0:
        return []
    return [-b - mp.sqrt(D), -b + mp.sqrt(D)]


def masses(h0, zenith_deg, t0, t1):
    h0 = mp.mpf(h0)
    r0 = R + h0
    mu = mp.cos(mp.radians(zenith_deg))
    top = crossings(r0, mu, TOP)
    if t1 is None:
        t1 = top[1]
    t0, t1 = mp.mpf(t0), mp.mpf(t1)
    t0 = max(t0, top[0])
    t1 = min(t1, top[1])
    cuts = {t0, t1}
    for t in [-r0 * mu] + [x for a in (10e3, 25e3, 40e3) for x in crossings(r0, mu, a)]:
        if t0 < t < t1:
            cuts.add(t)
    cuts = sorted(cuts)

    def h(t):
        return mp.sqrt(r0 * r0 + 2 * r0 * mu * t + t * t) - R

    out = []
    for rho in (rho_rayleigh, rho_mie, rho_ozone):
        out.append(mp.quad(lambda t: rho(h(t)), cuts))
    return out


def ground(h0, zenith_deg):
    r0 = R + mp.mpf(h0)
    return crossings(r0, mp.cos(mp.radians(zenith_deg)), mp.mpf(0))[0]


def main():
    rows = []
    # (altitude_m, zenith_deg, t0_m, t1_m or None = to the top)
    for h0, zen in [(0, 0), (0, 30), (0, 60), (0, 80), (0, 89), (0, 90), (1000, 90), (5000, 91), (20e3, 93),
                    (59e3, 95)]:
        rows.append((h0, zen, 0, None))
    for h0, zen in [(10e3, 95), (1000, 135), (30e3, 180), (5000, 92.5)]:
        rows.append((h0, zen, 0, ground(h0, zen)))
    # from 1000 km: through the limb (periapsis 20 km: zenith 180 - asin((R+20km)/(R+1000km)))
    r_far = R + 1e6
    for hp in (0.5e3, 20e3, 45e3):
        zen = 180 - mp.degrees(mp.asin((R + hp) / r_far))
        rows.append((1e6, zen, 0, None))
    # finite segments
    rows += [(5e3, 80, 1e3, 50e3), (3e3, 60, 100, 101), (30e3, 95, 10e3, 400e3), (0, 90, 250e3, 600e3)]
    print("altitude_m,zenith_deg,t0_m,t1_m,mass_rayleigh_m,mass_mie_m,mass_ozone_m")
    for h0, zen, t0, t1 in rows:
        m = masses(h0, zen, t0, t1)
        t1_text = "-1" if t1 is None else mp.nstr(t1, 20)
        print(",".join([mp.nstr(mp.mpf(h0), 20), mp.nstr(mp.mpf(zen), 20), mp.nstr(mp.mpf(t0), 20), t1_text] +
                       [mp.nstr(x, 20) for x in m]))


if __name__ == "__main__":
    main()
