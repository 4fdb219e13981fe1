"""Create Atmosphere Volume: the atmosphere as a Cycles volume, analytic or voxels.

Frame (both modes). 1 Blender unit = 1 km by default ("m" possible for small scenes).
The world origin is the point on the ground below the observer, Z up; the planet centre
is at (0, 0, −R). This is the scene frame of the library (scene.hpp) and of vdb_export's
`origin = surface` layout, so the sky texture, the Sun lamp and both volumes agree.

ANALYTIC — a shell domain mesh (outer sphere just outside the atmosphere top, inner
sphere just inside the ground, normals inward) whose material computes each
constituent's density exactly from the shading point, with Math nodes only:

    w  = Texture Coordinate "Object"     (the object sits at the origin: w = world point)
    q  = w·w − 2 w·c + (c·c − R²)        (= r² − R², no large radii subtracted)
    h  = q / (sqrt(q + R²) + R)          (altitude = r − R without cancellation)
    ρ  = profile(h) · [0 ≤ h ≤ h_top]    exponential: exp(−(h − h_ref)/H)
                                          tent: max(0, min((h−b)/(p−b), (t−h)/(t−p)))
                                          piecewise linear: Σ pieces × [h_k ≤ h < h_k+1]
                                          constant: v · [b ≤ h < t]

VDB — the library plans and samples the grids of the region the active camera needs (or
the whole planet); vdb_host writes them with this Blender's own OpenVDB module (`openvdb`
from 4.4, `pyopenvdb` before); each file becomes a Volume object (render clipping 0, FULL
precision), its material reads each grid by name with an Attribute node.

Material (both; built by material.py, which `airmass compare` renders too): per constituent, Volume Scatter with Colour = σs/max(σs) and Density =
ρ·max(σs) (σs per Blender unit at density 1, RGB), and Volume Absorption with Colour =
1 − σa/max(σa) and Density = ρ·max(σa): Cycles computes σs = Colour × Density and
σa = (1 − Colour) × Density, so both are exact per channel and every colour stays in
[0, 1]. Cycles drops a scatter closure whose mean σs is below 1e-5 per unit (absorption
has no cut-off); in km that happens only where the density is negligible, and the
operator reports the altitude and the optical depth lost when it matters. Phase: on
Blender 3.4–4.2 Henyey–Greenstein with the phase function's mean cosine (Rayleigh and
isotropic 0, Cornette–Shanks 3g(4+g²)/(5(2+g²)), HG g); on ≥ 4.3 the Rayleigh phase for
Rayleigh constituents and Draine with α = 1 (which is exactly Cornette–Shanks).
"""

import math
import os

import bpy
from mathutils import Vector

from . import compat, material, native, vdb_host
from .jobs import Plan
from .properties import KM, SettingsError, make_spec, resolve_output_folder

ROLE = "airmass_role"
COLLECTION_NAME = "Airmass"
VOLUME_NAME = "Airmass Atmosphere"
GROUND_NAME = "Airmass Ground"
CLOSURE_WEIGHT_CUTOFF = 1e-5  # cycles/kernel/svm/types.h

# UV-sphere resolution of the domain and the ground.
SPHERE_SEGMENTS = 256
SPHERE_RINGS = 128


def units(settings):
    return {"KM": ("km", KM), "M": ("m", 1.0)}[settings.length_unit]


# ---- the material: material.py (shared with compare/blender_render.py) ----------------------

def build_material(name, constituents, density_for, phase_mixing="DITHER", sun=None):
    """material.build_material, its MaterialError as the add-on's SettingsError."""
    try:
        return material.build_material(name, constituents, density_for, phase_mixing=phase_mixing, sun=sun)
    except material.MaterialError as e:
        raise SettingsError(str(e))


# ---- Analytic Sun lighting: the sun's columns and the sun -------------------------------------

SUN_COLUMNS_NAME = "Airmass Sun Columns"
SUN_MS_NAME = "Airmass Sun Multiple Scattering"
# Texels of the columns' table (Bruneton 2017 uses 256 × 64 for the transmittance); the error of
# this and other sizes against quadrature: bench/analytic_sun_trade.sh, docs/addon.md.
SUN_COLUMNS_MU, SUN_COLUMNS_R = 256, 64


# Texels of Hillaire's isotropic multiple-scattering table Ψ(μs, altitude): it is smooth (the
# library's own table is 24 sun × 12 altitude nodes); error: bench/analytic_sun_trade.sh.
SUN_MS_MU, SUN_MS_R = 64, 32
SUN_TABLE_ROLES = ("sun columns", "sun multiple scattering")


