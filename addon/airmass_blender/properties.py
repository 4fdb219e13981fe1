"""Settings on scene.airmass (AirmassSettings), and how they become a library scene (Spec).

Units as a user expects them: lengths in km, angles as Blender angles (stored in radians,
shown in degrees — the same as the Sky Texture node's Sun Elevation / Sun Rotation, so
values can be copied between them). Sun rotation follows Blender's Sky Texture: 0° puts
the sun toward +Y, 90° toward +X.

Ranges that a value can never leave (samples ≥ 1, albedo in [0, 1]) are hard limits;
physically related fields (planet radius vs atmosphere top) are checked by the library
when an operator runs, and its message names the field and the allowed range.
"""

import json
import math
import os

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty,
                       PointerProperty, StringProperty)

from . import native

KM = 1000.0

# Used when the library cannot be loaded (the panel still draws and says why).
_FALLBACK_PRESETS = ["earth", "earth-hazy", "atmosphere-plus", "blender-nishita", "mars"]
_FALLBACK_CHAPMAN = ["airmass", "exact"]

_PRESET_DESCRIPTIONS = {
    "earth": "Bruneton 2017 demo Earth: Rayleigh, Mie and ozone, 48 wavelengths",
    "earth-hazy": "Earth with a thicker aerosol layer",
    "atmosphere-plus": "The constants of the Atmosphere Plus notes",
    "blender-nishita": "Exactly Blender's own Nishita sky constants (21 wavelengths)",
    "mars": "A Mars-like atmosphere",
}
_CHAPMAN_DESCRIPTIONS = {
    "airmass": "Airmass' own tabulated Chapman function: fast and accurate (default)",
    "exact": "Adaptive quadrature: the reference, slow",
}


def _preset_items():
    try:
        names = native.preset_names()
    except native.NativeError:
        names = _FALLBACK_PRESETS
    return [(n, n, _PRESET_DESCRIPTIONS.get(n, "Built-in preset '%s'" % n)) for n in names]


def _chapman_items():
    try:
        names = native.chapman_method_names()
    except native.NativeError:
        names = _FALLBACK_CHAPMAN
    return [(n, n, _CHAPMAN_DESCRIPTIONS.get(n, "Chapman method '%s' (docs/chapman.md)" % n)) for n in names]


_PRESET_ITEMS = _preset_items()
_CHAPMAN_ITEMS = _chapman_items()


# ---- update callbacks -------------------------------------------------------------------

# Called with the scene when the sun angles change and live sync is on. sun.py adds its
# lamp sync here at register(), so this module never imports sun.py (one direction only).
sun_changed_hooks = []


def _sun_changed(self, context):
    # Live sync to the Sun lamp (sun.py), only when the user asked for it.
    if self.sun_live_sync and not _Guard.active:
        with _Guard():
            for hook in list(sun_changed_hooks):
                try:
                    hook(context.scene)
                except Exception:
                    pass  # a bad value is reported when an operator runs; never raise in an update


def _scene_changed(self, context):
    if not _Guard.active:
        refresh_constituents(self)


def _live_preview_changed(self, context):
    from . import live  # live.py imports this module: imported here, not at the top
    live.live_preview_changed(self, context)


class _Guard:
    """Re-entrancy guard for update callbacks that write other properties."""
    active = False

    def __enter__(self):
        _Guard.active = True
        return self

    def __exit__(self, *exc):
        _Guard.active = False
        return False


# ---- property groups -----------------------------------------------------------------------

class AirmassConstituent(bpy.types.PropertyGroup):
    # `name` (StringProperty of PropertyGroup) is the constituent's name in the scene.
    enabled: BoolProperty(
        name="Enabled", default=True,
        description="Include this constituent. A disabled one is removed from the scene and costs nothing")
    density_scale: FloatProperty(
        name="Density Scale", default=1.0, min=0.0, soft_max=10.0, precision=3,
        description="Multiplies this constituent's scattering and absorption coefficients (1 = as in the preset)")
    scale_height: FloatProperty(
        name="Scale Height (km)", default=0.0, soft_min=0.001, soft_max=100.0, precision=3,
        description="Exponential profiles only: the height over which the density falls by a factor e, km")
    profile_kind: StringProperty(name="Profile", description="Density profile of the scene (read only)")
    preset_scale_height: FloatProperty(name="Preset Scale Height (km)", default=0.0,
                                       description="The scene's own scale height, km (read only)")



