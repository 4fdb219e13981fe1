"""Every Blender-version-dependent call of the add-on, in one place (3.4 … 5.x).

No other module of the add-on looks at bpy.app.version: they call the functions here.
Each branch says which Blender it is for and where the fact comes from (docs/addon.md,
"Blender versions", lists what was verified and how). The tests run this module twice:
for real in Debian's Blender 3.4 (tests/blender/run_addon_tests.py) and under a stand-in
bpy for 3.4, 4.2, 4.3, 4.5 and 5.0 (tests/python/test_addon_compat.py) — so a function
here touches bpy only through what it is given and `bpy.app` / `bpy.data`.
"""

import bpy

V4_0 = (4, 0, 0)
V4_2 = (4, 2, 0)
V4_3 = (4, 3, 0)
V4_4 = (4, 4, 0)  # slotted actions (AnimData.action_slot)
V4_5 = (4, 5, 0)
V5_0 = (5, 0, 0)


def version():
    return tuple(bpy.app.version[:3])


def at_least(v):
    return version() >= tuple(v)


# ---- colour ----------------------------------------------------------------------------------

REC709 = "Linear Rec.709"

IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def working_space():
    """Name of the colour space Blender's scene-linear numbers (shader colours, lamp colours,
    float image pixels) are in, for this file."""
    if at_least(V5_0):
        # 5.0: every .blend has its own working space (Linear Rec.709, Linear Rec.2020 or
        # ACEScg): bpy.data.colorspace.working_space (rna_main.cc, BlendFileColorspace).
        return bpy.data.colorspace.working_space
    # 3.4–4.5: scene linear is fixed by the OpenColorIO config; Blender's own config makes it
    # Linear Rec.709 (named "Linear" before 4.0).
    return REC709


def float_image_colorspace():
    """The colour-space name to give a float image whose pixels are in working_space()."""
    if at_least(V5_0):
        return working_space()  # 5.0: the working space's own name (see working_space)
    if at_least(V4_0):
        return REC709  # 4.0–4.5: Blender 4.0's OpenColorIO config renamed "Linear" → "Linear Rec.709"
    return "Linear"  # 3.x (verified in Debian's 3.4: the enum has 'Linear', no 'Linear Rec.709')


def set_float_image_colorspace(image):
    """Tags `image` with float_image_colorspace() (the pixels written by this add-on are
    converted to the working space first, so Blender applies no further conversion)."""
    image.colorspace_settings.name = float_image_colorspace()
    return image.colorspace_settings.name


def prepare_float_image(image):
    """32-bit floats when Blender writes/packs `image` as OpenEXR (3.4 packs full float anyway,
    verified; the flag is the documented switch where it exists)."""
    if hasattr(image, "use_half_precision"):
        image.use_half_precision = False


# Non-colour data (tables of numbers): "Non-Color" in Blender's OpenColorIO configs of 3.4
# (verified in Debian's 3.4), 4.x and 5.x (their config.ocio; not run here).
DATA_COLORSPACE = "Non-Color"


def new_float_image(name, width, height, colorspace=None):
    """A new, empty 32-bit float RGBA image (not packed), tagged with `colorspace`: None is
    float_image_colorspace() (pixels in the working space), else that name. On a failure the image
    is removed again and the error names it and the step. packed_float_image and the Live Sky
    Preview (live.py, which fills and packs its image itself) make their images with it."""
    image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
    step = "colour space %r" % (colorspace or float_image_colorspace())
    try:
        if colorspace is None:
            set_float_image_colorspace(image)
        else:
            image.colorspace_settings.name = colorspace
        step = "32-bit float"
        prepare_float_image(image)
    except Exception as e:
        bpy.data.images.remove(image)
        raise RuntimeError("Blender could not make %r a 32-bit float image (%s): %s" % (name, step, e)) from e
    return image