def sun_columns_name(index):
    """The name of the columns' image `index` (constituents 3·index … 3·index + 2): "Airmass Sun
    Columns", then "Airmass Sun Columns 2", 3, … — one name each, not Blender's ".001" suffixes."""
    return SUN_COLUMNS_NAME if index == 0 else "%s %d" % (SUN_COLUMNS_NAME, index + 1)


def sun_choice(settings):
    """The Analytic Sun's settings, read on the main thread when the operator starts (the job's
    work() must not touch bpy): None for Volume Scatter, else {"multiple", "chapman"}."""
    if settings.volume_lighting != "SUN_EMISSION":
        return None
    return {"multiple": bool(settings.volume_multiple), "chapman": settings.chapman}


def sun_inputs(choice, spec, description, unit_name):
    """What the Analytic Sun needs from the library (no bpy; runs in the job): the columns'
    table [r, mu, constituent] and, with Multiple Scattering, (Ψ [r, mu, rgb], mu_s_min)."""
    table = native.sun_column_table(spec, len(description["constituents"]), mu_size=SUN_COLUMNS_MU,
                                    r_size=SUN_COLUMNS_R, unit=unit_name)
    ms = native.sun_ms_table(spec, mu_size=SUN_MS_MU, r_size=SUN_MS_R, unit=unit_name) \
        if choice["multiple"] else None
    return table, ms


def _data_image(name, role, rgb, created, properties=None):
    """A packed 32-bit float image of rgb [rows, columns, 3] (bottom row first), Non-Color data,
    made through Blender's image API (compat.packed_float_image), registered in `created` to take
    the name `name` once the previous run's images are gone (_swap_in)."""
    import numpy as np
    n_r, n_mu, _ = rgb.shape
    px = np.ones((n_r, n_mu, 4), dtype=np.float32)
    px[..., :3] = rgb
    # The table holds masses in km (up to hundreds): an 8-bit packing would clamp them to 1, which
    # packed_float_image's check of pixel 0 after packing catches.
    props = {ROLE: role}
    props.update(properties or {})
    return created.add(compat.packed_float_image(name, n_mu, n_r, px.ravel(), colorspace=compat.DATA_COLORSPACE,
                                                 properties=props, check_value=True), name=name)


def sun_lighting(description, light, table, created, ms=None):
    """material.SunLighting for the current sun `light` (native.sun_light) and the tables of
    sun_inputs as packed float images (three constituents per image, Non-Color data)."""
    import numpy as np
    names = [c["name"] for c in description["constituents"]]
    n_r, n_mu, _ = table.shape
    images, channel = [], {}
    for first in range(0, len(names), 3):
        group = names[first:first + 3]
        rgb = np.zeros((n_r, n_mu, 3), dtype=np.float32)
        for ch, name in enumerate(group):
            rgb[..., ch] = table[:, :, first + ch]
            channel[name] = (len(images), ch)
        images.append(_data_image(sun_columns_name(len(images)), SUN_TABLE_ROLES[0], rgb, created,
                                  {"airmass_constituents": ",".join(group)}))
    ms_image = _data_image(SUN_MS_NAME, SUN_TABLE_ROLES[1], ms[0], created) if ms is not None else None
    return material.SunLighting(
        direction=light["direction"], irradiance_rgb=light["irradiance_top_rgb"],
        angular_radius=0.5 * math.radians(light["angular_diameter_deg"]), images=images, channel=channel,
        center=description["planet_center"], radius=description["planet_radius"],
        top=description["atmosphere_top"],
        extinction={c["name"]: [float(a) + float(b) for a, b in zip(c["scattering_rgb"], c["absorption_rgb"])]
                    for c in description["constituents"]},
        ms_image=ms_image, ms_mu_s_min=ms[1] if ms is not None else -1.0)


def current_sun(context, choice):
    """native.sun_light of the panel's sun now (main thread)."""
    return native.sun_light(make_spec(context.scene.airmass), chapman=choice["chapman"])


def set_material_sun(mat, light):
    """Points an Analytic Sun material at `light` (native.sun_light): Sun Sync calls it for every
    Airmass atmosphere material after moving the sun. False when `mat` has no sun emission."""
    nodes = mat.node_tree.nodes if mat is not None and mat.node_tree is not None else None
    if nodes is None or nodes.get("sun direction") is None:
        return False
    sun_vec = nodes["sun direction"]
    for i in range(3):
        sun_vec.inputs[i].default_value = float(light["direction"][i])
    r_mu = nodes.get("sun r mu")
    if r_mu is not None:
        centre = mat.get("airmass_planet_center", (0.0, 0.0, 0.0))
        r_mu.inputs[1].default_value = sum(float(centre[i]) * float(light["direction"][i]) for i in range(3))
    irradiance = compat.convert_rgb(light["irradiance_top_rgb"])
    for ch in range(3):
        node = nodes.get("sun irradiance %d" % ch)
        if node is not None:
            node.inputs[1].default_value = max(0.0, float(irradiance[ch]))
    return True


