"""The C ABI of libairmass_c (plugin/capi/include/airmass/airmass_c.h), outside Blender:

    /usr/bin/python3 tests/blender/test_c_abi.py --lib build/lib/libairmass_c.so

Through ctypes, the way the add-on uses it, plus raw calls that a careless host could make:
NULL pointers, wrong struct sizes, tiny or absent message buffers, a sky buffer of the wrong
size or none, an unwritable output — each a status and a message, never a crash. The sun transmittance is checked against an
independent quadrature (scipy) of a one-constituent atmosphere. Exit status 1 on failure.
"""

import argparse
import ctypes
import math
import os
import sys
import tempfile
import threading

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "addon", "airmass_blender"))

sys.dont_write_bytecode = True  # keep the source tree clean
import native  # noqa: E402  (pure Python: no bpy)

FAILURES = []


def case(fn):
    try:
        fn()
        print("PASS", fn.__name__)
    except Exception as e:  # noqa: BLE001
        FAILURES.append(fn.__name__)
        print("FAIL", fn.__name__, "-", type(e).__name__, e)


def expect_error(call, status, needle):
    try:
        call()
    except native.NativeError as e:
        assert e.status == status, "status %s (%s), expected %s" % (e.status, e, status)
        assert needle in str(e), "message %r lacks %r" % (str(e), needle)
        return str(e)
    raise AssertionError("no error (expected %r)" % needle)


# One exponential, grey constituent: T toward the sun has a closed-form reference by quadrature.
GREY_TOML = """
name = "grey"
[planet]
radius_km = 6360.0
atmosphere_top_km = 6420.0
[spectrum]
basis = "rgb-schuler"
[[constituent]]
name = "haze"
profile = { type = "exponential", scale_height_km = 2.0 }
absorption = { law = "constant", value_per_m = 2.0e-5 }
"""


def test_version():
    assert native.library().airmass_abi_version() == native.ABI_VERSION
    assert native.version()
    assert native.has_vdb()
    assert "earth" in native.preset_names()
    assert "airmass" in native.chapman_method_names() and "exact" in native.chapman_method_names()
    lib = native.library()
    for s in (0, 1, 2, 3, 4, 5, 6, 99, 12345):
        assert lib.airmass_status_name(s)


def test_null_and_struct_size():
    lib = native.library()
    buf = ctypes.create_string_buffer(256)
    st = lib.airmass_validate_scene(None, None, buf, 256)
    assert st == native.INVALID_ARGUMENT and b"NULL" in buf.value, (st, buf.value)
    spec = native.SceneSpec()
    native._init_struct(lib.airmass_scene_spec_init, spec, "airmass_scene_spec")
    spec.struct_size = 8  # an older or newer host
    spec.preset = b"earth"
    st = lib.airmass_validate_scene(ctypes.byref(spec), None, buf, 256)
    assert st == native.INVALID_ARGUMENT and b"struct_size" in buf.value, (st, buf.value)
    # Both or neither source.
    native._init_struct(lib.airmass_scene_spec_init, spec, "airmass_scene_spec")
    st = lib.airmass_validate_scene(ctypes.byref(spec), None, buf, 256)
    assert st == native.INVALID_ARGUMENT and b"exactly one" in buf.value, buf.value
    # No message buffer at all, and a 1-byte one: status only, no crash, NUL-terminated.
    st = lib.airmass_validate_scene(None, None, None, 0)
    assert st == native.INVALID_ARGUMENT
    tiny = ctypes.create_string_buffer(b"x" * 7, 8)
    st = lib.airmass_validate_scene(None, None, tiny, 8)
    assert st == native.INVALID_ARGUMENT and len(tiny.value) == 7, tiny.raw
    one = ctypes.create_string_buffer(b"y", 1)
    lib.airmass_validate_scene(None, None, one, 1)
    assert one.raw == b"\0"
    # Long calls with NULL options / buffer.
    native._init_struct(lib.airmass_scene_spec_init, spec, "airmass_scene_spec")
    spec.preset = b"earth"
    pixels = (ctypes.c_float * (64 * 32 * 4))()
    st = lib.airmass_render_sky(ctypes.byref(spec), None, pixels, 64 * 32 * 4, None, None, buf, 256)
    assert st == native.INVALID_ARGUMENT and b"sky_options" in buf.value, (st, buf.value)
    opts = native.SkyOptions()
    native._init_struct(lib.airmass_sky_options_init, opts, "airmass_sky_options")
    st = lib.airmass_render_sky(ctypes.byref(spec), ctypes.byref(opts), None, 0, None, None, buf, 256)
    assert st == native.INVALID_ARGUMENT, st
    st = lib.airmass_sun_light_at_observer(ctypes.byref(spec), None, None, buf, 256)
    assert st == native.INVALID_ARGUMENT, st
    # Freeing NULL and a NULL token is harmless.
    lib.airmass_string_free(None)
    lib.airmass_cancel_token_free(None)
    lib.airmass_cancel_token_request(None)


