"""Extremes of every numeric command-line option (issue 17, item 3; docs/reliability.md "Extremes").

OPTIONS below lists, for every option of every `airmass` subcommand that takes a number (or a
list of numbers), its documented range. Each option is run at its bounds, just inside and just
outside them (the next integer; for real numbers the next double, np.nextafter), and at 0, -1,
1e308, -1e308, inf, -inf, nan, a non-number and (integers) 1.5, on a tiny base run of its
subcommand (a 16 x 8 sky, an 8 x 4 render, one CSV row ...). Every run must end either

  * refused: exit 2, stderr naming the option and its range, no traceback, and nothing new
    in the run's folder (no output, no temporary); or
  * accepted: exit 0 and the output complete and finite - EXR pixels finite and >= 0 (read with
    OpenImageIO), CSV fields finite (radiances and transmittances >= 0), the .pov and JSON
    without nan/inf;

never a signal, a hang (TIMEOUT) or anything else. A value inside the range must be accepted
(options marked `either` may refuse an in-range value that another limit stops - a voxel grid
over the memory budget, say - if the refusal names the option), a value outside refused.

`airmass compare` and `airmass report ...` are swept without their renders: the base run is
made to fail at its first step after the option checks (compare: --scripts names an empty
folder; report: --out lies under a regular file), so an accepted value shows as that error
and a refused one as the option's, with -o/--out never created.

test_every_numeric_option_is_in_the_table reads each subcommand's --help: every option whose
value is an INT or a FLOAT (CLI11's type names) must be in OPTIONS, so an option added without
a row here fails.

Run: AIRMASS_CLI=<build>/bin/airmass /usr/bin/python3 -m pytest -q tests/cli/test_cli_extremes.py
"""
import json
import math
import os
import re
import subprocess
from dataclasses import dataclass, field

import numpy as np
import pytest

TIMEOUT = 120  # s per run; a hang fails
INF = math.inf
DBL_MAX = np.finfo(np.float64).max
INT_MAX = 2**31 - 1
MS_TABLE = "6,16,12,4"  # small multiple-scattering tables (as tests/cli/test_cli.py)


@dataclass
class Base:
    """A cheap run of a subcommand. `fixed` options are replaced when the swept option is one of
    them; '{d}' is the run's folder."""
    args: list
    fixed: dict = field(default_factory=dict)
    stdin: str = None
    kind: str = "files"  # files: exit 0 writes outputs; csv / json: stdout; stopped: fails after the checks
    outputs: tuple = ()  # files an accepted run writes (relative to {d})
    stopped_by: str = None  # kind "stopped": the error an accepted value must end in
    absent: tuple = ()  # kind "stopped": paths that must never be created


SKY = ["sky", "--preset", "earth", "-q"]
SKY_FIXED = {"--width": "16", "--height": "8", "--samples": "2"}
SEQUENCE = {"--time-range": "2026-06-21T18:00:00Z,2026-06-21T18:00:00Z", "--fps": "1", "--latitude": "40",
            "--longitude": "-105"}
RENDER = ["render", "--preset", "earth", "-q", "-o", "{d}/r.exr"]
RENDER_FIXED = {"--width": "8", "--height": "4", "--samples": "2"}
POV = ["pov", "--preset", "earth", "-q", "-o", "{d}/x.pov"]
SMALL = {"--width": "8", "--height": "4"}

