"""Render one path of an Airmass comparison in headless Blender (docs/compare.md).

Run by `airmass compare` as

    blender -b --factory-startup --python-exit-code 1 --python compare/blender_render.py -- JOB.json PATH

with PATH one of sky_texture, analytic_volume, analytic_volume_ms, vdb_volume. JOB.json (written by
`airmass compare`) holds the camera in Blender's terms, the sun lamp, the planet, the
constituents' RGB coefficients and the files to use; everything is in kilometres
(1 Blender unit = 1 km), the scene frame of docs/scene.md (Z up, planet centre at
(0, 0, -R)). For each of the job's seeds the render is written (atomically) to
`blender_<PATH>_seed<k>.exr`, linear, 32-bit float, and `blender_<PATH>.json` records
the Blender version, the render time of every seed, the settings used and how the scene
was built.

Settings that make the render comparable with the native image:
  * Cycles on the CPU, denoising off, adaptive sampling off, no clamping;
  * pixel filter: for the volume paths a Gaussian of width 0.01 px (the minimum), i.e. rays
    through each pixel's centre, which is what the native renderer evaluates; for the sky
    texture path the Box filter, the pixel's mean, against native_physical_box (Cycles 3.4's
    Box filter ignores its width and always covers one pixel);
  * view transform Standard, exposure 0 (EXR output is linear either way);
  * volume paths: every bounce count 0 (single scattering, the ground lit by the sun
    only) — except analytic_volume_ms, multiple scattering: volume and diffuse bounces
    up to job["multiple"]["bounces"] (light scattered again and again, reflected by the
    ground and scattered again), Russian roulette being unbiased; a black world, a Sun lamp of angle 0 whose strength x colour is the sun's
    top-of-atmosphere irradiance in linear Rec.709 (W m^-2);
  * the planet: an opaque Lambertian sphere meshed with rings around the camera's nadir
    (millimetre facets below the camera, tens of metres on the far side), exact sphere
    normals; the atmosphere's analytic domain: an icosphere just outside the top.

The atmosphere's material is the add-on's: airmass_blender/material.py (build_material, the
builder of Create Atmosphere Volume), imported from the job's addon_dir or relative to this
script (load_material_module) without registering the add-on. Otherwise pure bpy + the
standard library (numpy is used when present for the mesh).
"""

import json
import math
import os
import sys
import time
import traceback

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # job_schema.py beside this file
import job_schema  # noqa: E402



# ---- small helpers --------------------------------------------------------------------

def log(msg):
    print("[airmass-compare] " + msg, flush=True)


def blender_version():
    return ".".join(str(v) for v in bpy.app.version)


def set_enum(obj, attr, *values):
    """Set the first accepted enum value (names change between Blender versions)."""
    last = None
    for v in values:
        try:
            setattr(obj, attr, v)
            return v
        except (TypeError, ValueError, AttributeError) as e:  # noqa: PERF203
            last = e
    raise RuntimeError("cannot set %s.%s to any of %s: %s" % (type(obj).__name__, attr, values, last))


def look_matrix(axis_x, axis_y, axis_z, location):
    from mathutils import Matrix

    m = Matrix.Identity(4)
    for r in range(3):
        m[r][0] = axis_x[r]
        m[r][1] = axis_y[r]
        m[r][2] = axis_z[r]
        m[r][3] = location[r]
    return m


def frame_from_z(z):
    """An orthonormal right-handed frame whose third axis is the unit vector z."""
    zx, zy, zz = z
    helper = (1.0, 0.0, 0.0) if abs(zx) < 0.9 else (0.0, 1.0, 0.0)
    # x = normalize(helper × z), y = z × x
    x = (helper[1] * zz - helper[2] * zy, helper[2] * zx - helper[0] * zz, helper[0] * zy - helper[1] * zx)
    n = math.sqrt(sum(c * c for c in x))
    x = tuple(c / n for c in x)
    y = (zy * x[2] - zz * x[1], zz * x[0] - zx * x[2], zx * x[1] - zy * x[0])
    return x, y, z


# ---- scene ----------------------------------------------------------------------------------

def reset_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    return scene


