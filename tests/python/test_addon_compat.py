"""addon/airmass_blender/compat.py under a stand-in `bpy` for Blender 3.4, 4.2, 4.3, 4.5 and 5.0,
and native.py's choice of library file per platform — in plain Python (no Blender).

The stand-in is strict where Blender is: setting an attribute a version does not have raises
AttributeError, an enum value it does not list raises TypeError, and `sockets[name]` matches
names only (as bpy_prop_collection does, verified in Debian's 3.4). Names marked "verified"
below were read in Blender's sources / API docs or in Debian's 3.4 (docs/addon.md, "Blender
versions"); the 4.x colour-space list is only what the add-on needs.
"""

import importlib.util
import pathlib
import re
import sys
import types

import pytest

sys.dont_write_bytecode = True  # keep the source tree clean

ROOT = pathlib.Path(__file__).resolve().parents[2]
ADDON = ROOT / "addon" / "airmass_blender"

VERSIONS = [(3, 4, 1), (4, 2, 0), (4, 3, 0), (4, 5, 0), (5, 0, 0)]

# Verified: Debian's 3.4 (bpy, colorspace_settings.name enum items).
COLORSPACES_3 = ["Filmic Log", "Filmic sRGB", "Linear", "Linear ACES", "Linear ACEScg", "Non-Color", "Raw", "sRGB",
                 "XYZ"]
# 4.x: Blender's 4.0 OpenColorIO config (what the add-on needs: "Linear Rec.709").
COLORSPACES_4 = ["ACEScg", "ACES2065-1", "Linear Rec.709", "Linear Rec.2020", "Non-Color", "sRGB"]
# Verified: BlendFileColorspace.working_space items (rna_main.cc; API docs 5.x).
WORKING_SPACES_5 = ["Linear Rec.709", "Linear Rec.2020", "ACEScg"]
# Verified: ShaderNodeVolumeScatter.phase (API docs 4.3, 4.5, current).
PHASES = ["HENYEY_GREENSTEIN", "FOURNIER_FORAND", "DRAINE", "RAYLEIGH", "MIE"]
# Verified: ShaderNodeTexSky.sky_type (API docs 4.2 … 4.4 and 5.0).
SKY_TYPES_OLD = ["PREETHAM", "HOSEK_WILKIE", "NISHITA"]
SKY_TYPES_5 = ["SINGLE_SCATTERING", "MULTIPLE_SCATTERING", "PREETHAM", "HOSEK_WILKIE"]

# Rec.709 → Rec.2020 (ITU-R BT.2087, both D65): the stand-in's scene-linear conversion for a
# Rec.2020 file, and the reference the test compares compat's matrix with.
BT2087 = ((0.6274, 0.3293, 0.0433), (0.0691, 0.9195, 0.0114), (0.0164, 0.0880, 0.8956))


# ---- the stand-in --------------------------------------------------------------------------------

class Strict:
    """An RNA-like struct: only the declared attributes exist; enums check their items."""

    def __init__(self, attrs, enums=None, hooks=None):
        object.__setattr__(self, "_attrs", dict(attrs))
        object.__setattr__(self, "_enums", dict(enums or {}))
        object.__setattr__(self, "_hooks", dict(hooks or {}))  # name → update callback (like RNA's)
        object.__setattr__(self, "_set", [])

    def __getattr__(self, name):
        attrs = object.__getattribute__(self, "_attrs")
        if name in attrs:
            return attrs[name]
        raise AttributeError("'%s' has no attribute '%s'" % (type(self).__name__, name))

    def __setattr__(self, name, value):
        attrs = object.__getattribute__(self, "_attrs")
        if name not in attrs:
            raise AttributeError("bpy_struct: attribute \"%s\" not found" % name)
        enums = object.__getattribute__(self, "_enums")
        if name in enums and value not in enums[name]:
            raise TypeError("bpy_struct: item.attr = val: enum \"%s\" not found in %s" % (value, enums[name]))
        attrs[name] = value
        object.__getattribute__(self, "_set").append(name)
        hook = object.__getattribute__(self, "_hooks").get(name)
        if hook:
            hook(self, value)

    @property
    def assigned(self):
        return object.__getattribute__(self, "_set")


