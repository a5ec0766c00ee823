"""Render options (crop, integrator, time limit, AOVs, statistics, progress bars), edits between renders that keep
the BVH, and the optics and colour tools, against the command line and closed forms."""

import math
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

import prismatic
from test_render import ROOT, SCENE, cli_binary, read_pfm

# A study's scene: a named glass ball on a floor in fog, lit by a distant light and a small area light.
STUDY = """
LookAt 0 1 -4  0 0.5 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 32 "integer yresolution" 24 "string filename" "x.exr"
Sampler "zsobol" "integer pixelsamples" 4
Integrator "volpath" "integer maxdepth" 8
WorldBegin
LightSource "distant" "point3 from" [ 1 4 -2 ] "blackbody L" 5500 "float scale" 2
MakeNamedMedium "fog" "string type" "homogeneous" "rgb sigma_a" [ 0.01 0.01 0.01 ] "rgb sigma_s" [ 0.05 0.05 0.05 ]
MediumInterface "" "fog"
Texture "checks" "spectrum" "checkerboard" "float uscale" 8 "float vscale" 8
MakeNamedMaterial "ball" "string type" "dielectric" "spectrum eta" "glass-BK7"
AttributeBegin
  NamedMaterial "ball"
  Translate 0 0.5 0
  Shape "sphere" "float radius" 0.5
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "blackbody L" 4000
  Translate 0 3 0
  Rotate 90 1 0 0
  Shape "disk" "float radius" 0.3
AttributeEnd
Material "diffuse" "texture reflectance" "checks"
Shape "trianglemesh" "point3 P" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5 ] "integer indices" [ 0 1 2  0 2 3 ]
  "point2 uv" [ 0 0 1 0 1 1 0 1 ]
"""


def study(replace=None):
    text = STUDY
    for old, new in (replace or {}).items():
        assert old in text
        text = text.replace(old, new)
    return prismatic.loads(text, base_dir=ROOT)


def test_a_crop_holds_the_pixels_of_the_full_render(tmp_path):
    scene = prismatic.load(SCENE)
    full = scene.render(spp=2, resolution=(40, 30), seed=5)
    crop = scene.render(spp=2, resolution=(40, 30), seed=5, crop=(0.25, 0.75, 0.5, 1.0))
    assert crop.bounds == (10, 30, 15, 30) and crop.rgb.shape == (15, 20, 3)
    assert np.array_equal(crop.rgb, full.rgb[15:30, 10:30])
    out = tmp_path / "crop.pfm"
    subprocess.run([cli_binary(), "render", str(SCENE), "--spp", "2", "--resolution", "40x30", "--seed", "5",
                    "--cropwindow", "0.25", "0.75", "0.5", "1", "--quiet", "-o", str(out)], check=True)
    assert np.array_equal(crop.rgb, read_pfm(out))
    for bad in [(0.5, 0.25, 0, 1), (0, 1, 0, 1.5)]:
        with pytest.raises(ValueError, match="crop"):
            scene.render(crop=bad)
    with pytest.raises(TypeError, match="crop"):
        scene.render(crop=(0, 1))


def test_the_integrator_option_replaces_the_scenes():
    scene = prismatic.load(SCENE)
    text = SCENE.read_text()
    assert 'Integrator "path" "integer maxdepth" 12' in text
    for option, directive in [("volpath", '"volpath"'), ('"bdpt" "integer maxdepth" 3', '"bdpt" "integer maxdepth" 3')]:
        image = scene.render(spp=2, resolution=(24, 18), seed=1, integrator=option)
        same = prismatic.loads(text.replace('"path" "integer maxdepth" 12', directive), base_dir=SCENE.parent)
        expected = same.render(spp=2, resolution=(24, 18), seed=1)
        assert image.stats["integrator"] == expected.stats["integrator"] != "path"
        assert np.array_equal(image.rgb, expected.rgb)
    assert scene.builds == 1, "another integrator keeps the BVH"
    # Without the option, the scene's integrator again.
    assert scene.render(spp=1, resolution=(24, 18)).stats["integrator"] == "path"
    with pytest.raises(ValueError, match="integrator"):
        scene.render(integrator="pathh")
    with pytest.raises(ValueError, match="integrator"):
        scene.render(integrator='"path" "integer maxdepth"')
    with pytest.raises(TypeError, match="integrator"):
        scene.render(integrator=3)


def test_a_time_limit_stops_at_a_pass_with_the_image_of_that_many_samples():
    scene = prismatic.load(SCENE)
    image = scene.render(resolution=(16, 12), seed=2, time_limit=0.3)
    assert image.spp >= 1 and image.stats["spp_requested"] is None
    assert 0.3 <= image.stats["render_seconds"] < 5
    assert np.array_equal(image.rgb, scene.render(spp=image.spp, resolution=(16, 12), seed=2).rgb)
    # With spp, whichever comes first.
    assert scene.render(spp=3, resolution=(16, 12), time_limit=60).spp == 3
    for bad in (0, -1, float("nan")):
        with pytest.raises(ValueError, match="time_limit"):
            scene.render(time_limit=bad)


