"""Command-line checks that need no renders (tests/cli/CMakeLists.txt registers them in CTest):

  * `airmass --version` prints "airmass X.Y.Z", X.Y.Z being project(... VERSION) in the top
    CMakeLists.txt, answered before any command is set up;
  * the table cache of `airmass sky`: a second run reads the tables the first one kept and
    writes the same pixels; a corrupted entry is replaced, never trusted; --no-cache neither
    reads nor writes; an unwritable cache folder is no error;
  * `airmass compare` takes its Blender children with it: a stand-in "blender" that records its
    pid and sleeps is started by `airmass compare`, the compare process is killed (SIGTERM: it
    cancels and kills the child's process group; SIGKILL: the kernel kills the child through
    PR_SET_PDEATHSIG) and the child must be gone within a few seconds.

Run: AIRMASS_CLI=<build>/bin/airmass /usr/bin/python3 -m pytest -q tests/cli/test_cli.py
"""
import os
import pathlib
import re
import resource
import signal
import subprocess
import sys
import time

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


# The airmass_bin fixture: tests/cli/conftest.py.


def project_version():
    text = (REPO / "CMakeLists.txt").read_text()
    m = re.search(r"project\s*\(\s*airmass\s+VERSION\s+([0-9][0-9.]*)", text)
    assert m, "no project(airmass VERSION ...) in CMakeLists.txt"
    return m.group(1)


# ---- --version ------------------------------------------------------------------------------------

def test_version_is_the_project_version(airmass_bin):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = subprocess.run([airmass_bin, "--version"], capture_output=True, text=True, timeout=60)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert r.returncode == 0, r
    assert r.stdout == "airmass %s\n" % project_version(), r.stdout
    assert r.stderr == ""
    # CPU time, not wall time (the machine may be loaded): the dynamic loader's work on the ~12
    # shared libraries the binary links (OpenVDB is not among them: test below) and nothing more; a
    # --version that set up a command or loaded a scene would not stay far below this.
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    assert cpu < 2.0, cpu


