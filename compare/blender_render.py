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

Pure bpy + the standard library (numpy is used when present for the mesh).
"""

import json
import math
import os
import sys
import time
import traceback

import bpy

PATHS = ("sky_texture", "analytic_volume", "analytic_volume_ms", "vdb_volume")


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


# ---- volume shaders -----------------------------------------------------------------------------

class Nodes:
    """A tiny helper to write node trees as expressions."""

    def __init__(self, tree):
        self.t = tree
        self.n = tree.nodes
        self.l = tree.links

    def math(self, op, a, b=None, clamp=False):
        node = self.n.new("ShaderNodeMath")
        node.operation = op
        node.use_clamp = clamp
        for i, v in enumerate((a, b)):
            if v is None:
                continue
            if isinstance(v, (int, float)):
                node.inputs[i].default_value = float(v)
            else:
                self.l.new(v, node.inputs[i])
        return node.outputs[0]

    def vmath(self, op, a, b=None):
        node = self.n.new("ShaderNodeVectorMath")
        node.operation = op
        for i, v in enumerate((a, b)):
            if v is None:
                continue
            if isinstance(v, (tuple, list)):
                node.inputs[i].default_value = v
            else:
                self.l.new(v, node.inputs[i])
        return node.outputs["Value"] if op in ("LENGTH", "DOT_PRODUCT", "DISTANCE") else node.outputs["Vector"]


def altitude_socket(nodes, center, radius):
    """h = |p - c| - R, written without cancellation when c = (0, 0, -R): (x² + y² + z(z + 2R)) / (|p - c| + R)."""
    geo = nodes.n.new("ShaderNodeNewGeometry")
    p = geo.outputs["Position"]
    rel = nodes.vmath("SUBTRACT", p, tuple(center))
    dist = nodes.vmath("LENGTH", rel)
    if abs(center[0]) < 1e-12 and abs(center[1]) < 1e-12 and abs(center[2] + radius) < 1e-9 * radius:
        sep = nodes.n.new("ShaderNodeSeparateXYZ")
        nodes.l.new(p, sep.inputs[0])
        x, y, z = sep.outputs[0], sep.outputs[1], sep.outputs[2]
        num = nodes.math("ADD", nodes.math("ADD", nodes.math("MULTIPLY", x, x), nodes.math("MULTIPLY", y, y)),
                         nodes.math("MULTIPLY", z, nodes.math("ADD", z, 2.0 * radius)))
        return nodes.math("DIVIDE", num, nodes.math("ADD", dist, radius))
    return nodes.math("SUBTRACT", dist, radius)


def profile_socket(nodes, h, profile, top_altitude):
    """Relative density of a profile (the analytic JSON of docs/vdb.md) at altitude socket h."""
    hc = nodes.math("MAXIMUM", h, 0.0)  # below the ground (inside the opaque planet): the ground value
    kind = profile["type"]
    if kind == "exponential":
        arg = nodes.math("DIVIDE", nodes.math("SUBTRACT", profile["reference_altitude"], hc), profile["scale_height"])
        rho = nodes.math("EXPONENT", arg)
    elif kind == "tent":
        b, k, t = profile["bottom"], profile["peak"], profile["top"]
        up = nodes.math("DIVIDE", nodes.math("SUBTRACT", hc, b), k - b)
        down = nodes.math("DIVIDE", nodes.math("SUBTRACT", t, hc), t - k)
        rho = nodes.math("MAXIMUM", nodes.math("MINIMUM", up, down), 0.0)
    elif kind == "piecewise_linear":
        # r0 + Σ (r_{k+1} − r_k) · clamp((h − h_k)/(h_{k+1} − h_k), 0, 1), zero outside the knots.
        knots = profile["knots"]
        h0, hn = knots[0][0], knots[-1][0]
        rho = nodes.math("ADD", nodes.math("MULTIPLY", hc, 0.0), knots[0][1])
        for (ha, ra), (hb, rb) in zip(knots[:-1], knots[1:]):
            if rb == ra:
                continue
            if hb > ha:
                ramp = nodes.math("DIVIDE", nodes.math("SUBTRACT", hc, ha), hb - ha, clamp=True)
            else:  # equal altitudes: a jump at ha
                ramp = nodes.math("GREATER_THAN", hc, ha)
            rho = nodes.math("ADD", rho, nodes.math("MULTIPLY", ramp, rb - ra))
        inside = nodes.math("MULTIPLY", nodes.math("GREATER_THAN", hc, h0 - 1e-9),
                            nodes.math("LESS_THAN", hc, hn + 1e-9))
        rho = nodes.math("MULTIPLY", rho, inside)
    elif kind == "constant":
        b = profile["bottom"]
        t = profile["top"] if profile.get("top") is not None else top_altitude
        inside = nodes.math("MULTIPLY", nodes.math("GREATER_THAN", hc, b - 1e-9), nodes.math("LESS_THAN", hc, t))
        rho = nodes.math("MULTIPLY", inside, profile["value"])
    else:
        raise RuntimeError("profile type %r is not supported by the comparison's node builder" % kind)
    below_top = nodes.math("LESS_THAN", h, top_altitude)
    return nodes.math("MULTIPLY", rho, below_top)


CLOSURES = {}  # material name -> Closures, for the split renders


class Closures:
    """The closure nodes of the atmosphere's material, so one material serves every render.

    Per constituent j: a Volume Scatter S_j (σs = colour × ρ_j, HG g_j), a Volume Absorption
    A_j for its absorption (σa = (1 − colour) × k ρ_j, k = max σa_j so the colour stays in
    [0, 1]) and a Volume Absorption X_j that can stand in for its scattering as extinction
    only. A zero-weight closure is dropped by Cycles, so it costs nothing and adds no phase.

      set_rgb():            S_j = σs_j (RGB), A_j = σa_j, X_j = 0 — the volume as users render it;
      set_split(c, i):      S_i = σs_i,c (grey), S_j = 0 and X_j = σs_j,c for j ≠ i,
                            A_j = σa_j,c — grey, one scattering closure, the full extinction.
    Single scattering is additive over scatterers, so Σ_i split(c, i) is channel c of the image.

    With multiple scattering (analytic_volume_ms) splitting by scatterer is wrong — light
    scattered by one constituent is scattered again by the other — so each render holds the
    whole medium at one channel, grey:
      set_ms(c, False):     S_j = σs_j,c for every j, A_j = σa_j,c — one closure per scatterer,
                            which Cycles 3.4 renders biased (the phase-summing bias, measured);
      set_ms(c, True):      every S_j = 0; the single closure D = Volume Scatter of density
                            Σ_j σs_j,c ρ_j whose anisotropy is g_j with probability
                            σs_j,c ρ_j / Σ σs, picked by a White Noise texture of the shading
                            position (a hash of the float bits: independent at every ray-marching
                            point). In expectation the phase at each point is Σ_j σs_j p_j / σs,
                            the mixture, with one closure: unbiased.
      set_rgb_dither():     the chromatic volume with D alone for scattering (the render users
                            would make with such a material): density Σ_j m_j ρ_j (m_j = max_c
                            σs_j,c), g_j and colour σs_j / m_j with probability m_j ρ_j / Σ m ρ —
                            per channel c the expected weight × phase is Σ_j σs_j,c ρ_j p_j.
    """

    def __init__(self):
        self.scatter = {}   # name -> node
        self.absorb = {}    # name -> (node, k)
        self.stand_in = {}  # name -> (node, k)
        self.constituents = {}
        self.dither = None  # Dither: the single dithered Volume Scatter

    def scatterers(self):
        return [n for n in self.scatter]

    @staticmethod
    def _absorb(node, k, values):
        node.inputs["Color"].default_value = tuple(1.0 - v / k for v in values) + (1.0,)

    def _apply(self, scatter, stand_in, absorb, dither=None):
        """Sets every closure: scatter(name, c) and stand_in(name, c) → RGB σ of constituent c's
        Volume Scatter and of the Volume Absorption standing in for it, absorb(c) → its σa;
        dither: Dither.set's (gain, weights, colours), or None to switch it off."""
        for name, c in self.constituents.items():
            if name in self.scatter:
                self.scatter[name].inputs["Color"].default_value = tuple(scatter(name, c)) + (1.0,)
                node, k = self.stand_in[name]
                self._absorb(node, k, stand_in(name, c))
            if name in self.absorb:
                node, k = self.absorb[name]
                self._absorb(node, k, absorb(c))
        if dither is not None and not self.dither:
            raise RuntimeError("the material has no dithered scattering closure")
        if self.dither:
            self.dither.set(*(dither or (0.0, {}, {})))

    def set_rgb(self):
        self._apply(lambda n, c: c["scattering_rgb"], _black, lambda c: c["absorption_rgb"])

    def set_split(self, channel, scatterer):
        def grey(v):
            return (v,) * 3

        self._apply(lambda n, c: grey(c["scattering_rgb"][channel]) if n == scatterer else _black(),
                    lambda n, c: _black() if n == scatterer else grey(c["scattering_rgb"][channel]),
                    lambda c: grey(c["absorption_rgb"][channel]))

    def set_ms(self, channel, dither):
        """Grey, the whole medium at `channel`: one closure per scatterer, or the dithered one."""
        weights = {n: float(c["scattering_rgb"][channel]) for n, c in self.constituents.items() if n in self.scatter}
        self._apply(lambda n, c: _black() if dither else (c["scattering_rgb"][channel],) * 3, _black,
                    lambda c: (c["absorption_rgb"][channel],) * 3, (1.0, weights, {}) if dither else None)

    def set_rgb_dither(self):
        m = {n: max(c["scattering_rgb"]) for n, c in self.constituents.items() if n in self.scatter}
        colours = {n: tuple(v / m[n] for v in self.constituents[n]["scattering_rgb"]) for n in m}
        self._apply(_black, _black, lambda c: c["absorption_rgb"], (1.0, m, colours))