def cutoff_notes(constituents, top_altitude, unit_name):
    """Where Cycles' 1e-5 cut-off drops a constituent's scattering, when it matters."""
    notes = []
    for c in constituents:
        mean_s = sum(float(x) for x in c["scattering_rgb"]) / 3.0
        prof = c.get("profile", {})
        if mean_s <= 0.0 or prof.get("type") != "exponential":
            continue
        H = float(prof["scale_height"])
        h0 = float(prof.get("reference_altitude", 0.0))
        if mean_s < CLOSURE_WEIGHT_CUTOFF:
            notes.append("%s scattering (%.3g/%s) is below Cycles' 1e-5 cut-off everywhere: use km units"
                         % (c["name"], mean_s, unit_name))
            continue
        h_cut = h0 + H * math.log(mean_s / CLOSURE_WEIGHT_CUTOFF)
        lost = CLOSURE_WEIGHT_CUTOFF * H  # vertical optical depth above h_cut
        if h_cut < top_altitude and lost > 1e-3:
            notes.append("%s scattering is dropped by Cycles above %.3g %s (vertical optical depth %.2g lost)"
                         % (c["name"], h_cut, unit_name, lost))
    return notes


# ---- meshes -----------------------------------------------------------------------------
#
# Built with numpy and Mesh.from_pydata (bmesh's UV sphere takes seconds at this size).
# A "cap" is the part of a sphere within polar angle theta_max of an axis; theta_max = π
# is the whole sphere. Vertex rings are at θ_i = theta_max·i/rings around the axis; faces
# are ordered so normals point out of the sphere (reversed for the inner boundary).

def _axis_frame(axis):
    """Rotation (3×3, columns) taking +Z to `axis`."""
    import numpy as np
    z = np.asarray(axis, dtype=float)
    z = z / np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


def _cap(radius, theta_max, segments, rings):
    """Vertices (N×3, around +Z, unit frame) and faces (lists) of a sphere cap, normals out."""
    import numpy as np
    full = theta_max >= math.pi * (1.0 - 1e-12)
    n_rings = rings - 1 if full else rings
    theta = theta_max * np.arange(1, n_rings + 1) / rings
    phi = 2.0 * math.pi * np.arange(segments) / segments
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    ring = np.stack([st * np.cos(phi)[None, :], st * np.sin(phi)[None, :], np.broadcast_to(ct, (n_rings, segments))],
                    axis=-1).reshape(-1, 3)
    verts = [np.array([[0.0, 0.0, 1.0]]), ring]
    idx = lambda i, j: 1 + i * segments + (j % segments)  # noqa: E731
    faces = [(0, idx(0, j), idx(0, j + 1)) for j in range(segments)]
    for i in range(n_rings - 1):
        faces += [(idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)) for j in range(segments)]
    rim = [idx(n_rings - 1, j) for j in range(segments)]
    if full:
        bottom = 1 + n_rings * segments
        verts.append(np.array([[0.0, 0.0, -1.0]]))
        faces += [(idx(n_rings - 1, j + 1), idx(n_rings - 1, j), bottom) for j in range(segments)]
        rim = None
    return np.concatenate(verts) * radius, faces, rim


def shell_geometry(center, axis, r_inner, r_outer, theta_max, segments=None, rings=None):
    """A closed shell between two spheres (or caps of them, joined by a wall): vertices
    (N×3, world) and faces with normals pointing out of the shell."""
    import numpy as np
    segments = segments or SPHERE_SEGMENTS
    rings = rings or SPHERE_RINGS
    outer_v, outer_f, outer_rim = _cap(r_outer, theta_max, segments, rings)
    inner_v, inner_f, inner_rim = _cap(r_inner, theta_max, segments, rings)
    n = len(outer_v)
    faces = list(outer_f) + [tuple(reversed([v + n for v in f])) for f in inner_f]
    if outer_rim is not None:
        m = len(outer_rim)
        faces += [(inner_rim[j] + n, inner_rim[(j + 1) % m] + n, outer_rim[(j + 1) % m], outer_rim[j])
                  for j in range(m)]
    verts = np.concatenate([outer_v, inner_v]) @ _axis_frame(axis).T + np.asarray(center, dtype=float)
    return verts, faces