def setup_render(scene, job, path):
    cam = job["camera"]
    r = scene.render
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.use_denoising = False
    if hasattr(cy, "use_preview_denoising"):
        cy.use_preview_denoising = False
    cy.use_adaptive_sampling = False
    cy.samples = int(job["samples"][path])
    cy.use_animated_seed = False
    if path == "sky_texture":
        # The pixel's mean (Cycles 3.4's Box filter is always one pixel wide, whatever its
        # width says; measured with the Window texture coordinate), against the native image
        # made with the box filter (native_physical_box): a texture of finite resolution
        # cannot put the horizon's jump where one ray per pixel finds it, but it integrates to
        # the right mean.
        set_enum(cy, "pixel_filter_type", "BOX")
        cy.filter_width = 1.0
    else:
        # One ray through the pixel centre, as natively: a Gaussian of the minimum width
        # 0.01 px (Cycles scales it to 0.03 px).
        set_enum(cy, "pixel_filter_type", "GAUSSIAN")
        cy.filter_width = 0.01
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.max_bounces = 0
    cy.diffuse_bounces = 0
    cy.glossy_bounces = 0
    cy.transmission_bounces = 0
    cy.volume_bounces = 0
    if path == "analytic_volume_ms":
        n = int(job["multiple"]["bounces"])
        cy.max_bounces = n
        cy.diffuse_bounces = n
        cy.volume_bounces = n
        cy.min_light_bounces = 0  # Russian roulette from the first bounce (unbiased)
    cy.transparent_max_bounces = 64
    cy.caustics_reflective = False
    cy.caustics_refractive = False
    if hasattr(cy, "use_light_tree"):
        cy.use_light_tree = False
    if hasattr(cy, "use_guiding"):
        cy.use_guiding = False
    threads = int(job.get("blender_threads", 0))
    if threads > 0:
        r.threads_mode = "FIXED"
        r.threads = threads
    r.resolution_x = int(cam["width"])
    r.resolution_y = int(cam["height"])
    r.resolution_percentage = 100
    r.pixel_aspect_x = 1.0
    r.pixel_aspect_y = 1.0
    r.use_border = False
    r.film_transparent = False
    r.dither_intensity = 0.0
    set_enum(scene.view_settings, "view_transform", "Standard")
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.cycles.film_exposure = 1.0
    s = r.image_settings
    s.file_format = "OPEN_EXR"
    s.color_mode = "RGB"
    s.color_depth = "32"
    s.exr_codec = "ZIP"
    r.use_file_extension = True


def make_camera(scene, cam):
    data = bpy.data.cameras.new("AirmassCompareCamera")
    if cam["type"] == "PANO":
        data.type = "PANO"
        # Blender 3.x keeps the panorama settings in data.cycles, 4.x in data.
        holder = data if hasattr(data, "panorama_type") else data.cycles
        holder.panorama_type = "EQUIRECTANGULAR"
        holder.latitude_min = math.radians(cam["latitude_min_deg"])
        holder.latitude_max = math.radians(cam["latitude_max_deg"])
        holder.longitude_min = math.radians(cam["longitude_min_deg"])
        holder.longitude_max = math.radians(cam["longitude_max_deg"])
    else:
        data.type = "PERSP"
        data.sensor_fit = cam["sensor_fit"]
        data.sensor_width = cam["sensor_width_mm"]
        data.sensor_height = cam["sensor_height_mm"]
        data.lens_unit = "MILLIMETERS"
        data.lens = cam["lens_mm"]
        data.shift_x = 0.0
        data.shift_y = 0.0
    data.clip_start = float(cam.get("clip_start", 1e-4))
    data.clip_end = float(cam.get("clip_end", 1e6))
    obj = bpy.data.objects.new("AirmassCompareCamera", data)
    scene.collection.objects.link(obj)
    obj.matrix_world = look_matrix(cam["axis_x"], cam["axis_y"], cam["axis_z"], cam["location"])
    scene.camera = obj
    return obj


def world_black(scene):
    world = bpy.data.worlds.new("AirmassCompareWorld")
    scene.world = world
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bg.inputs["Strength"].default_value = 0.0
    return world