def test_scene_errors_name_fields():
    s = native.Spec(preset="earth")
    s.planet_radius_m = -1.0
    expect_error(lambda: native.validate_scene(s), native.SCENE_ERROR, "planet.radius_km = -0.001")
    s = native.Spec(preset="earth")
    s.atmosphere_top_m = 6000e3
    expect_error(lambda: native.validate_scene(s), native.SCENE_ERROR, "planet.atmosphere_top_km")
    s = native.Spec(preset="earth")
    s.altitude_m = -5.0
    expect_error(lambda: native.validate_scene(s), native.SCENE_ERROR, "observer.altitude_km")
    s = native.Spec(preset="earth")
    s.constituents = [("mie", True, -1.0, None)]
    expect_error(lambda: native.validate_scene(s), native.SCENE_ERROR, "density_scale")
    s = native.Spec(toml="this is = not [toml", source_name="broken.toml")
    expect_error(lambda: native.validate_scene(s), native.SCENE_ERROR, "broken.toml")
    s = native.Spec(preset="earth")
    expect_error(lambda: native.sun_light(s, chapman="nope"), native.INVALID_ARGUMENT, "airmass")
    # Overrides land where they should.
    s = native.Spec(preset="earth")
    s.sun_elevation_deg, s.sun_rotation_deg, s.altitude_m = 33.0, 725.0, 1500.0
    s.basis = 1
    j = native.validate_scene(s)
    assert j["sun"]["elevation_deg"] == 33.0 and abs(j["sun"]["azimuth_deg"] - 5.0) < 1e-12, j["sun"]
    assert j["observer"]["altitude_m"] == 1500.0


def test_sun_transmittance_vs_quadrature():
    from scipy.integrate import quad
    R, top, H, sigma = 6360e3, 6420e3, 2000.0, 2.0e-5
    for elevation in (90.0, 30.0, 5.0, 0.0):
        s = native.Spec(toml=GREY_TOML)
        s.sun_elevation_deg, s.altitude_m = elevation, 500.0
        light = native.sun_light(s, chapman="exact")
        r0 = R + 500.0
        mu = math.sin(math.radians(elevation))
        t_top = -r0 * mu + math.sqrt((r0 * mu) ** 2 + top * top - r0 * r0)

        def rho(t):
            r = math.sqrt(r0 * r0 + t * t + 2.0 * r0 * t * mu)
            return math.exp(-(r - R) / H)

        mass = quad(rho, 0.0, t_top, epsabs=0.0, epsrel=1e-12, limit=400)[0]
        expected = math.exp(-sigma * mass)
        for c in range(3):
            got = light["transmittance_rgb"][c]
            assert abs(got - expected) <= 1e-9 * expected + 1e-15, (elevation, c, got, expected)
        assert not light["below_horizon"]
    s = native.Spec(toml=GREY_TOML)
    s.sun_elevation_deg = -20.0
    light = native.sun_light(s)
    assert light["below_horizon"] and light["irradiance_rgb"] == (0.0, 0.0, 0.0), light