def sphere_geometry(center, axis, radius, theta_max):
    """An open cap (or the whole sphere) of `radius`, normals out."""
    import numpy as np
    v, f, _rim = _cap(radius, theta_max, SPHERE_SEGMENTS, SPHERE_RINGS)
    return v @ _axis_frame(axis).T + np.asarray(center, dtype=float), f


def _circumscribe(radius, theta_max=math.pi):
    """Radius of a UV cap whose faces all lie outside the true sphere of `radius`."""
    half = math.hypot(math.pi / SPHERE_SEGMENTS, theta_max / (2 * SPHERE_RINGS))
    return radius / math.cos(half) * (1.0 + 1e-6)


def mesh_from(name, verts, faces, smooth=False):
    mesh = bpy.data.meshes.new(name)
    try:
        mesh.from_pydata(verts.tolist(), [], faces)
        mesh.validate(verbose=False)
        if smooth:
            try:
                mesh.polygons.foreach_set("use_smooth", [True] * len(mesh.polygons))
            except (AttributeError, TypeError):
                pass
        mesh.update()
    except Exception:
        bpy.data.meshes.remove(mesh)
        raise
    return mesh


def view_cap(context, settings, description, unit_m):
    """(axis, theta_max) of the region to model: around the active camera's sub-point, wide
    enough for every point within the view distance; the whole planet otherwise."""
    if settings.volume_region != "VIEW":
        return (0.0, 0.0, 1.0), math.pi
    cam = context.scene.camera
    if cam is None:
        raise SettingsError("Region 'Camera View' needs an active camera in the scene")
    center = Vector(description["planet_center"])
    R = float(description["planet_radius"])
    offset = cam.matrix_world.translation - center
    if offset.length < 1e-9:
        raise SettingsError("the camera is at the planet's centre")
    d = settings.view_distance * KM / unit_m
    theta = min(math.pi, 1.05 * d / R + 1e-3)
    return tuple(offset.normalized()), theta


def ground_material(albedo):
    mat = bpy.data.materials.new(GROUND_NAME)
    tree = compat.ensure_node_tree(mat)
    bsdf = tree.nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (albedo, albedo, albedo, 1.0)  # grey: the same in every working space
    out = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"), None)
    if out is None:  # 5.0: a new material's tree may come without an output
        out = tree.nodes.new("ShaderNodeOutputMaterial")
    for n in list(mat.node_tree.nodes):
        if n not in (bsdf, out):
            mat.node_tree.nodes.remove(n)
    mat.node_tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    mat[ROLE] = "ground"
    return mat


# ---- building, swapping, cleaning up ---------------------------------------------------------

class Created:
    """Datablocks made by one run, removed together if the run fails."""

    def __init__(self):
        self.items = []
        # (block, name): while the previous run's blocks exist a new one made under the same name
        # is called "name.001"; _swap_in gives it `name` once they are gone.
        self.names = []

    def add(self, block, name=None):
        self.items.append(block)
        if name is not None:
            self.names.append((block, name))
        return block

    def remove_all(self):
        for block in reversed(self.items):
            _remove_block(block)
        self.items.clear()
        self.names.clear()


def _remove_block(block):
    kind = type(block).__name__
    try:
        if kind == "Object":
            bpy.data.objects.remove(block)
        elif kind == "Mesh":
            bpy.data.meshes.remove(block)
        elif kind == "Volume":
            bpy.data.volumes.remove(block)
        elif kind == "Material":
            bpy.data.materials.remove(block)
        elif kind == "Collection":
            bpy.data.collections.remove(block)
        elif kind == "Image":
            bpy.data.images.remove(block)
    except ReferenceError:
        pass


def _old_objects(scene):
    return [o for o in scene.objects if o.get(ROLE) in ("atmosphere", "ground")]


def _remove_old(objects):
    for o in objects:
        data = o.data
        mats = [s.material for s in o.material_slots if s.material is not None]
        bpy.data.objects.remove(o)
        if data is not None and data.users == 0:
            _remove_block(data)
        for m in mats:
            if m.users == 0:
                images = [n.image for n in m.node_tree.nodes if n.bl_idname == "ShaderNodeTexImage"
                          and n.image is not None and n.image.get("airmass_role") in SUN_TABLE_ROLES] \
                    if m.node_tree is not None else []
                bpy.data.materials.remove(m)
                for image in images:
                    if image.users == 0:
                        bpy.data.images.remove(image)