def world_sky_texture(scene, image_path):
    world = bpy.data.worlds.new("AirmassCompareSky")
    scene.world = world
    world.use_nodes = True
    nt = world.node_tree
    bg = nt.nodes.get("Background")
    bg.inputs["Strength"].default_value = 1.0
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    img = bpy.data.images.load(image_path, check_existing=False)
    # Linear float data as is: no colour-space conversion of the radiance.
    set_enum(img.colorspace_settings, "name", "Non-Color", "Raw")
    if hasattr(img, "use_half_precision"):
        img.use_half_precision = False  # Cycles would store the float EXR as half (3 digits)
    tex.image = img
    tex.interpolation = "Linear"
    tex.projection = "EQUIRECTANGULAR"
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    # Nothing is lit by the World here (no surfaces): skip building its importance map
    # (seconds for a large texture).
    set_enum(world.cycles, "sampling_method", "NONE")
    return world


def make_sun(scene, sun):
    data = bpy.data.lights.new("AirmassCompareSun", "SUN")
    strength = float(sun["strength"])
    data.energy = strength
    data.color = tuple(sun["color"])
    data.angle = math.radians(float(sun.get("angle_deg", 0.0)))
    if hasattr(data, "cycles"):
        data.cycles.cast_shadow = True
    obj = bpy.data.objects.new("AirmassCompareSun", data)
    scene.collection.objects.link(obj)
    # A Sun lamp shines along its local -Z: local +Z points toward the sun.
    x, y, z = frame_from_z(tuple(sun["direction"]))
    obj.matrix_world = look_matrix(x, y, z, (0.0, 0.0, 0.0))
    if strength <= 0.0:
        obj.hide_render = True  # a lamp of strength 0 would only cost time
    return obj


# ---- the planet: an exact-normal sphere, fine under the camera -----------------------------

def ring_angles(radius, first_km, growth, max_step_rad):
    """Polar angles (from the nadir point) of the rings: geometric near the nadir, then uniform."""
    angles = [0.0]
    step = first_km / radius
    a = 0.0
    while a < math.pi:
        a = min(a + step, math.pi)
        angles.append(a)
        step = min(step * growth, max_step_rad)
    return angles