def test_statistics_count_samples_and_rays():
    image = prismatic.load(SCENE).render(spp=3, resolution=(20, 10), threads=2)
    s = image.stats
    assert s["samples"] == 20 * 10 * 3 and s["rays"] >= s["samples"]
    assert s["samples_per_second"] == pytest.approx(s["samples"] / s["render_seconds"])
    assert (s["spp"], s["spp_requested"], s["threads"], s["wavelengths"]) == (3, 3, 2, "hero")
    assert s["lights"] >= 1 and s["triangles"] >= 10


def test_aovs_hold_the_first_visible_surface():
    scene = prismatic.load(SCENE)
    plain = scene.render(spp=16, resolution=(24, 24), seed=1)
    assert plain.aovs == {}
    image = scene.render(spp=16, resolution=(24, 24), seed=1, aovs=True)
    assert np.array_equal(image.rgb, plain.rgb), "recording AOVs does not change the image"
    a = image.aovs
    assert set(a) == {"albedo", "normal", "position", "geometric_normal", "dzdxy", "uv", "variance",
                      "relative_variance"}
    assert a["albedo"].shape == (24, 24, 3) and a["dzdxy"].shape == (24, 24, 2)
    length = np.linalg.norm(a["normal"], axis=2)
    assert np.allclose(length[length > 0], 1, atol=1e-5) and (length > 0).mean() > 0.9
    # In camera space (x right, y up, z ahead): the ceiling's normal points down, the back wall's towards the
    # camera, the left (red) wall's to the right; the back wall lies ahead.
    assert np.allclose(a["normal"][1, 12], [0, -1, 0], atol=1e-4)
    assert np.allclose(a["normal"][10, 12], [0, 0, -1], atol=1e-4) and a["position"][10, 12, 2] > 0
    assert np.allclose(a["normal"][12, 1], [1, 0, 0], atol=1e-4)
    # Albedos: the back wall's "rgb reflectance" 0.73, the red wall's 0.63 0.065 0.05 (each sample records the
    # albedo at its few wavelengths: the mean over a block).
    assert np.allclose(a["albedo"][7:13, 8:16].reshape(-1, 3).mean(0), 0.73, atol=0.015)
    assert np.allclose(a["albedo"][8:15, 0:3].reshape(-1, 3).mean(0), [0.63, 0.065, 0.05], atol=0.015)


def test_progress_true_draws_a_tqdm_bar(monkeypatch):
    updates, closed = [], []

    class Bar:
        def __init__(self, total=None, unit=None, desc=None):
            self.total = total

        def update(self, n):
            updates.append(n)

        def close(self):
            closed.append(self.total)

    fake = types.ModuleType("tqdm.auto")
    fake.tqdm = Bar
    monkeypatch.setitem(sys.modules, "tqdm", types.ModuleType("tqdm"))
    monkeypatch.setitem(sys.modules, "tqdm.auto", fake)
    prismatic.load(SCENE).render(spp=20, resolution=(8, 8), progress=True)
    assert sum(updates) == 20 and closed == [20] and len(updates) >= 2
    # Without tqdm, progress=True is quiet.
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)
    assert prismatic.load(SCENE).render(spp=2, resolution=(8, 8), progress=True).spp == 2


def test_edits_render_what_the_edited_file_renders_and_keep_the_bvh():
    scene = study()
    assert scene.materials == {0: "diffuse", 1: "diffuse", "ball": "dielectric"}
    assert scene.media == {"fog": "homogeneous"} and scene.lights == ["distant"]
    before = scene.render(spp=2, seed=1)
    edits = [
        (lambda s: s.set_material("ball", "dielectric", '"spectrum eta" "glass-F11"'),
         {'"spectrum eta" "glass-BK7"': '"spectrum eta" "glass-F11"'}),
        (lambda s: s.set_material("ball", "diffuse", '"texture reflectance" "checks"'),
         {'"string type" "dielectric" "spectrum eta" "glass-BK7"': '"string type" "diffuse" "texture reflectance" "checks"'}),
        (lambda s: s.set_material(1, "conductor", '"float roughness" 0.2'),
         {'Material "diffuse" "texture reflectance" "checks"': 'Material "conductor" "float roughness" 0.2'}),
        (lambda s: s.set_medium("fog", "homogeneous", '"rgb sigma_a" [ 0.2 0.1 0.05 ] "rgb sigma_s" [ 0.3 0.3 0.3 ]'),
         {'"rgb sigma_a" [ 0.01 0.01 0.01 ] "rgb sigma_s" [ 0.05 0.05 0.05 ]':
          '"rgb sigma_a" [ 0.2 0.1 0.05 ] "rgb sigma_s" [ 0.3 0.3 0.3 ]'}),
        (lambda s: s.set_light(0, "distant", '"point3 from" [ -2 3 -1 ] "blackbody L" 3000'),
         {'"point3 from" [ 1 4 -2 ] "blackbody L" 5500 "float scale" 2': '"point3 from" [ -2 3 -1 ] "blackbody L" 3000'}),
    ]
    for edit, replace in edits:
        scene = study()
        scene.render(spp=2, seed=1)
        edit(scene)
        image = scene.render(spp=2, seed=1)
        assert scene.builds == 1, replace
        assert not image.stats["shapes_built"]
        assert not np.array_equal(image.rgb, before.rgb), f"the edit changed nothing: {replace}"
        assert np.array_equal(image.rgb, study(replace).render(spp=2, seed=1).rgb), replace