def _collection(scene, created):
    coll = bpy.data.collections.get(COLLECTION_NAME)
    if coll is None:
        coll = created.add(bpy.data.collections.new(COLLECTION_NAME))
    if coll.name not in scene.collection.children:
        scene.collection.children.link(coll)
    return coll


# Cycles counts every crossing of a volume's boundary (a surface with no surface shader) as a
# transparent bounce; a path that runs out of them stops there, so the volume renders dark.
# Measured in Blender 3.4 (24×14 px, 2 spp, seed 1, each against 64 bounces): the analytic shell
# renders exactly with 1 or more from the ground and from orbit and is 99 % dark with 0; a VDB
# view region in 4 overlapping tiles needs 12 (10: 2e-5 off, 6: 3 %, 3: 77 %, 0: black).
# Enough is 2 per closed boundary a ray can cross plus 4: the shell has two spheres (8, Cycles'
# default), a VDB volume one box per tile object (2 n + 4, at most Cycles' 1024).
TRANSPARENT_BOUNCES_KEY = "airmass_transparent_bounces"


def transparent_bounces_needed(boundaries):
    return min(1024, 2 * int(boundaries) + 4)


def _configure_scene(context, settings, description, step, unit_name, boundaries=2):
    """Units, ray marching, transparent bounces and the camera's clip end for a planet-sized
    volume of `boundaries` closed boundary surfaces."""
    scene = context.scene
    notes = []
    if settings.set_units:
        us = scene.unit_settings
        us.system = "METRIC"
        us.scale_length = 1000.0 if unit_name == "km" else 1.0
        us.length_unit = "KILOMETERS" if unit_name == "km" else "METERS"
    R = float(description["planet_radius"])
    top = float(description["atmosphere_top"])
    center = Vector(description["planet_center"])
    chord = 2.0 * math.sqrt(max(0.0, top * top - R * R))  # the longest path through the shell
    needed = int(math.ceil(chord / step)) + 16
    cycles = getattr(scene, "cycles", None)
    if cycles is not None and compat.volume_ray_marching(scene):
        if cycles.volume_max_steps < needed:
            cycles.volume_max_steps = min(65536, needed)
            notes.append("volume max steps %d" % cycles.volume_max_steps)
    elif cycles is not None:
        # Blender 5.0+ without Render → Volumes → Biased: unbiased null scattering; the step
        # rate (still set on the material) and max steps only apply to biased ray marching.
        notes.append("null scattering (unbiased): Step applies with Render > Volumes > Biased")
    if cycles is not None:
        needed_bounces = transparent_bounces_needed(boundaries)
        if cycles.transparent_max_bounces < needed_bounces:
            notes.append("transparent bounces %d -> %d (rays cross the volume's boundaries; fewer render "
                         "it dark)" % (cycles.transparent_max_bounces, needed_bounces))
            cycles.transparent_max_bounces = needed_bounces
    cam = scene.camera
    if cam is not None and cam.type == "CAMERA":
        far = (cam.matrix_world.translation - center).length + top
        if cam.data.clip_end < far * 1.001:
            cam.data.clip_end = far * 1.01
            notes.append("camera clip end %.4g %s" % (cam.data.clip_end, unit_name))
    return notes


def _lamp_update(scene):
    """(lamp, light values) for re-syncing an existing Sun lamp to top-of-atmosphere sunlight
    once a volume exists; computed before anything changes."""
    from . import sun
    lamp = sun.find_lamp(scene)
    if lamp is None:
        return None
    return lamp, sun.lamp_light(scene, top=True)[:3]


def _swap_in(context, settings, new_objects, created):
    """Links the new objects, removes the previous Airmass atmosphere and ground, and gives an
    existing Sun lamp the top-of-atmosphere sunlight (the volume now attenuates it)."""
    scene = context.scene
    lamp = _lamp_update(scene)
    old = _old_objects(scene)
    coll = _collection(scene, created)
    for o in new_objects:
        coll.objects.link(o)
    renames = list(created.names)
    created.items.clear()  # from here on they belong to the scene
    created.names.clear()
    _remove_old(old)
    # Canonical names once the previous ones are gone.
    for block, name in renames:
        block.name = name
    for o in new_objects:
        base = VOLUME_NAME if o.get(ROLE) == "atmosphere" else GROUND_NAME
        if len([x for x in new_objects if x.get(ROLE) == o.get(ROLE)]) == 1:
            o.name = base
            if o.data is not None:
                o.data.name = base
    if lamp is not None:
        from . import sun
        sun.apply_light(lamp[0], *lamp[1])


