"""Generate Sky: the sky rendered in memory by the library, stored as a packed float image,
wired into the World.

World node tree after the operator (names are how a re-run finds its nodes, so running
it again replaces the image and keeps one set of nodes):

    [Environment Texture "Airmass Sky"] → [Background "Airmass Background"] → [World Output]

The image "Airmass Sky" is a 32-bit float image packed into the .blend (Blender packs a
float image as OpenEXR), so the first Generate Sky works in a new, unsaved file; when the
Output Folder resolves (absolute, or // with a saved .blend) the same EXR is also written
there as <scene>_sky.exr (atomically: a temporary name in that folder, then os.replace).
Its pixels are the library's linear Rec.709 numbers converted to the file's working colour
space (compat.rec709_to_working_matrix: identity before Blender 5.0), rows flipped (the
library's row 0 is the zenith, Blender's image rows start at the bottom). The library's
metadata strings become custom properties of the image (image["airmass:version"], ...).

The sky is in Blender's own equirectangular convention (Z up, image centre = +X, a quarter
from the left = +Y, top row = zenith; docs/sky.md), so the Environment Texture needs no
Mapping node: a sun at Sky Texture rotation r sits where a Sun lamp synced with the same r
points.
"""

import os
import tempfile

import bpy

from . import compat, native
from .jobs import Plan
from .properties import make_spec, resolve_output_folder

ENV_NODE = "Airmass Sky"
BACKGROUND_NODE = "Airmass Background"
IMAGE_NAME = "Airmass Sky"
WORLD_NAME = "Airmass World"
PIXELS_KEY = "airmass:pixels"  # custom property: "rec709→<working space>" provenance of the pixels


def sky_path(scene, folder):
    return os.path.join(folder, "%s_sky.exr" % bpy.path.clean_name(scene.name))


def _world_output(tree):
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"]
    for n in outputs:
        if n.is_active_output:
            return n
    if outputs:
        return outputs[0]
    return tree.nodes.new("ShaderNodeOutputWorld")  # 5.0: a new World's tree is empty


def airmass_lamp_in_scene(scene):
    from . import sun
    return sun.find_lamp(scene) is not None


def wire_world(scene, image, strength):
    """Environment Texture → Background → World Output, reusing the Airmass nodes."""
    world = scene.world
    if world is None:
        world = bpy.data.worlds.new(WORLD_NAME)
        scene.world = world
    tree = compat.ensure_node_tree(world)
    out = _world_output(tree)
    env = tree.nodes.get(ENV_NODE)
    if env is None or env.bl_idname != "ShaderNodeTexEnvironment":
        env = tree.nodes.new("ShaderNodeTexEnvironment")
        env.name = env.label = ENV_NODE
    bg = tree.nodes.get(BACKGROUND_NODE)
    if bg is None or bg.bl_idname != "ShaderNodeBackground":
        bg = tree.nodes.new("ShaderNodeBackground")
        bg.name = bg.label = BACKGROUND_NODE
    env.location = (out.location.x - 500, out.location.y)
    bg.location = (out.location.x - 200, out.location.y)
    env.image = image
    env.projection = "EQUIRECTANGULAR"
    env.interpolation = "Linear"
    bg.inputs["Strength"].default_value = strength
    tree.links.new(env.outputs["Color"], bg.inputs["Color"])
    tree.links.new(bg.outputs["Background"], out.inputs["Surface"])
    # Importance-sample the sky (the sun disc is a few pixels): a map as fine as the image.
    cycles = getattr(world, "cycles", None)
    if cycles is not None and hasattr(cycles, "sampling_method"):
        cycles.sampling_method = "MANUAL"
        cycles.sample_map_resolution = max(256, min(4096, image.size[0]))
    # EEVEE 4.2+ would extract a second sun from the texture when the Airmass Sun lamp is there.
    if airmass_lamp_in_scene(scene):
        compat.set_world_sun_extraction(world, False)
    return world