BASES = {
    "sky": Base(SKY + ["--no-multiple", "-o", "{d}/sky.exr"], SKY_FIXED, outputs=("sky.exr",)),
    "sky_ms": Base(SKY + ["-o", "{d}/sky.exr"], {**SKY_FIXED, "--ms-table": MS_TABLE}, outputs=("sky.exr",)),
    "sky_seq": Base(SKY + ["--no-multiple", "-o", "{d}/sky_####.exr"], {**SKY_FIXED, **SEQUENCE},
                    outputs=("sky_0001.exr", "sky.csv")),
    "render": Base(RENDER, RENDER_FIXED, outputs=("r.exr",)),
    "render_ms": Base(RENDER + ["--multiple"], {**RENDER_FIXED, "--ms-table": MS_TABLE}, outputs=("r.exr",)),
    "pov": Base(POV + ["--path", "analytic"], SMALL, outputs=("x.pov",)),
    "pov_sky": Base(POV + ["--path", "sky"], {**SMALL, "--sky-width": "64"}, outputs=("x.pov",)),
    "pov_df3": Base(POV + ["--path", "df3"], {**SMALL, "--voxel-size": "20"}, outputs=("x.pov",)),
    "vdb": Base(["vdb", "--preset", "earth", "--region", "planet", "--json", "-q", "-o", "{d}/a.vdb"],
                {"--voxel-size": "50"}, kind="json"),  # 200 km: too coarse for the haze (fix 22)
    "eval": Base(["eval", "--preset", "earth", "--no-multiple"], {"--samples": "4"}, stdin="100,60,30,0\n",
                 kind="csv"),
    "eval_ms": Base(["eval", "--preset", "earth"], {"--samples": "4", "--ms-table": MS_TABLE},
                    stdin="100,60,30,0\n", kind="csv"),
    "sun": Base(["sun"], {"--latitude": "40", "--longitude": "-105", "--time": "2026-06-21T18:00:00Z"},
                kind="csv"),
    "sun_refraction": Base(["sun", "--refraction"],
                           {"--latitude": "40", "--longitude": "-105", "--time": "2026-06-21T18:00:00Z"}, kind="csv"),
    "compare": Base(["compare", "--preset", "earth", "--scripts", "{d}/no-scripts", "--blender", "{d}/no-blender",
                     "-q", "-o", "{d}/cmp"], SMALL, kind="stopped",
                    stopped_by="cannot find the compare scripts", absent=("cmp",)),
}
for _topic in ("chapman", "sky", "ms", "vdb"):
    BASES["report_" + _topic] = Base(["report", _topic, "--out", "{d}/blocker/out"], kind="stopped",
                                     stopped_by="--out", absent=("blocker/out",))


@dataclass
class Opt:
    base: str
    name: str
    kind: str  # "int", "number" or "text"
    lo: float = None
    hi: float = None
    ends: str = "[]"  # which bounds belong to the range: "[]", "(]", "[)", "()"
    range_text: str = None  # regex a refusal must show [default: the range as int_in/number_in print it]
    also_accepted: tuple = ()  # values outside [lo, hi] that are valid (a "-1: automatic")
    also_refused: tuple = ()  # values inside [lo, hi] that are not (an odd --sky-width)
    either: bool = False  # an in-range value may be refused by another limit, if the option is named
    not_run: tuple = ()  # accepted values too costly to run here (a 1e9-pixel sky)
    texts: tuple = ()  # kind "text": (value, accepted) pairs
    extra: tuple = ()  # more values to try


def _i(base, name, lo, hi, **kw):
    return Opt(base, name, "int", lo, hi, **kw)


def _n(base, name, lo, hi, ends="[]", **kw):
    return Opt(base, name, "number", lo, hi, ends, **kw)


def _t(base, name, range_text, texts, **kw):
    return Opt(base, name, "text", range_text=range_text, texts=tuple(texts), **kw)


def _camera(base):
    return [
        _n(base, "--fov", 1e-6, 180, "[)"),
        _n(base, "--max-distance", 0, 1e300, "(]"),
        _t(base, "--camera-position-km", r"\[-1e7, 1e7\]|finite number|3 comma",
           [("0,0,0.002", True), ("0,0,1e7", True), ("0,0,10000000.000000002", False), ("-1e7,0,1", True),
            ("0,0,1e308", False), ("0,0,inf", False), ("0,0,nan", False), ("0,0", False), ("a,b,c", False)]),
    ]


def _sun_overrides(base):
    return [_n(base, "--sun-elevation", -90, 90), _n(base, "--sun-rotation", -1e6, 1e6)]