def test_settings_errors_name_the_option():
    """ABI 3 writes no file (the host does), so there is no I/O error left to report; bad
    settings are refused with the option named, before any work."""
    s = native.Spec(preset="earth")
    expect_error(lambda: native.render_sky(s, width=0), native.SETTINGS_ERROR, "width")
    expect_error(lambda: native.vdb_plan(s, region="planet", voxel_size=-1.0), native.SETTINGS_ERROR, "voxel")
    expect_error(lambda: native.vdb_plan(s, region="moon"), native.INVALID_ARGUMENT, "planet, view or box")


def test_concurrent_calls():
    """Four skies at once (different suns) equal the same skies rendered one after another."""
    import numpy as np
    results, errors = {}, []

    def spec(i):
        s = native.Spec(preset="earth")
        s.sun_elevation_deg = 10.0 * i
        return s

    def work(i):
        try:
            results[i] = native.render_sky(spec(i), width=64, view_samples=4)[0]
            native.sun_light(spec(i))
        except Exception as e:  # noqa: BLE001
            errors.append(e)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    assert sorted(results) == [0, 1, 2, 3], sorted(results)
    for i in range(4):
        serial = native.render_sky(spec(i), width=64, view_samples=4)[0]
        assert np.array_equal(results[i], serial), (i, float(np.abs(results[i] - serial).max()))
    assert not np.array_equal(results[0], results[3]), "the sun elevation changed nothing"


def test_sky_session_concurrent_renders():
    """One session (C ABI 6), four suns rendered at once on four threads: each equals the one-shot
    native.render_sky of that sun, value for value (a session is immutable, its renders
    thread-safe); a closed session is refused; multiple scattering on (the tables made once)."""
    import numpy as np
    session = native.SkySession(native.Spec(preset="earth"), width=64, view_samples=4)
    results, errors = {}, []
    suns = [(-3.0, 10.0), (5.0, 100.0), (30.0, 200.0), (70.0, 300.0)]

    def work(i):
        try:
            results[i] = session.render(*suns[i])[0]
        except Exception as e:  # noqa: BLE001
            errors.append(e)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    for i, (e, r) in enumerate(suns):
        spec = native.Spec(preset="earth")
        spec.sun_elevation_deg, spec.sun_rotation_deg = e, r
        one_shot = native.render_sky(spec, width=64, view_samples=4)[0]
        assert np.array_equal(results[i], one_shot), (i, float(np.abs(results[i] - one_shot).max()))
    # a preview quality from the same session, and errors naming the field
    small = session.render(20.0, 0.0, width=32, grid=8, multiple_grid=4, multiple_samples=8)[0]
    assert small.shape == (16, 32, 4) and np.isfinite(small).all()
    expect_error(lambda: session.render(20.0, 0.0, chapman="exact"), native.SETTINGS_ERROR, "chapman")
    expect_error(lambda: session.render(20.0, 0.0, multiple_samples=0), native.SETTINGS_ERROR, "multiple_samples")
    session.close()
    expect_error(lambda: session.render(20.0, 0.0), native.INVALID_ARGUMENT, "closed")


