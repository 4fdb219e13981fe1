# Fixtures of the command-line tests (tests/cli; CTest sets AIRMASS_CLI, tests/cli/CMakeLists.txt).
import os

import pytest


@pytest.fixture(scope="module")
def airmass_bin():
    """The `airmass` executable CTest names in $AIRMASS_CLI."""
    path = os.environ.get("AIRMASS_CLI")
    if not path or not os.path.isfile(path):
        pytest.fail("set AIRMASS_CLI to the airmass executable (got %r)" % path)
    return path
