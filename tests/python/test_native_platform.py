"""native.py's choice of library on a stand-in macOS (`sys.platform == "darwin"`), against the add-on
zip this build made (<build>/addon/airmass_blender.zip) — in plain Python, without a Mac.

The zip carries one universal libairmass_c.dylib (arm64 + x86_64, scripts/build-macos.sh: built here
by cross-compilation, never run on a Mac here) when Zig could be installed, and its manifest then
lists macos-arm64 and macos-x64. native.py loads that one file on either CPU (`platform.machine()`
"arm64" or "x86_64"): the file must hold a slice for each, which the Mach-O fat header says. Without
the dylib native.py says plainly that the zip has no macOS library.
"""

import importlib.util
import platform
import re
import struct
import sys
import zipfile

import pytest

sys.dont_write_bytecode = True  # keep the source tree clean

FAT_MAGIC = 0xCAFEBABE                  # big-endian fat header (llvm-lipo / lipo)
CPU_TYPES = {0x0100000C: "arm64", 0x01000007: "x86_64"}   # CPU_TYPE_ARM64, CPU_TYPE_X86_64


def fat_slices(data):
    """The CPU names of a universal Mach-O file's slices ([] for anything else)."""
    if len(data) < 8 or struct.unpack_from(">I", data, 0)[0] != FAT_MAGIC:
        return []
    count = struct.unpack_from(">I", data, 4)[0]
    names = []
    for i in range(count):
        cputype, _sub, offset, size, _align = struct.unpack_from(">iiIII", data, 8 + 20 * i)
        slice_magic = struct.unpack_from("<I", data, offset)[0]
        assert slice_magic == 0xFEEDFACF, "slice %d is not a 64-bit Mach-O file" % i   # MH_MAGIC_64
        assert offset + size <= len(data)
        names.append(CPU_TYPES.get(cputype & 0xFFFFFFFF, hex(cputype)))
    return names


@pytest.fixture(scope="module")
def addon_zip(airmass_build):
    path = airmass_build / "addon" / "airmass_blender.zip"
    if not path.is_file():
        pytest.fail("no add-on zip at %s (build the airmass_addon_zip target)" % path)
    return path


@pytest.fixture
def unpacked(addon_zip, tmp_path):
    with zipfile.ZipFile(addon_zip) as z:
        z.extractall(tmp_path)
    return tmp_path / "airmass_blender"


def load_native(monkeypatch, folder):
    spec = importlib.util.spec_from_file_location("airmass_native_platform_test", folder / "native.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.delenv(module.LIBRARY_ENV, raising=False)
    return module


def manifest_platforms(folder):
    text = (folder / "blender_manifest.toml").read_text()
    m = re.search(r"^platforms\s*=\s*\[([^\]]*)\]", text, re.M)
    assert m, "the manifest has no platforms line"
    return set(re.findall(r'"([^"]+)"', m.group(1)))


@pytest.mark.parametrize("machine", ["arm64", "x86_64"])
def test_darwin_opens_the_universal_dylib_beside_native_py(monkeypatch, unpacked, machine):
    native = load_native(monkeypatch, unpacked)
    dylib = unpacked / "libairmass_c.dylib"
    macos = {"macos-arm64", "macos-x64"}
    if not dylib.is_file():
        # No Zig at build time: no macOS library, no macOS platform, and native.py says so.
        assert not (manifest_platforms(unpacked) & macos)
        monkeypatch.setattr(sys, "platform", "darwin")
        with pytest.raises(native.LibraryLoadError) as e:
            native.library()
        assert "carries no macOS library" in str(e.value)
        return
    assert macos <= manifest_platforms(unpacked)
    # One file serves both CPUs: it must hold this machine's slice.
    slices = fat_slices(dylib.read_bytes())
    assert sorted(slices) == ["arm64", "x86_64"], slices
    assert machine in slices
    monkeypatch.setattr(platform, "machine", lambda: machine)
    monkeypatch.setattr(sys, "platform", "darwin")
    opened = []

    def fake_cdll(path):
        opened.append(path)
        raise OSError("dlopen(%s): not run here (no Mac)" % path)

    monkeypatch.setattr(native.ctypes, "CDLL", fake_cdll)
    assert native.library_name() == "libairmass_c.dylib"
    with pytest.raises(native.LibraryLoadError) as e:
        native.library()
    assert opened == [str(dylib)], opened
    assert "failed to load" in str(e.value) and "carries no macOS library" not in str(e.value)


def test_linux_still_opens_the_so(monkeypatch, unpacked):
    """The stand-in darwin above must not change what Linux and Windows get from the same zip."""
    native = load_native(monkeypatch, unpacked)
    assert native.default_library_path("linux") == str(unpacked / "libairmass_c.so")
    assert native.default_library_path("win32") == str(unpacked / "airmass_c.dll")
    assert native.default_library_path("darwin") == str(unpacked / "libairmass_c.dylib")
