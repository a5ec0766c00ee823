"""Builds glTF test and gallery scenes with Blender (the `bpy` module, CPython 3.13: `pip install bpy`) and exports
them with Blender's own glTF exporter, so that Prismatic is tested on what Blender writes.

    python3.13 scenes/tools/gltf_scenes.py            # writes the files below

- scenes/gltf/gem.glb: the brilliant-cut diamond of scenes/diamond.pbrt (scenes/meshes/diamond.ply) as a
  KHR_materials_dispersion glass (n_d 2.4175, V_d 55.3: dispersion 20/55.3), under the same emissive softboxes
  (a disc above, six strips around) and seen by the same camera: its fire comes from the dispersion alone.
- crates/prismatic/tests/fixtures/gltf/dispersive-prism.glb: the equilateral N-SF11-like prism of the caustics
  tests (side 2, centroid at the origin, extruded from y = -1 to 1 in glTF's y-up coordinates), transmissive with
  IOR 1.78472 and KHR_materials_dispersion 20/25.68 (an Abbe number of 25.68), nothing else.
- crates/gltf-import/tests/fixtures/textured-plane.glb: a 2 m plane (Blender's default UVs) whose Principled BSDF
  reads a 2×2 image (red, green / blue, white from the top; closest-texel interpolation) as base colour, and a
  second, repeated 4 times by a Mapping node, through a Round node (the exporter's Alpha Clip) as a cut-out (alpha 0 and 1 in a checker); seen
  from above by an orthographic camera, under a sun straight down. Blender's exporter writes the images into the
  GLB and the Mapping node as KHR_texture_transform.
- crates/gltf-import/tests/fixtures/layered-plates.glb: four 0.9 m plates in a row, seen from above by an
  orthographic camera under a sun tilted 20°, each with one of the Principled BSDF's layers the exporter writes as
  a glTF extension: Coat (KHR_materials_clearcoat), Sheen (KHR_materials_sheen), Thin Film on a metal
  (KHR_materials_iridescence, with the weight and thinnest film from the "glTF Material Output" node group) and
  Specular IOR Level with Specular Tint (KHR_materials_specular).
- crates/gltf-import/tests/fixtures/shape-key-plane.glb: the 2 m plane of textured-plane.glb, grey, with a shape key
  that moves its +x edge to x = 0, at the value 0.5: the exporter writes it as a morph target (its displacements in
  a sparse accessor) with the mesh's default weight 0.5, so the plane ends at x = 0.5.
- crates/gltf-import/tests/fixtures/brushed-plate.glb: the 2 m plane as a brushed metal, the Principled BSDF's
  Anisotropic 0.8 at Anisotropic Rotation 0.1 (a tenth of a turn), which the exporter writes as
  KHR_materials_anisotropy; under a sun tilted 35°.

Blender is z-up and its exporter converts to glTF's y-up: a glTF point (x, y, z) is Blender's (x, -z, y).
Blender has no dispersion input of its own: the exporter reads Dispersion (and Thickness, which makes it write
KHR_materials_volume, without which it writes no dispersion) from its "glTF Material Output" node group.
"""

import math
import os
import sys

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def gltf_output_node(material, **inputs):
    """The exporter's "glTF Material Output" node group in `material`, with `inputs` set (underscores for spaces)."""
    from io_scene_gltf2.blender.com.material_helpers import create_settings_group, get_gltf_node_name

    name = get_gltf_node_name()
    group = bpy.data.node_groups.get(name) or create_settings_group(name)
    node = material.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    for key, value in inputs.items():
        node.inputs[key.replace("_", " ")].default_value = value
    return node


def glass(name, ior, abbe, roughness=0.0):
    """A clear glass of index `ior` (at the d line) and Abbe number `abbe`, as glTF's dispersion extension says."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf.inputs["Transmission Weight"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["IOR"].default_value = ior
    gltf_output_node(m, Thickness=1.0, Dispersion=20.0 / abbe)
    return m


def mesh_object(name, gltf_vertices, faces, material):
    """A mesh from vertices in glTF's coordinates (converted to Blender's) and faces (lists of vertex indices)."""
    verts = [(x, -z, y) for (x, y, z) in gltf_vertices]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def export(path):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    bpy.ops.export_scene.gltf(filepath=path, export_format="GLB", export_cameras=True, export_lights=True,
                              export_apply=True)
    print(f"wrote {os.path.relpath(path, ROOT)} ({os.path.getsize(path)} bytes)")


def emitter(name, strength):
    """A one-sided white emitter of luminance `strength` (exported as emissiveFactor 1 and emissive strength)."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Emission Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf.inputs["Emission Strength"].default_value = strength
    return m