def test_render_sky_buffer():
    """airmass_render_sky writes width·height RGBA floats, rows from the top: A = 1, RGB finite
    and ≥ 0, the zenith row brighter in blue than red at noon (Rayleigh), the ground dark
    below a bright sky; refuses a wrong float_count or a NULL buffer naming the field."""
    import numpy as np
    lib = native.library()
    s = native.Spec(preset="earth")
    s.sun_elevation_deg = 60.0
    px, meta = native.render_sky(s, width=64, view_samples=8, sun_disc=True)
    assert px.shape == (32, 64, 4) and px.dtype == np.float32, (px.shape, px.dtype)
    assert np.isfinite(px).all() and (px[..., :3] >= 0.0).all()
    assert (px[..., 3] == 1.0).all()
    zenith = px[0, :, :3].mean(axis=0)
    assert zenith[2] > 1.5 * zenith[0] > 0.0, zenith  # row 0 looks up: a blue sky
    # Rows from the top, Blender's equirectangular columns: the brightest pixel (the sun disc)
    # is toward the sun — rotation 0 = +Y, a quarter from the left — at 60° elevation,
    # i.e. row (90 − 60)/180 · 32 − ½ ≈ 4.8 (a flipped image would put it at row 27).
    lum = px[..., :3] @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
    row, col = np.unravel_index(int(np.argmax(lum)), lum.shape)
    assert abs(row - 4.83) <= 1.5 and abs(col - 15.5) <= 1.5, (row, col)
    assert meta.get("airmass:version") == native.version(), meta.get("airmass:version")
    assert '"width":64' in meta.get("airmass:settings", "").replace(" ", ""), meta.get("airmass:settings")
    # The raw call, the way a careless host would make it.
    spec, keep = s._to_c(lib)
    opts = native.SkyOptions()
    native._init_struct(lib.airmass_sky_options_init, opts, "airmass_sky_options")
    opts.width, opts.height, opts.view_samples = 16, 8, 2
    buf = ctypes.create_string_buffer(512)
    good = 16 * 8 * 4
    storage = (ctypes.c_float * (good + 8))()
    for count in (good - 4, good + 4, 16 * 16 * 4, 0):
        st = lib.airmass_render_sky(ctypes.byref(spec), ctypes.byref(opts), storage, count, None, None, buf, 512)
        assert st == native.INVALID_ARGUMENT, (count, st, buf.value)
        assert (b"float_count = %d" % count) in buf.value and str(good).encode() in buf.value, buf.value
    st = lib.airmass_render_sky(ctypes.byref(spec), ctypes.byref(opts), None, good, None, None, buf, 512)
    assert st == native.INVALID_ARGUMENT and b"rgba" in buf.value and b"NULL" in buf.value, (st, buf.value)
    # The right count works, with and without metadata, and fills every float.
    for k in range(good + 8):
        storage[k] = -7.0
    out = ctypes.c_void_p()
    st = lib.airmass_render_sky(ctypes.byref(spec), ctypes.byref(opts), storage, good, None, ctypes.byref(out),
                                buf, 512)
    assert st == native.OK, buf.value
    assert out.value and b"airmass:version" in ctypes.string_at(out.value)
    lib.airmass_string_free(out.value)
    assert all(storage[k] >= 0.0 for k in range(good)), "a float of the buffer was not written"
    assert all(storage[k] == -7.0 for k in range(good, good + 8)), "written past float_count"
    st = lib.airmass_render_sky(ctypes.byref(spec), ctypes.byref(opts), storage, good, None, None, buf, 512)
    assert st == native.OK, buf.value
    del keep


def test_analytic_density_and_vdb():
    s = native.Spec(preset="earth")
    d = native.analytic_density(s, unit="km")
    assert d["length_unit"] == "km" and d["planet_radius"] == 6360.0
    assert [c["name"] for c in d["constituents"]] == ["rayleigh", "mie", "ozone"]
    s.constituents = [("ozone", False, None, None), ("mie", True, 2.0, 1500.0)]
    d2 = native.analytic_density(s, unit="km")
    assert [c["name"] for c in d2["constituents"]] == ["rayleigh", "mie"]
    mie1 = d["constituents"][1]
    mie2 = d2["constituents"][1]
    assert abs(mie2["scattering_rgb"][1] - 2.0 * mie1["scattering_rgb"][1]) < 1e-15
    assert mie2["profile"]["scale_height"] == 1.5
    import numpy as np
    seen = []
    p = native.Progress(lambda f: seen.append(f) and False)
    box = dict(region="box", box=(-20, -20, 0, 20, 20, 20), voxel_size=2.0)
    plan = native.vdb_plan(native.Spec(preset="earth"), progress=p, **box)
    p.close()
    assert plan["voxel_size"] == 2.0 and plan["active_voxels"] > 0, plan.get("summary")
    assert seen and seen[-1] == 1.0
    # The grid's dense block holds exactly the plan's active voxels (0 elsewhere), all finite.
    g = plan["grids"][0]
    values = native.vdb_grid_values(native.Spec(preset="earth"), g["name"], g["bbox_min"], g["bbox_max"], **box)
    assert np.isfinite(values).all() and (values >= 0).all()
    assert int(np.count_nonzero(values)) == g["active_voxels"], (np.count_nonzero(values), g["active_voxels"])


