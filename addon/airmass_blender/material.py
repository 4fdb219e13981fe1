"""The one Cycles volume material of Airmass: built here for the add-on's Create Atmosphere
Volume (volume.py) and for `airmass compare` (compare/blender_render.py), so the comparison
renders exactly the node graph users get (tests/blender/test_material_graph.py dumps both).

Pure bpy + the standard library + compat.py (itself pure bpy): nothing here needs the native
library or the add-on's registered properties, so compare/blender_render.py imports this
module from the add-on's source folder or the installed zip without registering the add-on
(load_material_module in blender_render.py).

Constituents are dicts as in the library's analytic-density JSON (docs/vdb.md): name,
scattering_rgb, absorption_rgb (per Blender unit at density 1, linear Rec.709), phase, g and
g_hg — the Henyey–Greenstein g of the one phase → HG rule (henyey_greenstein_g in the
library's phase.hpp; compat.hg_anisotropy is the same rule when g_hg is absent, e.g. a VDB
grid's metadata) — and, for the analytic density, profile.

What differs between callers is a parameter, never a copy:
  * the density source: analytic_density(...) (the altitude profile from the shading point)
    or grid_density() (a VDB grid attribute named after the constituent);
  * phase_mixing: "DITHER" (one dithered Volume Scatter where Blender has HG only and the
    g differ) or "SEPARATE" (one Volume Scatter per constituent);
  * stand_ins: the comparison's split renders also need, per scatterer, a Volume Absorption
    that can take its scattering as extinction only ("<name> stand-in", zero until set).

  * lighting: "SCATTER" (Volume Scatter closures: Cycles samples the sun through the volume)
    or "SUN_EMISSION" (sun_emission below: the single-scattered sunlight evaluated in the
    shader as an emission, with the sun's columns from the library's table; the scatterers
    then only attenuate, as Volume Absorption "<name> extinction").

Node names the comparison (and the tests) address: "<name> scatter", "<name> scatter
density" (the MULTIPLY ρ × D feeding its Density), "<name> absorption", "<name> absorption
density", "<name> stand-in", "<name> stand-in density", "<name> scatter weight", "<name>
scatter colour", "scatter (dithered)".
"""

import math

import bpy

from . import compat


class MaterialError(ValueError):
    """A constituent the builder cannot express (the message names it)."""


def constituent_hg_g(c):
    """The Henyey–Greenstein g of a constituent: the library's g_hg (the one rule) when the
    description carries it, else the same rule in Python (compat.hg_anisotropy)."""
    if c.get("g_hg") is not None:
        return float(c["g_hg"])
    return compat.hg_anisotropy(c.get("phase", "isotropic"), float(c.get("g", 0.0)))


# ---- node helpers ------------------------------------------------------------------------

class NodeBuilder:
    """Creates shader nodes in columns, left to right, and wires constants or sockets."""

    def __init__(self, tree):
        self.tree = tree
        self.column = 0
        self.row = 0

    def place(self, node):
        node.location = (-1400 + 180 * self.column, 600 - 160 * self.row)
        self.row += 1
        if self.row > 12:
            self.row = 0
            self.column += 1
        return node

    def node(self, kind, **props):
        n = self.place(self.tree.nodes.new(kind))
        for k, v in props.items():
            setattr(n, k, v)
        return n

    def _feed(self, socket, value):
        if isinstance(value, bpy.types.NodeSocket):
            self.tree.links.new(value, socket)
        else:
            socket.default_value = value

    def math(self, op, a, b=None, c=None, name=None):
        n = self.node("ShaderNodeMath", operation=op)
        if name:
            n.name = n.label = name
        for i, v in enumerate((a, b, c)):
            if v is not None:
                self._feed(n.inputs[i], v)
        return n.outputs[0]

    def dot(self, a, b):
        n = self.node("ShaderNodeVectorMath", operation="DOT_PRODUCT")
        self._feed(n.inputs[0], a)
        self._feed(n.inputs[1], b)
        return n.outputs["Value"]