def _ms(base, max_samples):
    # --ms-orders: 0 (automatic) or [2, 1000]. 1000 orders of the small table take ~2 s: once
    # an order repeats the last bit for bit (after ~80-120 orders, the floor of ln G) the rest
    # are added, not recomputed (multiple_scattering.hpp repeats_after_order).
    return [
        _i(base, "--ms-orders", 0, 1000, range_text=r"\[[02], 1000\]", also_refused=(1,), extra=(2,)),
        _i(base, "--ms-samples", 1, max_samples, extra=(1000,)),
        _t(base, "--ms-table", r"whole number|four node counts|must be",
           [("6,16,12,4", True), ("6,16,12,0", True), ("-1,16,12,4", False), ("6,16,12", False),
            ("6,16,12,1e308", False), ("6,16,nan,4", False), ("6,16,12,inf", False), ("6,16,1.5,4", False),
            ("x", False)]),
    ]


SKY_MAX = 65536
OPTIONS = [
    # ---- sky ---------------------------------------------------------------------------------
    _i("sky", "--width", 4, SKY_MAX),
    _i("sky", "--height", 2, SKY_MAX),
    _i("sky", "--samples", 1, 65536),
    # --grid and --ms-grid at their tops: a grid with as many rays as the image evaluates is not
    # built (every pixel / every ray instead, sky.hpp), so 16384 on a 16 x 8 sky is 64 rays.
    _i("sky", "--grid", 4, 16384, range_text=r"\[(-1|4), 16384\]", also_accepted=(-1, 0), extra=(64,)),
    _i("sky", "--threads", 0, 4096),
    _n("sky", "--sun-elevation", -90, 90),
    _n("sky", "--sun-rotation", -1e6, 1e6),
    _n("sky", "--altitude-km", 0, 1e6),
    _t("sky", "--wavelengths", r"\[360, 830\]|\[1, 359\]|not a number",
       [("3", True), ("550,", True), ("360:830:47", True), ("359.9,500", False), ("500,830.0001", False),
        ("nan,500", False), ("inf", False), ("1e308", False), ("0", False), ("-5", False), ("x", False)],
       extra=()),
    # --ms-samples 100000: the 16 x 8 sky's 64 rays integrated with 1e5 intervals each (~9 s).
    *_ms("sky_ms", 100000),
    _i("sky_ms", "--ms-grid", 2, 16384, range_text=r"\[[02], 16384\]", also_accepted=(0,), extra=(64,)),
    _n("sky_seq", "--latitude", -90, 90),
    _n("sky_seq", "--longitude", -180, 180),
    _n("sky_seq", "--delta-t", -1e5, 1e5),
    _n("sky_seq", "--delta-ut1", -1, 1),
    _t("sky_seq", "--fps", r"between 1e-9 and 1e6",
       [("1", True), ("1/600", True), ("1e6", True), ("1e-9", True), ("1.0000001e6", False), ("0", False),
        ("-1", False), ("1e308", False), ("inf", False), ("nan", False), ("1/0", False), ("x", False)]),
    _t("sky_seq", "--frames", r"1 <= A <= B <= 1",
       [("1-1", True), ("1", True), ("0-1", False), ("1-2", False), ("-1", False), ("1e308", False),
        ("nan", False), ("x", False)]),
    # ---- render ------------------------------------------------------------------------------
    _i("render", "--width", 1, 65536),
    _i("render", "--height", 1, 65536),
    _i("render", "--samples", 1, 65536),
    _i("render", "--threads", 0, 4096),
    *_sun_overrides("render"),
    *_camera("render"),
    _t("render", "--box", r"\[-1e7, 1e7\]|finite number|6 comma",
       [("-10,-10,0,10,10,5", True), ("0,0,0,0,0,0", False), ("-1e7,-1e7,0,1e7,1e7,5", True),
        ("-10,-10,0,10,10,1e308", False), ("-10,-10,0,10,10,10000000.000000002", False), ("-10,-10,0,10,10,inf", False),
        ("-10,-10,0,10,10,nan", False), ("-10,-10,0,10,10", False), ("x", False)]),
    *_ms("render_ms", 65536),
    # ---- pov ---------------------------------------------------------------------------------
    _i("pov", "--width", 1, 65536),
    _i("pov", "--height", 1, 65536),
    _i("pov", "--media-intervals", 1, 100000),
    _i("pov", "--media-samples", 1, 100000),
    _i("pov", "--threads", 0, 4096),
    *_sun_overrides("pov"),
    *_camera("pov"),
    # --sky-width: even, and width x width/2 within a sky's 1e9 pixels; the top is not rendered here.
    _i("pov_sky", "--sky-width", 64, 44720, also_refused=(65, 44719), not_run=(44718, 44720)),
    _n("pov_df3", "--voxel-size", 0, 1e6, "(]", either=True),
    # ---- vdb ---------------------------------------------------------------------------------
    _n("vdb", "--voxel-size", 0, 1e6, "(]", either=True),
    _n("vdb", "--tolerance", 0, 1e300, either=True),
    _n("vdb", "--max-dense-mb", 0, 1e12, "(]", either=True),
    _n("vdb", "--max-memory-mb", 0, 1e12, "(]", either=True),
    _i("vdb", "--tile-voxels", -1, 65536, range_text=r"\[-1, 65536\]|multiple of 8", also_refused=(1, 65535, 65537),
       either=True, extra=(8, 64)),
    _i("vdb", "--max-tiles", 1, 100000, either=True),
    _i("vdb", "--threads", 0, 4096),
    # ---- eval --------------------------------------------------------------------------------
    _i("eval", "--samples", 1, 1000000),
    _i("eval", "--threads", 0, 4096),
    _n("eval", "--solar-irradiance", 0, 1e30),
    _t("eval", "--wavelengths", r"\(0, 1e6\)",
       [("550", True), ("680,550,440", True), ("0", False), ("-1", False), ("999999.99", True), ("1e6", False),
        ("nan", False), ("inf", False), ("1e308", False), ("x", False)]),
    *_ms("eval_ms", 100000),
    # ---- sun ---------------------------------------------------------------------------------
    _n("sun", "--latitude", -90, 90),
    _n("sun", "--longitude", -180, 180),
    _n("sun", "--delta-t", -1e5, 1e5),
    _n("sun", "--delta-ut1", -1, 1),
    _n("sun", "--site-elevation", -10000, 1e7),
    _n("sun_refraction", "--pressure", 0, 5000, "(]"),
    _n("sun_refraction", "--temperature", -120, 1000, "[)"),
    # ---- compare (stopped before any render) -----------------------------------------------------
    _i("compare", "--width", 1, 65536),
    _i("compare", "--height", 1, 65536),
    _i("compare", "--samples", 1, 1 << 20),
    _i("compare", "--seeds", 2, 1000),
    _i("compare", "--sky-samples", 1, 1 << 20),
    _i("compare", "--ms-bounces", 1, 1024),
    _i("compare", "--view-samples", 1, 65536),
    _n("compare", "--sky-oversample", 0.25, 16),
    _i("compare", "--sky-min-width", 64, 44720),
    _i("compare", "--sky-max-width", 64, 44720),
    _n("compare", "--voxel-size", 0, 1e6, "(]"),
    _n("compare", "--max-dense-mb", 0, 1e12, "(]"),
    _n("compare", "--step", 1e-4, 1e3),
    _i("compare", "--max-steps", 2, 65536),
    _i("compare", "--pov-intervals", 1, 100000),
    _i("compare", "--pov-samples", 1, 100000),
    _i("compare", "--threads", 0, 4096),
    _n("compare", "--timeout", 1, 1e6),
    *_sun_overrides("compare"),
    *_camera("compare"),
    # ---- report (stopped before any work) ------------------------------------------------------
    _i("report_chapman", "--points", 10, 1000000),
    _i("report_sky", "--width", 16, 4096),
    _i("report_sky", "--reference-samples", 16, 65536),
    _i("report_ms", "--paths", 100, 100000000),
    _i("report_ms", "--seed", 0, 2**63 - 1),
    _i("report_ms", "--threads", 0, 4096),
    _t("report_vdb", "--voxel-sizes", r"a length > 0",
       [("1,2", True), ("0", False), ("-1", False), ("nan", False), ("inf", False), ("x", False)]),
    _t("report_vdb", "--tolerances", r"an optical depth >= 0",
       [("1e-3,1e-2", True), ("0", True), ("-1", False), ("nan", False), ("inf", False), ("x", False)]),
    _n("report_vdb", "--tolerance-voxel-size", 1e-3, 1e3),
]


