#!/usr/bin/python3
"""The comparison report of `airmass compare` (docs/compare.md).

    blender -b --factory-startup --python-exit-code 1 --python compare/report.py -- DIR
    /usr/bin/python3 compare/report.py DIR            (any Python with numpy and OpenImageIO)

Reads DIR/job.json (written by `airmass compare`), the native EXRs and the renders — Blender's
(blender_<path>_seed<k>.exr, blender_<path>.json) and POV-Ray's (povray_<path>.json lists the
EXRs to sum) — and writes, atomically, DIR/report.md, DIR/summary.json and PNGs (DIR/png/*.png).
"Blender" below stands for the path's renderer (the path table's `renderer`); POV-Ray renders
deterministically, so its paths have one "seed", zero noise, and their sampling error is
measured by a second render at twice the media intervals (`sampling_check`).

Statistics, per path, per channel c and pixel p (B = mean of the K Blender seeds, N = the
native reference, s = the standard error of B from the K seeds, s = std/sqrt(K)):

    e = (B − N) / max(N, f_c),   f_c = 1e-3 · mean_p N_c   (relative error; the floor keeps
                                                            black pixels from dividing by 0)
    mean_rel_err = mean |e|, p95_rel_err = 95th percentile |e|, max_rel_err = max |e|
    noise_rel    = mean s / max(N, f_c)  (relative standard error of B)
    bias_beyond_noise = sqrt(max(0, mean e² − mean (s/max(N, f))²))  (RMS error not explained
                                                                      by Monte Carlo noise)

An unbiased B has mean |e| ≈ 0.8 · noise_rel (Gaussian noise), so `mean_rel_err ≤ x +
noise_rel` asserts a bias below x whatever the noise.

Needs numpy, and for the images either Blender's image API (inside Blender: bpy, used
whenever it is importable) or OpenImageIO (outside Blender). matplotlib is optional: without
it the side-by-side and error figures are composed with numpy (no text in the PNGs; the
captions in report.md say what they show). The statistics, summary.json and report.md do not
depend on the backends but for the one line of report.md that names them ("Made by
report.py ..."). A path that failed keeps its "error" in summary.json; the report never
fails because one path did.
"""

import json
import math
import os
import sys
import tempfile
import traceback

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # job_schema.py beside this file
import job_schema  # noqa: E402


def path_table(job):
    """{path: {"reference": native image, "title": ..., "renderer": "blender" | "povray"}}: the
    comparison paths as the job's plan carries them (compare/plan.json's path table, the one list)."""
    return {p["name"]: dict(p, renderer=p.get("renderer", "blender")) for p in job["plan"]["all_paths"]}


RENDERER_NAMES = {"blender": "Blender", "povray": "POV-Ray"}


FLOOR = 1e-3
FIGURES = ("native", "blender", "error", "side_by_side")  # png/<path>_<figure>.png
BACKEND_LINE = "Made by report.py"  # the only line of report.md that depends on the backends


# ---- backends: Blender's image API or OpenImageIO; matplotlib or numpy figures ------------------

def _module(name):
    """The module if it imports, else None (a broken install counts as missing)."""
    try:
        return __import__(name)
    except Exception:  # noqa: BLE001
        return None


class Backends:
    """Chosen once: bpy for images whenever it is importable (inside Blender), else
    OpenImageIO; matplotlib for the figures when it is importable, else numpy."""

    def __init__(self):
        self.bpy = _module("bpy")
        self.oiio = None if self.bpy is not None else _module("OpenImageIO")
        if self.bpy is None and self.oiio is None:
            raise SystemExit("report.py: no image backend: run it inside Blender (blender -b --factory-startup "
                             "--python report.py -- DIR) or with a Python that has OpenImageIO")
        self.plt = None
        mpl = _module("matplotlib")
        if mpl is not None:
            try:
                mpl.use("Agg")
                import matplotlib.pyplot as plt
                self.plt = plt
                self.mpl_version = mpl.__version__
            except Exception:  # noqa: BLE001
                self.plt = None
        self._scene = None

    def describe(self):
        if self.bpy is not None:
            images = "images read and written with Blender %s's image API (bpy)" % self.bpy.app.version_string
        else:
            images = "images read and written with OpenImageIO %s" % getattr(self.oiio, "__version__", "")
        if self.plt is not None:
            figures = "figures drawn with matplotlib %s" % self.mpl_version
        else:
            figures = ("figures composed with numpy, matplotlib not being importable (the PNGs hold no text: "
                       "panel names and the colour scale are in the captions)")
        return "%s (Python %s): %s; %s." % (BACKEND_LINE, sys.version.split()[0], images, figures)

    # -- EXR in -----------------------------------------------------------------------------
    def read_exr(self, path):
        """Linear RGB, H × W × 3 float64, top row first, the file's values unchanged."""
        if self.bpy is not None:
            px = self._read_bpy(path)
        else:
            buf = self.oiio.ImageBuf(path)
            if buf.has_error:
                raise RuntimeError("cannot read %s: %s" % (path, buf.geterror()))
            px = buf.get_pixels(self.oiio.FLOAT)
        if px is None or px.ndim != 3 or px.shape[2] < 3:
            raise RuntimeError("%s: expected an RGB image, got %s" % (path, None if px is None else px.shape))
        return np.asarray(px[:, :, :3], dtype=np.float64)

    def _read_bpy(self, path):
        bpy = self.bpy
        if not os.path.isfile(path):
            raise RuntimeError("cannot read %s: no such file" % path)
        img = bpy.data.images.load(path, check_existing=False)
        try:
            # Non-Color: the float buffer is the file's numbers, no colour-space conversion
            # ("Non-Color" in the configs of Blender 3.4 and 4.x; is_data is the same switch).
            try:
                img.colorspace_settings.name = "Non-Color"
            except TypeError:
                img.colorspace_settings.is_data = True
            w, h = img.size
            n = img.channels
            if w <= 0 or h <= 0 or not img.is_float:
                raise RuntimeError("cannot read %s as a float image (size %d × %d)" % (path, w, h))
            buf = np.empty(w * h * n, dtype=np.float32)
            img.pixels.foreach_get(buf)
            return buf.reshape(h, w, n)[::-1]  # Blender's rows run bottom to top
        finally:
            bpy.data.images.remove(img)

    # -- PNG out ---------------------------------------------------------------------------------
    def write_png(self, path, rgb01):
        """An 8-bit RGB PNG of display-referred (sRGB-encoded) values in [0, 1], atomically."""
        q = np.round(np.clip(np.asarray(rgb01, dtype=np.float64)[..., :3], 0.0, 1.0) * 255.0)
        tmp = path + ".tmp.png"
        try:
            if self.bpy is not None:
                self._write_bpy(tmp, q / 255.0)
            else:
                h, w = q.shape[:2]
                spec = self.oiio.ImageSpec(w, h, 3, self.oiio.UINT8)
                out = self.oiio.ImageBuf(spec)
                out.set_pixels(self.oiio.ROI(0, w, 0, h), q.astype(np.uint8))
                if not out.write(tmp, "uint8", "png"):
                    raise RuntimeError("cannot write %s: %s" % (tmp, out.geterror()))
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.remove(tmp)

    def _write_bpy(self, path, display):
        bpy = self.bpy
        if self._scene is None:
            self._scene = self._png_scene()
        h, w = display.shape[:2]
        img = bpy.data.images.new("airmass report png", w, h, alpha=False, float_buffer=True)
        try:
            px = np.ones((h, w, 4), dtype=np.float32)
            px[..., :3] = srgb_to_linear(display)[::-1]
            img.pixels.foreach_set(px.ravel())
            img.save_render(path, scene=self._scene)
        finally:
            bpy.data.images.remove(img)

    def _png_scene(self):
        """A scene of our own whose view is Standard on an sRGB display, no look, no dither: a
        float buffer (scene linear) is saved as the sRGB encoding of its values. Checked once
        on every 8-bit level, so that another Blender's colour management cannot change the
        figures unnoticed."""
        bpy = self.bpy
        sc = bpy.data.scenes.new("airmass report")
        sc.display_settings.display_device = "sRGB"
        vs = sc.view_settings
        vs.view_transform = "Standard"
        vs.look = "None"
        vs.exposure = 0.0
        vs.gamma = 1.0
        vs.use_curve_mapping = False
        sc.render.dither_intensity = 0.0
        f = sc.render.image_settings
        f.file_format = "PNG"
        f.color_mode = "RGB"
        f.color_depth = "8"
        f.compression = 90
        levels = np.arange(256, dtype=np.float64)
        ramp_img = np.repeat(levels[None, :, None] / 255.0, 3, axis=2)
        img = bpy.data.images.new("airmass report check", 256, 1, alpha=False, float_buffer=True)
        back = None
        fd, check_png = tempfile.mkstemp(suffix=".png", prefix="airmass-report-")
        os.close(fd)
        try:
            px = np.ones((1, 256, 4), dtype=np.float32)
            px[..., :3] = srgb_to_linear(ramp_img)
            img.pixels.foreach_set(px.ravel())
            img.save_render(check_png, scene=sc)
            back = bpy.data.images.load(check_png, check_existing=False)
            back.colorspace_settings.name = "Non-Color"
            got = np.empty(len(back.pixels), dtype=np.float32)
            back.pixels.foreach_get(got)
            got = np.round(got.reshape(-1, back.channels)[:, :3] * 255.0)
            worst = float(np.abs(got - levels[:, None]).max())
            if worst > 1.0:
                raise RuntimeError("Blender %s saves the report's PNGs with other colours than computed (an 8-bit "
                                   "level off by %g through the Standard view): colour management differs"
                                   % (bpy.app.version_string, worst))
        finally:
            bpy.data.images.remove(img)
            if back is not None:
                bpy.data.images.remove(back)
            os.remove(check_png)
        return sc