def make_planet(scene, planet, nadir, settings):
    """A closed sphere of radius R around `planet["center"]`, rings around `nadir` (unit)."""
    R = float(planet["radius"])
    c = planet["center"]
    segs = int(settings.get("ground_segments", 256))
    angles = ring_angles(R, float(settings.get("ground_first_km", 1e-4)), float(settings.get("ground_growth", 1.06)),
                         math.radians(float(settings.get("ground_max_step_deg", 0.5))))
    ex, ey, ez = frame_from_z(nadir)
    cos_phi = [math.cos(2.0 * math.pi * k / segs) for k in range(segs)]
    sin_phi = [math.sin(2.0 * math.pi * k / segs) for k in range(segs)]
    # Vertices relative to the nadir's surface point s0 = c + R·ez (exactly the origin in the
    # usual frame): R(n − ez) = R sin a (cos φ ex + sin φ ey) − 2R sin²(a/2) ez, so points a
    # metre from the camera keep their precision next to a 6360-km radius.
    s0 = tuple(c[i] + R * ez[i] for i in range(3))
    verts, normals = [s0], [tuple(ez)]
    for a in angles[1:-1]:
        sa, ca = math.sin(a), math.cos(a)
        dz = -2.0 * R * math.sin(0.5 * a) ** 2
        for k in range(segs):
            e = tuple(cos_phi[k] * ex[i] + sin_phi[k] * ey[i] for i in range(3))
            normals.append(tuple(sa * e[i] + ca * ez[i] for i in range(3)))
            verts.append(tuple(s0[i] + R * sa * e[i] + dz * ez[i] for i in range(3)))
    normals.append(tuple(-v for v in ez))
    verts.append(tuple(s0[i] - 2.0 * R * ez[i] for i in range(3)))
    rings = len(angles) - 2
    faces = []
    for k in range(segs):  # fan at the nadir
        faces.append((0, 1 + (k + 1) % segs, 1 + k))
    for r in range(rings - 1):
        b0, b1 = 1 + r * segs, 1 + (r + 1) * segs
        for k in range(segs):
            k1 = (k + 1) % segs
            faces.append((b0 + k, b0 + k1, b1 + k1, b1 + k))
    last = len(verts) - 1
    b0 = 1 + (rings - 1) * segs
    for k in range(segs):  # fan at the antipode
        faces.append((b0 + k, b0 + (k + 1) % segs, last))
    # The loops above wind clockwise seen from outside; Cycles takes the winding as the
    # geometric normal, which must point out of the planet.
    faces = [tuple(reversed(f)) for f in faces]
    mesh = bpy.data.meshes.new("AirmassPlanet")
    mesh.from_pydata(verts, [], faces)
    mesh.validate()
    for p in mesh.polygons:
        p.use_smooth = True
    # Exact sphere normals (needs auto smooth in 3.x; custom normals are always used in 4.1+).
    try:
        if hasattr(mesh, "use_auto_smooth"):
            mesh.use_auto_smooth = True
        mesh.normals_split_custom_set_from_vertices(normals)
    except Exception as e:  # noqa: BLE001
        log("planet: exact normals not set (%s); smooth shading only" % e)
    obj = bpy.data.objects.new("AirmassPlanet", mesh)
    scene.collection.objects.link(obj)
    mat = bpy.data.materials.new("AirmassGround")
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
    a = float(planet["albedo"])
    diffuse.inputs["Color"].default_value = (a, a, a, 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0
    nt.links.new(diffuse.outputs[0], out.inputs["Surface"])
    mesh.materials.append(mat)
    GROUND.append((diffuse, a))
    return obj, len(verts), len(faces)


GROUND = []  # (Diffuse BSDF node, albedo): the split renders light the ground in one render only


def set_ground_lit(lit):
    for node, a in GROUND:
        v = a if lit else 0.0
        node.inputs["Color"].default_value = (v, v, v, 1.0)


# ---- the volume material: the add-on's own builder (airmass_blender/material.py) -------------
#
# The comparison renders the material users get: airmass_blender.material.build_material,
# the builder of Create Atmosphere Volume, with the same density source (the analytic altitude
# profile or the VDB grid attribute) and the job's constituents (the library's analytic-density
# JSON: coefficients and g_hg, the one phase → Henyey–Greenstein rule). Each render mode uses
# the graph it needs and re-sets only its closures' constants (VolumeControl):
#   rgb        — phase mixing SEPARATE as built: one Volume Scatter per constituent;
#   rgb_dither — phase mixing DITHER as built (the add-on's default): one dithered Volume Scatter;
#   split      — SEPARATE with stand-ins, grey per (channel, scatterer);
#   ms closures / ms dither — SEPARATE / DITHER, grey per channel.

def material_module_candidates(job, here=None):
    """Folders that may hold the airmass_blender package: the job's addon_dir (the CLI's
    --addon), then relative to this script's folder `here` — the installed zip
    (<addons>/airmass_blender/compare_scripts/) and the source tree (compare/ beside addon/)."""
    here = os.path.dirname(os.path.abspath(__file__)) if here is None else here
    out = []
    if job.get("addon_dir"):
        out.append(job["addon_dir"])
    if os.path.basename(here) == "compare_scripts":
        out.append(os.path.dirname(os.path.dirname(here)))
    out.append(os.path.join(os.path.dirname(here), "addon"))
    return out


def load_material_module(job):
    """airmass_blender.material without importing the add-on's __init__ (which needs the native
    library and registers properties): the package is entered as a bare namespace module when
    it is not imported yet. Returns (module, file)."""
    import importlib
    import types

    tried = []
    pkg = sys.modules.get("airmass_blender")
    if pkg is None:
        for parent in material_module_candidates(job):
            folder = os.path.join(parent, "airmass_blender")
            tried.append(folder)
            if os.path.isfile(os.path.join(folder, "material.py")):
                pkg = types.ModuleType("airmass_blender")
                pkg.__path__ = [folder]
                pkg.__file__ = os.path.join(folder, "__init__.py")
                sys.modules["airmass_blender"] = pkg
                break
    if pkg is None:
        raise RuntimeError("cannot find the add-on's material builder airmass_blender/material.py; tried %s "
                           "(pass --addon DIR to airmass compare)" % ", ".join(tried))
    module = importlib.import_module("airmass_blender.material")
    return module, module.__file__


MATERIAL = None  # the airmass_blender.material module (main)


def _grey(v):
    return (float(v),) * 3 + (1.0,)


class VolumeControl:
    """The atmosphere objects and, per render mode, the material built by the add-on's builder;
    sets the constants of its named closures (material.py lists the names) for each render.

    Per constituent j of σs_j, σa_j (RGB): "<j> scatter" (Colour × "<j> scatter density"'s
    factor = σs), "<j> absorption" (σa = (1 − Colour) × factor), "<j> stand-in" (split only: its
    scattering as extinction), or in the dithered graph "<j> scatter weight"/"<j> scatter
    colour" feeding "scatter (dithered)". A zero-weight closure is dropped by Cycles.

      rgb, rgb_dither:  as built — the volume as users render it;
      split(c, i):      S_i = σs_i,c (grey), S_j = 0 and stand-in X_j = σs_j,c for j ≠ i,
                        A_j = σa_j,c — grey, one scattering closure, the full extinction. Single
                        scattering is additive over scatterers: Σ_i split(c, i) is channel c;
      ms(c, closures):  S_j = σs_j,c for every j, A_j = σa_j,c — one closure per scatterer, which
                        Cycles 3.4 renders biased (the phase-summing bias, measured);
      ms(c, dither):    the dithered closure with weights σs_j,c and white colours: the phase at
                        each point is Σ_j σs_j p_j / σs in expectation, with one closure.
    """

    GRAPHS = {"rgb": ("SEPARATE", False), "rgb_dither": ("DITHER", False), "split": ("SEPARATE", True),
              "closures": ("SEPARATE", False), "dither": ("DITHER", False)}

    def __init__(self, job, density_for, name):
        self.job = job
        self.density_for = density_for
        self.name = name
        self.constituents = {c["name"]: c for c in job["constituents"]}
        self.scatterers = sorted(n for n, c in self.constituents.items() if max(c["scattering_rgb"]) > 0.0)
        self.objects = []  # (id with .materials), e.g. a Mesh or a Volume
        self.materials = {}
        self.current = None

    def material(self, mode):
        """The material of a mode, built once (material.build_material)."""
        if mode not in self.materials:
            mixing, stand_ins = self.GRAPHS[mode]
            mat = MATERIAL.build_material("%s %s" % (self.name, mode), self.job["constituents"], self.density_for,
                                          phase_mixing=mixing, stand_ins=stand_ins)
            # Sampling, not the graph: distance sampling as in every comparison so far.
            set_enum(mat.cycles, "volume_interpolation", "LINEAR")
            set_enum(mat.cycles, "volume_sampling", "DISTANCE")
            self.materials[mode] = mat
        return self.materials[mode]

    def use(self, mode):
        mat = self.material(mode)
        for data in self.objects:
            if len(data.materials) == 0:
                data.materials.append(mat)
            else:
                data.materials[0] = mat
        self.current = mat
        return mat

    def dithered(self, mode):
        return "scatter (dithered)" in self.material(mode).node_tree.nodes

    # -- setting closures ----------------------------------------------------------------------
    def _nodes(self):
        return self.current.node_tree.nodes

    def _closure(self, kind, name, sigma, absorb):
        """Closure "<name> <kind>" to the grey coefficient sigma: colour white (scatter) or black
        (absorption) and its density factor sigma."""
        nodes = self._nodes()
        node = nodes.get("%s %s" % (name, kind))
        if node is None:
            if sigma > 0.0:
                raise RuntimeError("the material has no closure '%s %s'" % (name, kind))
            return
        node.inputs["Color"].default_value = _grey(0.0 if absorb else 1.0)
        nodes["%s %s density" % (name, kind)].inputs[1].default_value = float(sigma)

    def set_split(self, channel, scatterer):
        for name, c in self.constituents.items():
            s = float(c["scattering_rgb"][channel])
            if name in self.scatterers:
                self._closure("scatter", name, s if name == scatterer else 0.0, False)
                self._closure("stand-in", name, 0.0 if name == scatterer else s, True)
            self._closure("absorption", name, float(c["absorption_rgb"][channel]), True)

    def set_ms(self, channel, dither):
        nodes = self._nodes()
        for name, c in self.constituents.items():
            s = float(c["scattering_rgb"][channel])
            if dither:
                if name in self.scatterers:
                    nodes["%s scatter weight" % name].inputs[1].default_value = s
                    nodes["%s scatter colour" % name].outputs[0].default_value = _grey(1.0)
            else:
                self._closure("scatter", name, s, False)
            self._closure("absorption", name, float(c["absorption_rgb"][channel]), True)


VOLUME = []  # the VolumeControl of the scene (main)


def set_step(scene, mat, base_step_km, want_step_km, max_steps):
    """Cycles' step = base (0.1 × mean bounding-box size for procedural volumes, the voxel size
    for grids) × material rate × scene rate."""
    rate = want_step_km / base_step_km
    mat_rate = min(max(rate, 0.001), 1.0)
    scene_rate = min(max(rate / mat_rate, 0.01), 100.0)
    mat.cycles.volume_step_rate = mat_rate
    scene.cycles.volume_step_rate = scene_rate
    scene.cycles.volume_max_steps = int(max_steps)
    return base_step_km * mat_rate * scene_rate


def volume_modes(job, path):
    if path == "analytic_volume_ms":
        return list(job["multiple"].get("modes", ["dither", "closures"]))
    return list(job.get("volume_modes", ["split", "rgb"]))


def make_analytic_volume(scene, job, path):
    planet = job["planet"]
    R, top = float(planet["radius"]), float(planet["top"])
    margin = float(job["volume"].get("domain_margin_km", 5.0))
    # At the world origin, its mesh around the planet centre: the builder's Texture Coordinate
    # "Object" is then the world point, as in the add-on.
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=5, radius=top + margin, location=(0.0, 0.0, 0.0))
    obj = bpy.context.object
    obj.name = "AirmassAtmosphere"
    from mathutils import Matrix

    obj.data.transform(Matrix.Translation(tuple(planet["center"])))
    control = VolumeControl(job, MATERIAL.analytic_density(planet["center"], R, top - R, job["constituents"]),
                            "AirmassAtmosphereAnalytic")
    control.objects.append(obj.data)
    base = 0.1 * 2.0 * (top + margin)  # 0.1 × mean bounding-box size
    step = None
    for mode in volume_modes(job, path):
        step = set_step(scene, control.material(mode), base, float(job["volume"]["step_km"]), job["volume"]["max_steps"])
    VOLUME.append(control)
    return obj, {"step_km": step, "base_step_km": base, "domain_radius_km": top + margin}