# ---- the comparison paths: compare/plan.json, the one table ------------------------------------
# The zip carries the comparison's plan data beside its scripts (compare_scripts/plan.json, the
# file the bundled `airmass compare` was built with); a source checkout used as the add-on folder
# (tests: `blender --addon <repo>/addon`) has it at <repo>/compare/plan.json. The Paths checkboxes
# are its Blender paths, each with the bit the file fixes for it (a saved .blend stores the bits,
# so they must not move when paths are added), in the order of those bits, with its labels and
# defaults. Without a readable file the add-on does not enable, naming the file.
_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
COMPARE_PLAN_FILES = (os.path.join(_PACKAGE_DIR, "compare_scripts", "plan.json"),
                      os.path.join(_PACKAGE_DIR, "..", "..", "compare", "plan.json"))


def _compare_path_table():
    path = next((f for f in COMPARE_PLAN_FILES if os.path.isfile(f)), COMPARE_PLAN_FILES[0])
    try:
        with open(path, encoding="utf-8") as f:
            plan = json.load(f)
        paths = sorted((p for p in plan["paths"] if p["renderer"] == "blender"), key=lambda p: p["addon_flag"])
        items = [(p["name"].upper(), p["label"], p["description"], int(p["addon_flag"])) for p in paths]
        defaults = {p["name"].upper() for p in paths if p["default"] is True}
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as e:
        raise ImportError("Airmass: the comparison's plan %s is missing or unreadable (%s: %s); reinstall the "
                          "add-on zip" % (path, type(e).__name__, e)) from None
    if not items:
        raise ImportError("Airmass: the comparison's plan %s lists no Blender paths" % path)
    return items, defaults


_COMPARE_PATH_ITEMS, _COMPARE_PATH_DEFAULTS = _compare_path_table()