def _ground(description, albedo, created, axis=(0.0, 0.0, 1.0), theta=math.pi):
    R = float(description["planet_radius"])
    center = tuple(description["planet_center"])
    verts, faces = sphere_geometry(center, axis, R, min(math.pi, theta * 1.02))
    mesh = created.add(mesh_from(GROUND_NAME, verts, faces, smooth=True))
    mat = created.add(ground_material(albedo))
    mesh.materials.append(mat)
    obj = created.add(bpy.data.objects.new(GROUND_NAME, mesh))
    obj[ROLE] = "ground"
    return obj


# ---- the two modes ---------------------------------------------------------------------------

class AnalyticPlan(Plan):
    label = "Create Atmosphere Volume (analytic)"

    def __init__(self, context):
        s = context.scene.airmass
        self.settings = s
        self.unit_name, self.unit_m = units(s)
        self.spec = make_spec(s)
        native.validate_scene(self.spec)  # fail before any work, with the field's name
        if s.volume_region == "VIEW" and (context.scene.camera is None or context.scene.camera.type != "CAMERA"):
            raise SettingsError("Region 'Camera View' needs an active camera in the scene")
        self.albedo = None
        self.summary = None
        self.sun_choice = sun_choice(s)

    def work(self, progress):
        scene = native.validate_scene(self.spec)
        self.albedo = float(scene["planet"]["ground_albedo"])
        description = native.analytic_density(self.spec, unit=self.unit_name)
        sun = sun_inputs(self.sun_choice, self.spec, description, self.unit_name) if self.sun_choice else None
        return description, sun

    def finish(self, context, result):
        description, sun = result
        s = self.settings
        created = Created()
        try:
            R = float(description["planet_radius"])
            top = float(description["atmosphere_top"])
            top_alt = top - R
            center = tuple(float(x) for x in description["planet_center"])
            constituents = description["constituents"]

            density_for = material.analytic_density(center, R, top_alt, constituents)
            # The sun as it is now (it may have moved while the job ran).
            lighting = sun_lighting(description, current_sun(context, self.sun_choice), sun[0], created, sun[1]) \
                if sun is not None else None
            mat = created.add(build_material(VOLUME_NAME, constituents, density_for, phase_mixing=s.phase_mixing,
                                             sun=lighting))
            mat[ROLE] = "atmosphere"
            mat["airmass_lighting"] = "SUN_EMISSION" if lighting is not None else "SCATTER"
            mat["airmass_planet_center"] = list(center)
            axis, theta = view_cap(context, s, description, self.unit_m)
            verts, faces = shell_geometry(center, axis, R * (1.0 - 1e-4), _circumscribe(top, theta), theta)
            # Cycles marches procedural volumes in steps of 0.1 × the object's mean bounding-box
            # size × the material's step rate (min 0.001): choose the rate for the wanted step.
            size = float((verts.max(axis=0) - verts.min(axis=0)).mean())
            step_bu = s.step_km * KM / self.unit_m
            rate = step_bu / (0.1 * size)
            mat.cycles.volume_step_rate = min(1000.0, max(0.001, rate))
            step = 0.1 * size * mat.cycles.volume_step_rate
            mesh = created.add(mesh_from(VOLUME_NAME, verts, faces))
            mesh.materials.append(mat)
            obj = created.add(bpy.data.objects.new(VOLUME_NAME, mesh))
            obj[ROLE] = "atmosphere"
            obj["airmass_mode"] = "ANALYTIC"
            obj[TRANSPARENT_BOUNCES_KEY] = transparent_bounces_needed(2)
            obj.display_type = "WIRE"
            new = [obj]
            if s.add_ground:
                new.append(_ground(description, self.albedo, created, axis, theta))
            notes = _configure_scene(context, s, description, step, self.unit_name)
            _swap_in(context, s, new, created)
        except Exception:
            created.remove_all()
            raise
        if self.sun_choice is None:  # Volume Scatter: Cycles' closure cut-off applies to it
            notes += cutoff_notes(constituents, top_alt, self.unit_name)
        self.summary = "Airmass analytic atmosphere: %d constituents, step %.3g %s%s" % (
            len(constituents), step, self.unit_name, ("; " + "; ".join(notes)) if notes else "")