# ---- the values ----------------------------------------------------------------------------------

def _num_text(v):
    if isinstance(v, str):
        return v
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return "%.17g" % v


def _inside(opt, v):
    lo_ok = v > opt.lo if opt.ends[0] == "(" else v >= opt.lo
    hi_ok = v < opt.hi if opt.ends[1] == ")" else v <= opt.hi
    return lo_ok and hi_ok


def cases(opt):
    """(text, accepted) for every value the option is tried at."""
    if opt.kind == "text":
        return list(opt.texts)
    out = {}
    if opt.kind == "int":
        lo, hi = int(opt.lo), int(opt.hi)
        ints = {lo - 1, lo, lo + 1, hi - 1, hi, hi + 1, 0, -1, *opt.also_accepted, *opt.also_refused, *opt.extra}
        for v in ints:
            ok = (lo <= v <= hi or v in opt.also_accepted) and v not in opt.also_refused
            out[str(v)] = ok
        for text in ("1e308", "inf", "nan", "abc", "1.5", ""):
            out[text] = False
    else:
        vals = {0.0, -1.0, 1e308, -1e308, INF, -INF, *opt.extra}
        for b in (opt.lo, opt.hi):
            if math.isfinite(b):
                vals |= {b, float(np.nextafter(b, -INF)), float(np.nextafter(b, INF))}
        for v in vals:
            out[_num_text(v)] = _inside(opt, v)
        out["nan"] = False
        out["abc"] = False
        out[""] = False
    return sorted(out.items())