def _black(*_):
    return (0.0, 0.0, 0.0)


class Dither:
    """One Volume Scatter standing for several scatterers (Closures): density gain · Σ_j w_j ρ_j;
    where u · Σ w ρ (u = White Noise of the position) falls in scatterer j's share, anisotropy
    g_j and colour k_j. set(gain, {name: w_j}, {name: k_j}); colours not given are white."""

    def __init__(self, nodes, scatterers):
        self.weights, self.colours = {}, {}
        d = []
        for c, rho in scatterers:
            w = nodes.n.new("ShaderNodeMath")
            w.operation = "MULTIPLY"
            nodes.l.new(rho, w.inputs[0])
            w.inputs[1].default_value = 0.0
            self.weights[c["name"]] = w
            d.append(w.outputs[0])
            self.colours[c["name"]] = nodes.n.new("ShaderNodeRGB")
        total = d[0]
        for x in d[1:]:
            total = nodes.math("ADD", total, x)
        noise = nodes.n.new("ShaderNodeTexWhiteNoise")
        noise.noise_dimensions = "3D"
        nodes.l.new(nodes.n.new("ShaderNodeNewGeometry").outputs["Position"], noise.inputs["Vector"])
        u_total = nodes.math("MULTIPLY", noise.outputs["Value"], total)
        g = float(scatterers[0][0]["g_hg"])  # a constant until the first choice below adds to it
        colour = self.colours[scatterers[0][0]["name"]].outputs[0]
        cum = d[0]
        for j in range(1, len(scatterers)):
            chosen = nodes.math("GREATER_THAN", u_total, cum)  # scatterer j or a later one
            step = float(scatterers[j][0]["g_hg"]) - float(scatterers[j - 1][0]["g_hg"])
            g = nodes.math("ADD", g, nodes.math("MULTIPLY", chosen, step))
            mix = nodes.n.new("ShaderNodeMixRGB")
            mix.blend_type = "MIX"
            nodes.l.new(chosen, mix.inputs["Fac"])
            nodes.l.new(colour, mix.inputs["Color1"])
            nodes.l.new(self.colours[scatterers[j][0]["name"]].outputs[0], mix.inputs["Color2"])
            colour = mix.outputs["Color"]
            cum = nodes.math("ADD", cum, d[j])
        self.gain = nodes.n.new("ShaderNodeMath")
        self.gain.operation = "MULTIPLY"
        nodes.l.new(total, self.gain.inputs[0])
        self.scatter = nodes.n.new("ShaderNodeVolumeScatter")
        nodes.l.new(colour, self.scatter.inputs["Color"])
        nodes.l.new(self.gain.outputs[0], self.scatter.inputs["Density"])
        if isinstance(g, float):  # a single scatterer
            self.scatter.inputs["Anisotropy"].default_value = g
        else:
            nodes.l.new(g, self.scatter.inputs["Anisotropy"])
        self.set(0.0, {}, {})

    def set(self, gain, weights, colours):
        self.gain.inputs[1].default_value = float(gain)
        for name, node in self.weights.items():
            node.inputs[1].default_value = float(weights.get(name, 0.0))
        for name, node in self.colours.items():
            node.outputs[0].default_value = tuple(colours.get(name, (1.0, 1.0, 1.0))) + (1.0,)