def stage_file(path, data):
    """Writes bytes to a temporary file next to `path` (same folder, so the final os.replace
    is atomic) and returns its name; nothing is left behind on error."""
    folder = os.path.dirname(path)
    fd, tmp = tempfile.mkstemp(prefix=".%s.airmass-tmp-" % os.path.basename(path), dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
    except BaseException:
        _remove_quietly(tmp)
        raise
    return tmp


def _remove_quietly(path):
    try:
        os.remove(path)
    except OSError:
        pass


def _restore_world(scene, old_image):
    """After a failure: the Environment Texture shows the previous image again."""
    world = scene.world
    tree = getattr(world, "node_tree", None) if world is not None else None
    env = tree.nodes.get(ENV_NODE) if tree is not None else None
    if env is not None:
        env.image = old_image


def build_sky_image(name, width, height, flat, metadata, working_space):
    """The sky as a new packed 32-bit float image (compat.packed_float_image) of `flat`
    (width·height·4 floats, bottom row first, in the working space): bytes(image.packed_file.data)
    is the EXR file. The library's metadata become custom properties. Removed again on failure."""
    properties = dict(metadata)
    properties[PIXELS_KEY] = "linear Rec.709 -> %s" % working_space
    return compat.packed_float_image(name, width, height, flat, properties=properties)


def sky_options(settings, sun_disc=None):
    """native.render_sky's keyword arguments from the panel's quality settings (`sun_disc`: None
    takes the setting's)."""
    return {"width": settings.sky_width, "height": native.sky_height(settings.sky_width),
            "view_samples": settings.view_samples, "chapman": settings.chapman,
            "sun_disc": settings.sun_disc if sun_disc is None else sun_disc, "grid": settings.sky_grid,
            "multiple_scattering": settings.multiple_scattering}


class SkyPlan(Plan):
    label = "Generate Sky"

    def __init__(self, context):
        scene = context.scene
        s = scene.airmass
        self.scene_name = scene.name
        self.spec = make_spec(s)
        native.validate_scene(self.spec)  # fail before any work, with the field's name
        self.folder = resolve_output_folder(s, optional=True)  # None: packed only (unsaved .blend)
        self.path = sky_path(scene, self.folder) if self.folder else None
        self.options = sky_options(s)
        self.width, self.height = self.options["width"], self.options["height"]
        self.strength = s.sky_strength
        # Read on the main thread; applied to the pixels on the worker.
        self.matrix = compat.rec709_to_working_matrix()
        self.working_space = compat.working_space()
        self.summary = None

    def work(self, progress):
        pixels, metadata = native.render_sky(self.spec, progress=progress, **self.options)
        compat.convert_pixels(pixels, self.matrix)
        # Blender's image rows start at the bottom; the library's row 0 is the zenith.
        return pixels[::-1].ravel(), metadata

    def finish(self, context, result):
        flat, metadata = result
        scene = context.scene
        old = bpy.data.images.get(IMAGE_NAME)
        image = build_sky_image(IMAGE_NAME + " (new)", self.width, self.height, flat, metadata, self.working_space)
        staged = None
        try:
            if self.path:
                staged = stage_file(self.path, bytes(image.packed_file.data))
                image.filepath_raw = self.path  # stays packed; the file is its unpacked twin
            wire_world(scene, image, self.strength)
            if staged:
                os.replace(staged, self.path)  # last: nothing after it can fail
                staged = None
        except Exception:
            _restore_world(scene, old)
            bpy.data.images.remove(image)
            if staged:
                _remove_quietly(staged)
            raise
        if old is not None and old != image:
            bpy.data.images.remove(old)
        image.name = IMAGE_NAME
        where = ("packed and written to %s" % self.path) if self.path else \
            "packed into the .blend (no file: the Output Folder is relative to an unsaved .blend)"
        self.summary = "Airmass sky %dx%d %s" % (image.size[0], image.size[1], where)