def radius_excess_socket(nb, position, center, radius):
    """q = r² − R² = p·p − 2p·c + (c·c − R²): no planet-sized radii subtracted (float32)."""
    cc_minus_r2 = sum(x * x for x in center) - radius * radius
    pp = nb.dot(position, position)
    q = pp
    if any(center):
        pc = nb.dot(position, tuple(center))
        q = nb.math("MULTIPLY_ADD", pc, -2.0, pp)
    if cc_minus_r2 != 0.0:
        q = nb.math("ADD", q, cc_minus_r2)
    return q


def altitude_socket(nb, position, center, radius):
    """h = |p − c| − R computed as q/(sqrt(q + R²) + R), q = radius_excess_socket."""
    q = radius_excess_socket(nb, position, center, radius)
    r = nb.math("SQRT", nb.math("ADD", q, radius * radius))
    return nb.math("DIVIDE", q, nb.math("ADD", r, radius))


def in_band(nb, h, lo, hi):
    """1 where lo ≤ h < hi, else 0."""
    return nb.math("SUBTRACT", nb.math("LESS_THAN", h, hi), nb.math("LESS_THAN", h, lo))


def profile_socket(nb, h, profile, top_altitude):
    """ρ(h) of one profile (docs/vdb.md "Analytic density"), altitudes in Blender units."""
    kind = profile["type"].replace("-", "_")
    if kind == "exponential":
        H = float(profile["scale_height"])
        h0 = float(profile.get("reference_altitude", 0.0))
        return nb.math("EXPONENT", nb.math("MULTIPLY_ADD", h, -1.0 / H, h0 / H))
    if kind == "tent":
        b, p, t = float(profile["bottom"]), float(profile["peak"]), float(profile["top"])
        if p > b and t > p:
            up = nb.math("MULTIPLY_ADD", h, 1.0 / (p - b), -b / (p - b))
            down = nb.math("MULTIPLY_ADD", h, -1.0 / (t - p), t / (t - p))
            return nb.math("MAXIMUM", nb.math("MINIMUM", up, down), 0.0)
        knots = [(b, 0.0), (p, 1.0), (t, 0.0)]
    elif kind == "piecewise_linear":
        knots = [(float(a), float(d)) for a, d in profile["knots"]]
    elif kind == "constant":
        b = float(profile.get("bottom", 0.0) or 0.0)
        t = profile.get("top")
        t = top_altitude if t is None else float(t)
        return nb.math("MULTIPLY", in_band(nb, h, b, t), float(profile.get("value", 1.0)))
    else:
        raise MaterialError("unknown density profile type '%s' from the library" % profile["type"])
    total = None
    for (h0, r0), (h1, r1) in zip(knots, knots[1:]):
        if not h1 > h0:
            continue  # a jump: the next piece starts at the new value
        slope = (r1 - r0) / (h1 - h0)
        piece = nb.math("MULTIPLY", nb.math("MULTIPLY_ADD", h, slope, r0 - slope * h0), in_band(nb, h, h0, h1))
        total = piece if total is None else nb.math("ADD", total, piece)
    return total if total is not None else 0.0


# ---- density sources ------------------------------------------------------------------------

def analytic_density(center, radius, top_altitude, constituents):
    """density_for of the analytic volume: per constituent ρ = profile(h) · [0 < h < top],
    h the altitude of Texture Coordinate "Object" (the domain object sits at the world
    origin, so it is the world point; planet centre `center`, radius `radius`, Blender units).
    One altitude and one mask serve every constituent."""
    center = tuple(float(x) for x in center)
    radius, top_altitude = float(radius), float(top_altitude)
    by_name = {c["name"]: c for c in constituents}

    def density_for(nb, name):
        if getattr(nb, "h", None) is None:
            coords = nb.node("ShaderNodeTexCoord").outputs["Object"]
            nb.h = altitude_socket(nb, coords, center, radius)
            nb.mask = nb.math("MULTIPLY", nb.math("GREATER_THAN", nb.h, 0.0),
                              nb.math("LESS_THAN", nb.h, top_altitude))
        return nb.math("MULTIPLY", profile_socket(nb, nb.h, by_name[name]["profile"], top_altitude), nb.mask)

    return density_for