def range_text(opt):
    """A regex the refusal's message must match."""
    if opt.range_text:
        return opt.range_text
    def bound(v):
        if opt.kind == "int":
            return str(int(v))
        a = abs(v)
        first = int(math.floor(math.log10(a))) + 1 if 1 <= a < 1e6 else 1
        for digits in range(first, 18):
            s = "%.*g" % (digits, v)
            if float(s) == v:
                break
        m = re.fullmatch(r"(-?[0-9.]+)e([+-])0*([0-9]+)", s)
        return "%se%s%s" % (m.group(1), "-" if m.group(2) == "-" else "", m.group(3)) if m else s
    return re.escape("%s%s, %s%s" % (opt.ends[0], bound(opt.lo), bound(opt.hi), opt.ends[1]))


def names_range(opt, text, stderr):
    """A refusal names the range; of a non-number, naming the option is enough."""
    if text in ("abc", "", "x") and opt.kind == "text":
        return True
    return re.search(range_text(opt), stderr) is not None


PARAMS = []
for _opt in OPTIONS:
    for _text, _ok in cases(_opt):
        _id = "%s %s=%s" % (_opt.base, _opt.name, _text or "<empty>")
        if _ok and _text.lstrip("-").isdigit() and int(_text) in _opt.not_run:
            continue
        PARAMS.append(pytest.param(_opt, _text, _ok, id=_id))


# ---- running and checking --------------------------------------------------------------------------

def _files(d):
    return sorted(str(p.relative_to(d)) for p in d.rglob("*") if p.is_file())


