"""Airmass for Blender: physically based planet atmospheres.

Install the zip (Edit → Preferences → Add-ons → Install…), enable "Airmass", then use
World Properties → Airmass Atmosphere, or the Airmass tab of the 3D View sidebar.
Documentation: docs/addon.md in the Airmass repository.

Legacy add-on (bl_info) for Blender 3.x and 4.x, and an extension (blender_manifest.toml)
for Blender 4.2+. All native work goes through libairmass_c.so, bundled next to this
file and loaded with ctypes (native.py); if it cannot be loaded the add-on still
registers, the panel shows why, and every operator reports the error.
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

    for _m in (native, properties, jobs, world, sun, volume, compare, operators, ui):  # noqa: F821
        importlib.reload(_m)

import bpy  # noqa: E402,F401

from . import native  # noqa: E402
from . import properties  # noqa: E402
from . import jobs  # noqa: E402,F401
from . import world  # noqa: E402,F401
from . import sun  # noqa: E402
from . import volume  # noqa: E402,F401
from . import compare  # noqa: E402,F401
from . import operators  # noqa: E402
from . import ui  # noqa: E402

_MODULES = (properties, operators, ui, sun)


def register():
    for m in _MODULES:
        m.register()


def unregister():
    for m in reversed(_MODULES):
        m.unregister()