def grid_density():
    """density_for of the VDB volume: the grid named after the constituent (Attribute node)."""
    def density_for(nb, name):
        attr = nb.node("ShaderNodeAttribute", attribute_type="GEOMETRY", attribute_name=name)
        return compat.fac_socket(attr.outputs)

    return density_for


# ---- closures -------------------------------------------------------------------------------

def dithered_scatter(nb, scatterers):
    """One Volume Scatter standing for several scatterers with different Henyey–Greenstein g.

    Cycles 3.4 sums the phase functions of several Volume Scatter closures without their
    weights (measured +18 % on a clear sky, docs/compare.md). Here, at every shading point,
    scatterer j is chosen with probability P_j = m_j ρ_j / Σ m ρ (m_j = max_c σs_j,c) by a
    White Noise texture of the position (a hash of its float bits: a fresh draw at every
    ray-marching point), and the closure takes its anisotropy g_j and colour σs_j / m_j with
    density Σ m ρ. Per channel c the expected weight × phase is Σ_j P_j (σs_j,c/m_j) Σmρ p_j
    = Σ_j σs_j,c ρ_j p_j: the mixture, with a single closure.

    `scatterers`: [(name, σs rgb, g, density socket or float)]. Node names: "<name> scatter
    weight" (ρ_j × m_j), "<name> scatter colour" (σs_j / m_j), "scatter (dithered)"."""
    shares, colours = [], []
    for name, sigma_s, g, density in scatterers:
        m = max(sigma_s)
        w = nb.node("ShaderNodeMath", operation="MULTIPLY", name="%s scatter weight" % name,
                    label="%s scatter weight" % name)
        nb._feed(w.inputs[0], density)
        w.inputs[1].default_value = m
        w["airmass_sigma_s"] = list(sigma_s)
        shares.append(w.outputs[0])
        rgb = nb.node("ShaderNodeRGB", name="%s scatter colour" % name, label="%s scatter colour" % name)
        rgb.outputs[0].default_value = (*[x / m for x in sigma_s], 1.0)
        colours.append(rgb.outputs[0])
    total = shares[0]
    for x in shares[1:]:
        total = nb.math("ADD", total, x)
    noise = nb.node("ShaderNodeTexWhiteNoise", noise_dimensions="3D", name="scatterer choice",
                    label="scatterer choice")
    nb.tree.links.new(nb.node("ShaderNodeNewGeometry").outputs["Position"], noise.inputs["Vector"])
    u_total = nb.math("MULTIPLY", noise.outputs["Value"], total)
    g = float(scatterers[0][2])  # a constant until the first choice below adds to it
    colour = colours[0]
    cum = shares[0]
    for j in range(1, len(scatterers)):
        chosen = nb.math("GREATER_THAN", u_total, cum)  # scatterer j or a later one
        g = nb.math("MULTIPLY_ADD", chosen, float(scatterers[j][2]) - float(scatterers[j - 1][2]), g)
        mix, fac, a, b, result = compat.new_color_mix(nb.tree)
        nb.place(mix)
        nb.tree.links.new(chosen, fac)
        nb.tree.links.new(colour, a)
        nb.tree.links.new(colours[j], b)
        colour = result
        cum = nb.math("ADD", cum, shares[j])
    node = nb.node("ShaderNodeVolumeScatter", name="scatter (dithered)", label="scatter (dithered)")
    nb.tree.links.new(colour, node.inputs["Color"])
    nb.tree.links.new(total, node.inputs["Density"])
    nb._feed(node.inputs["Anisotropy"], g)
    return node


# ---- Analytic Sun lighting: single scattering as an emission ---------------------------------