def _assert_finite_exr(path):
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(str(path))
    assert not buf.has_error, buf.geterror()
    px = buf.get_pixels(oiio.FLOAT)
    assert px.size > 0
    bad = ~np.isfinite(px)
    assert not bad.any(), "%s: %d non-finite values" % (path.name, int(bad.sum()))
    assert px.min() >= 0.0, "%s: min %g" % (path.name, px.min())


def _csv_numbers(text):
    lines = [l for l in text.splitlines() if l.strip()]
    assert len(lines) >= 2, text
    header = lines[0].split(",")
    rows = []
    for line in lines[1:]:
        fields = line.split(",")
        assert len(fields) == len(header), line
        row = {}
        for name, f in zip(header, fields):
            try:
                row[name] = float(f)
            except ValueError:
                row[name] = f  # a time or a file name
        rows.append(row)
    return rows


def _check_numbers(obj, where, nonnegative=True):
    if isinstance(obj, dict):
        for k, v in obj.items():
            _check_numbers(v, "%s.%s" % (where, k), nonnegative)
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            _check_numbers(v, "%s[%d]" % (where, i), nonnegative)
    elif isinstance(obj, float) or (isinstance(obj, int) and not isinstance(obj, bool)):
        assert math.isfinite(obj), (where, obj)
        if nonnegative:
            assert obj >= 0, (where, obj)


def check_accepted_output(base, d, r):
    if base.kind == "csv":
        rows = _csv_numbers(r.stdout)
        for row in rows:
            for k, v in row.items():
                if isinstance(v, float):
                    assert math.isfinite(v), (k, v, r.stdout)
                    # eval: every column (inputs given >= 0, transmittance, radiances) >= 0;
                    # sun: angles and places are signed.
                    if base.args[0] == "eval":
                        assert v >= 0, (k, v, r.stdout)
        return
    if base.kind == "json":
        stats = json.loads(r.stdout)
        _check_numbers(stats, "stats", nonnegative=False)  # the box's corners are signed
        assert any(p.suffix == ".vdb" for p in d.iterdir()), _files(d)
        return
    for name in base.outputs:
        assert (d / name).is_file(), (name, _files(d), r.stderr)
    for p in d.rglob("*"):
        if p.suffix == ".exr":
            _assert_finite_exr(p)
        elif p.suffix in (".pov", ".inc", ".json"):
            text = p.read_text(errors="replace")
            assert not re.search(r"(?<![A-Za-z_])(nan|-?inf)(?![A-Za-z_])", text, re.I), p.name
        elif p.suffix == ".csv":
            for row in _csv_numbers(p.read_text()):
                for k, v in row.items():
                    assert not isinstance(v, float) or math.isfinite(v), (p.name, k, v)
    assert not [f for f in _files(d) if ".tmp" in f or f.endswith("~")], _files(d)


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory):
    # One table cache for the module: the multiple-scattering tables of MS_TABLE are computed once.
    return tmp_path_factory.mktemp("table-cache")