class AirmassSettings(bpy.types.PropertyGroup):
    # -- scene source
    source: EnumProperty(
        name="Source", default="PRESET", update=_scene_changed,
        items=[("PRESET", "Preset", "A built-in atmosphere"),
               ("FILE", "Scene File", "A scene description file (TOML, docs/scene.md)")],
        description="Where the atmosphere comes from")
    preset: EnumProperty(name="Preset", items=_PRESET_ITEMS, update=_scene_changed,
                         default="earth" if any(i[0] == "earth" for i in _PRESET_ITEMS) else _PRESET_ITEMS[0][0],
                         description="Built-in atmosphere (examples/*.toml in the Airmass repository)")
    scene_file: StringProperty(
        name="Scene File", subtype="FILE_PATH", update=_scene_changed,
        description="Scene description (TOML): planet, sun, constituents. May say preset = \"earth\" and override parts")

    # -- sun and observer (Blender Sky Texture convention)
    sun_elevation: FloatProperty(
        name="Sun Elevation", subtype="ANGLE", unit="ROTATION", default=math.radians(15.0),
        min=-math.pi / 2, max=math.pi / 2, update=_sun_changed,
        description="Sun angle above the horizon (as the Sky Texture node's Sun Elevation)")
    sun_rotation: FloatProperty(
        name="Sun Rotation", subtype="ANGLE", unit="ROTATION", default=0.0,
        soft_min=0.0, soft_max=2 * math.pi, update=_sun_changed,
        description="Sun direction around the zenith as the Sky Texture node's Sun Rotation: 0° toward +Y, 90° toward +X")
    altitude: FloatProperty(
        name="Altitude (km)", default=0.0, min=0.0, soft_max=1000.0, precision=3,
        description="Observer (camera) altitude above the ground, km, for the sky texture and the Sun lamp colour")
    sun_object: PointerProperty(
        name="Sun Lamp", type=bpy.types.Object,
        poll=lambda self, obj: obj.type == "LIGHT" and obj.data.type == "SUN",
        description="The Sun lamp kept in sync with the sun direction (created by Sun Sync when empty)")
    sun_live_sync: BoolProperty(
        name="Live Sync", default=False,
        description="Keep the Sun lamp and these settings in sync while either changes")

    # -- place and time, and Bake Sky Animation (animation.py; docs/sun.md)
    bake_sun_source: EnumProperty(
        name="Sun From", default="PLACE_TIME",
        items=[("PLACE_TIME", "Place and Time", "The sun of Latitude/Longitude at Date + Time (UTC) at each frame "
                                                "(NREL SPA, as `airmass sun`); the Sun lamp's rotation is keyframed"),
               ("LAMP", "Sun Lamp", "The Sun lamp's own (animated) direction at each frame; its rotation is kept")],
        description="Where Bake Sky Animation takes each frame's sun from")
    latitude: FloatProperty(
        name="Latitude (°)", default=48.8566, min=-90.0, max=90.0, precision=4,
        description="Place on Earth, degrees north (negative: south). Animatable")
    longitude: FloatProperty(
        name="Longitude (°)", default=2.3522, min=-180.0, max=180.0, precision=4,
        description="Place on Earth, degrees east (negative: west). Animatable")
    date: StringProperty(
        name="Date (UTC)", default="2026-06-21",
        description="Day of the animation, YYYY-MM-DD (UTC); Time counts hours from its 00:00 UTC")
    utc_hours: FloatProperty(
        name="Time (UTC h)", default=12.0, min=-240.0, max=264.0, precision=4,
        description="Hours after 00:00 UTC of Date (beyond 24 runs into the next days). Animatable: keyframe it "
                    "to move the sun, or use Minutes per Frame")
    minutes_per_frame: FloatProperty(
        name="Minutes per Frame", default=0.0, min=0.0, max=1440.0, precision=3,
        description="Added per frame after the scene's first: frame f shows Time(f) + (f - start)·this. 0 when "
                    "Time is keyframed")

    # -- planet overrides
    override_planet: BoolProperty(
        name="Override Planet", default=False, update=_scene_changed,
        description="Use the planet values below instead of the scene's")
    planet_radius: FloatProperty(
        name="Radius (km)", default=6360.0, soft_min=1.0, soft_max=100000.0, precision=1,
        description="Planet radius, km (must be > 0)")
    atmosphere_top: FloatProperty(
        name="Atmosphere Top (km)", default=6420.0, soft_min=1.0, soft_max=100000.0, precision=1,
        description="Radius of the top of the atmosphere, km (must be greater than the planet radius)")
    ground_albedo: FloatProperty(
        name="Ground Albedo", default=0.1, min=0.0, max=1.0,
        description="Lambertian reflectance of the ground, 0–1")

    constituents: CollectionProperty(type=AirmassConstituent)
    constituent_index: IntProperty(default=0)

    # -- spectral basis and accuracy
    basis: EnumProperty(
        name="Spectral Basis", default="SCENE",
        items=[("SCENE", "Scene's", "The spectral sampling the scene declares"),
               ("SPECTRAL", "Spectral", "Many wavelengths with CIE 1931 colour matching (accurate colours)"),
               ("RGB", "RGB (Schüler)", "Three wavelengths 615/535/445 nm with Schüler's matrix (fast)")],
        description="How spectra become RGB")
    chapman: EnumProperty(name="Chapman Method", items=_CHAPMAN_ITEMS,
                          default="airmass" if any(i[0] == "airmass" for i in _CHAPMAN_ITEMS) else _CHAPMAN_ITEMS[0][0],
                          description="How optical depths toward the sun are computed (docs/chapman.md)")
    sky_width: IntProperty(
        name="Sky Width", default=1024, min=16, max=16384, soft_max=8192,
        description="Width of the sky texture in pixels (height is half of it)")
    view_samples: IntProperty(
        name="View Samples", default=16, min=1, max=4096, soft_max=256,
        description="Samples per constituent along each view ray (more: more accurate, slower)")
    sky_grid: IntProperty(
        name="Sky Grid", default=-1, min=-1, max=16384,
        description="Interpolation grid of the sky (-1 automatic, 0 evaluate every pixel)")
    multiple_scattering: BoolProperty(
        name="Multiple Scattering", default=True,
        description="Add light scattered more than once (tables precomputed once per sky, about 1 s). Off: single "
                    "scattering only, as Blender's own Nishita sky; twilight and the Earth's shadow then come out "
                    "too dark")
    sun_disc: BoolProperty(
        name="Sun Disc", default=True,
        description="Put the solar disc into the sky texture. Turn off when a Sun lamp gives the direct sunlight, "
                    "or the sun is counted twice")
    live_preview: BoolProperty(
        name="Live Preview", default=False, update=lambda self, context: _live_preview_changed(self, context),
        description="While the sun moves (Sun Elevation / Sun Rotation, or the Sun lamp with Live Sync), re-render "
                    "the World's sky at a preview quality for the latest position; the full-quality sky (these "
                    "settings) when the sun has rested for 0.3 s. The atmosphere's tables are made once")
    live_status: StringProperty(name="Live Status", default="",
                                description="The live preview's last problem, if any (read only)")
    sky_strength: FloatProperty(
        name="Strength", default=1.0, min=0.0, soft_max=10.0,
        description="World Background strength. 1 keeps Airmass' units (those of Blender's Nishita sky)")

    # -- volumes
    volume_region: EnumProperty(
        name="Region", default="VIEW",
        items=[("VIEW", "Camera View", "Only the part of the atmosphere within View Distance of the active camera"),
               ("PLANET", "Whole Planet", "The whole shell, for views from orbit")],
        description="Which part of the atmosphere the volume covers (both modes)")
    voxel_size: FloatProperty(
        name="Voxel Size (km)", default=0.0, min=0.0, soft_max=50.0, precision=3,
        description="VDB voxel edge in km; 0 chooses it from the scale heights and the camera")
    voxel_values: EnumProperty(
        name="Voxel Values", default="AUTO",
        items=[("AUTO", "Automatic",
                "Per constituent: the mean over each voxel's footprint where a voxel spans more than half the "
                "constituent's thinnest layer and the camera looks across the layer (from above it; the whole "
                "planet), the density at the voxel's centre otherwise"),
               ("AVERAGE", "Footprint Mean",
                "Each voxel the density's mean over its trilinear footprint: the layer's mass at any voxel size "
                "(right from orbit), but the density at the ground is lost (wrong along the ground)"),
               ("POINT", "Centre Value",
                "Each voxel the density at its centre: exact at the ground, but coarse voxels put too much into "
                "rays across thin layers (26 % at 8 km for Earth's aerosol) and show rings")],
        description="What a VDB voxel holds (docs/vdb.md, Voxel values); Automatic suits both views")
    view_distance: FloatProperty(
        name="View Distance (km)", default=200.0, min=0.001, soft_max=5000.0,
        description="How far the Camera View region reaches from the camera, km")
    max_dense_mb: FloatProperty(
        name="Memory Limit (MiB)", default=1024.0, min=1.0, soft_max=16384.0,
        description="Refuse a VDB whose dense boxes (what Blender 3.4 allocates) exceed this")
    step_km: FloatProperty(
        name="Step (km)", default=0.5, min=0.0001, soft_max=10.0, precision=3,
        description="Cycles ray-marching step inside the atmosphere, km (smaller: more accurate, slower)")
    phase_mixing: EnumProperty(
        name="Phase Mixing", default="DITHER",
        items=[("DITHER", "One Dithered Scatter",
                "One Volume Scatter whose anisotropy and colour are those of a constituent picked at random per "
                "point in proportion to its scattering: the exact mixture of phases in expectation. Cycles 3.4 "
                "sums the phases of several Volume Scatter nodes unweighted (+18 % measured, docs/compare.md)"),
               ("SEPARATE", "Scatter per Constituent",
                "One Volume Scatter node per constituent: easier to edit, biased in Cycles 3.4")],
        description="How the constituents' phase functions share the volume material (Blender < 4.3; "
                    "4.3+ keeps one node per constituent with its own phase type)")
    volume_lighting: EnumProperty(
        name="Lighting", default="SCATTER",
        items=[("SCATTER", "Volume Scatter",
                "Cycles samples the Sun lamp through the volume (Volume Scatter): any light, shadows of the "
                "scene's geometry in the air, more bounces on request; noisy, Henyey-Greenstein phases before "
                "Blender 4.3"),
               ("SUN_EMISSION", "Analytic Sun",
                "The single-scattered sunlight is computed in the shader (the library's phase functions, the sun's "
                "optical depth from a table the library makes, the planet's shadow) and emitted, the volume only "
                "absorbs: nearly noise-free, but only the sun and the planet's shadow light the air (no shadows "
                "of the scene's objects in it, no other lamps); re-sync after moving the sun (Sun Sync does)")],
        description="How the sun lights the atmosphere volume (docs/addon.md, 'Analytic Sun')")
    volume_multiple: BoolProperty(
        name="Multiple Scattering", default=True,
        description="Analytic Sun: add every order of multiple scattering as Hillaire's isotropic source from a "
                    "table the library makes (it lights the Earth's shadow and the twilight sky, as in the sky "
                    "texture); off: single scattering only")
    add_ground: BoolProperty(
        name="Ground Sphere", default=True,
        description="Add the planet's ground as a sphere (albedo from the scene)")
    length_unit: EnumProperty(
        name="Length Unit", default="KM",
        items=[("KM", "Kilometres", "1 Blender unit = 1 km: planet-scale scenes (recommended: Cycles drops "
                                    "scattering below 1e-5 per unit)"),
               ("M", "Metres", "1 Blender unit = 1 m: small local scenes only")],
        description="Length of one Blender unit for the atmosphere volumes")
    set_units: BoolProperty(
        name="Kilometre Units", default=True,
        description="Set the scene's unit system to kilometres (1 Blender unit = 1 km), as the volumes are built")

    # -- Compare with Native (airmass compare, docs/compare.md)
    compare_width: IntProperty(
        name="Width", default=160, min=4, max=16384, soft_min=16, soft_max=1920,
        description="Width of the comparison images in pixels; the height keeps the render resolution's aspect "
                    "(small is fast: every path renders in Cycles several times)")
    compare_samples: IntProperty(
        name="Samples", default=16, min=1, max=1 << 20, soft_max=1024,
        description="Cycles samples per render and seed (every path)")
    compare_seeds: IntProperty(
        name="Seeds", default=2, min=2, max=1000, soft_max=16,
        description="Independent Blender renders per volume path; their spread measures the noise (at least 2)")
    compare_paths: EnumProperty(
        name="Paths", options={"ENUM_FLAG"},
        default=_COMPARE_PATH_DEFAULTS,
        items=_COMPARE_PATH_ITEMS,
        description="Which ways of bringing the atmosphere into Blender are rendered and compared")
    compare_volume_modes: EnumProperty(
        name="Volume Renders", options={"ENUM_FLAG"}, default={"SPLIT", "RGB"},
        items=[("SPLIT", "Split", "One grey render per colour channel and scattering constituent, summed: "
                                  "unbiased in Cycles 3.4 (docs/compare.md)"),
               ("RGB", "RGB", "One chromatic render, as users render the volume: shows Cycles 3.4's colour bias"),
               ("RGB_DITHER", "RGB Dithered",
                "One chromatic render with the constituents' phases dithered into one Volume Scatter: Cycles 3.4's "
                "colour bias without its phase-summing bias")],
        description="How the volume paths are rendered")
    compare_report: StringProperty(
        name="Report", subtype="FILE_PATH", default="",
        description="report.md of the last comparison (written by Compare with Native)")
    compare_summary: StringProperty(
        name="Last Comparison", default="",
        description="Per-path mean and 95th-percentile relative errors of the last comparison")

    # -- output
    output_folder: StringProperty(
        name="Output Folder", subtype="DIR_PATH", default="//airmass/",
        description="Folder for the sky EXR and VDB files (created if missing; // is the .blend file's folder). "
                    "The sky is always packed into the .blend; it is also saved here when the folder resolves")