class SunLighting:
    """What sun_emission needs: the sun and the table of its columns (native.sun_column_table,
    docs/addon.md "Analytic Sun"), all in Blender units of the scene frame.

    direction: unit vector toward the sun; irradiance_rgb: top-of-atmosphere sunlight, linear
    Rec.709 (W m⁻², the Sun lamp's strength × colour); angular_radius: of the sun disc (rad);
    images: float images holding the columns, three constituents per image (R, G, B), texel
    (i, j) at x_mu = i/(width − 1), x_r = j/(height − 1); channel: {constituent name: (image
    index, channel index)}; center, radius, top: planet centre, radius, radius of the top;
    ms_image: Hillaire's isotropic multiple scattering Ψ (RGB, per unit irradiance, sr⁻¹), texel
    (i, j) at μs = ms_mu_s_min + (1 − ms_mu_s_min)·i/(width − 1), x_r = j/(height − 1), or None."""

    def __init__(self, direction, irradiance_rgb, angular_radius, images, channel, center, radius, top,
                 extinction, ms_image=None, ms_mu_s_min=-1.0):
        # {name: σs + σa, linear Rec.709, per Blender unit} of *every* constituent of the scene: the
        # sun's path crosses them all, also those a VDB region holds no voxel of.
        self.extinction = {n: tuple(float(x) for x in v) for n, v in extinction.items()}
        self.ms_image = ms_image  # Ψ (native.sun_ms_table) as RGB, or None: single scattering only
        self.ms_mu_s_min = float(ms_mu_s_min)
        self.direction = tuple(float(x) for x in direction)
        self.irradiance_rgb = tuple(float(x) for x in irradiance_rgb)
        self.angular_radius = float(angular_radius)
        self.images = list(images)
        self.channel = dict(channel)
        self.center = tuple(float(x) for x in center)
        self.radius, self.top = float(radius), float(top)


def phase_socket(nb, kind, g, cos_theta):
    """The library's phase function (phase.hpp) of `kind` at the scattering angle's cosine, per
    steradian: A (B + C cos²) d^(−3/2), d = 1 + g² − 2 g cos (d = 1 for g = 0)."""
    pi = math.pi
    g = float(g)
    if kind == "isotropic":
        return 1.0 / (4.0 * pi)
    if kind == "rayleigh":
        a, b, c, uses_d = 3.0 / (16.0 * pi), 1.0, 1.0, False
    elif kind == "rayleigh_modified":
        a, b, c, uses_d = 30.0 / 47.0 / (4.0 * pi), 1.4, 0.5, False
    elif kind == "cornette_shanks":
        a, b, c, uses_d = 3.0 / (8.0 * pi) * (1.0 - g * g) / (2.0 + g * g), 1.0, 1.0, True
    elif kind == "henyey_greenstein":
        a, b, c, uses_d = (1.0 - g * g) / (4.0 * pi), 1.0, 0.0, True
    else:
        raise MaterialError("unknown phase function '%s' from the library" % kind)
    value = a * b if c == 0.0 else nb.math("MULTIPLY_ADD", nb.math("MULTIPLY", cos_theta, cos_theta), a * c, a * b)
    if uses_d and g != 0.0:
        d = nb.math("MULTIPLY_ADD", cos_theta, -2.0 * g, 1.0 + g * g)
        value = nb.math("MULTIPLY", value, nb.math("POWER", d, -1.5))
    return value


def texel_lookup(nb, image, u, v, name):
    """RGB sockets of `image` (Linear, Extend) at unit coordinates x_u = a·s + b for u = (s, a, b)
    and likewise v, where texel i sits at x = i/(n − 1): the image's u = (x (n − 1) + 0.5)/n."""
    w, h = image.size
    uv = nb.node("ShaderNodeCombineXYZ")
    for axis, (sock, a, b), n in ((0, u, w), (1, v, h)):
        nb.tree.links.new(nb.math("MULTIPLY_ADD", sock, a * (n - 1.0) / n, (b * (n - 1.0) + 0.5) / n),
                          uv.inputs[axis])
    tex = nb.node("ShaderNodeTexImage", name=name, label=name, interpolation="Linear", extension="EXTEND")
    tex.image = image
    nb.tree.links.new(uv.outputs[0], tex.inputs["Vector"])
    sep = nb.node("ShaderNodeSeparateXYZ")
    nb.tree.links.new(tex.outputs["Color"], sep.inputs[0])
    return [sep.outputs[ch] for ch in range(3)]