def test_an_edit_that_changes_what_the_bvh_records_builds_the_shapes_again():
    scene = study()
    scene.render(spp=1, seed=1)
    scene.set_material("ball", "interface")
    image = scene.render(spp=1, seed=1)
    assert scene.builds == 2, "the edit built the shapes again"
    assert image.stats["build_seconds"] == 0, "the edit built the scene the render uses"
    replace = {'"string type" "dielectric" "spectrum eta" "glass-BK7"': '"string type" "interface"'}
    assert np.array_equal(image.rgb, study(replace).render(spp=1, seed=1).rgb)


def test_a_bad_edit_is_refused_and_leaves_the_scene_as_it_was():
    scene = study()
    before = scene.render(spp=1, seed=3)
    with pytest.raises(KeyError, match="no material named 'bal'"):
        scene.set_material("bal", "diffuse")
    with pytest.raises(IndexError):
        scene.set_material(7, "diffuse")
    with pytest.raises(TypeError):
        scene.set_material(1.5, "diffuse")
    with pytest.raises(ValueError, match="dielectrc"):
        scene.set_material("ball", "dielectrc")
    with pytest.raises(ValueError, match=r"params \(column 1\)"):
        scene.set_material("ball", "dielectric", '"flot eta" 1.5')
    with pytest.raises(ValueError, match="no texture named 'dots'"):
        scene.set_material("ball", "diffuse", '"texture reflectance" "dots"')
    with pytest.raises(ValueError, match="type"):
        scene.set_material("ball", 'dielectric" "x')
    with pytest.raises(KeyError):
        scene.set_medium("smoke", "homogeneous")
    with pytest.raises(IndexError):
        scene.set_light(1, "point")
    with pytest.raises(ValueError, match="params"):
        scene.set_light(0, "distant", '"float scale" 1 "blackbody L" 0')
    with pytest.raises(ValueError, match="set_light 0"):
        scene.set_light(0, "laser")
    assert np.array_equal(scene.render(spp=1, seed=3).rgb, before.rgb)
    assert scene.materials["ball"] == "dielectric" and scene.builds == 1


def cli(*args):
    return subprocess.run([cli_binary(), *args], check=True, capture_output=True, text=True).stdout


def test_prism_deviation_is_the_command_lines_and_the_closed_form():
    nm = [450.0, 550.0, 650.0]
    d = prismatic.prism_deviation("N-SF11", nm, apex=60)
    n = prismatic.ior("N-SF11", nm)
    assert np.allclose(d, np.degrees(2 * np.arcsin(n * math.sin(math.radians(30))) - math.radians(60)), atol=1e-12)
    out = cli("ior", "N-SF11", "--prism", "60", "--nm", *map(str, nm))
    printed = [float(line.split("=")[1].strip().rstrip("°")) for line in out.splitlines() if " D = " in line]
    assert len(printed) >= 3 and np.allclose(sorted(printed[:3]), sorted(d), atol=1e-3), out
    assert prismatic.prism_deviation(1.5) == pytest.approx(37.18075578, abs=1e-7)
    assert math.isnan(prismatic.prism_deviation(2.5))
    assert prismatic.prism_deviation([1.5, 2.0]).shape == (2,)
    with pytest.raises(ValueError, match="apex"):
        prismatic.prism_deviation(1.5, apex=200)
    with pytest.raises(TypeError, match="nm"):
        prismatic.prism_deviation("N-BK7")
    with pytest.raises(ValueError, match="metal"):
        prismatic.prism_deviation("Au", 550)