class Socket:
    def __init__(self, name, identifier=None, enabled=True, value=0.0):
        self.name, self.identifier, self.enabled, self.default_value = name, identifier or name, enabled, value


class Sockets(list):
    def __getitem__(self, key):
        if isinstance(key, str):  # bpy_prop_collection: by name only
            for s in self:
                if s.name == key:
                    return s
            raise KeyError('bpy_prop_collection[key]: key "%s" not found' % key)
        return list.__getitem__(self, key)


def node_factory(version):
    phase = version >= (4, 3, 0)
    five = version >= (5, 0, 0)

    def scatter():
        inputs = [Socket("Color"), Socket("Density"), Socket("Anisotropy")]
        if phase:  # 4.3+: the phase-specific inputs (manual, Volume Scatter)
            inputs += [Socket("IOR"), Socket("Backscatter"), Socket("Alpha"), Socket("Diameter")]
        inputs.append(Socket("Weight"))
        attrs = {"bl_idname": "ShaderNodeVolumeScatter", "inputs": Sockets(inputs), "outputs": Sockets([Socket("Volume")])}
        enums = {}
        if phase:
            attrs["phase"] = "HENYEY_GREENSTEIN"
            enums["phase"] = PHASES
        return Strict(attrs, enums)

    def mix():  # verified in 3.4: identifiers of ShaderNodeMix
        ins = [Socket("Factor", "Factor_Float"), Socket("Factor", "Factor_Vector", False),
               Socket("A", "A_Float", False), Socket("B", "B_Float", False), Socket("A", "A_Vector", False),
               Socket("B", "B_Vector", False), Socket("A", "A_Color"), Socket("B", "B_Color")]
        outs = [Socket("Result", "Result_Float", False), Socket("Result", "Result_Vector", False),
                Socket("Result", "Result_Color")]
        return Strict({"bl_idname": "ShaderNodeMix", "inputs": Sockets(ins), "outputs": Sockets(outs),
                       "data_type": "FLOAT", "blend_type": "MIX", "clamp_factor": True},
                      {"data_type": ["FLOAT", "VECTOR", "RGBA"], "blend_type": ["MIX", "ADD", "MULTIPLY"]})

    def attribute():  # 5.0: "Factor" with identifier "Fac" (node declarations); 3.4: "Fac"
        fac = Socket("Factor", "Fac") if five else Socket("Fac")
        return Strict({"bl_idname": "ShaderNodeAttribute", "inputs": Sockets([]),
                       "outputs": Sockets([Socket("Color"), Socket("Vector"), fac, Socket("Alpha")])})

    def sky():
        attrs = {"bl_idname": "ShaderNodeTexSky", "sky_type": "PREETHAM", "air_density": 1.0, "ozone_density": 1.0,
                 "inputs": Sockets([Socket("Vector")]), "outputs": Sockets([Socket("Color")])}
        attrs["aerosol_density" if five else "dust_density"] = 1.0
        return Strict(attrs, {"sky_type": SKY_TYPES_5 if five else SKY_TYPES_OLD})

    def output_world():
        return Strict({"bl_idname": "ShaderNodeOutputWorld", "inputs": Sockets([Socket("Surface")]),
                       "outputs": Sockets([])})

    return {"ShaderNodeVolumeScatter": scatter, "ShaderNodeMix": mix, "ShaderNodeAttribute": attribute,
            "ShaderNodeTexSky": sky, "ShaderNodeOutputWorld": output_world}


class Nodes(list):
    def __init__(self, factory):
        super().__init__()
        self.factory = factory

    def new(self, kind):
        n = self.factory[kind]()
        self.append(n)
        return n


class Tree:
    def __init__(self, factory):
        self.nodes = Nodes(factory)