def sun_emission(nb, scatterers, extinctions, sun, irradiance_ws):
    """An Emission closure of single-scattered sunlight: at the shading point p, toward the
    ray's origin (Geometry "Incoming": correct for every ray, camera or bounce),

        L_e = f · E_top ⊙ exp(−Σ_k σt_k m_k(r, μ)) ⊙ Σ_j σs_j ρ_j(p) P_j(−s·I)

    — the integrand of the library's single scattering (single_scattering.hpp), which Cycles
    then integrates along the ray with the volume's extinction. m_k: constituent k's column
    toward the sun from the table (bilinear), r = |p − c|, μ = the sun's zenith cosine there;
    f: the fraction of the sun's disc above the planet's horizon (the area of a disc of angular
    radius α above a straight line at the sun's elevation e = (rμ + ρ)/R over that horizon,
    ρ = sqrt(r² − R²)).

    With sun.ms_image, every order of multiple scattering is added as Hillaire's (2020) isotropic
    source, unshadowed: + E_top ⊙ Ψ(r, μs) ⊙ Σ_j σs_j ρ_j.

    `scatterers`: [(constituent dict, σs rgb, density socket or float)]; `extinctions`: {name:
    σs + σa rgb} of every constituent of the scene (the material's own may be fewer: a VDB region
    without voxels of one); `irradiance_ws`: the sun's top-of-atmosphere RGB; all in the working
    space."""
    R, top = sun.radius, sun.top
    H = math.sqrt(max(0.0, top * top - R * R))
    c = sun.center
    s_dir = sun.direction
    position = nb.node("ShaderNodeNewGeometry", name="sun position", label="sun position")
    P = position.outputs["Position"]
    # q = r² − R² (radius_excess_socket), ≥ 0 for the square roots; r μ = p·s − c·s.
    q = nb.math("MAXIMUM", radius_excess_socket(nb, P, c, R), 0.0)
    r = nb.math("SQRT", nb.math("ADD", q, R * R))
    rho = nb.math("SQRT", q)
    sun_vec = nb.node("ShaderNodeCombineXYZ", name="sun direction", label="sun direction")
    for i in range(3):
        sun_vec.inputs[i].default_value = s_dir[i]
    s_sock = sun_vec.outputs[0]
    r_mu = nb.math("SUBTRACT", nb.dot(P, s_sock), sum(c[i] * s_dir[i] for i in range(3)), name="sun r mu")
    # Bruneton's transmittance parametrisation (volume.hpp sun_column_table).
    disc = nb.math("ADD", nb.math("MULTIPLY", r_mu, r_mu), nb.math("SUBTRACT", H * H, q))
    d = nb.math("SUBTRACT", nb.math("SQRT", disc), r_mu)
    d_min = nb.math("SUBTRACT", top, r)
    d_max = nb.math("ADD", rho, H)
    x_mu = nb.math("DIVIDE", nb.math("SUBTRACT", d, d_min), nb.math("SUBTRACT", d_max, d_min))
    x_r = nb.math("DIVIDE", rho, H)
    columns = {}
    for index, image in enumerate(sun.images):
        rgb = texel_lookup(nb, image, (x_mu, 1.0, 0.0), (x_r, 1.0, 0.0), "sun columns %d" % index)
        for name, (img, ch) in sun.channel.items():
            if img == index:
                columns[name] = rgb[ch]
    # −τ per channel, then T; the sun's irradiance and the disc fraction folded in.
    minus_tau = [0.0, 0.0, 0.0]
    for name, ext in extinctions.items():
        if name not in columns:
            raise MaterialError("constituent '%s' has no column in the sun's table" % name)
        for ch in range(3):
            if ext[ch] > 0.0:
                minus_tau[ch] = nb.math("MULTIPLY_ADD", columns[name], -float(ext[ch]), minus_tau[ch])
    if sun.angular_radius > 0.0:
        # x = e/α clamped to [−1, 1], e = (rμ + ρ)/R the sun's elevation over the planet's horizon:
        # the disc's area above a straight horizon, ½ + (x sqrt(1 − x²) + asin x)/π.
        x = nb.math("MINIMUM", nb.math("MAXIMUM", nb.math("MULTIPLY", nb.math("ADD", r_mu, rho),
                                                          1.0 / (sun.angular_radius * R)), -1.0), 1.0)
        chord = nb.math("MULTIPLY", x, nb.math("SQRT", nb.math("MULTIPLY_ADD", x, nb.math("MULTIPLY", x, -1.0), 1.0)))
        lit = nb.math("MULTIPLY_ADD", nb.math("ADD", chord, nb.math("ARCSINE", x)), 1.0 / math.pi, 0.5)
        lit = nb.math("MULTIPLY", lit, nb.math("GREATER_THAN", x, -1.0))  # exactly 0 below the disc (no rounding)
    else:
        lit = nb.math("GREATER_THAN", nb.math("ADD", r_mu, rho), 0.0)
    lit.node.name = lit.node.label = "sun disc above the horizon"
    # cos θ = −s · I (I: from the point toward the ray's origin).
    cos_theta = nb.math("MULTIPLY", nb.dot(s_sock, position.outputs["Incoming"]), -1.0, name="cos theta")
    source = [0.0, 0.0, 0.0]
    for cdesc, sigma_s, density in scatterers:
        phase = phase_socket(nb, cdesc.get("phase", "isotropic"), float(cdesc.get("g", 0.0)), cos_theta)
        weight = nb.math("MULTIPLY", density, phase, name="%s sun source" % cdesc["name"])
        for ch in range(3):
            if sigma_s[ch] > 0.0:
                source[ch] = nb.math("MULTIPLY_ADD", weight, float(sigma_s[ch]), source[ch])
    psi = None
    ms_source = [0.0, 0.0, 0.0]
    if sun.ms_image is not None:
        lo = sun.ms_mu_s_min  # x = (μs − lo)/(1 − lo)
        mu_s = nb.math("DIVIDE", r_mu, r)
        psi = texel_lookup(nb, sun.ms_image, (mu_s, 1.0 / (1.0 - lo), -lo / (1.0 - lo)), (x_r, 1.0, 0.0),
                           "sun multiple scattering")
        for _cdesc, sigma_s, density in scatterers:
            for ch in range(3):
                if sigma_s[ch] > 0.0:
                    ms_source[ch] = nb.math("MULTIPLY_ADD", density, float(sigma_s[ch]), ms_source[ch])
    rgb = nb.node("ShaderNodeCombineXYZ", name="sun emission colour", label="sun emission colour")
    for ch in range(3):
        e = float(irradiance_ws[ch])
        term = nb.math("MULTIPLY", nb.math("EXPONENT", minus_tau[ch]) if not isinstance(minus_tau[ch], float)
                       else math.exp(minus_tau[ch]), lit)
        term = nb.math("MULTIPLY", term, source[ch]) if not isinstance(source[ch], float) else 0.0
        if psi is not None and not isinstance(ms_source[ch], float):
            ms = nb.math("MULTIPLY", psi[ch], ms_source[ch], name="multiple scattering %d" % ch)
            term = ms if isinstance(term, float) else nb.math("ADD", term, ms)
        if isinstance(term, float):
            rgb.inputs[ch].default_value = 0.0
        else:
            nb.tree.links.new(nb.math("MULTIPLY", term, e, name="sun irradiance %d" % ch), rgb.inputs[ch])
    emission = nb.node("ShaderNodeEmission", name="sun emission", label="sun emission")
    nb.tree.links.new(rgb.outputs[0], emission.inputs["Color"])
    emission.inputs["Strength"].default_value = 1.0
    return emission


