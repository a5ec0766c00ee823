"""Tests of the Python package against the command line and the scene files' errors.

Run by scripts/test.sh, which builds the command line and sets PRISMATIC_BIN to it.
"""

import os
import signal
import struct
import subprocess
import sys
import threading
import zlib
from pathlib import Path

import numpy as np
import pytest

import prismatic

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenes" / "cornell-glass.pbrt"


def cli_binary():
    path = os.environ.get("PRISMATIC_BIN", str(ROOT / "target" / "quick-release" / "prismatic"))
    assert Path(path).is_file(), f"no prismatic binary at {path}: build it (scripts/test.sh does) or set PRISMATIC_BIN"
    return path


def read_pfm(path):
    """A PFM file as height x width x 3 float32, rows from the top."""
    data = Path(path).read_bytes()
    magic, size, scale, pixels = data.split(b"\n", 3)
    assert magic == b"PF"
    w, h = map(int, size.split())
    dtype = "<f4" if float(scale) < 0 else ">f4"
    return np.frombuffer(pixels, dtype=dtype).reshape(h, w, 3)[::-1]


def read_png_rgb8(path, width, height):
    """The pixels of an 8-bit RGB PNG as height x width x 3 uint8 (zlib and the PNG row filters, no imaging
    library needed)."""
    data = Path(path).read_bytes()
    idat, i = b"", 8
    while i < len(data):
        n, kind = struct.unpack(">I4s", data[i:i + 8])
        if kind == b"IDAT":
            idat += data[i + 8:i + 8 + n]
        i += 12 + n
    raw = zlib.decompress(idat)
    stride = width * 3
    rows, prev = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - 3] if x >= 3 else 0
            b = prev[x]
            c = prev[x - 3] if x >= 3 else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prev = line
    return np.frombuffer(b"".join(rows), dtype=np.uint8).reshape(height, width, 3)


def test_render_equals_the_command_line_bit_for_bit(tmp_path):
    scene = prismatic.load(SCENE)
    for seed in (1, 7):
        image = scene.render(spp=4, resolution=(48, 36), seed=seed)
        out = tmp_path / f"cli-{seed}.pfm"
        subprocess.run(
            [cli_binary(), "render", str(SCENE), "--spp", "4", "--resolution", "48x36", "--seed", str(seed),
             "--quiet", "-o", str(out)],
            check=True,
        )
        cli = read_pfm(out)
        assert image.rgb.shape == (36, 48, 3) and image.rgb.dtype == np.float32
        assert (image.width, image.height, image.spp) == (48, 36, 4)
        assert image.rgb.mean() > 0.01, "a black image would match trivially"
        assert np.array_equal(image.rgb, cli), f"seed {seed}: max difference {np.abs(image.rgb - cli).max()}"


def test_threads_and_strategies_and_rebuilds():
    scene = prismatic.load(SCENE)
    a = scene.render(spp=2, resolution=(32, 24), seed=3)
    b = scene.render(spp=2, resolution=(32, 24), seed=3, threads=1)
    assert np.array_equal(a.rgb, b.rgb), "one thread and all cores give the same image"
    c = scene.render(spp=2, resolution=(32, 24), seed=4, wavelengths="cmf")
    assert not np.array_equal(a.rgb, c.rgb)
    assert scene.builds == 1, "another seed, thread count or strategy builds nothing"
    assert a.stats["shapes_built"] and a.stats["build_seconds"] > 0
    assert b.stats["build_seconds"] == 0 and not b.stats["shapes_built"]
    d = scene.render(spp=2, resolution=(16, 12), seed=3)
    assert scene.builds == 1, "another resolution builds the film and camera, not the shapes"
    assert d.stats["build_seconds"] > 0 and not d.stats["shapes_built"]
    assert np.array_equal(d.rgb, prismatic.load(SCENE).render(spp=2, resolution=(16, 12), seed=3).rgb)


def test_loads_resolves_files_from_base_dir():
    text = (SCENE.read_text())
    scene = prismatic.loads(text, base_dir=SCENE.parent)
    a = scene.render(spp=1, resolution=(16, 12), seed=2)
    b = prismatic.load(SCENE).render(spp=1, resolution=(16, 12), seed=2)
    assert np.array_equal(a.rgb, b.rgb)
    assert scene.path is None and prismatic.load(SCENE).path == str(SCENE)


def test_scene_errors_say_where():
    with pytest.raises(prismatic.SceneError) as e:
        prismatic.loads('WorldBegin\nShape "sphere" "float radius" "x"\n')
    assert (e.value.file, e.value.line, e.value.column) == ("<string>", 2, 31)
    assert "float radius" in e.value.message
    # An error found when building (an unknown shape type) is raised by render, with its place.
    scene = prismatic.loads('WorldBegin\n\nShape "blob"\n')
    with pytest.raises(prismatic.SceneError) as e:
        scene.render(spp=1, resolution=(8, 8))
    assert (e.value.file, e.value.line) == ("<string>", 3) and "blob" in e.value.message
    with pytest.raises(prismatic.SceneError) as e:
        prismatic.load(ROOT / "no-such-scene.pbrt")
    assert e.value.file.endswith("no-such-scene.pbrt")