def test_sky_multiple_scattering_switch():
    """multiple_scattering = 0 gives the single-scattering sky; 1 (the default) adds a positive
    amount everywhere above the horizon; on the half of the sky away from the sun (the Earth's
    shadow at twilight) relatively more at sun -6° than at 45°."""
    import numpy as np
    s = native.Spec(preset="earth")
    gains = {}
    for elevation in (45.0, -6.0):
        s.sun_elevation_deg = elevation
        imgs = {}
        for ms in (False, True):
            px, meta_dict = native.render_sky(s, width=64, view_samples=8, sun_disc=False, multiple_scattering=ms)
            # the upper hemisphere (rows from the top), the half of the azimuths centred on -Y
            # (the sun, rotation 0, is at +Y)
            imgs[ms] = px[:16, 32:, :3]
            meta = meta_dict.get("airmass:settings", "").replace(" ", "")
            assert ('"multiple_scattering":%s' % ("true" if ms else "false")) in meta, meta[:400]
        assert np.isfinite(imgs[True]).all() and (imgs[True] >= imgs[False] - 1e-6).all()
        gains[elevation] = imgs[True].sum() / imgs[False].sum()
    assert gains[45.0] > 1.05 and gains[-6.0] > 1.5 * gains[45.0], gains


def test_solar_position():
    """native.solar_position (ABI 5): the SPA report's worked example (17 October 2003 12:30:30 at
    UT−7, Golden, Colorado; e0 = 39.872046°, azimuth 194.340241°), and errors naming the field."""
    p = native.solar_position(39.742476, -105.1786, "2003-10-17T12:30:30-07:00", delta_t_s=67.0,
                              site_elevation_m=1830.14)
    assert abs(p["elevation_deg"] - 39.872046) < 2e-6 and abs(p["azimuth_deg"] - 194.340241) < 1e-5, p
    assert p["delta_t_s"] == 67.0 and p["blender_rotation_deg"] == p["azimuth_deg"], p
    # ΔT by default: Espenak & Meeus (about 64.5 s in 2003), which moves the sun by < 0.0002°.
    q = native.solar_position(39.742476, -105.1786, "2003-10-17T19:30:30Z", site_elevation_m=1830.14)
    assert 60.0 < q["delta_t_s"] < 70.0 and abs(q["elevation_deg"] - p["elevation_deg"]) < 2e-4, q
    expect_error(lambda: native.solar_position(91.0, 0.0, "2026-06-21T12:00:00Z"), native.INVALID_ARGUMENT,
                 "latitude_deg = 91")
    expect_error(lambda: native.solar_position(0.0, 181.0, "2026-06-21T12:00:00Z"), native.INVALID_ARGUMENT,
                 "longitude_deg")
    expect_error(lambda: native.solar_position(0.0, 0.0, "2026-06-21T12:00:00"), native.INVALID_ARGUMENT, "utc")