def _density_times(nb, density, k, name):
    """ρ × k as a named MULTIPLY (the comparison re-sets k per render), or a constant."""
    if isinstance(density, float):
        return density * k
    return nb.math("MULTIPLY", density, k, name=name)


def build_material(name, constituents, density_for, phase_mixing="DITHER", stand_ins=False, sun=None):
    """A volume material from constituent descriptions (name, scattering_rgb, absorption_rgb,
    phase, g, g_hg) and `density_for(nb, name)` → a socket (or float) of the relative density
    (analytic_density or grid_density).

    phase_mixing "DITHER": where Blender has Henyey–Greenstein only (< 4.3,
    compat.needs_phase_dither), scatterers of different g share one dithered Volume Scatter
    (dithered_scatter); "SEPARATE", or 4.3+ with its own phase types (compat.set_scatter_phase):
    one Volume Scatter per constituent. Coefficients are the library's linear Rec.709 numbers
    converted to the file's working colour space (compat; identity before 5.0); the node
    properties airmass_sigma_s / airmass_sigma_a keep the library's own numbers.
    stand_ins: per scatterer also a Volume Absorption "<name> stand-in" of σa 0 (dropped by
    Cycles until the comparison sets it).
    sun: a SunLighting for the Analytic Sun lighting (sun_emission): each scatterer becomes a
    Volume Absorption of its σs ("<name> extinction") and one Emission ("sun emission") carries
    the single-scattered sunlight; None: Volume Scatter (Cycles samples the sun lamp)."""
    if phase_mixing not in ("DITHER", "SEPARATE"):
        raise MaterialError("phase_mixing must be DITHER or SEPARATE, not %r" % (phase_mixing,))
    mat = bpy.data.materials.new(name)
    try:
        tree = compat.ensure_node_tree(mat)
        tree.nodes.clear()
        compat.set_heterogeneous_volume(mat)
        nb = NodeBuilder(tree)
        out = tree.nodes.new("ShaderNodeOutputMaterial")
        out.location = (900, 300)
        matrix = compat.rec709_to_working_matrix()
        shaders = []
        scatterers = [c for c in constituents if max(float(x) for x in c["scattering_rgb"]) > 0.0]
        dither = phase_mixing == "DITHER" and compat.needs_phase_dither(
            [("henyey_greenstein", constituent_hg_g(c)) for c in scatterers])
        dithered = []
        emitters = []
        for c in constituents:
            sigma_s = [max(0.0, float(x)) for x in c["scattering_rgb"]]
            sigma_a = [max(0.0, float(x)) for x in c["absorption_rgb"]]
            if max(sigma_s) <= 0.0 and max(sigma_a) <= 0.0:
                continue
            # In the working space (Rec.709 ⊂ Rec.2020, ACEScg: positive stays positive).
            ws_s = [max(0.0, x) for x in compat.convert_rgb(sigma_s, matrix)]
            ws_a = [max(0.0, x) for x in compat.convert_rgb(sigma_a, matrix)]
            n = c["name"]
            density = density_for(nb, n)
            phase = c.get("phase", "isotropic")
            if max(ws_s) > 0.0 and sun is not None:
                ds = max(ws_s)
                node = nb.node("ShaderNodeVolumeAbsorption", name="%s extinction" % n, label="%s extinction" % n)
                node.inputs["Color"].default_value = (1.0 - ws_s[0] / ds, 1.0 - ws_s[1] / ds, 1.0 - ws_s[2] / ds,
                                                      1.0)
                nb._feed(node.inputs["Density"], _density_times(nb, density, ds, "%s extinction density" % n))
                node["airmass_sigma_s"] = sigma_s
                shaders.append(node.outputs[0])
                emitters.append((c, ws_s, density))
            elif max(ws_s) > 0.0 and dither:
                dithered.append((n, ws_s, constituent_hg_g(c), density))
            elif max(ws_s) > 0.0:
                ds = max(ws_s)
                node = nb.node("ShaderNodeVolumeScatter", name="%s scatter" % n, label="%s scatter" % n)
                node.inputs["Color"].default_value = (*[x / ds for x in ws_s], 1.0)
                nb._feed(node.inputs["Density"], _density_times(nb, density, ds, "%s scatter density" % n))
                node["airmass_phase"] = compat.set_scatter_phase(node, phase, float(c.get("g", 0.0)),
                                                                 hg_g=constituent_hg_g(c))
                node["airmass_sigma_s"] = sigma_s
                shaders.append(node.outputs[0])
            if max(ws_s) > 0.0 and stand_ins:
                ds = max(ws_s)
                node = nb.node("ShaderNodeVolumeAbsorption", name="%s stand-in" % n, label="%s stand-in" % n)
                node.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
                nb._feed(node.inputs["Density"], _density_times(nb, density, ds, "%s stand-in density" % n))
                shaders.append(node.outputs[0])
            if max(ws_a) > 0.0:
                da = max(ws_a)
                node = nb.node("ShaderNodeVolumeAbsorption", name="%s absorption" % n, label="%s absorption" % n)
                node.inputs["Color"].default_value = (*[1.0 - x / da for x in ws_a], 1.0)
                nb._feed(node.inputs["Density"], _density_times(nb, density, da, "%s absorption density" % n))
                node["airmass_sigma_a"] = sigma_a
                shaders.append(node.outputs[0])
        if dithered:
            shaders.append(dithered_scatter(nb, dithered).outputs[0])
        if emitters:
            irradiance = [max(0.0, x) for x in compat.convert_rgb(sun.irradiance_rgb, matrix)]
            ext_ws = {n: [max(0.0, x) for x in compat.convert_rgb(v, matrix)] for n, v in sun.extinction.items()}
            shaders.append(sun_emission(nb, emitters, ext_ws, sun, irradiance).outputs[0])
        if not shaders:
            raise MaterialError("the scene has no constituent that scatters or absorbs light")
        total = shaders[0]
        for s in shaders[1:]:
            add = nb.node("ShaderNodeAddShader")
            tree.links.new(total, add.inputs[0])
            tree.links.new(s, add.inputs[1])
            total = add.outputs[0]
        tree.links.new(total, out.inputs["Volume"])
        return mat
    except Exception:
        bpy.data.materials.remove(mat)
        raise


