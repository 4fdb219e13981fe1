"""Sun Sync: the sun direction shared with a Sun lamp, and the lamp's strength and colour.

Direction. Blender's Sky Texture puts the sun at s = (cos e sin r, cos e cos r, sin e)
for elevation e and rotation r (0 → +Y, 90° → +X). A Sun lamp shines along its local −Z,
so its local +Z must point at s; the Euler rotation (XYZ) that does it is

    (π/2 − e, 0, π − r)

(rotating +Z about X by π/2 − e gives (0, −cos e, sin e); rotating that about Z by π − r
gives s). The inverse reads s from the lamp's world matrix: e = asin(s_z),
r = atan2(s_x, s_y).

Strength and colour. With an Airmass volume in the scene, Cycles attenuates the lamp inside
the volume, so the lamp carries the top-of-atmosphere irradiance E(λ) instead (same RGB
mapping). Otherwise the library returns the direct sunlight at the observer, E(λ)·T(λ)
(top-of-atmosphere irradiance times the transmittance toward the sun, zero when the
planet is in the way), as linear Rec.709 in the sky texture's units (W/m², Σ·CMF·Δλ
without 683 lm/W). A Sun lamp emits strength × colour, so strength = the largest channel
and colour = rgb / strength (each ≤ 1): the lamp adds exactly the light the sky's sun
disc would, which is why the sky's Sun Disc should be off when the lamp is used.
"""

import math

import bpy
from mathutils import Euler, Vector

from . import compat, native, properties
from .properties import _Guard, make_spec

LAMP_NAME = "Airmass Sun"
ROLE = "airmass_role"


def lamp_rotation(elevation, rotation):
    """Euler (XYZ) of a Sun lamp pointing from the sun at (elevation, rotation), radians."""
    return Euler((math.pi / 2 - elevation, 0.0, math.pi - rotation), "XYZ")


def sun_vector(elevation, rotation):
    ce = math.cos(elevation)
    return Vector((ce * math.sin(rotation), ce * math.cos(rotation), math.sin(elevation)))


def lamp_angles(obj):
    """(elevation, rotation) in radians of the direction a lamp object comes from."""
    z = (obj.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0))).normalized()
    elevation = math.asin(max(-1.0, min(1.0, z.z)))
    rotation = math.atan2(z.x, z.y) if abs(z.z) < 1.0 - 1e-12 else 0.0
    return elevation, rotation % (2 * math.pi)


def find_lamp(scene):
    s = scene.airmass
    obj = s.sun_object
    if obj is not None and obj.type == "LIGHT" and obj.data.type == "SUN" and obj.name in scene.objects:
        return obj
    for o in scene.objects:
        if o.get(ROLE) == "sun" and o.type == "LIGHT" and o.data.type == "SUN":
            return o
    return None


def new_lamp(scene):
    data = bpy.data.lights.new(LAMP_NAME, type="SUN")
    compat.set_light_shadow(data, True)
    obj = bpy.data.objects.new(LAMP_NAME, data)
    obj[ROLE] = "sun"
    scene.collection.objects.link(obj)
    return obj


def has_atmosphere_volume(scene):
    return any(o.get(ROLE) == "atmosphere" for o in scene.objects)


def lamp_light(scene, top=None, spec=None):
    """(strength W/m², colour, angle rad, light dict) of the sun (native call); `spec`: the
    library scene (None: make_spec of the settings; Bake Sky Animation passes each frame's).

    Without an Airmass volume in the scene the lamp carries the sunlight transmitted to the
    observer (the sky texture already holds the atmosphere). With one, Cycles attenuates the
    lamp's light inside the volume itself, so the lamp carries the top-of-atmosphere
    irradiance (`top`: None = decide from the scene)."""
    s = scene.airmass
    if top is None:
        top = has_atmosphere_volume(scene)
    light = native.sun_light(make_spec(s) if spec is None else spec, chapman=s.chapman)
    rgb = light["irradiance_top_rgb" if top else "irradiance_rgb"]
    strength = max(rgb)
    colour = tuple(c / strength for c in rgb) if strength > 0.0 else (1.0, 1.0, 1.0)
    return strength, colour, math.radians(light["angular_diameter_deg"]), light


