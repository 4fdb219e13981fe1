"""Command-line checks (tests/cli/CMakeLists.txt registers them in CTest):

  * `airmass --version` prints "airmass X.Y.Z", X.Y.Z being project(... VERSION) in the top
    CMakeLists.txt, answered before any command is set up.

Run: AIRMASS_CLI=<build>/bin/airmass /usr/bin/python3 -m pytest -q tests/cli/test_cli.py
"""
import os
import pathlib
import re
import resource
import subprocess

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