def test_start_loads_no_openvdb(airmass_bin):
    """libopenvdb's ≈ 64 000 relocations were most of every start of the tool; only the commands
    that write grids load it, through the module beside the executable (plugin/cli/vdb_module.hpp)."""
    env = dict(os.environ, LD_TRACE_LOADED_OBJECTS="1")  # the loader lists what a start maps
    r = subprocess.run([airmass_bin, "--version"], capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 0, r
    assert "libc.so" in r.stdout, r.stdout  # the listing happened
    assert "libopenvdb" not in r.stdout, r.stdout
    module = pathlib.Path(airmass_bin).parent / "libairmass_vdb_module.so"
    assert module.is_file(), "the OpenVDB writer module is not beside %s" % airmass_bin
    r = subprocess.run(["ldd", str(module)], capture_output=True, text=True, timeout=60)
    assert "libopenvdb" in r.stdout, r.stdout


def test_missing_vdb_module_is_a_named_error(airmass_bin, tmp_path):
    """A copy of the executable without its module: `airmass vdb` says which file it could not
    load, exits 2 and writes nothing; commands without grids are unaffected."""
    lonely = tmp_path / "airmass"
    lonely.write_bytes(pathlib.Path(airmass_bin).read_bytes())
    lonely.chmod(0o755)
    out = tmp_path / "out.vdb"
    r = subprocess.run([str(lonely), "vdb", "--preset", "earth", "--voxel-size", "20", "-o", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r
    assert "libairmass_vdb_module.so" in r.stderr and "cannot load the OpenVDB writer" in r.stderr, r.stderr
    assert list(tmp_path.iterdir()) == [lonely]
    r = subprocess.run([str(lonely), "--version"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r


def test_version_is_in_help(airmass_bin):
    r = subprocess.run([airmass_bin, "--help"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0 and "--version" in r.stdout, r


# ---- the table cache ---------------------------------------------------------------------------------

@pytest.mark.parametrize("args, first_line, hint", [
    (["sky", "--width", "-5"], "airmass: sky: --width: '-5': must be an integer in [4, 65536]", "airmass sky --help"),
    (["sky", "--bogus"], "airmass: sky: unknown option '--bogus'", "airmass sky --help"),
    # A mistyped option with a value: named, with the option meant, not CLI11's "scene excludes
    # --preset" (the value had become the scene file).
    (["sky", "--preset", "earth", "--out", "x.exr"], "airmass: sky: unknown option '--out' (did you mean --output?)",
     "airmass sky --help"),
    (["sky", "--preset", "earth", "--widht=64"], "airmass: sky: unknown option '--widht' (did you mean --width?)",
     "airmass sky --help"),
    (["sky", "--preset", "earth", "--sun-elevation", "-inf"],
     "airmass: sky: --sun-elevation: '-inf': must be a number in [-90, 90]", "airmass sky --help"),
    (["frob"], "airmass: unknown command 'frob' (commands: chapman, eval, sky, vdb, render, compare, sun, pov, "
               "report)", "airmass --help"),
    (["report", "frob"], "airmass: report: unknown command 'frob' (commands: chapman, sky, vdb, ms)",
     "airmass report --help"),
    (["report", "sky", "--bogus"], "airmass: report sky: unknown option '--bogus'",
     "airmass report sky --help"),
])
def test_bad_command_line_is_one_format(airmass_bin, args, first_line, hint):
    """A bad command line reads like every other refusal (issue 17): `airmass: <command>: <what>`,
    then where the options are listed; exit 2, nothing on stdout."""
    r = subprocess.run([str(airmass_bin)] + args, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and r.stdout == "", (r.returncode, r.stdout, r.stderr)
    lines = r.stderr.splitlines()
    assert lines[0] == first_line and len(lines) == 2 and "`%s`" % hint in lines[1], r.stderr


def _sky(airmass_bin, cache, out, *extra):
    env = dict(os.environ, AIRMASS_CACHE_DIR=str(cache))
    r = subprocess.run([airmass_bin, "sky", "--preset", "earth", "--basis", "rgb", "--width", "64",
                        "--ms-table", "6,16,12,4", "-o", str(out), *extra],
                       capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, r
    return r.stderr


def test_table_cache_hit_corrupt_and_bypass(airmass_bin, tmp_path):
    cache = tmp_path / "cache"
    first = _sky(airmass_bin, cache, tmp_path / "a.exr")
    assert "tables computed and cached" in first, first
    entries = sorted(cache.glob("ms-*.amt"))
    assert len(entries) == 1 and not [p for p in cache.iterdir() if p.suffix != ".amt"], list(cache.iterdir())
    second = _sky(airmass_bin, cache, tmp_path / "b.exr")
    assert "tables from the cache" in second, second
    assert (tmp_path / "a.exr").read_bytes() == (tmp_path / "b.exr").read_bytes()
    # One flipped byte in the middle: refused, replaced, and the image is still the same.
    raw = bytearray(entries[0].read_bytes())
    raw[len(raw) // 2] ^= 0x01
    entries[0].write_bytes(bytes(raw))
    third = _sky(airmass_bin, cache, tmp_path / "c.exr")
    assert "bad cache entry replaced" in third, third
    assert (tmp_path / "c.exr").read_bytes() == (tmp_path / "a.exr").read_bytes()
    assert "tables from the cache" in _sky(airmass_bin, cache, tmp_path / "d.exr")
    # Other table settings are another entry.
    _sky(airmass_bin, cache, tmp_path / "e.exr", "--ms-orders", "3")
    assert len(list(cache.glob("ms-*.amt"))) == 2
    # --no-cache: nothing read, nothing written.
    other = tmp_path / "other"
    assert "tables computed (--no-cache)" in _sky(airmass_bin, other, tmp_path / "f.exr", "--no-cache")
    assert not other.exists()


def test_table_cache_unwritable_folder_is_no_error(airmass_bin, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    err = _sky(airmass_bin, blocker / "cache", tmp_path / "a.exr")
    assert "not cached" in err, err
    assert (tmp_path / "a.exr").stat().st_size > 0


def test_exr_compression_changes_the_file_not_the_pixels(airmass_bin, tmp_path):
    """--exr-compression (sky and render): none (the default), zip and piz give the same pixels;
    a bad value is refused with the allowed ones named and nothing written."""
    import numpy as np
    import OpenImageIO as oiio

    cache = tmp_path / "cache"
    _sky(airmass_bin, cache, tmp_path / "default.exr")
    pixels = {}
    for c in ("none", "zip", "piz"):
        _sky(airmass_bin, cache, tmp_path / ("%s.exr" % c), "--exr-compression", c)
        inp = oiio.ImageInput.open(str(tmp_path / ("%s.exr" % c)))
        assert inp.spec().get_string_attribute("compression") == c, inp.spec().get_string_attribute("compression")
        pixels[c] = np.asarray(inp.read_image("float"))
        inp.close()
    assert (tmp_path / "default.exr").read_bytes() == (tmp_path / "none.exr").read_bytes()
    assert np.array_equal(pixels["none"], pixels["zip"]) and np.array_equal(pixels["none"], pixels["piz"])
    assert (tmp_path / "zip.exr").stat().st_size < (tmp_path / "none.exr").stat().st_size
    for cmd in (["sky", "--preset", "earth"], ["render", "--preset", "earth"]):
        r = subprocess.run([str(airmass_bin), *cmd, "--exr-compression", "zip9", "-o", str(tmp_path / "bad.exr")],
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == 2 and "--exr-compression: zip9 not in {none,zip,piz}" in r.stderr, r.stderr
        assert not (tmp_path / "bad.exr").exists()


# ---- compare ends its Blender child ------------------------------------------------------------------

def _alive(pid):
    """True while `pid` exists and is not a zombie."""
    try:
        with open("/proc/%d/stat" % pid) as f:
            state = f.read().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


def _wait_for(predicate, seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.05)
    return predicate()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_compare_child_dies_with_compare(airmass_bin, tmp_path, sig):
    pid_file = tmp_path / "blender.pid"
    fake = tmp_path / "blender"
    # The stand-in keeps its pid through exec; it ignores nothing, so only a signal ends it early.
    fake.write_text("#!/bin/sh\necho $$ > '%s.tmp' && mv '%s.tmp' '%s'\nexec sleep 600\n"
                    % (pid_file, pid_file, pid_file))
    fake.chmod(0o755)
    cmd = [airmass_bin, "compare", "--preset", "earth", "-o", str(tmp_path / "out"), "--width", "8",
           "--height", "4", "--view-samples", "1", "--paths", "analytic_volume", "--threads", "1",
           "--blender", str(fake), "--scripts", str(REPO / "compare"), "--no-report", "-q"]
    # Its own session: the signal is sent to the compare process alone, as `kill PID` would.
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
    child = None
    try:
        assert _wait_for(lambda: pid_file.is_file() or proc.poll() is not None, 120), "no Blender started"
        assert proc.poll() is None, "compare ended before its Blender: %s" % proc.stdout.read()
        child = int(pid_file.read_text())
        assert _alive(child), "the stand-in Blender is not running"
        time.sleep(0.3)
        assert _alive(child) and proc.poll() is None  # compare waits for it
        os.kill(proc.pid, sig)
        proc.wait(timeout=10)
        if sig == signal.SIGKILL:
            assert proc.returncode == -signal.SIGKILL
        else:
            assert proc.returncode != 0  # cancelled, not a success
        assert _wait_for(lambda: not _alive(child), 5.0), \
            "the Blender child %d outlived `airmass compare` killed by %s" % (child, sig.name)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if child is not None and _alive(child):
            os.kill(child, signal.SIGKILL)


@pytest.mark.parametrize("quiet", [False, True], ids=["progress", "quiet"])
def test_report_sky_ctrl_c_writes_nothing(airmass_bin, tmp_path, quiet):
    # `report sky` takes minutes: Ctrl-C (SIGINT) stops the render under way and writes no table;
    # off a terminal it says what it does a line at a time, nothing with -q.
    out = tmp_path / "sky"
    cmd = [airmass_bin, "report", "sky", "--quick", "--out", str(out)] + (["-q"] if quiet else [])
    err = tmp_path / "stderr.txt"
    with open(err, "wb") as stderr:
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=stderr)
        try:
            # the first reference image alone takes seconds; the output directory exists by then
            assert _wait_for(lambda: out.is_dir() or proc.poll() is not None, 60)
            time.sleep(1.0)
            assert proc.poll() is None, "report sky ended before the interrupt: %s" % err.read_text()
            proc.send_signal(signal.SIGINT)
            proc.wait(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    text = err.read_text()
    assert proc.returncode == 2, text
    assert "airmass: report sky: cancelled; nothing written" in text
    assert ("report sky: reference (exact Chapman" in text) == (not quiet), text
    assert sorted(p.name for p in out.iterdir()) == []
