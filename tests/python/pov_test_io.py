"""Helpers shared by the POV-Ray tests (test_pov.py, test_pov_compare.py): run a command and
read / write linear EXR through OpenImageIO."""
import subprocess

import numpy as np
import pytest

oiio = pytest.importorskip("OpenImageIO")


def run(cmd, check=True, cwd=None, timeout=600):
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout, cwd=cwd)
    if check and p.returncode != 0:
        raise AssertionError(f"{' '.join(map(str, cmd))} failed ({p.returncode}):\n{p.stderr[-3000:]}")
    return p


def read_exr(path):
    buf = oiio.ImageBuf(str(path))
    assert not buf.has_error, buf.geterror()
    return buf.get_pixels(oiio.FLOAT)[:, :, :3].astype(np.float64)


def write_exr(path, img):
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(img.shape[1], img.shape[0], img.shape[2], oiio.FLOAT))
    out.write_image(img.astype(np.float32))
    out.close()