CLASSES = (AirmassConstituent, AirmassSettings)


# ---- from settings to the library --------------------------------------------------------

class SettingsError(ValueError):
    """A setting that cannot be used; the message names it."""


def base_spec(settings):
    """The scene source as a native.Spec (no overrides)."""
    if settings.source == "FILE":
        path = bpy.path.abspath(settings.scene_file) if settings.scene_file else ""
        if not path:
            raise SettingsError("Scene File is empty: choose a scene description (.toml) or use a Preset")
        if not os.path.isfile(path):
            raise SettingsError("Scene File '%s' does not exist" % path)
        try:
            with open(path, "r", encoding="utf-8") as f:
                text = f.read()
        except OSError as e:
            raise SettingsError("Scene File '%s' cannot be read: %s" % (path, e))
        return native.Spec(toml=text, source_name=path)
    return native.Spec(preset=settings.preset)


def make_spec(settings, with_constituents=True):
    """The full scene for the library: source + sun + observer + planet/constituent overrides."""
    spec = base_spec(settings)
    # Blender stores angles as float32 radians: ±π/2 reads back as ±90.0000025°. Snap
    # representation error (not user error) to the exact limit.
    elevation_deg = math.degrees(settings.sun_elevation)
    if 90.0 < abs(elevation_deg) <= 90.0 + 1e-4:
        elevation_deg = math.copysign(90.0, elevation_deg)
    spec.sun_elevation_deg = elevation_deg
    spec.sun_rotation_deg = math.degrees(settings.sun_rotation)
    spec.altitude_m = settings.altitude * KM
    if settings.override_planet:
        spec.planet_radius_m = settings.planet_radius * KM
        spec.atmosphere_top_m = settings.atmosphere_top * KM
        spec.ground_albedo = settings.ground_albedo
    spec.basis = {"SCENE": -1, "SPECTRAL": 0, "RGB": 1}[settings.basis]
    if with_constituents:
        for c in settings.constituents:
            scale = None if c.density_scale == 1.0 else c.density_scale
            changed = abs(c.scale_height - c.preset_scale_height) > 1e-6 * max(1.0, c.preset_scale_height)
            height = c.scale_height * KM if changed and c.profile_kind == "exponential" else None
            if c.enabled and scale is None and height is None:
                continue
            spec.constituents.append((c.name, c.enabled, scale, height))
    return spec