def volume_closures(nodes, constituent, density, closures):
    out = []
    name = constituent["name"]
    closures.constituents[name] = constituent
    s = constituent["scattering_rgb"]
    a = constituent["absorption_rgb"]
    if max(s) > 0.0:
        sc = nodes.n.new("ShaderNodeVolumeScatter")
        nodes.l.new(density, sc.inputs["Density"])
        sc.inputs["Anisotropy"].default_value = float(constituent["g_hg"])
        closures.scatter[name] = sc
        out.append(sc.outputs[0])
        k = max(s)
        x = nodes.n.new("ShaderNodeVolumeAbsorption")
        nodes.l.new(nodes.math("MULTIPLY", density, k), x.inputs["Density"])
        closures.stand_in[name] = (x, k)
        out.append(x.outputs[0])
    if max(a) > 0.0:
        k = max(a)
        ab = nodes.n.new("ShaderNodeVolumeAbsorption")
        nodes.l.new(nodes.math("MULTIPLY", density, k), ab.inputs["Density"])
        closures.absorb[name] = (ab, k)
        out.append(ab.outputs[0])
    return out


def needs_dither(job, path):
    """Whether a mode of `path` renders the dithered Volume Scatter: its nodes would cost shader
    time at every ray-marching step of the other renders too."""
    if path == "analytic_volume_ms":
        return "dither" in job["multiple"]["modes"]
    return "rgb_dither" in job.get("volume_modes", [])