def camera_spec(context, unit_m, max_distance_m):
    """The active camera for the VDB view region, in the library's frame (metres)."""
    scene = context.scene
    cam = scene.camera
    if cam is None or cam.type != "CAMERA":
        raise SettingsError("Region 'Camera View' needs an active camera in the scene")
    if cam.data.type != "PERSP":
        raise SettingsError("Region 'Camera View' needs a perspective camera ('%s' is %s)"
                            % (cam.name, cam.data.type.lower()))
    m = cam.matrix_world
    rot = m.to_3x3().normalized()
    position = m.translation * unit_m
    direction = rot @ Vector((0.0, 0.0, -1.0))
    up = rot @ Vector((0.0, 1.0, 0.0))
    frame = cam.data.view_frame(scene=scene)  # corners at depth −z, shift and sensor fit included
    depth = abs(frame[0].z)
    # The library's fov_deg spans the larger image side (Blender's sensor fit AUTO), so a
    # portrait camera gives its vertical angle.
    half = max(max(abs(v.x) for v in frame), max(abs(v.y) for v in frame))
    fov_deg = math.degrees(2.0 * math.atan(half / depth))
    r = scene.render
    width = max(1, int(r.resolution_x * r.resolution_percentage / 100))
    height = max(1, int(r.resolution_y * r.resolution_percentage / 100))
    return {"position_m": tuple(position), "direction": tuple(direction), "up": tuple(up), "fov_deg": fov_deg,
            "max_distance_m": max_distance_m, "width": width, "height": height}


def read_grid_metadata(path):
    """{grid name: metadata dict} from a .vdb via pyopenvdb/openvdb, or None if neither imports."""
    module = None
    for name in ("openvdb", "pyopenvdb"):
        try:
            module = __import__(name)
            break
        except ImportError:
            continue
    if module is None:
        return None
    out = {}
    for grid in module.readAllGridMetadata(path):
        meta = dict(grid.metadata)
        out[grid.name] = meta
    return out


# vdb_export names its options as the CLI spells them; in Blender the panel's names mean more.
_UI_OPTION_NAMES = (("--voxel-size", "Voxel Size"), ("--voxel-values", "Voxel Values"), ("--max-dense-mb", "Memory Limit (MiB)"),
                    ("--max-memory-mb", "the grid memory limit"), ("--region view", "Region: Camera View"),
                    ("--region box", "a box region"), ("--region", "Region"), ("--units", "Length Unit"),
                    ("--tolerance", "tolerance"))


def ui_option_names(message):
    for cli, ui in _UI_OPTION_NAMES:
        message = message.replace(cli, ui)
    return message