def make_vdb_volume(scene, job):
    vdb = job["vdb"]
    files = vdb["files"]
    vs = float(vdb["voxel_size"])
    half_voxel = bpy.app.version < (5, 0, 0) and vdb.get("half_voxel_correction", True)
    control = VolumeControl(job, MATERIAL.grid_density(), "AirmassAtmosphereVDB")
    objs = []
    for i, f in enumerate(files):
        vol = bpy.data.volumes.new("AirmassVDB%d" % i)
        vol.filepath = f
        vol.render.precision = "FULL"
        vol.render.clipping = 0.0
        set_enum(vol.render, "space", "WORLD")
        vol.render.step_size = 0.0  # automatic: the voxel size (× the rates below)
        obj = bpy.data.objects.new("AirmassVDB%d" % i, vol)
        scene.collection.objects.link(obj)
        if half_voxel:
            # Blender < 5.0 puts voxel (i, j, k)'s value at the voxel centre, (i + ½) · size,
            # where OpenVDB (and the exporter) mean i · size: move the object back by half a voxel.
            obj.location = (-0.5 * vs, -0.5 * vs, -0.5 * vs)
        control.objects.append(vol)
        vol.grids.load()
        names = [g.name for g in vol.grids]
        missing = [c["name"] for c in job["constituents"] if c["name"] not in names]
        if missing:
            raise RuntimeError("%s: grids %s missing (has %s)" % (f, missing, names))
        objs.append(obj)
    step = None
    for mode in volume_modes(job, "vdb_volume"):
        step = set_step(scene, control.material(mode), vs, float(job["volume"].get("vdb_step_km", vs)),
                        job["volume"]["max_steps"])
    VOLUME.append(control)
    return objs, {"step_km": step, "voxel_size_km": vs, "half_voxel_correction": bool(half_voxel)}


