# pytest configuration for Airmass's Python tests (run by CTest with Debian's python3:
#   /usr/bin/python3 -m pytest tests/python --airmass-build=<build dir>).
import os
import pathlib

import pytest


def pytest_addoption(parser):
    parser.addoption(
        "--airmass-build",
        action="store",
        default=os.environ.get("AIRMASS_BUILD", "build"),
        help="CMake build directory holding bin/airmass (default: $AIRMASS_BUILD or ./build)",
    )


@pytest.fixture(scope="session")
def airmass_build(pytestconfig):
    """The build directory given by --airmass-build, as an absolute path."""
    return pathlib.Path(pytestconfig.getoption("--airmass-build")).resolve()


@pytest.fixture(scope="session")
def airmass_bin(airmass_build):
    """Path of the `airmass` command-line tool, <build>/bin/airmass."""
    path = airmass_build / "bin" / "airmass"
    if not path.is_file():
        pytest.fail(f"airmass binary not found at {path} (pass --airmass-build=<cmake build dir>)")
    return path