@pytest.mark.parametrize(
    "options, error, name",
    [
        (dict(spp=0), ValueError, "spp"),
        (dict(spp="4"), TypeError, "spp"),
        (dict(resolution=(0, 10)), ValueError, "resolution"),
        (dict(resolution=(8,)), TypeError, "resolution"),
        (dict(threads=0), ValueError, "threads"),
        (dict(seed=-1), ValueError, "seed"),
        (dict(wavelengths="blue"), ValueError, "wavelengths"),
    ],
)
def test_bad_options_name_the_parameter(options, error, name):
    scene = prismatic.load(SCENE)
    with pytest.raises(error) as e:
        scene.render(**options)
    assert name in str(e.value)


def test_the_gil_is_released_while_rendering():
    scene = prismatic.load(SCENE)
    scene.render(spp=1, resolution=(8, 8))  # builds outside the measured render
    ticks = 0
    done = threading.Event()

    def count():
        nonlocal ticks
        while not done.is_set():
            ticks += 1

    worker = threading.Thread(target=count)
    worker.start()
    try:
        before = ticks
        scene.render(spp=64, resolution=(8, 8), threads=1)
        during = ticks - before
    finally:
        done.set()
        worker.join()
    assert during > 1000, f"the Python thread ran {during} times during the render"


def test_save_writes_what_the_command_line_writes(tmp_path):
    scene = prismatic.load(SCENE)
    image = scene.render(spp=2, resolution=(24, 16), seed=5)
    image.save(tmp_path / "py.pfm")
    subprocess.run(
        [cli_binary(), "render", str(SCENE), "--spp", "2", "--resolution", "24x16", "--seed", "5", "--quiet",
         "-o", str(tmp_path / "cli.pfm")],
        check=True,
    )
    assert (tmp_path / "py.pfm").read_bytes() == (tmp_path / "cli.pfm").read_bytes()
    image.save(tmp_path / "py.png")
    assert (tmp_path / "py.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(OSError) as e:
        image.save(tmp_path / "py.bmp")
    assert "bmp" in str(e.value)


SPECTRAL = """LookAt 0 0 -5  0 0 0  0 1 0
Camera "perspective" "float fov" 30
Film "spectral" "integer xresolution" 12 "integer yresolution" 8 "integer nbuckets" 10
    "float lambdamin" 400 "float lambdamax" 700
WorldBegin
LightSource "infinite" "blackbody L" 5000
Material "dielectric" "string glass" "N-SF11"
Shape "sphere" "float radius" 1
"""


def test_a_spectral_film_gives_its_buckets():
    image = prismatic.loads(SPECTRAL).render(spp=4, seed=1)
    assert image.spectral.shape == (8, 12, 10) and image.spectral.dtype == np.float32
    assert np.allclose(image.wavelengths, np.linspace(400, 700, 11))
    assert (image.spectral >= 0).all() and image.spectral.mean() > 0
    assert prismatic.load(SCENE).render(spp=1, resolution=(8, 8)).spectral is None


def test_progress_is_reported_after_each_pass():
    calls = []
    prismatic.load(SCENE).render(spp=40, resolution=(8, 8), progress=lambda done, total: calls.append((done, total)))
    assert calls[-1] == (40, 40) and all(t == 40 for _, t in calls)
    assert [d for d, _ in calls] == sorted(d for d, _ in calls) and len(calls) >= 2
    with pytest.raises(TypeError):
        prismatic.load(SCENE).render(spp=1, progress=3)

    def stop(done, total):
        raise RuntimeError(f"stopped at {done}")

    with pytest.raises(RuntimeError) as e:
        prismatic.load(SCENE).render(spp=40, resolution=(8, 8), progress=stop)
    assert e.value.image.spp == 1, "the first pass is one sample per pixel"


def test_ctrl_c_stops_at_the_end_of_a_pass_with_the_partial_image():
    scene = prismatic.load(SCENE)
    scene.render(spp=1, resolution=(16, 16))  # built before the clock starts
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt) as e:
            scene.render(spp=1 << 14, resolution=(16, 16), threads=1)
    finally:
        timer.cancel()
    partial = e.value.image
    assert 0 < partial.spp < 1 << 14
    assert partial.rgb.mean() > 0.01