def volume_material(name, job, density_of, dither):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    nodes = Nodes(nt)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    shaders = []
    closures = Closures()
    scatterers = []
    for c in job["constituents"]:
        rho = density_of(nodes, c)
        shaders += volume_closures(nodes, c, rho, closures)
        if max(c["scattering_rgb"]) > 0.0:
            scatterers.append((c, rho))
    if not shaders:
        raise RuntimeError("no constituent scatters or absorbs: nothing to render")
    if dither and scatterers:
        closures.dither = Dither(nodes, scatterers)
        shaders.append(closures.dither.scatter.outputs[0])
    closures.set_rgb()
    acc = shaders[0]
    for sh in shaders[1:]:
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(acc, add.inputs[0])
        nt.links.new(sh, add.inputs[1])
        acc = add.outputs[0]
    nt.links.new(acc, out.inputs["Volume"])
    mat.cycles.homogeneous_volume = False
    set_enum(mat.cycles, "volume_interpolation", "LINEAR")
    set_enum(mat.cycles, "volume_sampling", "DISTANCE")
    CLOSURES[mat.name] = closures
    return mat


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


def make_analytic_volume(scene, job, path):
    planet = job["planet"]
    R, top = float(planet["radius"]), float(planet["top"])
    top_alt = top - R
    margin = float(job["volume"].get("domain_margin_km", 5.0))
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=5, radius=top + margin, location=tuple(planet["center"]))
    obj = bpy.context.object
    obj.name = "AirmassAtmosphere"

    def density_of(nodes, c):
        h = altitude_socket(nodes, planet["center"], R)
        return profile_socket(nodes, h, c["profile"], top_alt)

    mat = volume_material("AirmassAtmosphereAnalytic", job, density_of, needs_dither(job, path))
    obj.data.materials.append(mat)
    base = 0.1 * 2.0 * (top + margin)  # 0.1 × mean bounding-box size
    step = set_step(scene, mat, base, float(job["volume"]["step_km"]), job["volume"]["max_steps"])
    return obj, {"step_km": step, "base_step_km": base, "domain_radius_km": top + margin}


def make_vdb_volume(scene, job):
    vdb = job["vdb"]
    files = vdb["files"]
    vs = float(vdb["voxel_size"])
    objs = []
    half_voxel = bpy.app.version < (5, 0, 0) and vdb.get("half_voxel_correction", True)

    def density_of(nodes, c):
        attr = nodes.n.new("ShaderNodeAttribute")
        attr.attribute_type = "GEOMETRY"
        attr.attribute_name = c["name"]
        return attr.outputs["Fac"]

    mat = volume_material("AirmassAtmosphereVDB", job, density_of, needs_dither(job, "vdb_volume"))
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
        vol.materials.append(mat)
        vol.grids.load()
        names = [g.name for g in vol.grids]
        missing = [c["name"] for c in job["constituents"] if c["name"] not in names]
        if missing:
            raise RuntimeError("%s: grids %s missing (has %s)" % (f, missing, names))
        objs.append(obj)
    step = set_step(scene, mat, vs, float(job["volume"].get("vdb_step_km", vs)), job["volume"]["max_steps"])
    return objs, {"step_km": step, "voxel_size_km": vs, "half_voxel_correction": bool(half_voxel)}


