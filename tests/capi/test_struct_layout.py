"""The add-on's ctypes mirrors of the C ABI's structs (addon/airmass_blender/native.py) against
the C compilers' layouts (issue 17, item 5), and struct_size set from the mirror.

  * Linux: capi_struct_layout (built from tests/capi/struct_layout.py's generated program) prints
    every header struct's sizeof and each field's offsetof/sizeof; every mirror must match it
    field by field, with the header's field names in the header's order (so a field missing from
    a mirror is caught even where it would hide in trailing padding).
  * Windows x64: the same layout as _Static_asserts of the mirror's numbers, compiled with
    x86_64-w64-mingw32-gcc against the header; skipped, saying so, without the compiler. ctypes
    here lays the mirror out by the SysV rules; the mirror uses only types whose size and
    alignment Win64 shares (asserted below: no c_long, c_longdouble, bit fields, packing).
  * struct_size: the *_init functions take the size the host sets (ctypes.sizeof of the mirror)
    and refuse any other, leaving the struct untouched, so a stale mirror fails loudly.

Run: /usr/bin/python3 -m pytest -q tests/capi/test_struct_layout.py  with
  AIRMASS_STRUCT_LAYOUT=<capi_struct_layout executable> AIRMASS_C_LIBRARY=<libairmass_c.so>
"""
import ctypes
import importlib.util
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys

import pytest

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parents[1]
HEADER = REPO / "plugin" / "capi" / "include" / "airmass" / "airmass_c.h"
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(REPO / "addon" / "airmass_blender"))
import native  # noqa: E402  (pure Python, no bpy)
import struct_layout  # noqa: E402

MINGW = "x86_64-w64-mingw32-gcc"
# ctypes types whose size and alignment are the same under SysV x86-64 and Win64.
PORTABLE = (ctypes.c_uint32, ctypes.c_int32, ctypes.c_uint64, ctypes.c_int64, ctypes.c_double,
            ctypes.c_float, ctypes.c_char_p, ctypes.c_void_p)


def c_name(cls):
    """SceneSpec -> airmass_scene_spec."""
    return "airmass_" + re.sub(r"(?<!^)([A-Z])", r"_\1", cls.__name__).lower()


def _load(path, name):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# bench/portable_vs_native.py carries its own mirrors of two structs: checked as well.
BENCH = _load(REPO / "bench" / "portable_vs_native.py", "airmass_bench_portable")


def mirrors(module=native):
    found = {}
    for value in vars(module).values():
        if isinstance(value, type) and issubclass(value, ctypes.Structure) and value is not ctypes.Structure:
            found[c_name(value)] = value
    return found


def mirror_layout(cls):
    return {"size": ctypes.sizeof(cls), "align": ctypes.alignment(cls),
            "fields": [[name, getattr(cls, name).offset, getattr(cls, name).size] for name, *_ in cls._fields_]}


def header_structs():
    return struct_layout.parse_header(HEADER.read_text(encoding="utf-8"))


def test_every_header_struct_is_mirrored_and_nothing_else():
    structs, mirrored = header_structs(), mirrors()
    # The header has seven structs today; a parser that found none would make the rest vacuous.
    assert len(structs) >= 7, structs
    assert set(mirrored) == set(structs), (sorted(mirrored), sorted(structs))


@pytest.mark.parametrize("name", sorted(header_structs()))
def test_mirror_fields_are_the_headers(name):
    cls = mirrors()[name]
    assert [f[0] for f in cls._fields_] == header_structs()[name]


def _portable(t):
    if isinstance(t, type) and issubclass(t, ctypes.Array):
        return _portable(t._type_)
    if isinstance(t, type) and issubclass(t, (ctypes._Pointer, ctypes._CFuncPtr)):
        return True
    return t in PORTABLE or (isinstance(t, type) and issubclass(t, ctypes.Structure) and c_name(t) in mirrors())


@pytest.mark.parametrize("name", sorted(header_structs()))
def test_mirror_types_lay_out_alike_on_linux_and_windows(name):
    cls = mirrors()[name]
    assert not getattr(cls, "_pack_", 0), "%s: _pack_ set" % name
    for field in cls._fields_:
        assert len(field) == 2, "%s.%s: bit field" % (name, field[0])
        assert _portable(field[1]), "%s.%s: %r differs between SysV and Win64" % (name, field[0], field[1])


@pytest.fixture(scope="module")
def linux_layout():
    exe = os.environ.get("AIRMASS_STRUCT_LAYOUT")
    if not exe or not os.path.isfile(exe):
        pytest.fail("set AIRMASS_STRUCT_LAYOUT to the capi_struct_layout executable (got %r)" % exe)
    return json.loads(subprocess.run([exe], check=True, capture_output=True, text=True).stdout)["structs"]