def test_sun_column_table_vs_quadrature():
    """The sun's columns (airmass_sun_column_table) at texels of Bruneton's parametrisation, each
    against scipy's quadrature of the constituent's profile (analytic_density's own description:
    exponential Rayleigh and Mie, tent ozone) along the texel's ray to the top: the mapping and
    the masses at once."""
    import numpy as np
    from scipy.integrate import quad
    s = native.Spec(preset="earth")
    d = native.analytic_density(s, unit="km")
    R, top = float(d["planet_radius"]), float(d["atmosphere_top"])
    cons = d["constituents"]
    n_mu, n_r = 33, 9
    t = native.sun_column_table(s, len(cons), mu_size=n_mu, r_size=n_r, unit="km")
    assert t.shape == (n_r, n_mu, len(cons)) and np.isfinite(t).all() and (t >= 0).all()
    H = math.sqrt(top * top - R * R)

    def profile(p, h):
        if p["type"] == "exponential":
            return math.exp(-(h - p.get("reference_altitude", 0.0)) / p["scale_height"])
        if p["type"] == "tent":
            b, k, u = p["bottom"], p["peak"], p["top"]
            return max(0.0, min((h - b) / (k - b), (u - h) / (u - k)))
        raise AssertionError("profile %s" % p["type"])

    worst = 0.0
    for j in (0, 1, 4, 8):
        for i in (0, 5, 16, 28, 31, 32):
            x_mu, x_r = i / (n_mu - 1), j / (n_r - 1)
            rho = H * x_r
            r = math.sqrt(rho * rho + R * R)
            d_min, d_max = top - r, rho + H
            dist = d_min + x_mu * (d_max - d_min)
            mu = 1.0 if dist <= 0 else (H * H - rho * rho - dist * dist) / (2 * r * dist)
            mu = min(1.0, max(-1.0, mu))
            if i == n_mu - 1:
                mu += 1e-9  # the grazing ray: the table nudges it off the ground the same way
            t_top = -r * mu + math.sqrt(max(0.0, (r * mu) ** 2 + top * top - r * r))
            for k, c in enumerate(cons):
                def rho_at(tt, p=c["profile"]):
                    h = math.sqrt(r * r + tt * tt + 2.0 * r * tt * mu) - R
                    return profile(p, h) if h <= top - R else 0.0
                pts = [x for x in (-r * mu,) if 0.0 < x < t_top]  # the periapsis
                ref = quad(rho_at, 0.0, t_top, points=pts or None, epsabs=1e-10, epsrel=1e-10, limit=800)[0]
                got = float(t[j, i, k])
                err = abs(got - ref) / max(ref, 1e-6)
                worst = max(worst, err)
                # float32 storage (6e-8) and the library's Chapman fit (≤ 1e-6, bench_chapman's
                # report): 2e-5 relative leaves room for neither a wrong texel nor a wrong unit.
                assert err <= 2e-5, (c["name"], i, j, got, ref)
    print("    sun columns vs quadrature: worst relative %.2e" % worst)
    expect_error(lambda: native.sun_column_table(s, len(cons), mu_size=1, r_size=9, unit="km"),
                 native.SETTINGS_ERROR, "mu_size = 1")
    expect_error(lambda: native.sun_column_table(s, len(cons) + 1, mu_size=8, r_size=8, unit="km"),
                 native.INVALID_ARGUMENT, "float_count")
    # The multiple scattering of the same lighting: Hillaire's isotropic Ψ per unit irradiance at the
    # exporter's RGB wavelengths; finite, non-negative, 0 toward the night end of its sun axis,
    # largest for a high sun, bluer (440 nm) than red (680 nm) by day at the ground.
    psi, mu_lo = native.sun_ms_table(s, mu_size=16, r_size=8, unit="km")
    assert psi.shape == (8, 16, 3) and np.isfinite(psi).all() and (psi >= 0).all(), psi
    assert -1.0 < mu_lo < 0.0, mu_lo
    assert psi[0, 0].max() < 1e-6 * psi[0, -1].max(), (psi[0, 0], psi[0, -1])
    assert psi[0, -1, 2] > psi[0, -1, 0] > 0.0, psi[0, -1]
    expect_error(lambda: native.sun_ms_table(s, mu_size=4097, r_size=8, unit="km"), native.SETTINGS_ERROR,
                 "mu_size = 4097")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lib", required=True)
    args = ap.parse_args()
    os.environ[native.LIBRARY_ENV] = os.path.abspath(args.lib)
    native.reset()
    for fn in (test_version, test_null_and_struct_size, test_scene_errors_name_fields,
               test_sun_transmittance_vs_quadrature, test_settings_errors_name_the_option, test_concurrent_calls,
               test_render_sky_buffer, test_analytic_density_and_vdb, test_sky_multiple_scattering_switch,
               test_solar_position, test_sky_session_concurrent_renders, test_sun_column_table_vs_quadrature):
        case(fn)
    if FAILURES:
        print("FAILED:", ", ".join(FAILURES))
        sys.exit(1)
    print("all C ABI tests passed")


if __name__ == "__main__":
    main()