# ---- main --------------------------------------------------------------------------------------------

RENDERS = [0]  # renders made (checked against the job's plan)


def render_to(scene, out_dir, name):
    """One render to out_dir/name, atomically; returns the render seconds."""
    final = os.path.join(out_dir, name)
    tmp = os.path.join(out_dir, ".%s.tmp-%d.exr" % (name[:-4], os.getpid()))
    scene.render.filepath = tmp
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - t0
    if not os.path.isfile(tmp):
        raise RuntimeError("Blender did not write %s" % tmp)
    os.replace(tmp, final)
    RENDERS[0] += 1
    log("%s: %.2f s" % (name, seconds))
    return seconds


def render_seeds(scene, job, path, out_dir, sun_obj):
    """Renders every seed of every mode the job asks for; returns {mode: [seconds per seed]}.

    Modes of the volume paths (docs/compare.md, "Two Cycles 3.4 biases"):
      rgb   — the volume as users render it: one render, chromatic coefficients, every
              constituent's Volume Scatter in one material;
      split — per channel c and scattering constituent i one render of a grey medium with a
              single Volume Scatter (constituent i at channel c's value), every other
              extinction as Volume Absorption, and a white lamp of strength E_c; channel c of
              the image is the sum over i of channel c of those renders. Cycles 3.4 is biased
              for a chromatic heterogeneous medium (it picks a colour channel afresh at every
              ray-marching step) and for a material with several Volume Scatter closures (the
              phase functions are summed unweighted); a grey medium with one scattering
              closure is neither.
    """
    seeds = int(job["seeds"][path])
    base = int(job.get("seed_base", 0))
    times = {}
    if path == "sky_texture":
        times["rgb"] = []
        for k in range(seeds):
            scene.cycles.seed = base + k
            times["rgb"].append(render_to(scene, out_dir, "blender_%s_seed%d.exr" % (path, k)))
        return times
    control = VOLUME[0]
    sun = sun_obj.data
    e = job["sun"]["irradiance_rgb"]
    scatterers = control.scatterers
    if path == "analytic_volume_ms":
        # Multiple scattering: per channel c one grey render of the whole medium at c, white
        # lamp of E_c, the ground lit (it reflects sun- and skylight back into the medium).
        set_ground_lit(True)
        sun.color = (1.0, 1.0, 1.0)
        for mode in volume_modes(job, path):
            control.use(mode)
            if mode == "dither" and not control.dithered(mode):
                raise RuntimeError("the add-on's DITHER material has no dithered Volume Scatter in this Blender "
                                   "(its own phase types): use --ms-modes closures")
            times[mode] = []
            for k in range(seeds):
                scene.cycles.seed = base + k
                t = 0.0
                for ch in range(3):
                    control.set_ms(ch, mode == "dither")
                    sun.energy = float(e[ch])
                    sun_obj.hide_render = sun.energy <= 0.0
                    t += render_to(scene, out_dir, "blender_%s_%s_seed%d_c%d.exr" % (path, mode, k, ch))
                times[mode].append(t)
        return times
    for mode in volume_modes(job, path):
        control.use(mode)
        times[mode] = []
        for k in range(seeds):
            scene.cycles.seed = base + k
            if mode in ("rgb", "rgb_dither"):
                # As built: the material users render.
                set_ground_lit(True)
                sun.color = tuple(job["sun"]["color"])
                sun.energy = float(job["sun"]["strength"])
                sun_obj.hide_render = sun.energy <= 0.0
                times[mode].append(render_to(scene, out_dir, "blender_%s_%s_seed%d.exr" % (path, mode, k)))
            else:
                t = 0.0
                for ch in range(3):
                    for i, name in enumerate(scatterers):
                        control.set_split(ch, name)
                        # The sunlit ground belongs to the image once: lit in the first render,
                        # black (still opaque, still shadowing) in the others.
                        set_ground_lit(i == 0)
                        sun.color = (1.0, 1.0, 1.0)
                        sun.energy = float(e[ch])
                        sun_obj.hide_render = sun.energy <= 0.0
                        t += render_to(scene, out_dir, "blender_%s_split_seed%d_c%d_s%d.exr" % (path, k, ch, i))
                times[mode].append(t)
    return times