@pytest.mark.parametrize("name", sorted(header_structs()))
def test_mirror_matches_the_linux_layout(linux_layout, name):
    c, py = linux_layout[name], mirror_layout(mirrors()[name])
    assert py["fields"] == c["fields"], "%s: ctypes [name, offset, size] != C" % name
    assert (py["size"], py["align"]) == (c["size"], c["align"]), "%s: sizeof/alignment" % name


@pytest.mark.parametrize("name", sorted(mirrors(BENCH)))
def test_bench_mirror_matches_the_linux_layout(linux_layout, name):
    cls = mirrors(BENCH)[name]
    assert [f[0] for f in cls._fields_] == header_structs()[name]
    c, py = linux_layout[name], mirror_layout(cls)
    assert py["fields"] == c["fields"] and py["size"] == c["size"], "bench %s: ctypes != C" % name


def test_bench_has_mirrors():
    assert set(mirrors(BENCH)) == {"airmass_scene_spec", "airmass_sky_options"}


def test_windows_layout_matches_the_mirror(tmp_path):
    cc = shutil.which(MINGW)
    if cc is None:
        pytest.skip("%s is not installed (scripts/setup.sh installs mingw-w64): Windows layout not checked" % MINGW)
    expected = {name: mirror_layout(cls) for name, cls in mirrors().items()}
    src = tmp_path / "layout_win64.c"
    src.write_text(struct_layout.c_static_asserts(expected))
    r = subprocess.run([cc, "-std=c11", "-fsyntax-only", "-I", str(HEADER.parents[1]), str(src)],
                       capture_output=True, text=True)
    assert r.returncode == 0, "the Windows x64 layout differs from the ctypes mirror:\n" + r.stderr
    # ... and the check can fail: one wrong offset is refused.
    name, cls = sorted(expected.items())[0]
    expected[name]["fields"][-1][1] += 4
    src.write_text(struct_layout.c_static_asserts(expected))
    r = subprocess.run([cc, "-std=c11", "-fsyntax-only", "-I", str(HEADER.parents[1]), str(src)],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "the ctypes mirror" in r.stderr, r.stderr


# ---- struct_size comes from the mirror ------------------------------------------------------------

INITS = [("airmass_scene_spec_init", "SceneSpec"), ("airmass_sky_options_init", "SkyOptions"),
         ("airmass_sky_view_init", "SkyView"),
         ("airmass_solar_query_init", "SolarQuery"),
         ("airmass_vdb_options_init", "VdbOptions"), ("airmass_vdb_block_init", "VdbBlock")]


@pytest.fixture(scope="module")
def lib():
    path = os.environ.get(native.LIBRARY_ENV)
    if not path or not os.path.isfile(path):
        pytest.fail("set %s to libairmass_c (got %r)" % (native.LIBRARY_ENV, path))
    return native.library()


@pytest.mark.parametrize("fn,cls", INITS)
def test_init_keeps_the_hosts_size_and_refuses_another(lib, fn, cls):
    cls = getattr(native, cls)
    init = getattr(lib, fn)
    good = cls()
    good.struct_size = ctypes.sizeof(cls)
    assert init(ctypes.byref(good)) == native.OK
    assert good.struct_size == ctypes.sizeof(cls)
    # A stale mirror: its size is refused and nothing is written (the marker stays; a library that
    # wrote its own defaults and size would overwrite both).
    for delta in (-8, 8):
        bad = (ctypes.c_ubyte * (ctypes.sizeof(cls) + 16))()
        ctypes.memset(bad, 0xAB, len(bad))
        ctypes.cast(bad, ctypes.POINTER(ctypes.c_uint32))[0] = ctypes.sizeof(cls) + delta
        assert init(ctypes.cast(bad, ctypes.POINTER(cls))) == native.INVALID_ARGUMENT
        assert ctypes.cast(bad, ctypes.POINTER(ctypes.c_uint32))[0] == ctypes.sizeof(cls) + delta
        assert all(b == 0xAB for b in bytes(bad)[4:]), "%s wrote into a struct it refused" % fn
    assert init(None) == native.INVALID_ARGUMENT


def test_wrappers_raise_a_clear_error_for_a_stale_mirror(lib, monkeypatch):
    """native.py sets struct_size from ctypes.sizeof: a mirror one field short is named."""
    class Short(ctypes.Structure):
        _fields_ = native.SkyOptions._fields_[:-1]
    # The signature names the real mirror; let the short one through, as a stale add-on's would be.
    monkeypatch.setattr(lib.airmass_sky_options_init, "argtypes", None)
    with pytest.raises(native.NativeError) as e:
        native._init_struct(lib.airmass_sky_options_init, Short(), "airmass_sky_options")
    assert e.value.status == native.INVALID_ARGUMENT
    assert "airmass_sky_options" in e.value.message and str(ctypes.sizeof(Short)) in e.value.message