def try_addon(job, path):
    """The add-on's builders, when it is importable and offers them; else None and why."""
    addon_dir = job.get("addon_dir")
    if not addon_dir or job.get("use_addon", "auto") == "never":
        return None, "add-on use disabled by the job"
    if addon_dir not in sys.path:
        sys.path.insert(0, addon_dir)
    try:
        import airmass_blender  # noqa: F401
    except Exception as e:  # noqa: BLE001
        return None, "add-on package airmass_blender not importable from %s (%s)" % (addon_dir, e)
    try:
        from airmass_blender import compare as hook
    except Exception as e:  # noqa: BLE001
        return None, "airmass_blender.compare not importable (%s)" % e
    builder = getattr(hook, "build_volume_for_compare", None)
    if builder is None:
        return None, "airmass_blender.compare has no build_volume_for_compare(scene, job, path)"
    return builder, "add-on builder airmass_blender.compare.build_volume_for_compare"


# ---- main --------------------------------------------------------------------------------------------

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
    closures = list(CLOSURES.values())
    sun = sun_obj.data
    e = job["sun"]["irradiance_rgb"]
    scatterers = sorted({n for c in closures for n in c.scatterers()})
    if path == "analytic_volume_ms":
        # Multiple scattering: per channel c one grey render of the whole medium at c, white
        # lamp of E_c, the ground lit (it reflects sun- and skylight back into the medium).
        set_ground_lit(True)
        sun.color = (1.0, 1.0, 1.0)
        for mode in job["multiple"].get("modes", ["dither", "closures"]):
            times[mode] = []
            for k in range(seeds):
                scene.cycles.seed = base + k
                t = 0.0
                for ch in range(3):
                    for c in closures:
                        c.set_ms(ch, mode == "dither")
                    sun.energy = float(e[ch])
                    sun_obj.hide_render = sun.energy <= 0.0
                    t += render_to(scene, out_dir, "blender_%s_%s_seed%d_c%d.exr" % (path, mode, k, ch))
                times[mode].append(t)
        return times
    for mode in job.get("volume_modes", ["split", "rgb"]):
        times[mode] = []
        for k in range(seeds):
            scene.cycles.seed = base + k
            if mode in ("rgb", "rgb_dither"):
                for c in closures:
                    if mode == "rgb":
                        c.set_rgb()
                    else:
                        c.set_rgb_dither()
                set_ground_lit(True)
                sun.color = tuple(job["sun"]["color"])
                sun.energy = float(job["sun"]["strength"])
                sun_obj.hide_render = sun.energy <= 0.0
                times[mode].append(render_to(scene, out_dir, "blender_%s_%s_seed%d.exr" % (path, mode, k)))
            else:
                t = 0.0
                for ch in range(3):
                    for i, name in enumerate(scatterers):
                        for c in closures:
                            c.set_split(ch, name)
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
    if len(argv) != 2 or argv[1] not in PATHS:
        raise SystemExit("usage: blender -b --python blender_render.py -- JOB.json {%s}" % "|".join(PATHS))
    job_path, path = argv
    with open(job_path) as f:
        job = json.load(f)
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
        builder, why = try_addon(job, path)
        used_addon = False
        if builder is not None:
            try:
                info["build"]["volume"] = builder(scene, job, path)
                used_addon = True
            except Exception as e:  # noqa: BLE001
                why = "add-on builder failed: %s" % e
                info["notes"].append(why)
        if used_addon and not CLOSURES:
            if path == "analytic_volume_ms":
                raise RuntimeError("the add-on's material exposes no closures: the grey per-channel renders of "
                                   "multiple scattering cannot be made")
            info["notes"].append("the add-on's material exposes no closures: only the rgb mode is rendered")
            job["volume_modes"] = ["rgb"]
        if not used_addon:
            info["notes"].append("volume built by compare/blender_render.py itself (%s)" % why)
            if path in ("analytic_volume", "analytic_volume_ms"):
                _, b = make_analytic_volume(scene, job, path)
            else:
                _, b = make_vdb_volume(scene, job)
            info["build"]["volume"] = b
        info["build"]["used_addon"] = used_addon
    info["build_seconds"] = time.perf_counter() - t_start
    info["render_seconds"] = render_seeds(scene, job, path, out_dir, sun_obj)
    info["modes"] = list(info["render_seconds"].keys())
    info["scatterers"] = sorted({n for c in CLOSURES.values() for n in c.scatterers()})
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