B = None  # the Backends, chosen in main()


def read_exr(path):
    return B.read_exr(path)


def write_png(path, rgb01):
    B.write_png(path, rgb01)


# ---- images -----------------------------------------------------------------------------

def luminance(img):
    return 0.2126 * img[..., 0] + 0.7152 * img[..., 1] + 0.0722 * img[..., 2]


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_to_linear(v):
    v = np.clip(v, 0.0, 1.0)
    return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))


def exposure_for(img):
    y = luminance(img)
    y = y[np.isfinite(y)]
    top = float(np.percentile(y, 99.5)) if y.size else 0.0
    return 0.8 / top if top > 0 else 1.0


def tone_map(img, k):
    return srgb(img * k)

# ---- statistics -------------------------------------------------------------------------

def rel_stats(b, n, se=None):
    """Relative error statistics of image b against reference n (H × W × 3)."""
    floor = FLOOR * np.maximum(n.reshape(-1, 3).mean(axis=0), 1e-300)
    den = np.maximum(n, floor)
    e = (b - n) / den
    a = np.abs(e)
    out = {
        "mean_rel_err": float(a.mean()),
        "p95_rel_err": float(np.percentile(a, 95)),
        "max_rel_err": float(a.max()),
        "signed_mean_rel_err": float(e.mean()),
        "per_channel": {},
    }
    for c, name in enumerate("RGB"):
        ac = a[..., c]
        out["per_channel"][name] = {
            "mean_rel_err": float(ac.mean()),
            "p95_rel_err": float(np.percentile(ac, 95)),
            "max_rel_err": float(ac.max()),
            "signed_mean_rel_err": float(e[..., c].mean()),
        }
    if se is not None:
        s = se / den
        out["noise_rel"] = float(s.mean())
        out["bias_beyond_noise"] = float(math.sqrt(max(0.0, float((e * e).mean() - (s * s).mean()))))
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(s > 0, a / s, np.where(a > 0, np.inf, 0.0))
        out["fraction_beyond_3_sigma"] = float((z > 3).mean())
        for c, name in enumerate("RGB"):
            out["per_channel"][name]["noise_rel"] = float(s[..., c].mean())
    return out, e


def stack_stats(imgs):
    """A stack (K × H × W × 3) of independent renders, their mean and its standard error (0 for
    one render)."""
    stack = np.stack(imgs)
    mean = stack.mean(axis=0)
    se = stack.std(axis=0, ddof=1) / math.sqrt(len(imgs)) if len(imgs) > 1 else np.zeros_like(mean)
    return mean, se, stack


def load_listed(d, images):
    """Renders listed by the renderer's info (POV-Ray: povray_<path>.json): per seed, the files
    to sum (split passes)."""
    return stack_stats([sum(read_exr(os.path.join(d, f)) for f in files) for files in images])


def load_blender(d, path, seeds, mode, scatterers=1, info=None):
    """The K seeds of one mode as a stack (K × H × W × 3), their mean and its standard error."""
    if info is not None and "images" in info:
        return load_listed(d, info["images"][mode])
    imgs = []
    for k in range(seeds):
        if path == "sky_texture":
            imgs.append(read_exr(os.path.join(d, "blender_%s_seed%d.exr" % (path, k))))
        elif mode in ("rgb", "rgb_dither"):
            imgs.append(read_exr(os.path.join(d, "blender_%s_%s_seed%d.exr" % (path, mode, k))))
        elif mode in ("dither", "closures"):  # multiple scattering: channel c = channel c of the grey render c
            imgs.append(np.stack([read_exr(os.path.join(d, "blender_%s_%s_seed%d_c%d.exr" % (path, mode, k, c)))[..., c]
                                  for c in range(3)], axis=-1))
        else:  # split: channel c = Σ_i channel c of the grey render of scatterer i at channel c
            chans = [sum(read_exr(os.path.join(d, "blender_%s_split_seed%d_c%d_s%d.exr" % (path, k, c, i)))[..., c]
                         for i in range(scatterers)) for c in range(3)]
            imgs.append(np.stack(chans, axis=-1))
    return stack_stats(imgs)


def other_render(d, path, info, mode, ref):
    """A path's renders in another mode (rgb, rgb_dither, closures) against its reference:
    (statistics with the Blender seconds, the mean image)."""
    b, se, stack = load_blender(d, path, int(info["seeds"]), mode)
    if not np.all(np.isfinite(stack)):
        raise RuntimeError("non-finite pixels in the %s Blender render" % mode)
    st, _ = rel_stats(b, ref, se)
    r = {k: st[k] for k in ("mean_rel_err", "p95_rel_err", "max_rel_err", "noise_rel", "bias_beyond_noise",
                            "signed_mean_rel_err", "per_channel")}
    r["blender_seconds"] = float(sum(info["render_seconds"][mode]))
    return r, b


# ---- figures ------------------------------------------------------------------------------