def packed_float_image(name, width, height, flat, colorspace=None, properties=None, check_value=False):
    """A new 32-bit float RGBA image of `flat` (width·height·4 floats, bottom row first), packed
    into the .blend — Blender packs a float image as OpenEXR, so bytes(image.packed_file.data) is
    the EXR file — with the custom properties `properties` (a dict).

    `colorspace`: None tags the image with float_image_colorspace() (pixels in the working space),
    else that name (DATA_COLORSPACE for tables of numbers). After packing the image must be packed,
    float and width × height; with `check_value` it must also give pixel 0 back (an 8-bit or half
    image would have clamped or rounded it) — for small tables only: reading one pixel makes RNA
    copy the whole array (0.5 s and 128 MB for a 4096 × 2048 sky in Blender 3.4). On any
    failure the image is removed again and the error names it and the step."""
    count = width * height * 4
    if len(flat) != count:
        raise ValueError("image %r: %d values for %dx%d RGBA (%d)" % (name, len(flat), width, height, count))
    image = new_float_image(name, width, height, colorspace)
    step = "pixels"
    try:
        image.pixels.foreach_set(flat)
        step = "pack"
        image.pack()
        step = "check after packing"
        first = float(flat[0])
        if image.packed_file is None:
            raise RuntimeError("not packed")
        if not image.is_float:
            raise RuntimeError("not a float image")
        if tuple(image.size) != (width, height):
            raise RuntimeError("%dx%d, not %dx%d" % (image.size[0], image.size[1], width, height))
        if check_value:
            back = image.pixels[0]  # one read: copies the pixels once (RNA reads the whole array)
            if abs(back - first) > 1e-6 * max(1.0, abs(first)):
                raise RuntimeError("pixel 0 reads back %r, not %r" % (back, first))
        step = "custom properties"
        for key, value in (properties or {}).items():
            image[key] = value
    except Exception as e:
        bpy.data.images.remove(image)
        raise RuntimeError("Blender could not make %r a packed 32-bit float image (%s): %s"
                           % (name, step, e)) from e
    return image


def rec709_to_working_matrix():
    """3×3 matrix (rows) taking linear Rec.709 RGB — what libairmass_c returns — to the working
    space's RGB. Identity unless Blender ≥ 5.0 and the file's working space is not Rec.709."""
    if not at_least(V5_0) or working_space() == REC709:
        # 3.4–4.5 (and 5.0 files in Rec.709): the numbers are already in the working space.
        return IDENTITY
    # 5.0 with Rec.2020 / ACEScg: Blender's own conversion (its OpenColorIO config, so the
    # chromatic adaptation is the one Blender uses), read off on the basis vectors.
    # mathutils.Color.from_rec709_linear_to_scene_linear: python/mathutils/mathutils_Color.cc.
    from mathutils import Color
    columns = [tuple(Color(e).from_rec709_linear_to_scene_linear()) for e in IDENTITY]
    return tuple(tuple(columns[j][i] for j in range(3)) for i in range(3))


def convert_rgb(rgb, matrix=None):
    """One linear Rec.709 colour → the working space (a tuple of 3 floats)."""
    m = rec709_to_working_matrix() if matrix is None else matrix
    if m is IDENTITY:
        return tuple(float(c) for c in rgb[:3])
    return tuple(sum(m[i][j] * float(rgb[j]) for j in range(3)) for i in range(3))


def convert_pixels(pixels, matrix):
    """In place: the RGB of an (…, 4) float32 numpy array, linear Rec.709 → working space."""
    if matrix is IDENTITY:
        return pixels
    import numpy as np
    m = np.asarray(matrix, dtype=np.float64)
    rgb = pixels[..., :3].astype(np.float64) @ m.T
    pixels[..., :3] = rgb.astype(np.float32)
    return pixels


# ---- node trees ------------------------------------------------------------------------------

def ensure_node_tree(idblock):
    """The node tree of a World or Material, made to exist.

    3.4–4.5: `use_nodes = True` creates it (a new World has node_tree None until then — seen
    in Debian's 3.4). 5.0: `use_nodes` is deprecated ("Setting the property has no effect,
    and getting it always returns True", rna_world.cc / rna_material.cc) and a new World's
    tree exists but is empty — callers create the nodes they need (World Output included)."""
    if not at_least(V5_0):
        idblock.use_nodes = True
    return idblock.node_tree


def find_socket(sockets, *names):
    """The socket whose identifier or name is one of `names` (enabled ones first).

    `node.inputs["X"]` matches the *name* only (verified in 3.4: "A_Color" is not found), and
    5.0 renamed the Fac sockets to "Factor" while keeping the identifier "Fac"
    (node declarations: add_input<decl::Float>("Factor", "Fac")). Looking up by identifier,
    then by name, works in every version."""
    found = None
    for s in sockets:
        if s.identifier in names or s.name in names:
            if getattr(s, "enabled", True):
                return s
            found = found or s
    if found is None:
        raise KeyError("no socket %s among %s" % (" / ".join(names), [s.identifier for s in sockets]))
    return found