def apply_light(obj, strength, colour, angle):
    """Strength × colour = the library's linear Rec.709 sunlight, the colour converted to the
    file's working colour space (Blender 5.0+; identity before)."""
    obj.data.energy = strength
    obj.data.color = compat.convert_rgb(colour)
    obj.data.angle = angle


def sync_volume_sun(scene, light):
    """The Analytic Sun of the scene's atmosphere volume follows the sun (volume.set_material_sun)."""
    from . import volume
    for o in scene.objects:
        if o.get(ROLE) == "atmosphere":
            for slot in o.material_slots:
                volume.set_material_sun(slot.material, light)


def stop_world_sun_extraction(scene):
    """EEVEE (4.2+) must not extract a second sun from the World while the lamp gives it."""
    if scene.world is not None:
        compat.set_world_sun_extraction(scene.world, False)


def settings_to_lamp(scene, create=True):
    """Points the lamp at the settings' sun and sets its strength and colour. Returns it.

    Everything that can fail (the native call) runs before any datablock is created."""
    s = scene.airmass
    obj = find_lamp(scene)
    if obj is None and not create:
        if any(o.get(ROLE) == "atmosphere" for o in scene.objects):  # no lamp: the volume's sun still moves
            sync_volume_sun(scene, lamp_light(scene)[3])
        return None
    strength, colour, angle, light = lamp_light(scene)
    if obj is None:
        obj = new_lamp(scene)
    with _Guard():
        obj.rotation_mode = "XYZ"
        obj.rotation_euler = lamp_rotation(s.sun_elevation, s.sun_rotation)
        apply_light(obj, strength, colour, angle)
        s.sun_object = obj
        sync_volume_sun(scene, light)
    stop_world_sun_extraction(scene)
    return obj


def lamp_to_settings(scene):
    """Reads the lamp's direction into the settings, then updates its strength and colour."""
    s = scene.airmass
    obj = find_lamp(scene)
    if obj is None:
        raise ValueError("No Sun lamp to read: choose one in Sun Lamp, or sync from the settings first")
    elevation, rotation = lamp_angles(obj)
    old = (s.sun_elevation, s.sun_rotation)
    with _Guard():
        s.sun_elevation = elevation
        s.sun_rotation = rotation
    try:
        strength, colour, angle, light = lamp_light(scene)
    except Exception:
        with _Guard():
            s.sun_elevation, s.sun_rotation = old
        raise
    with _Guard():
        apply_light(obj, strength, colour, angle)
        s.sun_object = obj
        sync_volume_sun(scene, light)
    stop_world_sun_extraction(scene)
    return obj


# ---- live sync: lamp moved → settings ---------------------------------------------------------

def _depsgraph_update(scene, depsgraph):
    s = getattr(scene, "airmass", None)
    if s is None or not s.sun_live_sync or _Guard.active:
        return
    obj = find_lamp(scene)
    if obj is None:
        return
    for update in depsgraph.updates:
        if update.is_updated_transform and getattr(update.id, "original", None) == obj:
            elevation, rotation = lamp_angles(obj)
            same_rotation = abs(math.remainder(rotation - s.sun_rotation, 2 * math.pi)) < 1e-6
            if abs(elevation - s.sun_elevation) < 1e-6 and same_rotation:
                return
            try:
                lamp_to_settings(scene)
            except Exception:
                pass
            return


def _sync_lamp(scene):
    settings_to_lamp(scene, create=False)


def register():
    if _depsgraph_update not in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.append(_depsgraph_update)
    if _sync_lamp not in properties.sun_changed_hooks:
        properties.sun_changed_hooks.append(_sync_lamp)


def unregister():
    if _sync_lamp in properties.sun_changed_hooks:
        properties.sun_changed_hooks.remove(_sync_lamp)
    if _depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_depsgraph_update)