class VdbPlan(Plan):
    """The VDB volume: the library plans and samples the grids (no OpenVDB in it), vdb_host
    writes them with this Blender's own OpenVDB module (atomically, block by block with
    progress and Esc), and each .vdb becomes a Volume object."""

    label = "Create Atmosphere Volume (VDB)"

    def __init__(self, context):
        s = context.scene.airmass
        self.settings = s
        reason = vdb_host.unavailable_reason()
        if reason:
            raise SettingsError(reason)
        self.unit_name, self.unit_m = units(s)
        self.spec = make_spec(s)
        self.region = "view" if s.volume_region == "VIEW" else "planet"
        if self.region == "view":
            self.spec.camera = camera_spec(context, self.unit_m, s.view_distance * KM)
        native.validate_scene(self.spec)
        self.folder = resolve_output_folder(s)
        self.stem = "%s_atmosphere" % bpy.path.clean_name(context.scene.name)
        self.path = os.path.join(self.folder, self.stem + ".vdb")
        self.voxel = s.voxel_size * KM / self.unit_m if s.voxel_size > 0 else None
        self.max_dense_mb = s.max_dense_mb
        self.voxel_values = s.voxel_values.lower()  # AUTO/AVERAGE/POINT -> the library's names
        self.files = []
        self.sun_choice = sun_choice(s)
        self.sun = None  # (columns' table, multiple-scattering table) for the Analytic Sun
        self.written = None  # vdb_host.Written once the files are in place
        self.summary = None

    def options(self):
        return {"region": self.region, "unit": self.unit_name, "voxel_size": self.voxel,
                "max_dense_mb": self.max_dense_mb, "voxel_values": self.voxel_values}

    def work(self, progress):
        scene = native.validate_scene(self.spec)
        albedo = float(scene["planet"]["ground_albedo"])
        description = native.analytic_density(self.spec, unit=self.unit_name)
        self.sun = sun_inputs(self.sun_choice, self.spec, description, self.unit_name) if self.sun_choice else None
        try:
            written = vdb_host.write_volume(self.spec, self.folder, self.stem, progress=progress, **self.options())
            self.written = written
        except vdb_host.NoOpenVdbModule as e:
            raise SettingsError(str(e))
        except native.NativeError as e:
            raise native.NativeError(e.status, ui_option_names(str(e)))
        self.files = list(written.files)
        return written, description, albedo

    def abort(self):
        # vdb_host writes atomically; a failure after it wrote (in Blender) puts the previous
        # files back (the previous volume objects still point at them), or removes the new ones.
        if self.written is not None:
            self.written.restore()
        self.written = None
        self.files = []

    def finish(self, context, result):
        written, description, albedo = result
        plan = written.plan
        s = self.settings
        created = Created()
        try:
            voxel = float(plan["voxel_size"])
            volumes = []
            for i, f in enumerate(written.vdb_files):
                vol = created.add(bpy.data.volumes.new("%s %d" % (VOLUME_NAME, i)))
                vol.filepath = f
                vol.render.clipping = 0.0
                vol.render.precision = "FULL"
                vol.render.space = "WORLD"
                vol.render.step_size = max(1e-6, s.step_km * KM / self.unit_m)
                if not vol.grids.load():
                    raise RuntimeError("Blender cannot read '%s': %s" % (f, vol.grids.error_message))
                volumes.append(vol)
            # The grids carry the plan's metadata: take the coefficients from it directly.
            metadata = {g["name"]: vdb_host.metadata_of(g) for g in plan["grids"]}
            grid_names = sorted({g.name for v in volumes for g in v.grids})
            constituents = self._constituents(description, metadata, grid_names)

            lighting = sun_lighting(description, current_sun(context, self.sun_choice), self.sun[0], created,
                                    self.sun[1]) if self.sun is not None else None
            mat = created.add(build_material(VOLUME_NAME, constituents, material.grid_density(),
                                             phase_mixing=s.phase_mixing, sun=lighting))
            mat[ROLE] = "atmosphere"
            mat["airmass_lighting"] = "SUN_EMISSION" if lighting is not None else "SCATTER"
            mat["airmass_planet_center"] = list(float(x) for x in description["planet_center"])
            new = []
            for i, vol in enumerate(volumes):
                vol.materials.append(mat)
                obj = created.add(bpy.data.objects.new("%s %d" % (VOLUME_NAME, i) if len(volumes) > 1
                                                       else VOLUME_NAME, vol))
                obj[ROLE] = "atmosphere"
                obj["airmass_mode"] = "VDB"
                if compat.voxel_centre_shift():
                    # OpenVDB puts voxel (i, j, k)'s value at i·v (the centre of its cell); Blender
                    # < 5.0 renders it at the centre of [i, i+1]·v: shift back by half a voxel.
                    obj.location = (-0.5 * voxel, -0.5 * voxel, -0.5 * voxel)
                new.append(obj)
            if s.add_ground:
                axis, theta = view_cap(context, s, description, self.unit_m) if self.region == "view" \
                    else ((0.0, 0.0, 1.0), math.pi)
                new.append(_ground(description, albedo, created, axis, theta))
            for o in new:
                if o.get(ROLE) == "atmosphere":
                    o[TRANSPARENT_BOUNCES_KEY] = transparent_bounces_needed(len(volumes))
            notes = _configure_scene(context, s, description, s.step_km * KM / self.unit_m, self.unit_name,
                                     boundaries=len(volumes))
            _swap_in(context, s, new, created)
        except Exception:
            created.remove_all()
            raise
        written.keep()  # the new volume is in place: the previous files' links go
        self.written = None
        self.summary = ("Airmass VDB atmosphere: %d file(s), voxel %.3g %s, %s active voxels, written with "
                        "Blender's %s module%s"
                        % (len(written.vdb_files), voxel, self.unit_name, plan.get("active_voxels"),
                           written.module_name, ("; " + "; ".join(notes)) if notes else ""))

    @staticmethod
    def _constituents(description, metadata, grid_names):
        """Per grid: coefficients and phase from the grid metadata when readable, else from the
        analytic description (which carries the same numbers)."""
        by_name = {c["name"]: c for c in description["constituents"]}
        out = []
        for name in grid_names:
            meta = metadata.get(name)
            if meta and "airmass:scattering_rgb" in meta:
                out.append({"name": name,
                            "scattering_rgb": list(meta["airmass:scattering_rgb"]),
                            "absorption_rgb": list(meta.get("airmass:absorption_rgb", (0.0, 0.0, 0.0))),
                            "phase": meta.get("airmass:phase", "isotropic"),
                            "g": float(meta.get("airmass:g", 0.0)),
                            "g_hg": by_name.get(name, {}).get("g_hg"),
                            "profile": by_name.get(name, {}).get("profile", {})})
            elif name in by_name:
                out.append(by_name[name])
            else:
                raise RuntimeError("grid '%s' has no airmass metadata and is not in the scene" % name)
        return out