def test_rainbow_angles_are_descartes():
    assert prismatic.rainbow_angle(1.333) == pytest.approx(42.08, abs=0.01)
    assert prismatic.rainbow_angle(1.333, order=2) == pytest.approx(50.89, abs=0.01)
    red, violet = prismatic.rainbow_angle("water", [700, 400])
    assert red > violet, "red outside in the primary bow"
    # The same as a numerical minimum of the deviation D(i) = 180 + 2i - 4r over incidence angles.
    n = float(prismatic.ior("water", 550))
    i = np.linspace(0, math.pi / 2, 200001)
    r = np.arcsin(np.sin(i) / n)
    dmin = np.degrees(np.min(math.pi + 2 * i - 4 * r))
    assert prismatic.rainbow_angle("water", 550) == pytest.approx(180 - dmin, abs=1e-6)
    assert math.isnan(prismatic.rainbow_angle(1.0))
    with pytest.raises(ValueError, match="order"):
        prismatic.rainbow_angle(1.33, order=0)


def test_spectra_have_the_colours_the_command_line_prints():
    d65 = prismatic.spectrum("stdillum-D65")
    x, y = d65.xy()
    assert (round(x, 4), round(y, 4)) == (0.3127, 0.3290)
    assert d65.xyz()[1] == pytest.approx(1.0, abs=1e-9)
    for spec, under in [("blackbody:3000", None), ("rgb:0.8,0.2,0.1", "stdillum-A"), ("glass-BK7", None)]:
        args = ["spectrum", spec] + (["--under", under] if under else [])
        lines = {line[:12].strip(): line[12:].split() for line in cli(*args).splitlines()}
        s = prismatic.spectrum(spec)
        assert np.allclose(s.xyz(under=under), [float(v) for v in lines["XYZ"]], atol=2e-6)
        assert np.allclose(s.rgb(under=under), [float(v) for v in lines["linear srgb"]], atol=2e-6)
    # From samples: a constant 1 has Y = 1 and the equal-energy white point.
    flat = prismatic.spectrum([360, 830], [1, 1])
    assert flat.xyz()[1] == pytest.approx(1.0, abs=1e-9)
    assert np.allclose(flat.xy(), (1 / 3, 1 / 3), atol=2e-4)
    assert np.allclose(flat(np.array([400.0, 500.0])), 1)
    # A reflectance of 1 under any light is that light's white, Y = 1.
    assert flat.xyz(under=d65) == pytest.approx(d65.xyz(), abs=1e-6)
    with pytest.raises(ValueError, match="spec"):
        prismatic.spectrum("stdillum-D66")
    with pytest.raises(ValueError):
        prismatic.spectrum([500, 400], [1, 1])
    with pytest.raises(ValueError, match="observer"):
        d65.xyz(observer="cie2000")
    with pytest.raises(ValueError, match="colorspace"):
        d65.rgb(colorspace="adobe")


def test_spectral_buckets_and_aovs_equal_the_command_lines_exr(tmp_path):
    openexr = pytest.importorskip("OpenEXR")
    from test_render import SPECTRAL

    path = tmp_path / "spectral.pbrt"
    path.write_text(SPECTRAL)
    out = tmp_path / "cli.exr"
    subprocess.run([cli_binary(), "render", str(path), "--spp", "4", "--seed", "1", "--aovs", "--quiet", "-o", str(out)],
                   check=True)
    image = prismatic.load(path).render(spp=4, seed=1, aovs=True)
    with openexr.File(str(out)) as f:
        channels = {name: c.pixels for name, c in f.channels().items()}
    assert np.array_equal(image.rgb, channels["RGB"])
    centres = (image.wavelengths[:-1] + image.wavelengths[1:]) / 2
    for b, centre in enumerate(centres):
        name = f"S0.{centre:.6f}nm".replace(".", ",").replace(",", ".", 1)
        assert np.array_equal(image.spectral[:, :, b], channels[name]), name
    assert image.spectral.mean() > 0
    a = image.aovs
    assert np.array_equal(a["albedo"], channels["Albedo"])
    assert np.array_equal(a["variance"], channels["Variance"])
    assert np.array_equal(a["relative_variance"], channels["RelativeVariance"])
    for key, names in [("normal", ["Ns.X", "Ns.Y", "Ns.Z"]), ("geometric_normal", ["N.X", "N.Y", "N.Z"]),
                       ("position", ["P.X", "P.Y", "P.Z"]), ("dzdxy", ["dzdx", "dzdy"]), ("uv", ["u", "v"])]:
        assert np.array_equal(a[key], np.stack([channels[n] for n in names], axis=2)), key


def test_the_arrays_are_handed_out_without_copies():
    image = prismatic.load(SCENE).render(spp=1, resolution=(16, 8), aovs=True)
    assert image.rgb is image.rgb and image.aovs["albedo"] is image.aovs["albedo"]