def fac_socket(sockets):
    """A "Fac" socket (Attribute output, Mix RGB input …): "Fac" up to 4.5, "Factor" (identifier
    "Fac") from 5.0."""
    return find_socket(sockets, "Fac", "Factor")


def new_color_mix(tree):
    """A colour Mix node: (node, factor, a, b, result) sockets.

    ShaderNodeMix (data_type RGBA, blend MIX) exists from 3.4 on, with the identifiers
    Factor_Float, A_Color, B_Color, Result_Color (verified in Debian's 3.4); the legacy
    ShaderNodeMixRGB is not used, so no version branch is needed here."""
    node = tree.nodes.new("ShaderNodeMix")
    node.data_type = "RGBA"
    node.blend_type = "MIX"
    node.clamp_factor = False
    return (node, find_socket(node.inputs, "Factor_Float"), find_socket(node.inputs, "A_Color"),
            find_socket(node.inputs, "B_Color"), find_socket(node.outputs, "Result_Color"))


# ---- Sky Texture (Blender's own physical sky) ----------------------------------------------------

def set_physical_sky(node, multiple_scattering=False, aerosol_density=None):
    """Blender's Sky Texture node set to its physical (Nishita-type) model.

    5.0: sky_type SINGLE_SCATTERING / MULTIPLE_SCATTERING and `aerosol_density` (API docs
    ShaderNodeTexSky 5.0; DNA SHD_SKY_SINGLE_SCATTERING = 2 took NISHITA's value).
    3.x–4.5: sky_type NISHITA (single scattering only) and `dust_density`."""
    if at_least(V5_0):
        node.sky_type = "MULTIPLE_SCATTERING" if multiple_scattering else "SINGLE_SCATTERING"
        if aerosol_density is not None:
            node.aerosol_density = aerosol_density
        return node.sky_type
    if multiple_scattering:
        raise ValueError("Blender %d.%d's Sky Texture has no multiple scattering (5.0+)" % version()[:2])
    node.sky_type = "NISHITA"
    if aerosol_density is not None:
        node.dust_density = aerosol_density
    return node.sky_type


# ---- World ---------------------------------------------------------------------------------------

def set_world_sun_extraction(world, enabled):
    """EEVEE 4.2+ turns world texels brighter than World.sun_threshold into a sun light
    (rna_world.cc: "If non-zero, the maximum value for world contribution ... The excess
    contribution is converted to a sun light"). With an Airmass Sun lamp that sun would be
    counted twice: `enabled=False` sets the threshold to 0 (no extraction). Returns whether
    the property exists (3.4–4.1: no such thing, nothing to do)."""
    if not at_least(V4_2):
        return False
    if not enabled:
        world.sun_threshold = 0.0
    return True


# ---- animation ---------------------------------------------------------------------------------

def action_state(idblock):
    """(action, slot) an ID animates with, for restore_action_state; (None, None) without one.
    4.4+ actions have slots (AnimData.action_slot); before, the slot is None."""
    ad = idblock.animation_data
    if ad is None:
        return None, None
    return ad.action, getattr(ad, "action_slot", None)


def restore_action_state(idblock, state):
    """Assigns the (action, slot) action_state() returned (None: no action)."""
    action, slot = state
    if action is None and idblock.animation_data is None:
        return
    ad = idblock.animation_data_create()
    ad.action = action
    if action is not None and slot is not None and at_least(V4_4):
        ad.action_slot = slot


# ---- lights and materials --------------------------------------------------------------------------

def set_light_shadow(light, cast):
    """Shadow casting of a light. `light.use_shadow` (the shared property) in every version;
    3.x–4.x additionally have Cycles' own `light.cycles.cast_shadow` (verified in 3.4), which
    5.x's Cycles property groups no longer define."""
    light.use_shadow = bool(cast)
    cycles = getattr(light, "cycles", None)
    if not at_least(V5_0) and cycles is not None and hasattr(cycles, "cast_shadow"):
        cycles.cast_shadow = bool(cast)


