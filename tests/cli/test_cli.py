"""Command-line checks that need no renders (tests/cli/CMakeLists.txt registers them in CTest):

  * `airmass --version` prints "airmass X.Y.Z", X.Y.Z being project(... VERSION) in the top
    CMakeLists.txt, answered before any command is set up;
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


@pytest.fixture(scope="module")
def airmass_bin():
    path = os.environ.get("AIRMASS_CLI")
    if not path or not os.path.isfile(path):
        pytest.fail("set AIRMASS_CLI to the airmass executable (got %r)" % path)
    return path


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
    # CPU time, not wall time (the machine may be loaded): the dynamic loader's work on the ~260
    # shared libraries the binary links (≈ 0.3-0.5 s here) and nothing more; a --version that set
    # up a command or loaded a scene would not stay far below this.
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    assert cpu < 2.0, cpu


def test_version_is_in_help(airmass_bin):
    r = subprocess.run([airmass_bin, "--help"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0 and "--version" in r.stdout, r


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