def refresh_constituents(settings):
    """Fill settings.constituents from the scene the source describes, keeping the user's
    overrides for names that remain. Returns None or the error message."""
    old = {c.name: (c.enabled, c.density_scale, c.scale_height) for c in settings.constituents}
    old_preset_height = {c.name: c.preset_scale_height for c in settings.constituents}
    try:
        spec = base_spec(settings)
        scene = native.validate_scene(spec)
    except (native.NativeError, SettingsError) as e:
        return str(e)
    if settings.override_planet is False and "planet" in scene:
        planet = scene["planet"]
        # Show the scene's own planet values (km) as the starting point for overrides.
        for key, prop, scale in (("radius_m", "planet_radius", 1 / KM), ("atmosphere_top_m", "atmosphere_top", 1 / KM),
                                 ("ground_albedo", "ground_albedo", 1.0)):
            if key in planet:
                with _Guard():
                    setattr(settings, prop, float(planet[key]) * scale)
    settings.constituents.clear()
    for c in scene.get("constituents", []):
        item = settings.constituents.add()
        item.name = c.get("name", "?")
        profile = c.get("profile", {})
        item.profile_kind = str(profile.get("type", "")).replace("-", "_")
        item.preset_scale_height = float(profile.get("scale_height_m", 0.0) or 0.0) / KM
        item.scale_height = item.preset_scale_height
        if item.name in old:
            item.enabled, item.density_scale, height = old[item.name]
            if height != old_preset_height.get(item.name, height):
                item.scale_height = height  # the user's override survives a refresh
    return None


