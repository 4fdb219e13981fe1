"""Airmass for Blender: physically based planet atmospheres.

Install the zip (Edit → Preferences → Add-ons → Install…), enable "Airmass", then use
World Properties → Airmass Atmosphere, or the Airmass tab of the 3D View sidebar.
Documentation: docs/addon.md in the Airmass repository.

Legacy add-on (bl_info) for Blender 3.4+ (still installable in 4.2+), and an extension
(blender_manifest.toml, Linux and Windows x86-64) for Blender 4.2+. All native work goes
through the native library bundled next to this file (libairmass_c.so on Linux,
airmass_c.dll on Windows), loaded with ctypes (native.py); if it cannot be loaded (or on
macOS, which the zip has no library for) the add-on still registers, the panel shows why,
and every operator reports the error. Everything that differs between Blender versions
(3.4 … 5.x) is in compat.py.
"""

bl_info = {
    "name": "Airmass",
    "author": "Airmass contributors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > World > Airmass Atmosphere; 3D View > Sidebar > Airmass",
    "description": "Physically based planet atmospheres: sky texture, Sun lamp and atmosphere volumes",
    "category": "Lighting",
}

if "bpy" in locals():
    import importlib

    for _m in (compat, native, properties, jobs, world, sun, live, animation, vdb_host, volume, compare, operators, ui):  # noqa: F821
        importlib.reload(_m)

import bpy  # noqa: E402,F401

from . import compat  # noqa: E402,F401
from . import native  # noqa: E402
from . import properties  # noqa: E402
from . import jobs  # noqa: E402,F401
from . import world  # noqa: E402,F401
from . import sun  # noqa: E402
from . import live  # noqa: E402
from . import animation  # noqa: E402,F401
from . import vdb_host  # noqa: E402,F401
from . import volume  # noqa: E402,F401
from . import compare  # noqa: E402,F401
from . import operators  # noqa: E402
from . import ui  # noqa: E402

_MODULES = (properties, operators, ui, sun, live)


def register():
    for m in _MODULES:
        m.register()


def unregister():
    for m in reversed(_MODULES):
        m.unregister()
