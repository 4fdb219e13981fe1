"""Generate Sky: the sky EXR through the library, wired into the World.

World node tree after the operator (names are how a re-run finds its nodes, so running
it again replaces the image and keeps one set of nodes):

    [Environment Texture "Airmass Sky"] → [Background "Airmass Background"] → [World Output]

The EXR is written in Blender's own equirectangular convention (Z up, image centre = +X,
a quarter from the left = +Y, top row = zenith; docs/sky.md), so the Environment Texture
needs no Mapping node: the identity orientation is the right one, and a sun at Sky
Texture rotation r sits where a Sun lamp synced with the same r points.
"""

import os

import bpy

from . import native
from .jobs import Plan
from .properties import make_spec, resolve_output_folder

ENV_NODE = "Airmass Sky"
BACKGROUND_NODE = "Airmass Background"
IMAGE_NAME = "Airmass Sky"
WORLD_NAME = "Airmass World"


def sky_path(scene, folder):
    return os.path.join(folder, "%s_sky.exr" % bpy.path.clean_name(scene.name))


def _linear_colorspace(image):
    for name in ("Linear Rec.709", "Linear"):  # 4.x name, then 3.x name
        try:
            image.colorspace_settings.name = name
            return
        except TypeError:
            continue


def _world_output(tree):
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"]
    for n in outputs:
        if n.is_active_output:
            return n
    if outputs:
        return outputs[0]
    return tree.nodes.new("ShaderNodeOutputWorld")


def wire_world(scene, image, strength):
    """Environment Texture → Background → World Output, reusing the Airmass nodes."""
    world = scene.world
    if world is None:
        world = bpy.data.worlds.new(WORLD_NAME)
        scene.world = world
    world.use_nodes = True
    tree = world.node_tree
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
    return world


class SkyPlan(Plan):
    label = "Generate Sky"

    def __init__(self, context):
        scene = context.scene
        s = scene.airmass
        self.scene_name = scene.name
        self.spec = make_spec(s)
        native.validate_scene(self.spec)  # fail before any work, with the field's name
        self.folder = resolve_output_folder(s)
        self.path = sky_path(scene, self.folder)
        self.width = s.sky_width
        self.samples = s.view_samples
        self.chapman = s.chapman
        self.sun_disc = s.sun_disc
        self.grid = s.sky_grid
        self.multiple_scattering = s.multiple_scattering
        self.strength = s.sky_strength
        self.summary = None

    def work(self, progress):
        native.write_sky_exr(self.spec, self.path, width=self.width, height=max(2, self.width // 2),
                             view_samples=self.samples, chapman=self.chapman, sun_disc=self.sun_disc,
                             grid=self.grid, multiple_scattering=self.multiple_scattering, progress=progress)
        return self.path

    def finish(self, context, path):
        scene = context.scene
        old = bpy.data.images.get(IMAGE_NAME)
        image = bpy.data.images.load(path, check_existing=False)
        try:
            _linear_colorspace(image)
            image.reload()
            if image.size[0] == 0:
                raise RuntimeError("Blender could not read the sky image '%s'" % path)
            wire_world(scene, image, self.strength)
        except Exception:
            bpy.data.images.remove(image)
            raise
        if old is not None and old != image:
            bpy.data.images.remove(old)
        image.name = IMAGE_NAME
        self.summary = "Airmass sky %dx%d written to %s" % (image.size[0], image.size[1], path)