# ---- a canonical dump (tests) ------------------------------------------------------------------

def _value(v):
    if isinstance(v, float):
        return float("%.7g" % v)
    if isinstance(v, (int, bool, str)) or v is None:
        return v
    try:
        return [_value(x) for x in v]
    except TypeError:
        return repr(v)


_SKIP_PROPS = {"rna_type", "name", "label", "location", "width", "width_hidden", "height", "dimensions",
               "inputs", "outputs", "internal_links", "parent", "select", "show_options", "show_preview",
               "hide", "mute", "show_texture", "use_custom_color", "color", "bl_idname", "bl_label",
               "bl_description", "bl_icon", "bl_static_type", "bl_width_default", "bl_width_min",
               "bl_width_max", "bl_height_default", "bl_height_min", "bl_height_max", "type", "is_active_output",
               "warning_propagation", "location_absolute"}


def graph_dump(material):
    """The material's node graph as plain data, independent of node names' creation order:
    every node (type, its enum/number settings, each unlinked input's default value, custom
    properties) keyed by name, and every link as (from node, socket) → (to node, socket).
    Two materials render the same when their dumps are equal."""
    tree = material.node_tree
    nodes = {}
    for n in tree.nodes:
        props = {}
        for p in n.bl_rna.properties:
            if p.identifier in _SKIP_PROPS or p.type in ("POINTER", "COLLECTION"):
                continue
            props[p.identifier] = _value(getattr(n, p.identifier))
        inputs = {}
        for i, s in enumerate(n.inputs):
            if s.is_linked or not hasattr(s, "default_value") or not s.enabled:
                continue
            inputs["%d:%s" % (i, s.identifier)] = _value(s.default_value)
        # An RGB node's colour is its output's default value.
        outputs = {"%d:%s" % (i, s.identifier): _value(s.default_value)
                   for i, s in enumerate(n.outputs) if n.bl_idname == "ShaderNodeRGB"}
        custom = {k: _value(n[k]) for k in n.keys() if k.startswith("airmass_")}
        nodes[n.name] = {"type": n.bl_idname, "props": props, "inputs": inputs, "outputs": outputs,
                         "custom": custom}
    links = sorted(
        (l.from_node.name, "%d:%s" % (list(l.from_node.outputs).index(l.from_socket), l.from_socket.identifier),
         l.to_node.name, "%d:%s" % (list(l.to_node.inputs).index(l.to_socket), l.to_socket.identifier))
        for l in tree.links)
    cycles = getattr(material, "cycles", None)
    settings = {}
    if cycles is not None and hasattr(cycles, "homogeneous_volume"):
        settings["homogeneous_volume"] = bool(cycles.homogeneous_volume)
    return {"nodes": nodes, "links": [list(l) for l in links], "settings": settings}