def set_heterogeneous_volume(material):
    """Tells Cycles the volume's density varies. 3.x–4.x: `material.cycles.homogeneous_volume`
    (verified in 3.4) must be False; 5.x's Cycles has no such property (it detects it)."""
    cycles = getattr(material, "cycles", None)
    if not at_least(V5_0) and cycles is not None and hasattr(cycles, "homogeneous_volume"):
        cycles.homogeneous_volume = False


def volume_ray_marching(scene):
    """Whether Cycles ray-marches volumes (so the step rate and max steps matter).

    ≤ 4.5: always. 5.0: volumes use unbiased null scattering unless Render → Volumes → Biased
    (`scene.cycles.volume_biased`, Cycles' addon/properties.py: "Biased option uses ray
    marching, with controls for steps size and max steps")."""
    if not at_least(V5_0):
        return True
    cycles = getattr(scene, "cycles", None)
    return bool(cycles is not None and getattr(cycles, "volume_biased", False))


def voxel_centre_shift():
    """Blender < 5.0 renders VDB voxel values at voxel centres (OpenVDB stores them at index
    points): shift by −½ voxel. 5.0 fixed it (cycles commit f73e56d, renderer-facts)."""
    return not at_least(V5_0)


# ---- Volume Scatter phase functions ------------------------------------------------------------------

def has_phase_types():
    """Volume Scatter has a `phase` enum from 4.3 on (HENYEY_GREENSTEIN, FOURNIER_FORAND, DRAINE,
    RAYLEIGH, MIE: API docs ShaderNodeVolumeScatter 4.3); 3.4–4.2 have Henyey–Greenstein only."""
    return at_least(V4_3)


def hg_anisotropy(phase, g):
    """Henyey–Greenstein g with the same mean cosine as the scene's phase function: the one
    phase → HG rule, henyey_greenstein_g in the library's phase.hpp (docs/compare.md; the
    analytic-density JSON carries the library's value as g_hg, tests check they agree)."""
    if phase == "henyey_greenstein":
        return g
    if phase == "cornette_shanks":
        return 3.0 * g * (4.0 + g * g) / (5.0 * (2.0 + g * g))
    return 0.0  # rayleigh, rayleigh_modified, isotropic: symmetric


def exact_phase(phase):
    """Whether this Blender's Volume Scatter can hold the scene phase `phase` exactly."""
    if phase in ("henyey_greenstein", "isotropic"):
        return True
    if phase in ("rayleigh", "cornette_shanks"):
        return has_phase_types()
    return False  # rayleigh_modified (depolarised) and others: approximated


def set_scatter_phase(node, phase, g, hg_g=None):
    """The constituent's phase on a Volume Scatter node. Returns the phase Blender renders.

    4.3+: Rayleigh → RAYLEIGH; Cornette–Shanks → DRAINE with Alpha = 1 (Draine's α blends
    HG (0) and Cornette–Shanks (1): manual, Volume Scatter); HG and isotropic → HENYEY_GREENSTEIN.
    3.4–4.2 (no `phase`): Henyey–Greenstein of g `hg_g` (the library's g_hg), by default
    hg_anisotropy(phase, g) — the same rule."""
    if has_phase_types():
        if phase in ("rayleigh", "rayleigh_modified"):
            node.phase = "RAYLEIGH"
            return "RAYLEIGH"
        if phase == "cornette_shanks":
            node.phase = "DRAINE"
            find_socket(node.inputs, "Anisotropy").default_value = g
            find_socket(node.inputs, "Alpha").default_value = 1.0
            return "DRAINE"
        node.phase = "HENYEY_GREENSTEIN"
    find_socket(node.inputs, "Anisotropy").default_value = hg_anisotropy(phase, g) if hg_g is None else hg_g
    return "HENYEY_GREENSTEIN"


def needs_phase_dither(phases):
    """Whether scatterers with these (phase, g) must share one dithered Volume Scatter.

    3.4–4.2: one Henyey–Greenstein closure per constituent has its phase summed unweighted by
    Cycles (docs/compare.md), and HG is all there is: dither when the g differ. 4.3+: each
    constituent keeps its own node with its real phase type (no dithering)."""
    if has_phase_types():
        return False
    return len({round(hg_anisotropy(p, g), 12) for p, g in phases}) > 1