# A blue–white–red ramp (the ends and midpoints of matplotlib's RdBu_r) for the numpy heat map.
RAMP = np.array([[0.020, 0.188, 0.380], [0.263, 0.576, 0.765], [0.969, 0.969, 0.969],
                 [0.839, 0.376, 0.302], [0.404, 0.000, 0.122]])


def error_limit(e):
    """The heat map's colour scale: ±(99th percentile of |mean over R, G, B of e|), ≥ 0.5 %."""
    return max(0.005, float(np.percentile(np.abs(e.mean(axis=2)), 99)))


def ramp(t):
    """t in [−1, 1] → RGB of RAMP, piecewise linear."""
    x = (np.clip(t, -1.0, 1.0) + 1.0) * 0.5 * (len(RAMP) - 1)
    i = np.minimum(np.floor(x).astype(int), len(RAMP) - 2)
    f = (x - i)[..., None]
    return RAMP[i] * (1.0 - f) + RAMP[i + 1] * f


def _scale_for(w):
    """Integer nearest-neighbour magnification so a panel is at least ≈ 256 px wide."""
    return max(1, min(32, -(-256 // max(w, 1))))


def _enlarge(img, s):
    return np.repeat(np.repeat(img, s, axis=0), s, axis=1)


def heat_map(path_png, e, title, lim):
    y = e.mean(axis=2)
    if B.plt is None:
        # the map, then a gap and a colour bar from −lim (left) through 0 to +lim (right)
        s = _scale_for(y.shape[1])
        m = _enlarge(ramp(y / lim), s)
        h, w = m.shape[:2]
        pad = max(4, s)
        bar = np.repeat(ramp(np.linspace(-1.0, 1.0, w))[None], max(8, h // 12), axis=0)
        out = np.ones((pad + h + pad + bar.shape[0] + pad, w + 2 * pad, 3))
        out[pad:pad + h, pad:pad + w] = m
        out[2 * pad + h:2 * pad + h + bar.shape[0], pad:pad + w] = bar
        write_png(path_png, out)
        return
    plt = B.plt
    fig, ax = plt.subplots(figsize=(6, 6 * y.shape[0] / y.shape[1] + 0.8), dpi=110)
    im = ax.imshow(y, cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest")
    ax.set_title(title, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])
    cb = fig.colorbar(im, ax=ax, orientation="horizontal", fraction=0.06, pad=0.04)
    cb.set_label("relative error (Blender − native) / native, mean of R, G, B")
    fig.tight_layout()
    _save_figure(fig, path_png)


def side_by_side(path_png, panels, title):
    if B.plt is None:
        # the panels left to right, on white
        h, w = panels[0][1].shape[:2]
        s = _scale_for(w)
        pad = max(4, s)
        out = np.ones((h * s + 2 * pad, len(panels) * (w * s + pad) + pad, 3))
        for i, (_, img) in enumerate(panels):
            x = pad + i * (w * s + pad)
            out[pad:pad + h * s, x:x + w * s] = _enlarge(img[..., :3], s)
        write_png(path_png, out)
        return
    plt = B.plt
    h, w = panels[0][1].shape[:2]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 4.2 * h / w + 0.7), dpi=110)
    for ax, (name, img) in zip(axes, panels):
        ax.imshow(img, interpolation="nearest")
        ax.set_title(name, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    _save_figure(fig, path_png)


def _save_figure(fig, path_png):
    tmp = path_png + ".tmp.png"
    try:
        fig.savefig(tmp)
        os.replace(tmp, path_png)
    finally:
        B.plt.close(fig)
        if os.path.exists(tmp):
            os.remove(tmp)


# ---- known differences: numbers ---------------------------------------------------------------

def closure_cutoff_loss(job):
    """Optical depth Cycles drops because closures below 1e-5 per BU (km) are skipped."""
    cut = 1e-5
    out = {}
    for c in job.get("constituents", []):
        prof = c["profile"]
        if prof["type"] != "exponential":
            continue
        H = prof["scale_height"]
        href = prof.get("reference_altitude", 0.0)
        top = job["planet"]["top"] - job["planet"]["radius"]
        for kind in ("scattering_rgb", "absorption_rgb"):
            for ch, sigma in zip("RGB", c[kind]):
                if sigma <= 0:
                    continue
                # sigma exp(−(h − href)/H) < cut above h_cut
                h_cut = href + H * math.log(sigma / cut) if sigma > cut else 0.0
                if h_cut >= top:
                    continue
                lost = sigma * H * (math.exp(-(h_cut - href) / H) - math.exp(-(top - href) / H))
                key = "%s %s" % (c["name"], "scattering" if kind.startswith("scat") else "absorption")
                out.setdefault(key, {})[ch] = {"above_km": h_cut, "vertical_optical_depth_lost": lost}
    return out


def voxel_estimates(job):
    vdb = job.get("vdb")
    if not vdb:
        return {}
    vs = vdb["voxel_size"]
    out = {}
    for c in job.get("constituents", []):
        p = c["profile"]
        if p["type"] == "exponential":
            H = p["scale_height"]
            out[c["name"]] = {
                # linear interpolation of exp(−h/H) between nodes Δ apart: mean excess (Δ/H)²/12
                "trilinear_mean_overestimate": (vs / H) ** 2 / 12.0,
                "half_voxel_shift_if_uncorrected": math.exp(0.5 * vs / H) - 1.0,
            }
    return out


# ---- the report ------------------------------------------------------------------------------------

def fmt_pct(x):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    return "%.3f %%" % (100.0 * x)


def fmt_s(x):
    return "—" if x is None else "%.2f s" % x


def analyse(d, job):
    summary = {"format": "airmass-compare-summary-1", "scene": job.get("scene_name"), "paths": {},
               "camera": job.get("camera"), "native_gaps": {}}
    pngdir = os.path.join(d, "png")
    os.makedirs(pngdir, exist_ok=True)
    natives = {}
    for name, entry in job.get("native", {}).items():
        try:
            natives[name] = read_exr(os.path.join(d, entry["file"]))
            if not np.all(np.isfinite(natives[name])):
                raise RuntimeError("non-finite pixels in %s" % entry["file"])
        except Exception as e:  # noqa: BLE001
            summary.setdefault("native_errors", {})[name] = str(e)

    # Native-only decomposition of the known differences (no noise).
    def gap(a, b, what):
        if a in natives and b in natives:
            st, _ = rel_stats(natives[a], natives[b])
            st["what"] = what
            return st
        return None

    gaps = {
        "phase_function": gap("native_hg_spectral", "native_physical",
                              "Henyey–Greenstein phases (Rayleigh g = 0) vs the scene's phase functions, spectral"),
        "rgb_model": gap("native_matched", "native_hg_spectral",
                         "three wavelengths as R, G, B with the lamp's RGB irradiance vs the spectral integral"),
        "renderer_matched_total": gap("native_matched", "native_physical",
                                      "everything Blender's volume path changes by design: phases + RGB model"),
        "region_box": gap("native_matched_box", "native_matched",
                          "the medium cut to the exported VDB box vs the whole shell"),
        "multiple_scattering": gap("native_matched", "native_matched_ms",
                                   "single scattering only vs single + multiple scattering (renderer-matched)"),
        "povray_matched_total": gap("native_povray_matched", "native_physical",
                                    "everything POV-Ray's media change by design: Rayleigh kept, the other phases as "
                                    "Henyey–Greenstein, RGB model"),
        "povray_region_box": gap("native_povray_matched_box", "native_povray_matched",
                                 "the medium cut to the df3 box vs the whole shell (POV-Ray-matched)"),
    }
    summary["native_gaps"] = {k: v for k, v in gaps.items() if v is not None}

    images = {}
    table = path_table(job)
    for path in job["plan"]["paths"]:
        entry = {"title": table[path]["title"]}
        summary["paths"][path] = entry
        err = job.get("errors", {}).get(path)
        if err:
            entry["error"] = err
            continue
        try:
            ref_name = table[path]["reference"]
            if ref_name not in natives:
                raise RuntimeError("native reference %s missing: %s" % (
                    ref_name, summary.get("native_errors", {}).get(ref_name, "not rendered")))
            ref = natives[ref_name]
            renderer = table[path]["renderer"]
            info_path = os.path.join(d, "%s_%s.json" % (renderer, path))
            with open(info_path, encoding="utf-8") as f:
                info = json.load(f)
            modes = info.get("modes", ["rgb"])
            mode = next((m for m in ("split", "dither") if m in modes), modes[0])
            nsc = max(1, len(info.get("scatterers", [])))
            b, se, stack = load_blender(d, path, int(info["seeds"]), mode, nsc, info)
            if b.shape != ref.shape:
                raise RuntimeError("Blender image %s vs native %s: sizes differ" % (b.shape, ref.shape))
            if not np.all(np.isfinite(stack)):
                raise RuntimeError("non-finite pixels in the Blender render")
            st, e = rel_stats(b, ref, se)
            entry.update({k: st[k] for k in ("mean_rel_err", "p95_rel_err", "max_rel_err", "noise_rel")})
            entry["renderer"] = renderer
            entry["blender_seconds"] = float(sum(info["render_seconds"][mode]))  # the renderer's, POV-Ray's too
            entry["blender_mode"] = mode
            entry["native_seconds"] = float(job["native"][ref_name]["seconds"])
            entry["reference"] = ref_name
            entry["bias_beyond_noise"] = st["bias_beyond_noise"]
            entry["signed_mean_rel_err"] = st["signed_mean_rel_err"]
            entry["fraction_beyond_3_sigma"] = st["fraction_beyond_3_sigma"]
            entry["per_channel"] = st["per_channel"]
            entry["blender"] = {
                "version": info.get("blender_version", info.get("version")),  # POV-Ray's info: "version"
                "samples_per_seed": info.get("samples"),
                "seeds": info.get("seeds"),
                "render_seconds_per_seed": info["render_seconds"][mode],
                "modes": modes,
                "build_seconds": info.get("build_seconds"),
                "wall_seconds": job.get("blender_runs", {}).get(path, {}).get("wall_seconds"),
                "build": info.get("build"),
                "cycles": info.get("cycles"),
                "notes": info.get("notes", []),
                "renderer": renderer,
                "passes": info.get("pass_constituents"),
                "intervals": info.get("intervals"),
                "media_samples": info.get("media_samples"),
            }
            if "refined" in info:
                # POV-Ray is deterministic: its sampling error is measured by the same scene at twice
                # the media intervals. Method 3's error is about first order in the interval length,
                # so image(N) − image(2N) estimates half the error of image(N); the refined image
                # against the reference shows what is left.
                b2, _, stack2 = load_listed(d, info["refined"]["images"])
                if not np.all(np.isfinite(stack2)):
                    raise RuntimeError("non-finite pixels in the refined render")
                vr, _ = rel_stats(b, b2)
                rr, _ = rel_stats(b2, ref)
                entry["sampling_check"] = {
                    "intervals": info.get("intervals"),
                    "refined_intervals": info["refined"]["intervals"],
                    "vs_refined": {k: vr[k] for k in ("mean_rel_err", "p95_rel_err", "max_rel_err",
                                                      "signed_mean_rel_err")},
                    "refined_vs_reference": {k: rr[k] for k in ("mean_rel_err", "p95_rel_err", "max_rel_err",
                                                                "signed_mean_rel_err")},
                    "refined_seconds": float(sum(info["refined"]["render_seconds"])),
                }
            if path == "analytic_volume_ms":
                # Does the comparison see multiple scattering at all? The same Blender image
                # against the single-scattering reference must be off by far more than noise.
                if "native_matched" in natives:
                    ss, _ = rel_stats(b, natives["native_matched"], se)
                    entry["vs_single_scattering"] = {k: ss[k] for k in (
                        "mean_rel_err", "p95_rel_err", "signed_mean_rel_err", "bias_beyond_noise",
                        "fraction_beyond_3_sigma", "per_channel")}
                if mode == "dither" and "closures" in modes:
                    # Cycles 3.4's phase-summing bias: one Volume Scatter per constituent.
                    entry["closures_render"], _ = other_render(d, path, info, "closures", ref)
            if ref_name != "native_physical_box" and path != "analytic_volume_ms" and "native_physical" in natives:
                phys, _ = rel_stats(b, natives["native_physical"], se)
                entry["vs_physical"] = {k: phys[k] for k in ("mean_rel_err", "p95_rel_err", "max_rel_err",
                                                              "signed_mean_rel_err", "per_channel")}
            for rgb_mode in ("rgb", "rgb_dither"):
                if path == "sky_texture" or mode != "split" or rgb_mode not in modes:
                    continue
                # The same volume rendered in one RGB render, the way users render it: Cycles'
                # per-step colour-channel sampling bias, and with one Volume Scatter per
                # constituent (rgb) its phase-summing bias; rgb_dither has one dithered closure.
                r, b_rgb = other_render(d, path, info, rgb_mode, ref)
                cb, _ = rel_stats(b_rgb, b)
                r["vs_split_signed_mean"] = cb["signed_mean_rel_err"]
                r["vs_split_per_channel_signed"] = {ch: v["signed_mean_rel_err"] for ch, v in cb["per_channel"].items()}
                entry[rgb_mode + "_render"] = r
            if path == "sky_texture":
                entry["sky_texture_seconds"] = job.get("sky_texture", {}).get("seconds")
            if renderer == "povray":
                entry["scene_seconds"] = job.get("pov", {}).get(path, {}).get("seconds")
            k = exposure_for(ref)
            tb, tn = tone_map(b, k), tone_map(ref, k)
            write_png(os.path.join(pngdir, "%s_native.png" % path), tn)
            write_png(os.path.join(pngdir, "%s_blender.png" % path), tb)
            lim = error_limit(e)
            heat_map(os.path.join(pngdir, "%s_error.png" % path), e, "%s: relative error vs %s" % (path, ref_name), lim)
            if renderer == "povray":
                label = "POV-Ray" + (", %d split passes, %s media intervals" % (
                    len(info.get("passes") or []), info.get("intervals")) if info.get("passes") else
                    ", 9 × 9 rays per pixel")
            else:
                label = "Blender, %d seeds × %d samples" % (info["seeds"], info["samples"])
            panels = [("native (%s)" % ref_name, tn), (label, tb)]
            if path == "analytic_volume_ms" and "native_matched" in natives:
                # what multiple scattering adds: the same reference without it
                panels.append(("native, single scattering only (native_matched)", tone_map(natives["native_matched"], k)))
            elif ref_name != "native_physical_box" and "native_physical" in natives:
                panels.append(("native physical (scene phases, spectral)", tone_map(natives["native_physical"], k)))
            side_by_side(os.path.join(pngdir, "%s_side_by_side.png" % path), panels, table[path]["title"])
            images[path] = {"panels": [name for name, _ in panels], "error_limit": lim}
        except Exception as ex:  # noqa: BLE001
            entry.clear()
            entry["error"] = "%s: %s" % (type(ex).__name__, ex)
            traceback.print_exc()
            for kind in FIGURES:  # no figure of a path that failed
                f = os.path.join(pngdir, "%s_%s.png" % (path, kind))
                if os.path.exists(f):
                    os.remove(f)
    summary["closure_cutoff"] = closure_cutoff_loss(job)
    summary["voxelisation_estimates"] = voxel_estimates(job)
    return summary, images


def markdown(job, summary, images):
    cam = job.get("camera", {})
    L = []
    add = L.append
    add("# Airmass vs %s: scene `%s`" % (" / ".join(sorted({RENDERER_NAMES[path_table(job)[p]["renderer"]]
                                                          for p in summary["paths"]})) or "Blender", summary.get("scene")))
    add("")
    add("Camera: %s, %d × %d px, %.2f° × %.2f° field of view, at (%.4g, %.4g, %.4g) km looking along (%.3f, %.3f, %.3f); "
        "sun elevation %.2f°, rotation %.2f°. Generated by `airmass compare` (docs/compare.md)." % (
            "perspective" if cam.get("type") == "PERSP" else "equirectangular panorama", cam.get("width", 0),
            cam.get("height", 0), cam.get("horizontal_fov_deg", 0), cam.get("vertical_fov_deg", 0),
            *cam.get("location", [0, 0, 0]), *[-v for v in cam.get("axis_z", [0, 0, 1])],
            job.get("sun", {}).get("elevation_deg", 0), job.get("sun", {}).get("rotation_deg", 0)))
    add("")
    add("## Summary")
    add("")
    add("| path | reference | mean rel. err. | 95th pct | max | MC noise (rel. s.e.) | bias beyond noise | %s render | native render |" % (
        " / ".join(sorted({RENDERER_NAMES[path_table(job)[p]["renderer"]] for p in summary["paths"]}, reverse=False)) or "Blender"))
    add("|---|---|---|---|---|---|---|---|---|")
    for path, e in summary["paths"].items():
        if "error" in e:
            add("| %s | — | **failed** | | | | | | |" % path)
            continue
        add("| %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            path + (" (%s)" % e["blender_mode"] if e.get("blender_mode") in ("split", "dither") else ""),
            e["reference"], fmt_pct(e["mean_rel_err"]), fmt_pct(e["p95_rel_err"]), fmt_pct(e["max_rel_err"]),
            fmt_pct(e["noise_rel"]), fmt_pct(e["bias_beyond_noise"]), fmt_s(e["blender_seconds"]),
            fmt_s(e["native_seconds"])))
    add("")
    add("Relative error e = (Blender − native)/max(native, 10⁻³·mean native) per pixel and channel; Blender = mean of "
        "K independent seeds; noise = their standard error. References: `native_physical_box` (spectral, the scene's "
        "phase functions, multiple scattering included as in the texture, each pixel's mean as Cycles' Box filter takes it) for the sky texture, `native_matched` (Henyey–Greenstein phases, Blender's RGB model) "
        "for the analytic volume, `native_matched_box` (the same, medium cut to the exported box) for the VDB volume, "
        "`native_matched_ms` (`native_matched` + multiple scattering) for the analytic volume rendered with Cycles' "
        "volume and diffuse bounces.")
    if any(path_table(job)[p]["renderer"] == "povray" for p in summary["paths"]):
        add("")
        add("POV-Ray rows (pov_*): POV-Ray's image in place of Blender's. POV-Ray 3.7 renders deterministically (its "
            "media jitter is seeded the same in every run: two renders are bit-identical), so there is one render, "
            "its noise is 0 and 'bias beyond noise' is the RMS error; its sampling error is measured by a second "
            "render at twice the media intervals (each path's section). References: `native_physical_box` for "
            "pov_sky, `native_povray_matched` (Rayleigh kept as POV-Ray's scattering type 4, the other phases as "
            "Henyey–Greenstein of the one rule, three wavelengths) for pov_analytic, `native_povray_matched_box` "
            "(the same, medium cut to the df3 box) for pov_df3.")
    rgb_rows = [(p + (", one Volume Scatter per constituent" if k == "rgb_render" else ", phases dithered into one"),
                 e[k]) for p, e in summary["paths"].items() for k in ("rgb_render", "rgb_dither_render") if k in e]
    if rgb_rows:
        add("")
        add("The volume rows above are split renders (grey, one Volume Scatter per render, summed; see each path's "
            "known differences). One chromatic render per seed, the way users make it, is biased in Cycles 3.4 "
            "(per-step colour-channel sampling; and phase functions of several closures summed unweighted):")
        add("")
        add("| path, one RGB render | mean rel. err. | 95th pct | max | signed mean | bias beyond noise | Blender render |")
        add("|---|---|---|---|---|---|---|")
        for p, r in rgb_rows:
            add("| %s | %s | %s | %s | %s | %s | %s |" % (p, fmt_pct(r["mean_rel_err"]), fmt_pct(r["p95_rel_err"]),
                                                      fmt_pct(r["max_rel_err"]), fmt_pct(r["signed_mean_rel_err"]),
                                                      fmt_pct(r["bias_beyond_noise"]), fmt_s(r["blender_seconds"])))
    ms = summary["paths"].get("analytic_volume_ms", {})
    if "vs_single_scattering" in ms or "closures_render" in ms:
        add("")
        add("Multiple scattering (analytic_volume_ms, grey render per channel): the same Blender image against the "
            "single-scattering reference, and the volume rendered with one Volume Scatter per constituent (Cycles 3.4 "
            "sums their phase functions unweighted):")
        add("")
        add("| analytic_volume_ms | reference | mean rel. err. | 95th pct | signed mean | bias beyond noise |")
        add("|---|---|---|---|---|---|")
        for what, ref, r in (("dithered phase (above)", "native_matched (single scattering)", ms.get("vs_single_scattering")),
                             ("one closure per constituent", ms.get("reference"), ms.get("closures_render"))):
            if r:
                add("| %s | %s | %s | %s | %s | %s |" % (what, ref, fmt_pct(r["mean_rel_err"]), fmt_pct(r["p95_rel_err"]),
                                                         fmt_pct(r["signed_mean_rel_err"]),
                                                         fmt_pct(r["bias_beyond_noise"])))
    add("")
    for path, e in summary["paths"].items():
        add("## %s — %s" % (path, e.get("title", path)))
        add("")
        if "error" in e:
            add("**This path could not run:**")
            add("")
            add("```")
            add(str(e["error"]).strip())
            add("```")
            add("")
            continue
        if path in images:
            fig = images[path]
            add("![%s side by side](png/%s_side_by_side.png)" % (path, path))
            add("")
            add("Left to right: %s." % "; ".join(fig["panels"]))
            add("")
            add("![%s relative error](png/%s_error.png)" % (path, path))
            add("")
            add("Relative error (%s − native)/native against %s, mean of R, G, B: blue −%s, white 0, red +%s "
                "(and beyond)." % (RENDERER_NAMES[e.get("renderer", "blender")], e["reference"],
                                   fmt_pct(fig["error_limit"]), fmt_pct(fig["error_limit"])))
            add("")
        add("| channel | mean rel. err. | 95th pct | max | signed mean | MC noise |")
        add("|---|---|---|---|---|---|")
        for ch, c in e["per_channel"].items():
            add("| %s | %s | %s | %s | %s | %s |" % (ch, fmt_pct(c["mean_rel_err"]), fmt_pct(c["p95_rel_err"]),
                                                    fmt_pct(c["max_rel_err"]), fmt_pct(c["signed_mean_rel_err"]),
                                                    fmt_pct(c.get("noise_rel"))))
        add("")
        b = e["blender"]
        if e.get("renderer") == "povray":
            add("POV-Ray %s: one deterministic render%s, %s (scene written in %s, processes %s)." % (
                b["version"], (" of %d split passes (%s), method 3 with %s intervals and samples %s" % (
                    len(b["passes"]), ", ".join(b["passes"]), b["intervals"], b["media_samples"])
                    if b.get("passes") else " with a regular grid of rays per pixel (%s)" % " ".join(
                        job.get("pov", {}).get(path, {}).get("flags", []))),
                ", ".join("%.2f s" % t for t in b["render_seconds_per_seed"] or []), fmt_s(b["build_seconds"]),
                fmt_s(b["wall_seconds"])))
            sc = e.get("sampling_check")
            if sc:
                add("")
                add("Sampling error, measured: the same scene at %d intervals differs from this image by mean %s, "
                    "95th pct %s, signed %s (method 3's error is about first order in the interval length, so this "
                    "is about half of this image's sampling error); the %d-interval image against the reference: "
                    "mean %s, 95th pct %s, max %s, signed %s (%s)." % (
                        sc["refined_intervals"], fmt_pct(sc["vs_refined"]["mean_rel_err"]),
                        fmt_pct(sc["vs_refined"]["p95_rel_err"]), fmt_pct(sc["vs_refined"]["signed_mean_rel_err"]),
                        sc["refined_intervals"], fmt_pct(sc["refined_vs_reference"]["mean_rel_err"]),
                        fmt_pct(sc["refined_vs_reference"]["p95_rel_err"]),
                        fmt_pct(sc["refined_vs_reference"]["max_rel_err"]),
                        fmt_pct(sc["refined_vs_reference"]["signed_mean_rel_err"]), fmt_s(sc["refined_seconds"])))
        else:
            add("Blender %s: %s seeds × %s samples, %s per seed (scene build %s, process %s). %s" % (
                b["version"], b["seeds"], b["samples_per_seed"],
                ", ".join("%.2f s" % t for t in b["render_seconds_per_seed"] or []), fmt_s(b["build_seconds"]),
                fmt_s(b["wall_seconds"]), " ".join(b["notes"])))
        add("")
        if "vs_physical" in e:
            p = e["vs_physical"]
            add("Against the physically exact native image (spectral, the scene's phase functions): mean %s, "
                "95th pct %s, max %s, signed mean %s — documented, not asserted; the known differences below "
                "account for it." % (fmt_pct(p["mean_rel_err"]), fmt_pct(p["p95_rel_err"]), fmt_pct(p["max_rel_err"]),
                                     fmt_pct(p["signed_mean_rel_err"])))
            add("")
        add("### Known differences")
        add("")
        for line in known_differences(job, summary, path):
            add("* " + line)
        add("")
    add("## Units")
    add("")
    s = job.get("sun", {})
    add("The native image is linear Rec.709 of spectral radiance (W m⁻² sr⁻¹ nm⁻¹) with XYZ = Σ L·CMF·Δλ (no "
        "683 lm/W), the unit of Blender's Nishita sky and of `airmass sky`; a World/texture value is radiance in those "
        "units. The Sun lamp's strength × colour is the top-of-atmosphere irradiance through the same map, "
        "E_rgb = (%.4g, %.4g, %.4g) W m⁻² (strength %.4g, colour %s); Cycles' Sun strength is irradiance "
        "(a white Lambertian plane facing a Sun of strength 1 renders 1/π). Lengths: 1 Blender unit = 1 km, "
        "so coefficients are per km." % (*s.get("irradiance_rgb", [0, 0, 0]), s.get("strength", 0),
                                          ", ".join("%.4f" % c for c in s.get("color", []))))
    add("")
    add("## This report")
    add("")
    add(B.describe())
    add("")
    return "\n".join(L) + "\n"


def bias_summary(r):
    """"mean x, signed y (R, G, B), z beyond noise" of an rgb_render-like entry."""
    pc = r.get("per_channel", {})
    return "mean %s, signed %s (R %s, G %s, B %s), %s beyond noise" % (
        fmt_pct(r["mean_rel_err"]), fmt_pct(r["signed_mean_rel_err"]),
        *[fmt_pct(pc.get(ch, {}).get("signed_mean_rel_err")) for ch in "RGB"], fmt_pct(r["bias_beyond_noise"]))


def known_differences_povray(job, summary, path):
    """The known differences of a POV-Ray path (docs/povray.md)."""
    gaps = summary.get("native_gaps", {})
    pj = job.get("pov", {}).get(path, {})
    out = ["**Half-float EXR.** POV-Ray's `+FE` writes 16-bit floats: 2⁻¹¹ relative rounding (≈ 0.05 %) per "
           "pixel, below every tolerance."]
    if path == "pov_sky":
        cam = job.get("camera", {})
        w = pj.get("sky_width", 0)
        out.append("**Texture resolution.** The sky texture (`airmass sky` at the camera's altitude, multiple "
                   "scattering included, no sun disc) is %d × %d (%.4f° per texel) against %.4f° per camera pixel; "
                   "POV-Ray's `image_map { exr … map_type 1 interpolate 2 }` interpolates it bilinearly, mapped "
                   "onto Blender's equirectangular convention by `scale <-1, 1, 1>` (orientation tested texel by "
                   "texel, tests/python/test_pov.py)." % (w, w // 2, 360.0 / max(w, 1),
                                                          cam.get("horizontal_fov_deg", 0) / max(cam.get("width", 1), 1)))
        out.append("**Pixel sampling.** Both images are pixel means: POV-Ray averages a regular 9 × 9 grid of rays "
                   "per pixel (`%s`, its largest), natively a 4 × 4 Gauss–Legendre rule split exactly at the horizon. "
                   "The residual is in the horizon row: a regular grid of n × n rays integrates the ground–sky step "
                   "within a pixel only to 1/(2n) of the step, and the texture's bilinear interpolation smears it "
                   "over a texel." % " ".join(pj.get("flags", [])))
        return out
    pm = gaps.get("povray_matched_total")
    if pm:
        out.append("**By design of the renderer.** POV-Ray's media have Rayleigh (type 4) and Henyey–Greenstein "
                   "(type 5) phases only, and colours as three channels: the reference keeps Rayleigh, gives the "
                   "other constituents the HG of equal mean cosine and renders three wavelengths lit by the sun's "
                   "RGB irradiance. Against the physically exact image that reference differs by mean %s, 95th pct "
                   "%s, signed %s (the gap reported under each POV-Ray path as 'against the physically exact "
                   "native image')." % (fmt_pct(pm["mean_rel_err"]), fmt_pct(pm["p95_rel_err"]),
                                        fmt_pct(pm["signed_mean_rel_err"])))
    out.append("**Split passes.** POV-Ray averages the phase functions of all media on a ray (media.cpp, "
               "ComputeMediaScatteringAttenuation divides by the number of media), so the image is the sum of one "
               "render per scatterer (%s: `Declare=Airmass_Pass=K`), each holding every extinction." % (
                   ", ".join(pj.get("pass_constituents", [])) or "—"))
    sc = summary["paths"].get(path, {}).get("sampling_check")
    out.append("**Media sampling.** Method 3 (adaptive) with %s intervals and samples %s along each ray through the "
               "container, and the same for every shadow ray: a bias about first order in the interval length, "
               "positive (the sub-interval ends are weighted like its middle)%s. No jitter: POV-Ray 3.7 seeds it "
               "identically in every run, so renders cannot be made independent and the noise column is 0." % (
                   pj.get("intervals"), pj.get("media_samples"),
                   ("; measured: at %d intervals the image changes by mean %s (signed %s)" % (
                       sc["refined_intervals"], fmt_pct(sc["vs_refined"]["mean_rel_err"]),
                       fmt_pct(sc["vs_refined"]["signed_mean_rel_err"]))) if sc else ""))
    if path == "pov_df3":
        est = {}
        vs = pj.get("voxel_size_km", 0)
        for c in job.get("constituents", []):
            pr = c["profile"]
            if pr["type"] == "exponential" and vs:
                est[c["name"]] = (vs / pr["scale_height"]) ** 2 / 12.0
        out.append("**df3 voxels.** 32-bit df3 files of ρ/max ρ every %.4g km, `interpolate 1` (trilinear); linear "
                   "interpolation of exp(−h/H) overestimates the density by about (Δ/H)²/12: %s. The files fill the "
                   "unit cube with a border of one zero voxel (POV-Ray's interpolation wraps at the cube's faces); "
                   "POV-Ray puts sample i of n at i/n of the cube (measured), so `Airmass_Df3_Transform` scales it "
                   "by n voxels and moves it to the box's first voxel (docs/vdb.md)." % (
                       vs, ", ".join("%s ≈ %s" % (n, fmt_pct(x)) for n, x in est.items()) or "—"))
        rb = gaps.get("povray_region_box")
        if rb:
            out.append("**Region.** The media container is the box %s km the camera sees within its max distance; "
                       "the reference is cut to the same box (the whole shell differs from it by mean %s, signed %s)." % (
                           ", ".join("%.4g" % x for x in pj.get("medium_box_km", [])), fmt_pct(rb["mean_rel_err"]),
                           fmt_pct(rb["signed_mean_rel_err"])))
    out.append("**The planet.** A POV-Ray sphere, Lambertian (`diffuse 1/π`), lit by the sun only — POV-Ray's media "
               "have no multiple scattering and the native references leave it out too, as they leave out the sun "
               "disc and the skylight on the ground.")
    return out


def known_differences(job, summary, path):
    if path_table(job)[path]["renderer"] == "povray":
        return known_differences_povray(job, summary, path)
    gaps = summary.get("native_gaps", {})
    out = []
    if path == "sky_texture":
        t = job.get("sky_texture", {})
        cam = job.get("camera", {})
        texel = 360.0 / t.get("width", 1)
        pix = cam.get("horizontal_fov_deg", 0) / max(cam.get("width", 1), 1)
        out.append("**Texture resolution.** The sky texture is %d × %d (%.4f° per texel) against %.4f° per camera pixel "
                   "at the centre; Blender interpolates it bilinearly (Environment Texture, Linear), so the error is "
                   "the curvature of the sky over a texel, largest next to the horizon where sky meets ground "
                   "within one texel. The texture is made as `airmass sky` makes it (sky grid %s, whose own "
                   "interpolation error is below 2·10⁻⁴ at the 95th percentile, docs/sky.md); the sun disc is left "
                   "out of both images (a disc a fraction of a pixel wide is a sampling question, not a radiance "
                   "one)." % (t.get("width", 0), t.get("height", 0), texel, pix,
                              t.get("grid") if t.get("grid") else "off"))
        if t.get("camera_off_axis_m", 0) > 1.0:
            out.append("**Parallax.** The camera is %.0f m off the scene's vertical axis; a World texture has no "
                       "position, so it shows the sky of the observer on the axis." % t["camera_off_axis_m"])
        out.append("**Pixel sampling.** Both images are pixel means: Blender's Box filter (one pixel wide in Cycles "
                   "3.4 whatever its width) and, natively, a 4×4 Gauss–Legendre rule per pixel split exactly at the "
                   "horizon. One ray per pixel centre would not do: the texture's bilinear interpolation smears the "
                   "ground–sky jump over a texel, and a pixel centre that falls within that texel is off by up to "
                   "the jump itself (25 % at 2 m altitude), however fine the texture. The remaining error in the "
                   "horizon row is the texel-wide smear as a fraction of the pixel.")
        return out
    pf = gaps.get("phase_function")
    if pf:
        out.append("**Phase function.** Blender 3.4's Volume Scatter is Henyey–Greenstein only: Rayleigh becomes "
                   "isotropic (g = 0) and Cornette–Shanks becomes HG with the same g. Natively, swapping them changes "
                   "the image by mean %s, 95th pct %s, max %s (signed %s). This gap is by design of the renderer; "
                   "Blender 4.3+ has a Rayleigh phase." % (fmt_pct(pf["mean_rel_err"]), fmt_pct(pf["p95_rel_err"]),
                                                            fmt_pct(pf["max_rel_err"]),
                                                            fmt_pct(pf["signed_mean_rel_err"])))
    rg = gaps.get("rgb_model")
    if rg:
        wl = job.get("rgb_wavelengths_nm", [])
        out.append("**RGB rendering.** Cycles multiplies three coefficients (the exporter's, at %s nm) by the lamp's RGB "
                   "irradiance instead of integrating the spectrum: mean %s, 95th pct %s, max %s (signed %s)." % (
                       "/".join("%g" % w for w in wl), fmt_pct(rg["mean_rel_err"]), fmt_pct(rg["p95_rel_err"]),
                       fmt_pct(rg["max_rel_err"]), fmt_pct(rg["signed_mean_rel_err"])))
    e = summary["paths"].get(path, {})
    rr = e.get("rgb_render")
    if e.get("blender_mode") == "split":
        text = ("**Two Cycles 3.4 biases, and how this image avoids them.** The Blender image above is the sum of "
                "grey renders with one Volume Scatter each: per channel c and scattering constituent i, every "
                "coefficient at channel c's value, constituent i scattering, every other extinction as Volume "
                "Absorption, a white lamp of channel c's irradiance, the ground lit in one render only. One render "
                "the way users make it — chromatic coefficients, every constituent's Volume Scatter in one material — "
                "is biased in Cycles 3.4: it picks a colour channel afresh at every ray-marching step "
                "(volume_integrate_step_scattering), which biases a chromatic heterogeneous medium, and it sums the "
                "phase functions of several Volume Scatter closures without their weights "
                "(_volume_shader_phase_eval_mis). ")
        if rr:
            text += "Here that render differs from the same reference by %s." % bias_summary(rr)
        else:
            text += "That render was not made in this run (--volume-modes)."
        rd = e.get("rgb_dither_render")
        if rd:
            text += (" With the scatterers' phases dithered into one Volume Scatter (anisotropy and colour of "
                     "constituent j with probability ∝ max σs_j ρ_j, White Noise of the position; rgb_dither) only "
                     "the colour-channel bias is left: %s." % bias_summary(rd))
        out.append(text)
    elif e.get("blender_mode") == "dither":
        m = job.get("multiple", {})
        text = ("**Multiple scattering, and Cycles 3.4's phase-summing bias.** Cycles renders every order of "
                "scattering (volume and diffuse bounces up to %s, Russian roulette after that is unbiased), the ground "
                "lit by sun and sky and reflecting back into the medium; natively the orders-of-scattering tables at "
                "their default size add it (docs/multiple_scattering.md). Scattering is not additive over "
                "constituents once light scatters twice, so each of the three renders per seed holds the whole medium, "
                "grey, at one channel, lit by a white lamp of that channel's irradiance. The constituents' "
                "Henyey–Greenstein phases are merged into one Volume Scatter whose anisotropy is g_j with probability "
                "σs_j/σs at each point, drawn by a White Noise texture of the position: in expectation the phase is "
                "the mixture Σ σs_j p_j/σs, with one closure, which Cycles handles without bias." % m.get("bounces"))
        cr = e.get("closures_render")
        if cr:
            text += (" The same medium with one Volume Scatter per constituent, as users build it, differs from the "
                     "reference by mean %s, signed %s, %s beyond noise: Cycles 3.4 sums the phase functions of "
                     "several closures without their weights (_volume_shader_phase_eval_mis)." % (
                         fmt_pct(cr["mean_rel_err"]), fmt_pct(cr["signed_mean_rel_err"]),
                         fmt_pct(cr["bias_beyond_noise"])))
        out.append(text)
        ms_gap = gaps.get("multiple_scattering")
        vs = e.get("vs_single_scattering")
        if ms_gap and vs:
            out.append("**What is being checked.** Leaving multiple scattering out changes the native image by mean "
                       "%s (signed %s); against that single-scattering image this Blender render is off by mean %s, "
                       "%s beyond noise — the agreement above is the multiple scattering's, not luck." % (
                           fmt_pct(ms_gap["mean_rel_err"]), fmt_pct(ms_gap["signed_mean_rel_err"]),
                           fmt_pct(vs["mean_rel_err"]), fmt_pct(vs["bias_beyond_noise"])))
    elif e.get("blender_mode") == "rgb":
        out.append("**Cycles 3.4 biases.** This is one render with chromatic coefficients and every Volume Scatter in "
                   "one material, which Cycles 3.4 renders biased (per-step colour-channel sampling; unweighted sum of "
                   "phase functions); the split renders that avoid both were not made in this run.")
    vol = job.get("volume", {})
    b = summary["paths"].get(path, {}).get("blender", {}).get("build", {}).get("volume", {}) or {}
    out.append("**Cycles' ray marching.** Volumes are marched with step %s km (volume_max_steps %s; longer rays get "
               "longer steps) at a random offset per ray, which is unbiased for the in-scatter integral and biased "
               "only at second order in the optical depth of one step; the noise it adds is in the MC noise column." % (
                   ("%.4g" % b["step_km"]) if "step_km" in b else vol.get("step_km"), vol.get("max_steps")))
    if path == "vdb_volume":
        v = job.get("vdb", {})
        est = summary.get("voxelisation_estimates", {})
        parts = ", ".join("%s ≈ %s" % (n, fmt_pct(x["trilinear_mean_overestimate"])) for n, x in est.items())
        out.append("**Voxelisation.** Densities are stored every %.4g km and interpolated trilinearly; linear "
                   "interpolation of exp(−h/H) overestimates the density by about (Δ/H)²/12: %s." % (
                       v.get("voxel_size", 0), parts or "—"))
        half = ", ".join("%s %s" % (n, fmt_pct(x["half_voxel_shift_if_uncorrected"])) for n, x in est.items())
        out.append("**Half-voxel offset.** Blender before 5.0 places a voxel's value at the voxel centre, half a voxel "
                   "from OpenVDB's convention; the comparison moves the volume object by −½ voxel on each axis to undo "
                   "it%s. Uncorrected, densities would be off by exp(Δ/2H) − 1: %s." % (
                       "" if b.get("half_voxel_correction", True) else " (NOT applied in this run)", half or "—"))
        rb = gaps.get("region_box")
        if rb:
            out.append("**Region.** The VDB holds the box %s km around what the camera sees within its max distance; "
                       "view and sun rays find no medium outside it. The native reference is cut to the same box; "
                       "the whole shell differs from it by mean %s, 95th pct %s (signed %s)." % (
                           ", ".join("%.4g" % x for x in v.get("box_km", [])), fmt_pct(rb["mean_rel_err"]),
                           fmt_pct(rb["p95_rel_err"]), fmt_pct(rb["signed_mean_rel_err"])))
    cut = summary.get("closure_cutoff", {})
    if cut:
        worst = max(((k, ch, x) for k, v in cut.items() for ch, x in v.items()),
                    key=lambda t: t[2]["vertical_optical_depth_lost"])
        out.append("**Closure cut-off.** Cycles skips closures weaker than 10⁻⁵ per Blender unit (km); the largest "
                   "loss is %s %s above %.1f km, a vertical optical depth of %.2g." % (
                       worst[0], worst[1], worst[2]["above_km"], worst[2]["vertical_optical_depth_lost"]))
    out.append("**The planet.** Blender's ground is a mesh of rings around the camera's nadir (facets of millimetres "
               "below the camera, tens of metres on the far side) with exact sphere normals; natively it is a sphere.")
    return out


def write_outputs(d, contents):
    """Every file of `contents` ({name: text}) to a temporary file first, then all renamed into
    place: a failure leaves none of them half-written (and no temporary file)."""
    tmps = {}
    try:
        for name, content in contents.items():
            tmps[name] = os.path.join(d, "." + name + ".tmp")
            with open(tmps[name], "w", encoding="utf-8") as f:
                f.write(content)
        for name, tmp in tmps.items():
            os.replace(tmp, os.path.join(d, name))
    finally:
        for tmp in tmps.values():
            if os.path.exists(tmp):
                os.remove(tmp)


def arguments(argv):
    """DIR, from `report.py DIR` or, inside Blender, from what follows `--`."""
    if "--" in argv:
        argv = argv[argv.index("--") + 1:]
    elif B.bpy is not None:
        argv = []  # Blender's own arguments are not ours
    else:
        argv = argv[1:]
    if len(argv) != 1:
        raise SystemExit("usage: report.py DIR  (in Blender: blender -b --factory-startup --python-exit-code 1 "
                         "--python report.py -- DIR)")
    return os.path.abspath(argv[0])


def main(argv):
    global B
    B = Backends()
    d = arguments(argv)
    print("report: " + B.describe())
    try:
        job = job_schema.load(os.path.join(d, "job.json"))
    except job_schema.JobSchemaError as e:
        raise SystemExit("report.py: %s" % e) from None
    summary, images = analyse(d, job)
    text = markdown(job, summary, images)
    write_outputs(d, {"summary.json": json.dumps(summary, indent=2) + "\n", "report.md": text})
    for path, e in summary["paths"].items():
        if "error" in e:
            print("%-16s ERROR %s" % (path, str(e["error"]).splitlines()[0]))
        else:
            print("%-16s mean %.4f%%  p95 %.4f%%  max %.4f%%  noise %.4f%%  %s %.1f s  native %.2f s" % (
                path, 100 * e["mean_rel_err"], 100 * e["p95_rel_err"], 100 * e["max_rel_err"], 100 * e["noise_rel"],
                e.get("renderer", "blender"), e["blender_seconds"], e["native_seconds"]))


if __name__ == "__main__":
    main(sys.argv)