@pytest.mark.parametrize("opt, text, accepted", PARAMS)
def test_option_extreme(airmass_bin, tmp_path, cache_dir, opt, text, accepted):
    base = BASES[opt.base]
    d = tmp_path / "run"
    d.mkdir()
    if base.kind == "stopped" and base.absent and base.absent[0].startswith("blocker/"):
        (d / "blocker").write_text("a file where --out wants a folder")
    fixed = dict(base.fixed)
    fixed.pop(opt.name, None)
    args = [a.replace("{d}", str(d)) for a in base.args]
    for k, v in fixed.items():
        args.append("%s=%s" % (k, v))
    args.append("%s=%s" % (opt.name, text))  # '=': values that start with '-' stay values
    before = _files(d)
    env = dict(os.environ, AIRMASS_CACHE_DIR=str(cache_dir))
    try:
        r = subprocess.run([airmass_bin, *args], input=base.stdin or "", capture_output=True, text=True,
                           timeout=TIMEOUT, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail("hang: no exit within %d s: %s" % (TIMEOUT, " ".join(args)))
    what = "%s -> exit %d\nstderr: %s" % (" ".join(args), r.returncode, r.stderr[-2000:])
    assert r.returncode >= 0, "killed by signal %d: %s" % (-r.returncode, what)
    assert "Traceback" not in r.stderr and "terminate called" not in r.stderr, what
    assert r.returncode in (0, 2), what

    if base.kind == "stopped":
        for p in base.absent:
            assert not (d / p).exists(), "%s created: %s" % (p, what)
        if accepted:
            assert r.returncode == 2 and base.stopped_by in r.stderr and opt.name + ":" not in r.stderr \
                and "%s " % opt.name not in r.stderr.replace(base.stopped_by, ""), \
                "an in-range value was refused: " + what
        else:
            assert r.returncode == 2 and opt.name in r.stderr and names_range(opt, text, r.stderr), \
                "not refused with the option and its range: " + what
        return

    if r.returncode == 2:
        assert opt.name in r.stderr, "refused without naming %s: %s" % (opt.name, what)
        assert _files(d) == before, "a refused run left files: %s\n%s" % (_files(d), what)
        if accepted:
            assert opt.either, "an in-range value was refused: " + what
        else:
            assert names_range(opt, text, r.stderr), "the range %r not named: %s" % (range_text(opt), what)
        return
    assert accepted, "an out-of-range value was accepted: " + what
    check_accepted_output(base, d, r)


# ---- completeness ------------------------------------------------------------------------------

SUBCOMMANDS = [["sky"], ["render"], ["pov"], ["vdb"], ["eval"], ["sun"], ["chapman"], ["compare"],
               ["report", "chapman"], ["report", "sky"], ["report", "ms"], ["report", "vdb"]]


def _numeric_options(airmass_bin, sub):
    r = subprocess.run([airmass_bin, *sub, "--help"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r
    found = set()
    for line in r.stdout.splitlines():
        m = re.match(r"\s+(?:-\w,)?(--[\w-]+)(?:\s+(\S+))?", line)
        if m and m.group(2) and re.match(r"(INT|UINT|FLOAT|NUMBER)\b", m.group(2)):
            found.add(m.group(1))
    return found, r.stdout


def _table_key(sub):
    return "report_" + sub[1] if sub[0] == "report" else sub[0]


def test_every_numeric_option_is_in_the_table(airmass_bin):
    swept = {}
    for o in OPTIONS:
        swept.setdefault(o.base.split("_")[0] if not o.base.startswith("report_") else o.base, set()).add(o.name)
    missing = {}
    for sub in SUBCOMMANDS:
        found, text = _numeric_options(airmass_bin, sub)
        key = _table_key(sub)
        if sub == ["sky"]:
            assert "--width" in found, text  # the parse works
        lacking = sorted(found - swept.get(key, set()))
        if lacking:
            missing[" ".join(sub)] = lacking
    assert not missing, "numeric options without a row in OPTIONS: %s" % missing


def test_ranges_are_in_the_help(airmass_bin):
    """Each swept option's help line states its range ("in [lo, hi]" from the check, or the range
    in the description)."""
    lacking = []
    for sub in SUBCOMMANDS:
        r = subprocess.run([airmass_bin, *sub, "--help"], capture_output=True, text=True, timeout=60)
        key = _table_key(sub)
        for o in OPTIONS:
            base = o.base if o.base.startswith("report_") else o.base.split("_")[0]
            if base != key or o.kind == "text":
                continue
            m = re.search(r"^\s+(?:-\w,)?%s\b.*$" % re.escape(o.name), r.stdout, re.M)
            assert m, (sub, o.name)
            if not re.search(r"[\[(]\s*-?[0-9.e+-]+,", m.group(0)):
                lacking.append("%s %s" % (" ".join(sub), o.name))
    assert not lacking, "no range in --help: %s" % lacking