def gem():
    from mathutils import Euler, Vector

    reset()
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 560, 420
    bpy.ops.wm.ply_import(filepath=os.path.join(ROOT, "scenes/meshes/diamond.ply"))
    stone = bpy.context.selected_objects[0]
    stone.name = "diamond"
    stone.data.materials.clear()
    stone.data.materials.append(glass("diamond", 2.4175, 55.3))
    # A disc above facing down, and six strips at 60 degree steps, 7 units out and 5 up, tilted towards the stone.
    bpy.ops.mesh.primitive_circle_add(vertices=48, radius=3.0, fill_type="NGON", location=(0.0, 0.0, 7.0),
                                      rotation=(math.pi, 0.0, 0.0))
    top = bpy.context.active_object
    top.data.materials.append(emitter("softbox", 1.5))
    for k in range(6):
        a = math.radians(60.0 * k)
        bpy.ops.mesh.primitive_plane_add(size=1.0, location=(7.0 * math.cos(a), 7.0 * math.sin(a), 5.0))
        strip = bpy.context.active_object
        strip.scale = (0.8, 3.0, 1.0)
        # The plane faces +z: turn it to face -x (towards the stone), tilted 35.5 degrees down, then around z.
        strip.rotation_euler = Euler((0.0, math.radians(-90.0 + 35.5), a), "XYZ")
        strip.data.materials.append(emitter(f"strip-{k}", 1.3))
    cam_data = bpy.data.cameras.new("camera")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle = math.radians(18.0)
    cam = bpy.data.objects.new("camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = (0.0, -4.95, 4.95)
    cam.rotation_euler = (Vector((0.0, 0.0, 0.02)) - cam.location).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    export(os.path.join(ROOT, "scenes/gltf/gem.glb"))


def dispersive_prism():
    reset()
    h = math.sqrt(3.0)
    tri = [(-1.0, -h / 3.0), (1.0, -h / 3.0), (0.0, 2.0 * h / 3.0)]  # (x, z) in glTF
    verts = [(x, y, z) for (x, z) in tri for y in (-1.0, 1.0)]  # vertex 2i: y = -1, 2i + 1: y = 1
    # Faces wound outwards (Blender computes normals from the winding; the exporter writes them).
    faces = [(0, 2, 4), (1, 5, 3), (0, 1, 3, 2), (2, 3, 5, 4), (4, 5, 1, 0)]
    obj = mesh_object("prism", verts, faces, glass("N-SF11-like", 1.78472, 25.68))
    # Outward normals whatever the winding above: let Blender make them consistent.
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.normals_make_consistent(inside=False)
    bpy.ops.object.mode_set(mode="OBJECT")
    export(os.path.join(ROOT, "crates/prismatic/tests/fixtures/gltf/dispersive-prism.glb"))


def image(name, pixels, size):
    """A packed Blender image of `size` (w, h) from RGBA `pixels` listed from the top row (Blender stores rows from
    the bottom)."""
    w, h = size
    img = bpy.data.images.new(name, width=w, height=h, alpha=True)
    rows = [pixels[r * w:(r + 1) * w] for r in range(h)]
    img.pixels = [c for row in reversed(rows) for px in row for c in px]
    img.file_format = "PNG"
    img.pack()
    return img


def ortho_camera_and_sun(width, resolution, sun_tilt_degrees):
    """An orthographic camera 5 m above the origin looking down, `width` metres across at `resolution`, and a sun of
    1 W/m² shining down, tilted by `sun_tilt_degrees` about x."""
    scene = bpy.context.scene
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 1.0
    sun_obj = bpy.data.objects.new("sun", sun)
    scene.collection.objects.link(sun_obj)
    sun_obj.rotation_euler = (math.radians(sun_tilt_degrees), 0.0, 0.0)
    cam_data = bpy.data.cameras.new("camera")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = width
    cam = bpy.data.objects.new("camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = (0.0, 0.0, 5.0)
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y = resolution


def textured_plane():
    reset()
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    m = bpy.data.materials.new("textured")
    m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = 1.0
    # Red and white opaque, green and blue transparent; repeated twice across the plane by a Mapping node.
    colours = image("colours", [(0.8, 0.05, 0.05, 1), (0.05, 0.8, 0.05, 0), (0.05, 0.05, 0.8, 0), (0.9, 0.9, 0.9, 1)],
                    (2, 2))
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = colours
    tex.interpolation = "Closest"
    uv = nodes.new("ShaderNodeTexCoord")
    mapping = nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (2.0, 2.0, 1.0)
    links.new(uv.outputs["UV"], mapping.inputs["Vector"])
    links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    # Blender's exporter writes alphaMode MASK (cutoff 0.5) for an alpha passed through a Math "Round" node.
    round_node = nodes.new("ShaderNodeMath")
    round_node.operation = "ROUND"
    links.new(tex.outputs["Alpha"], round_node.inputs[0])
    links.new(round_node.outputs["Value"], bsdf.inputs["Alpha"])
    plane.data.materials.append(m)
    ortho_camera_and_sun(2.0, (64, 64), 0.0)
    export(os.path.join(ROOT, "crates/gltf-import/tests/fixtures/textured-plane.glb"))


def principled(name, **inputs):
    """A Principled BSDF material with `inputs` (underscores for spaces in the input names)."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    for key, value in inputs.items():
        bsdf.inputs[key.replace("_", " ")].default_value = value
    return m


def layered_plates():
    reset()
    size = 0.9
    plates = [
        principled("coat", Base_Color=(0.5, 0.05, 0.05, 1.0), Roughness=0.6, Coat_Weight=1.0, Coat_Roughness=0.1),
        principled("velvet", Base_Color=(0.05, 0.05, 0.4, 1.0), Roughness=0.8, Sheen_Weight=1.0,
                   Sheen_Tint=(0.9, 0.8, 0.7, 1.0), Sheen_Roughness=0.4),
        principled("film", Base_Color=(0.9, 0.9, 0.9, 1.0), Metallic=1.0, Roughness=0.45, Thin_Film_Thickness=350.0,
                   Thin_Film_IOR=1.35),
        principled("tinted", Base_Color=(0.2, 0.2, 0.2, 1.0), Roughness=0.3, Specular_IOR_Level=0.3,
                   Specular_Tint=(1.0, 0.6, 0.3, 1.0)),
    ]
    # Blender has no iridescence weight: the exporter reads it and the thinnest film from its output node group.
    gltf_output_node(plates[2], Iridescence_Factor=1.0, Iridescence_Thickness_Minimum=100.0)
    for i, m in enumerate(plates):
        bpy.ops.mesh.primitive_plane_add(size=size, location=((i - 1.5) * 1.0, 0.0, 0.0))
        bpy.context.active_object.data.materials.append(m)
    ortho_camera_and_sun(4.0, (128, 32), 20.0)
    export(os.path.join(ROOT, "crates/gltf-import/tests/fixtures/layered-plates.glb"))


def plane_under_the_camera(material, sun_tilt_degrees):
    """A 2 m plane of `material` (made after `reset()`) filling a 64×64 orthographic view from above, under a sun
    tilted by `sun_tilt_degrees`: the plane object."""
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    plane.data.materials.append(material)
    ortho_camera_and_sun(2.0, (64, 64), sun_tilt_degrees)
    return plane


def shape_key_plane():
    reset()
    plane = plane_under_the_camera(principled("grey", Base_Color=(0.8, 0.8, 0.8, 1.0), Roughness=1.0), 0.0)
    plane.shape_key_add(name="Basis")
    narrow = plane.shape_key_add(name="Narrow")
    for point in narrow.data:
        if point.co.x > 0.0:
            point.co.x = 0.0
    narrow.value = 0.5
    export(os.path.join(ROOT, "crates/gltf-import/tests/fixtures/shape-key-plane.glb"))


def brushed_plate():
    reset()
    brushed = principled("brushed", Base_Color=(0.9, 0.9, 0.9, 1.0), Metallic=1.0, Roughness=0.4, Anisotropic=0.8,
                         Anisotropic_Rotation=0.1)
    plane_under_the_camera(brushed, 35.0)
    export(os.path.join(ROOT, "crates/gltf-import/tests/fixtures/brushed-plate.glb"))


if __name__ == "__main__":
    gem()
    dispersive_prism()
    textured_plane()
    layered_plates()
    shape_key_plane()
    brushed_plate()