def resolve_output_folder(settings, optional=False):
    """Absolute, existing, writable output folder (created when missing), or SettingsError.

    optional=True (the sky, which lives packed in the .blend): a folder relative to a .blend
    that is not saved yet gives None (no file is written) instead of an error."""
    raw = settings.output_folder.strip()
    if not raw:
        raise SettingsError("Output Folder is not set: choose a folder for the generated files")
    if raw.startswith("//") and not bpy.data.filepath:
        if optional:
            return None
        raise SettingsError("Output Folder '%s' is relative to the .blend file, which is not saved yet: "
                            "save the file or choose an absolute folder" % raw)
    return ensure_folder(os.path.normpath(bpy.path.abspath(raw)))


def ensure_folder(path):
    """`path` (absolute) as an existing, writable folder, created when missing; SettingsError
    naming the Output Folder otherwise."""
    if os.path.exists(path) and not os.path.isdir(path):
        raise SettingsError("Output Folder '%s' is a file, not a folder" % path)
    if not os.path.isdir(path):
        try:
            os.makedirs(path, exist_ok=True)
        except OSError as e:
            raise SettingsError("Output Folder '%s' cannot be created: %s" % (path, e.strerror or e))
    if not os.access(path, os.W_OK | os.X_OK):
        raise SettingsError("Output Folder '%s' is not writable" % path)
    return path


def fill_empty_constituent_lists():
    """Show each scene's constituents in the panel without a click (after load/enable)."""
    for scene in bpy.data.scenes:
        s = getattr(scene, "airmass", None)
        if s is not None and len(s.constituents) == 0:
            refresh_constituents(s)


@bpy.app.handlers.persistent
def _load_post(_dummy=None):
    fill_empty_constituent_lists()


def _first_fill():
    try:
        fill_empty_constituent_lists()
    except Exception:
        pass
    return None  # run once


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Scene.airmass = PointerProperty(type=AirmassSettings)
    bpy.app.handlers.load_post.append(_load_post)
    bpy.app.timers.register(_first_fill, first_interval=0.1)


def unregister():
    if _load_post in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_load_post)
    if bpy.app.timers.is_registered(_first_fill):
        bpy.app.timers.unregister(_first_fill)
    del bpy.types.Scene.airmass
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