def test_the_display_image_is_the_command_line_png(tmp_path):
    scene = prismatic.load(SCENE)
    image = scene.render(spp=2, resolution=(24, 16), seed=5)
    image.save(tmp_path / "py.png")
    assert image._repr_png_() == (tmp_path / "py.png").read_bytes()
    shown = image.display()
    assert shown.shape == (16, 24, 3) and shown.dtype == np.uint8 and shown.max() > 0
    clipped = image.display(view="clip")
    assert not np.array_equal(shown, clipped)
    png_pixels = read_png_rgb8(tmp_path / "py.png", 24, 16)
    assert np.array_equal(shown, png_pixels)
    with pytest.raises(ValueError) as e:
        image.display(view="sepia")
    assert "view" in str(e.value)


def test_ior_is_the_catalogue_sellmeier_and_metal_tables():
    # SCHOTT's Sellmeier coefficients for N-BK7 (wavelength in micrometres).
    b = (1.03961212, 0.231792344, 1.01046945)
    c = (0.00600069867, 0.0200179144, 103.560653)
    lam = np.array([[404.7, 486.1], [587.5618, 656.3]])
    l2 = (lam / 1000) ** 2
    expected = np.sqrt(1 + sum(bi * l2 / (l2 - ci) for bi, ci in zip(b, c)))
    n = prismatic.ior("N-BK7", lam)
    assert n.shape == (2, 2) and np.allclose(n, expected, rtol=0, atol=1e-7)
    assert np.ndim(prismatic.ior("N-BK7", 587.5618)) == 0
    assert abs(prismatic.ior("N-BK7", 587.5618) - 1.5168) < 1e-6
    gold = prismatic.ior("Au", 550)  # Johnson & Christy 1972, the table's row at 550 nm
    assert np.iscomplexobj(gold) and abs(gold - (0.42415 + 2.4721j)) < 1e-9
    with pytest.raises(ValueError) as e:
        prismatic.ior("N-BK8", 550)
    assert "N-BK7" in str(e.value), "close matches are suggested"
    with pytest.raises(ValueError) as e:
        prismatic.ior("N-BK7", [550, -1])
    assert "nm" in str(e.value)
    with pytest.raises(TypeError) as e:
        prismatic.ior("N-BK7", "green")
    assert "nm" in str(e.value)
    entries = {m["name"]: m for m in prismatic.catalogue()}
    assert abs(entries["N-BK7"]["nd"] - 1.5168) < 1e-4 and abs(entries["N-BK7"]["vd"] - 64.17) < 0.01
    assert entries["Au"]["nd"] is None and entries["Au"]["category"] == "metal"


def resident_bytes():
    """The process's resident set size now (Linux)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE")


def test_fifty_renders_do_not_leak():
    scene = prismatic.load(SCENE)
    for _ in range(5):  # the allocator's and the thread pool's steady state
        scene.render(spp=1, resolution=(128, 128), seed=1).rgb.sum()
    before = resident_bytes()
    for seed in range(50):
        image = scene.render(spp=1, resolution=(128, 128), seed=seed)
        image.display()
        del image
    grown = resident_bytes() - before
    # A film of 128×128 pixels is about 0.5 MB: keeping each would grow the process by about 26 MB.
    assert grown < 8 << 20, f"resident memory grew by {grown / 2**20:.1f} MB over 50 renders"


def test_two_threads_can_render_one_scene_with_different_options():
    # One thread builds (holding the scene's build lock) while the others wait for it: waiting must not hold the
    # GIL, or the builder could never return. Run in a child process, so that a deadlock fails within a minute.
    code = f"""
import threading, prismatic
scene = prismatic.load({str(SCENE)!r})
results = {{}}
def render(size):
    results[size] = scene.render(spp=1, resolution=(size, size), seed=2).rgb.shape
workers = [threading.Thread(target=render, args=(size,)) for size in (8, 12, 16, 20)]
for w in workers:
    w.start()
for w in workers:
    w.join()
assert results == {{s: (s, s, 3) for s in (8, 12, 16, 20)}}, results
"""
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


def test_a_gltf_file_renders_as_the_command_line_renders_it(tmp_path):
    gem = ROOT / "scenes" / "gltf" / "gem.glb"
    scene = prismatic.load(gem)
    image = scene.render(spp=2, resolution=(56, 42), seed=3, integrator='"path" "integer maxdepth" 12')
    out = tmp_path / "gem.pfm"
    subprocess.run([cli_binary(), "render", str(gem), "--spp", "2", "--resolution", "56x42", "--seed", "3",
                    "--integrator", '"path" "integer maxdepth" 12', "--quiet", "-o", str(out)], check=True)
    assert image.rgb.mean() > 0.005 and np.array_equal(image.rgb, read_pfm(out))
    with pytest.raises(prismatic.SceneError) as e:
        prismatic.load(gem, camera="nope")
    assert "no camera named or numbered 'nope'" in str(e.value) and e.value.file.endswith("gem.glb")
    with pytest.raises(ValueError, match="camera"):
        prismatic.load(SCENE, camera="front")