def make_world(version, factory):
    five = version >= (5, 0, 0)
    attrs = {"node_tree": Tree(factory) if five else None, "use_nodes": five}
    if version >= (4, 2, 0):
        attrs["sun_threshold"] = 10.0  # verified: World.sun_threshold (rna_world.cc, 4.2+)

    def use_nodes_update(world, value):
        # 3.4–4.5: setting use_nodes creates the default tree (Background + World Output);
        # 5.0: "Setting the property has no effect" (rna_world.cc).
        a = object.__getattribute__(world, "_attrs")
        if five:
            a["use_nodes"] = True
        elif value and a["node_tree"] is None:
            a["node_tree"] = Tree(factory)
            a["node_tree"].nodes.new("ShaderNodeOutputWorld")

    return Strict(attrs, hooks={"use_nodes": use_nodes_update})


class Color(tuple):
    """mathutils.Color stand-in: scene linear = a Rec.2020 file's working space."""

    def __new__(cls, rgb):
        return tuple.__new__(cls, rgb)

    def from_rec709_linear_to_scene_linear(self):
        return Color(tuple(sum(BT2087[i][j] * self[j] for j in range(3)) for i in range(3)))


def install(monkeypatch, version, working_space="Linear Rec.709"):
    """Installs the stand-in bpy (and mathutils) and returns a fresh compat module."""
    bpy = types.ModuleType("bpy")
    bpy.app = types.SimpleNamespace(version=version)
    data = types.SimpleNamespace()
    if version >= (5, 0, 0):
        data.colorspace = Strict({"working_space": working_space}, {"working_space": WORKING_SPACES_5})
    bpy.data = data
    mathutils = types.ModuleType("mathutils")
    mathutils.Color = Color
    monkeypatch.setitem(sys.modules, "bpy", bpy)
    monkeypatch.setitem(sys.modules, "mathutils", mathutils)
    spec = importlib.util.spec_from_file_location("airmass_compat_under_test_%d_%d" % version[:2], ADDON / "compat.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module, node_factory(version)


def image(version):
    if version >= (5, 0, 0):
        names = WORKING_SPACES_5 + ["Non-Color", "sRGB"]
    elif version >= (4, 0, 0):
        names = COLORSPACES_4
    else:
        names = COLORSPACES_3
    settings = Strict({"name": names[0]}, {"name": names})
    attrs = {"colorspace_settings": settings}
    if version < (5, 0, 0):
        attrs["use_half_precision"] = True
    return Strict(attrs)


class Pixels:
    """Image.pixels: foreach_set of exactly width·height·4 values; an 8-bit buffer clamps to [0, 1]."""

    def __init__(self, count, clamp):
        self.values, self.count, self.clamp = [0.0] * count, count, clamp

    def foreach_set(self, seq):
        if len(seq) != self.count:
            raise RuntimeError("internal error setting the array")
        self.values = [min(1.0, max(0.0, float(v))) if self.clamp else float(v) for v in seq]

    def __getitem__(self, i):
        return self.values[i]


class ImageBlock(Strict):
    """A new image datablock; `fault`: "no pack" (pack() leaves packed_file None), "8 bit" (the
    buffer is bytes: values clamped, is_float False)."""

    def __init__(self, version, name, width, height, fault=None):
        base = object.__getattribute__(image(version), "_attrs")
        eight = fault == "8 bit"
        super().__init__(dict(base, name=name, size=(width, height), is_float=not eight, packed_file=None,
                              pixels=Pixels(width * height * 4, eight)))
        object.__setattr__(self, "fault", fault)
        object.__setattr__(self, "props", {})

    def pack(self):
        if object.__getattribute__(self, "fault") != "no pack":
            object.__getattribute__(self, "_attrs")["packed_file"] = object()

    def __setitem__(self, key, value):
        object.__getattribute__(self, "props")[key] = value

    def __getitem__(self, key):
        return object.__getattribute__(self, "props")[key]


class Images(list):
    """bpy.data.images: new(name, width, height, alpha, float_buffer) and remove(image)."""

    def __init__(self, version, fault=None):
        super().__init__()
        self.version, self.fault = version, fault

    def new(self, name, width, height, alpha=False, float_buffer=False):
        assert alpha and float_buffer
        img = ImageBlock(self.version, name, width, height, self.fault)
        self.append(img)
        return img

    def remove(self, img):
        list.remove(self, img)


# ---- tests -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("version", VERSIONS)
def test_float_image_colorspace(monkeypatch, version):
    compat, _ = install(monkeypatch, version)
    img = image(version)
    name = compat.set_float_image_colorspace(img)
    expected = "Linear" if version < (4, 0, 0) else "Linear Rec.709"
    assert name == expected == img.colorspace_settings.name
    compat.prepare_float_image(img)
    if version < (5, 0, 0):
        assert img.use_half_precision is False


@pytest.mark.parametrize("space", WORKING_SPACES_5)
def test_working_space_5(monkeypatch, space):
    compat, _ = install(monkeypatch, (5, 0, 0), working_space=space)
    assert compat.working_space() == space
    img = image((5, 0, 0))
    assert compat.set_float_image_colorspace(img) == space


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("data", [False, True])
def test_packed_float_image(monkeypatch, version, data):
    compat, _ = install(monkeypatch, version)
    images = sys.modules["bpy"].data.images = Images(version)
    flat = [37.5, 0.25, 2.0, 1.0] * 6  # 3 × 2 pixels: more than 1, which an 8-bit buffer clamps
    img = compat.packed_float_image("Table", 3, 2, flat, colorspace=compat.DATA_COLORSPACE if data else None,
                                    properties={"airmass_role": "sun columns"})
    assert list(images) == [img] and img.packed_file is not None and img.pixels.values == flat
    expected = "Non-Color" if data else ("Linear" if version < (4, 0, 0) else "Linear Rec.709")
    assert img.colorspace_settings.name == expected
    if version < (5, 0, 0):
        assert img.use_half_precision is False
    assert img["airmass_role"] == "sun columns"


@pytest.mark.parametrize("fault, what", [("no pack", "not packed"), ("8 bit", "not a float image")])
def test_packed_float_image_faults_remove_the_image(monkeypatch, fault, what):
    compat, _ = install(monkeypatch, (4, 2, 0))
    images = sys.modules["bpy"].data.images = Images((4, 2, 0), fault)
    with pytest.raises(RuntimeError, match="'Sky'.*check after packing.*%s" % what):
        compat.packed_float_image("Sky", 2, 1, [37.5, 0.0, 0.0, 1.0] * 2)
    assert list(images) == []
    with pytest.raises(RuntimeError, match=r"'Sky'.*colour space 'Linear'.*not found"):  # 4.x has no 'Linear'
        compat.packed_float_image("Sky", 2, 1, [0.5] * 8, colorspace="Linear")
    assert list(images) == []
    with pytest.raises(ValueError, match="'Sky': 7 values for 2x1 RGBA"):
        compat.packed_float_image("Sky", 2, 1, [0.5] * 7)
    assert list(images) == []


def test_packed_float_image_checks_pixel_0(monkeypatch):
    """A float buffer that does not give the value back (a half or clamped packing) is refused."""
    compat, _ = install(monkeypatch, (3, 4, 1))
    images = sys.modules["bpy"].data.images = Images((3, 4, 1))
    original = Pixels.foreach_set
    monkeypatch.setattr(Pixels, "foreach_set", lambda self, seq: (original(self, seq),
                                                                  self.values.__setitem__(0, 37.5 + 0.01))[0])
    with pytest.raises(RuntimeError, match="'Sky'.*pixel 0 reads back 37.51, not 37.5"):
        compat.packed_float_image("Sky", 1, 1, [37.5, 0.0, 0.0, 1.0], properties={"k": 1}, check_value=True)
    assert list(images) == []
    # without check_value (a sky: reading a pixel copies them all) the value is not read back
    img = compat.packed_float_image("Sky", 1, 1, [37.5, 0.0, 0.0, 1.0])
    assert list(images) == [img]


@pytest.mark.parametrize("version", VERSIONS)
def test_rec709_to_working_matrix(monkeypatch, version):
    import numpy as np
    compat, _ = install(monkeypatch, version, working_space="Linear Rec.2020")
    m = compat.rec709_to_working_matrix()
    if version < (5, 0, 0):
        assert m is compat.IDENTITY
        px = np.arange(24, dtype=np.float32).reshape(2, 3, 4)
        before = px.copy()
        assert compat.convert_pixels(px, m) is px and np.array_equal(px, before)
        assert compat.convert_rgb((0.2, 0.5, 1.5)) == (0.2, 0.5, 1.5)
        return
    # 5.0 in a Rec.2020 file: Blender's conversion (stand-in: BT.2087), read off on the basis.
    assert np.allclose(m, BT2087, atol=1e-12), m
    assert np.allclose(np.sum(m, axis=1), 1.0, atol=2e-4)  # white stays white (both D65)
    px = np.array([[[1.0, 0.0, 0.0, 1.0], [0.25, 0.5, 2.0, 1.0]]], dtype=np.float32)
    out = compat.convert_pixels(px.copy(), m)
    assert np.allclose(out[..., :3], px[..., :3] @ np.asarray(BT2087).T, rtol=1e-6)
    assert (out[..., 3] == 1.0).all()
    assert compat.convert_rgb((1.0, 0.0, 0.0)) == pytest.approx((0.6274, 0.0691, 0.0164))
    # A 5.0 file in Rec.709: nothing to convert.
    compat709, _ = install(monkeypatch, version, working_space="Linear Rec.709")
    assert compat709.rec709_to_working_matrix() is compat709.IDENTITY


@pytest.mark.parametrize("version", VERSIONS)
def test_ensure_node_tree(monkeypatch, version):
    compat, factory = install(monkeypatch, version)
    world = make_world(version, factory)
    tree = compat.ensure_node_tree(world)
    if version < (5, 0, 0):
        assert world.node_tree is tree is not None and world.use_nodes is True
        assert [n.bl_idname for n in tree.nodes] == ["ShaderNodeOutputWorld"]
    else:
        assert tree is world.node_tree and len(tree.nodes) == 0  # 5.0: empty, callers add the output
        assert "use_nodes" not in world.assigned  # deprecated in 5.0: never set


@pytest.mark.parametrize("version", VERSIONS)
def test_sockets(monkeypatch, version):
    compat, factory = install(monkeypatch, version)
    attr = factory["ShaderNodeAttribute"]()
    fac = compat.fac_socket(attr.outputs)
    assert fac.identifier == "Fac" and fac.name == ("Factor" if version >= (5, 0, 0) else "Fac")
    if version >= (5, 0, 0):
        with pytest.raises(KeyError):
            attr.outputs["Fac"]  # what the add-on used to do: fails in 5.0
    tree = Tree(factory)
    node, f, a, b, result = compat.new_color_mix(tree)
    assert node.data_type == "RGBA" and node.blend_type == "MIX" and node.clamp_factor is False
    assert (f.identifier, a.identifier, b.identifier, result.identifier) == \
        ("Factor_Float", "A_Color", "B_Color", "Result_Color")
    assert node.inputs["A"].identifier == "A_Float"  # a name lookup would pick the float socket
    with pytest.raises(KeyError):
        compat.find_socket(node.inputs, "Color1")


@pytest.mark.parametrize("version", VERSIONS)
def test_physical_sky(monkeypatch, version):
    compat, factory = install(monkeypatch, version)
    sky = factory["ShaderNodeTexSky"]()
    if version >= (5, 0, 0):
        assert compat.set_physical_sky(sky, aerosol_density=2.0) == "SINGLE_SCATTERING"
        assert sky.aerosol_density == 2.0
        assert compat.set_physical_sky(sky, multiple_scattering=True) == "MULTIPLE_SCATTERING"
        with pytest.raises(TypeError):
            sky.sky_type = "NISHITA"
    else:
        assert compat.set_physical_sky(sky, aerosol_density=2.0) == "NISHITA" and sky.dust_density == 2.0
        with pytest.raises(ValueError):
            compat.set_physical_sky(sky, multiple_scattering=True)


@pytest.mark.parametrize("version", VERSIONS)
def test_world_sun_extraction(monkeypatch, version):
    compat, factory = install(monkeypatch, version)
    world = make_world(version, factory)
    has = compat.set_world_sun_extraction(world, False)
    if version >= (4, 2, 0):
        assert has and world.sun_threshold == 0.0
    else:
        assert not has and "sun_threshold" not in object.__getattribute__(world, "_attrs")
    if version >= (4, 2, 0):
        world2 = make_world(version, factory)
        compat.set_world_sun_extraction(world2, True)
        assert world2.sun_threshold == 10.0  # left as the user had it


@pytest.mark.parametrize("version", VERSIONS)
def test_lights_materials_and_volume_settings(monkeypatch, version):
    compat, _ = install(monkeypatch, version)
    five = version >= (5, 0, 0)
    light = Strict({"use_shadow": False, "cycles": Strict({} if five else {"cast_shadow": False})})
    compat.set_light_shadow(light, True)
    assert light.use_shadow is True
    if not five:
        assert light.cycles.cast_shadow is True
    mat = Strict({"cycles": Strict({"volume_step_rate": 1.0} if five else
                                   {"volume_step_rate": 1.0, "homogeneous_volume": True})})
    compat.set_heterogeneous_volume(mat)
    if not five:
        assert mat.cycles.homogeneous_volume is False
    scene = types.SimpleNamespace(cycles=types.SimpleNamespace(volume_biased=False))
    assert compat.volume_ray_marching(scene) is (not five)
    scene.cycles.volume_biased = True
    assert compat.volume_ray_marching(scene) is True
    assert compat.voxel_centre_shift() is (not five)


@pytest.mark.parametrize("version", VERSIONS)
def test_scatter_phase(monkeypatch, version):
    compat, factory = install(monkeypatch, version)
    typed = version >= (4, 3, 0)
    assert compat.has_phase_types() is typed
    g_cs = 3 * 0.8 * (4 + 0.64) / (5 * (2 + 0.64))
    cases = [("rayleigh", 0.0, "RAYLEIGH", 0.0), ("cornette_shanks", 0.8, "DRAINE", 0.8),
             ("henyey_greenstein", 0.3, "HENYEY_GREENSTEIN", 0.3), ("isotropic", 0.0, "HENYEY_GREENSTEIN", 0.0)]
    for phase, g, typed_result, typed_g in cases:
        node = factory["ShaderNodeVolumeScatter"]()
        got = compat.set_scatter_phase(node, phase, g)
        anis = node.inputs["Anisotropy"].default_value
        if typed:
            assert got == typed_result == node.phase, (phase, got)
            assert anis == pytest.approx(typed_g) or typed_result == "RAYLEIGH"
            if typed_result == "DRAINE":
                assert node.inputs["Alpha"].default_value == 1.0  # α = 1: exactly Cornette–Shanks
        else:
            assert got == "HENYEY_GREENSTEIN"
            with pytest.raises(AttributeError):
                node.phase = "RAYLEIGH"  # 3.4–4.2 have no phase enum
            expected = g_cs if phase == "cornette_shanks" else g
            assert anis == pytest.approx(expected, rel=1e-12), (phase, anis)
    earth = [("rayleigh", 0.0), ("cornette_shanks", 0.8)]
    assert compat.needs_phase_dither(earth) is (not typed)
    assert compat.needs_phase_dither([("rayleigh", 0.0), ("isotropic", 0.0)]) is False
    assert compat.exact_phase("rayleigh") is typed and compat.exact_phase("henyey_greenstein") is True


def test_no_version_checks_outside_compat():
    """Only compat.py looks at bpy.app.version."""
    offenders = []
    for path in sorted(ADDON.glob("*.py")):
        if path.name in ("compat.py",):
            continue
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if "bpy.app.version" in line:
                offenders.append("%s:%d" % (path.name, i))
    assert not offenders, offenders


# ---- native.py: the library file per platform ------------------------------------------------------

def load_native(monkeypatch, folder):
    spec = importlib.util.spec_from_file_location("airmass_native_under_test", ADDON / "native.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "__file__", str(folder / "native.py"))
    monkeypatch.delenv(module.LIBRARY_ENV, raising=False)
    return module


def test_library_names():
    spec = importlib.util.spec_from_file_location("airmass_native_names", ADDON / "native.py")
    native = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(native)
    # The ctypes mirror declares the version the C header defines (never a number kept here).
    header = (ADDON.parents[1] / "plugin" / "capi" / "include" / "airmass" / "airmass_c.h").read_text()
    declared = int(re.search(r"#define AIRMASS_C_ABI_VERSION (\d+)", header).group(1))
    assert native.ABI_VERSION == declared
    assert native.library_name("linux") == "libairmass_c.so"
    assert native.library_name("win32") == "airmass_c.dll"
    assert native.library_name("darwin") == "libairmass_c.dylib"


def test_macos_without_library(monkeypatch, tmp_path):
    native = load_native(monkeypatch, tmp_path)
    with pytest.raises(native.LibraryLoadError) as e:
        native._load(platform="darwin")
    msg = str(e.value)
    assert "this build of the add-on carries no macOS library" in msg and "build from source" in msg, msg
    # With the override set the usual "not found" message names the path instead.
    monkeypatch.setenv(native.LIBRARY_ENV, str(tmp_path / "custom.dylib"))
    with pytest.raises(native.LibraryLoadError) as e:
        native._load(platform="darwin")
    assert "not found at" in str(e.value) and "custom.dylib" in str(e.value)


def test_macos_with_dylib_beside(monkeypatch, tmp_path):
    native = load_native(monkeypatch, tmp_path)
    (tmp_path / "libairmass_c.dylib").write_bytes(b"not a Mach-O file")
    opened = []

    def fake_cdll(path):
        opened.append(path)
        raise OSError("dlopen(%s): not a mach-o file" % path)

    monkeypatch.setattr(native.ctypes, "CDLL", fake_cdll)
    with pytest.raises(native.LibraryLoadError) as e:
        native._load(platform="darwin")
    assert opened == [str(tmp_path / "libairmass_c.dylib")]
    assert "failed to load" in str(e.value) and "OpenImageIO" not in str(e.value)


def test_windows_adds_dll_directory_first(monkeypatch, tmp_path):
    native = load_native(monkeypatch, tmp_path)
    (tmp_path / "airmass_c.dll").write_bytes(b"MZ")
    calls = []

    def add_dll_directory(folder):
        calls.append(("add_dll_directory", folder))
        return object()

    def fake_cdll(path):
        calls.append(("CDLL", path))
        raise OSError("[WinError 193] %1 is not a valid Win32 application")

    monkeypatch.setattr(native.os, "add_dll_directory", add_dll_directory, raising=False)
    monkeypatch.setattr(native.ctypes, "CDLL", fake_cdll)
    with pytest.raises(native.LibraryLoadError) as e:
        native._load(platform="win32")
    assert calls == [("add_dll_directory", str(tmp_path)), ("CDLL", str(tmp_path / "airmass_c.dll"))], calls
    assert "WinError 193" in str(e.value)


def test_linux_load_error_has_no_dependency_hint(monkeypatch, tmp_path):
    native = load_native(monkeypatch, tmp_path)
    (tmp_path / "libairmass_c.so").write_bytes(b"garbage")
    with pytest.raises(native.LibraryLoadError) as e:
        native._load(platform="linux")
    msg = str(e.value)
    assert "failed to load" in msg and "OpenImageIO" not in msg and "TBB" not in msg, msg