def main(argv):
    global MATERIAL
    if len(argv) != 2:
        raise SystemExit("usage: blender -b --python blender_render.py -- JOB.json PATH")
    job_path, path = argv
    try:
        job = job_schema.load(job_path)
    except job_schema.JobSchemaError as e:
        raise SystemExit("blender_render.py: %s" % e) from None
    paths = [p["name"] for p in job["plan"]["all_paths"]]  # compare/plan.json's path table, the one list
    if path not in paths:
        raise SystemExit("blender_render.py: unknown path %r (the job's paths: %s)" % (path, "|".join(paths)))
    planned = job["plan"]["blender_renders"].get(path)
    out_dir = os.path.dirname(os.path.abspath(job_path))
    info = {"path": path, "blender_version": blender_version(), "notes": [], "build": {}}
    sun_obj = None
    t_start = time.perf_counter()
    scene = reset_scene()
    setup_render(scene, job, path)
    make_camera(scene, job["camera"])
    if path == "sky_texture":
        world_sky_texture(scene, job["sky_texture"]["file"])
        info["build"]["sky_texture"] = job["sky_texture"]
    else:
        world_black(scene)
        sun_obj = make_sun(scene, job["sun"])
        _, nv, nf = make_planet(scene, job["planet"], job["planet"]["nadir"], job.get("ground", {}))
        info["build"]["planet_mesh"] = {"vertices": nv, "faces": nf}
        MATERIAL, material_file = load_material_module(job)
        info["build"]["material_builder"] = material_file
        if path in ("analytic_volume", "analytic_volume_ms"):
            _, b = make_analytic_volume(scene, job, path)
        else:
            _, b = make_vdb_volume(scene, job)
        info["build"]["volume"] = b
        # The Henyey–Greenstein g each graph gives Cycles (the one rule; tests compare it with
        # the job's g_hg and the native renderer-matched image).
        info["build"]["anisotropy"] = {n: MATERIAL.constituent_hg_g(c) for n, c in VOLUME[0].constituents.items()
                                       if n in VOLUME[0].scatterers}
    info["build_seconds"] = time.perf_counter() - t_start
    info["render_seconds"] = render_seeds(scene, job, path, out_dir, sun_obj)
    made = RENDERS[0]
    if planned is not None and made != planned:
        raise RuntimeError("made %d renders where the job's plan says %d (plugin/src/compare/plan.cpp planned_renders "
                           "and render_seeds disagree)" % (made, planned))
    info["renders"] = made
    info["modes"] = list(info["render_seconds"].keys())
    info["scatterers"] = VOLUME[0].scatterers if VOLUME else []
    info["samples"] = int(job["samples"][path])
    info["seeds"] = int(job["seeds"][path])
    info["cycles"] = {
        "volume_step_rate": scene.cycles.volume_step_rate,
        "volume_max_steps": scene.cycles.volume_max_steps,
        "filter_width": scene.cycles.filter_width,
        "pixel_filter_type": scene.cycles.pixel_filter_type,
    }
    tmp = os.path.join(out_dir, ".blender_%s.json.tmp" % path)
    with open(tmp, "w") as f:
        json.dump(info, f, indent=2)
    os.replace(tmp, os.path.join(out_dir, "blender_%s.json" % path))


if __name__ == "__main__":
    try:
        main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
    except SystemExit:
        raise
    except Exception:
        traceback.print_exc()
        sys.exit(1)
