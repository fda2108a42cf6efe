# implicit crosscheck: render a <case>.cycles.json scene with Blender Cycles.
#
# Usage (Blender 3.4, headless, CPU):
#   blender -b --factory-startup -noaudio -t 1 -P blender_render.py -- \
#       SCENE.cycles.json OUTPUT_PREFIX SAMPLES BATCHES [FIRST_SEED [BOUNCES
#       [DETAIL]]]
# writes OUTPUT_PREFIX_<k>.exr for k = 0 .. BATCHES-1, each an independent
# render (Cycles seed FIRST_SEED + k) of SAMPLES samples per pixel, linear
# RGBA float. BOUNCES is ypathtrace's --bounces (default 16), see below.
# A description with `objects` (make_sdfunction.py) is built object by
# object instead: boxes, box frames, spheres (icospheres subdivided DETAIL
# times, default 6), tori (64 x 32 quads times 4^(DETAIL - 4)) and capped
# cones (64 x 2^(DETAIL - 4) sides), each placed by its matrix.
#
# The scene is built from meshes only: the sphere is an icosphere
# subdivided 6 times (81920 triangles, smooth shaded), the floor a box mesh,
# the light an emission-shaded quad (not a Blender area light, so that both
# renderers see the same emitter), the environment the world colour.
#
# Settings chosen to make Cycles an unbiased reference comparable to ours:
# no denoising, no adaptive sampling, no clamping, no glossy filter
# (blur_glossy 0), caustics on, light threshold 0, box pixel filter 1 px
# wide (ours: uniform jitter inside the pixel), Standard view transform (the
# EXR is linear anyway), and the same path length: ypathtrace --bounces N
# intersects at most N times, so a path scatters at most N - 1 times before
# the emitter it reaches; Cycles' "max bounces" M allows M + 1 scattering
# events (M = 0 is direct light only; its kernel uses max_bounce = M + 1).
# So every Cycles bounce limit (total, diffuse, glossy, transmission, volume,
# transparent) is set to N - 2. Only paths that long differ otherwise (ours
# also counts crossings of index-matched and thin surfaces, Cycles counts
# those as transparent bounces), and with N = 16 only the light trapped in
# the subsurface sphere reaches that length.
import json
import math
import os
import sys

import bmesh
import bpy
from mathutils import Matrix

# Ours is y up, Blender z up: (x, y, z) -> (x, -z, y).
Y_UP_TO_Z_UP = Matrix.Rotation(math.radians(90), 4, "X")


def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    for mesh in list(bpy.data.meshes):
        bpy.data.meshes.remove(mesh)
    for material in list(bpy.data.materials):
        bpy.data.materials.remove(material)


def add_mesh_object(name, bm, matrix, material):
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    obj.matrix_world = Y_UP_TO_Z_UP @ matrix
    bpy.context.scene.collection.objects.link(obj)
    return obj


def new_material(name):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes = material.node_tree.nodes
    for node in list(nodes):
        nodes.remove(node)
    output = nodes.new("ShaderNodeOutputMaterial")
    return material, nodes, material.node_tree.links, output


def rgba(color):
    return (color[0], color[1], color[2], 1.0)


def make_material(name, spec):
    material, nodes, links, output = new_material(name)
    kind = spec["node"]
    if kind == "diffuse":
        bsdf = nodes.new("ShaderNodeBsdfDiffuse")
        bsdf.inputs["Color"].default_value = rgba(spec["color"])
        bsdf.inputs["Roughness"].default_value = 0.0  # Lambert
        links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    elif kind == "emission":
        emit = nodes.new("ShaderNodeEmission")
        emit.inputs["Color"].default_value = rgba(spec["color"])
        emit.inputs["Strength"].default_value = 1.0
        links.new(emit.outputs["Emission"], output.inputs["Surface"])
    elif kind == "glossy":
        bsdf = nodes.new("ShaderNodeBsdfGlossy")
        bsdf.distribution = "GGX"
        bsdf.inputs["Color"].default_value = rgba(spec["color"])
        bsdf.inputs["Roughness"].default_value = spec["roughness"]
        links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    elif kind == "glass":
        bsdf = nodes.new("ShaderNodeBsdfGlass")
        roughness = spec.get("roughness", 0.0)
        bsdf.distribution = spec.get("distribution", "GGX") if roughness > 0 else "SHARP"
        bsdf.inputs["Color"].default_value = rgba(spec["color"])
        bsdf.inputs["Roughness"].default_value = roughness
        bsdf.inputs["IOR"].default_value = spec["ior"]
        links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    elif kind == "thin_dielectric":
        # F reflected by a sharp white mirror, (1 - F) color straight through.
        # Cycles' Fresnel node inverts the IOR on back faces; ours does not,
        # so give it 1/ior there: ior + backfacing * (1/ior - ior).
        geometry = nodes.new("ShaderNodeNewGeometry")
        ior = nodes.new("ShaderNodeMath")
        ior.operation = "MULTIPLY_ADD"
        links.new(geometry.outputs["Backfacing"], ior.inputs[0])
        ior.inputs[1].default_value = 1 / spec["ior"] - spec["ior"]
        ior.inputs[2].default_value = spec["ior"]
        fresnel = nodes.new("ShaderNodeFresnel")
        links.new(ior.outputs["Value"], fresnel.inputs["IOR"])
        transparent = nodes.new("ShaderNodeBsdfTransparent")
        transparent.inputs["Color"].default_value = rgba(spec["color"])
        mirror = nodes.new("ShaderNodeBsdfGlossy")
        mirror.distribution = "SHARP"
        mirror.inputs["Color"].default_value = (1, 1, 1, 1)
        mix = nodes.new("ShaderNodeMixShader")
        links.new(fresnel.outputs["Fac"], mix.inputs["Fac"])
        links.new(transparent.outputs["BSDF"], mix.inputs[1])
        links.new(mirror.outputs["BSDF"], mix.inputs[2])
        links.new(mix.outputs["Shader"], output.inputs["Surface"])
    elif kind == "none":
        # No surface closure: an index-matched boundary around the volume.
        pass
    elif kind == "principled_metal":
        bsdf = principled(nodes, [1, 1, 1], spec["roughness"])
        bsdf.inputs["Base Color"].default_value = rgba(spec["color"])
        bsdf.inputs["Metallic"].default_value = 1.0
        # The Specular socket clamps typed values to [0, 1]; a linked value
        # is passed through unclamped.
        value = nodes.new("ShaderNodeValue")
        value.outputs["Value"].default_value = spec["specular"]
        links.new(value.outputs["Value"], bsdf.inputs["Specular"])
        links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    elif kind == "plastic":
        # (1 - F(n.o)) * Diffuse(color) + dielectric GGX with F(h.i).
        fresnel = nodes.new("ShaderNodeFresnel")
        fresnel.inputs["IOR"].default_value = spec["ior"]
        diffuse = nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = rgba(spec["color"])
        diffuse.inputs["Roughness"].default_value = 0.0
        mix = nodes.new("ShaderNodeMixShader")
        links.new(fresnel.outputs["Fac"], mix.inputs["Fac"])
        links.new(diffuse.outputs["BSDF"], mix.inputs[1])  # weight 1 - Fac
        # mix.inputs[2] left empty: weight Fac goes to no closure.
        specular = principled(nodes, [0, 0, 0], spec["roughness"])
        # Specular 0.5 is F0 0.04, i.e. ior 1.5 (Cycles: 2/(1-sqrt(0.08 s))-1).
        f0 = ((spec["ior"] - 1) / (spec["ior"] + 1)) ** 2
        specular.inputs["Specular"].default_value = f0 / 0.08
        add = nodes.new("ShaderNodeAddShader")
        links.new(mix.outputs["Shader"], add.inputs[0])
        links.new(specular.outputs["BSDF"], add.inputs[1])
        links.new(add.outputs["Shader"], output.inputs["Surface"])
    else:
        raise ValueError("unknown Cycles material node: " + kind)
    if "volume" in spec:
        add_medium(material, nodes, links, output, spec["volume"])
    return material


def add_medium(material, nodes, links, output, medium):
    # Homogeneous medium with per-channel coefficients: Cycles' Volume
    # Absorption gives sigma_a = (1 - color) density and Volume Scatter
    # sigma_s = color density, so density = the largest coefficient.
    shaders = []
    sigma_a, sigma_s = medium["absorption"], medium["scattering"]
    if max(sigma_a) > 0:
        node = nodes.new("ShaderNodeVolumeAbsorption")
        density = max(sigma_a)
        node.inputs["Color"].default_value = rgba([1 - s / density for s in sigma_a])
        node.inputs["Density"].default_value = density
        shaders.append(node.outputs["Volume"])
    if max(sigma_s) > 0:
        node = nodes.new("ShaderNodeVolumeScatter")
        density = max(sigma_s)
        node.inputs["Color"].default_value = rgba([s / density for s in sigma_s])
        node.inputs["Density"].default_value = density
        node.inputs["Anisotropy"].default_value = medium["anisotropy"]
        shaders.append(node.outputs["Volume"])
    if len(shaders) == 2:
        add = nodes.new("ShaderNodeAddShader")
        links.new(shaders[0], add.inputs[0])
        links.new(shaders[1], add.inputs[1])
        shaders = [add.outputs["Shader"]]
    if shaders:
        links.new(shaders[0], output.inputs["Volume"])
        material.cycles.homogeneous_volume = True


def principled(nodes, base_color, roughness):
    # Single-scatter GGX Principled with no extra lobes.
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.distribution = "GGX"
    bsdf.inputs["Base Color"].default_value = rgba(base_color)
    bsdf.inputs["Metallic"].default_value = 0.0
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Specular Tint"].default_value = 0.0
    bsdf.inputs["Sheen"].default_value = 0.0
    bsdf.inputs["Clearcoat"].default_value = 0.0
    bsdf.inputs["Transmission"].default_value = 0.0
    bsdf.inputs["Subsurface"].default_value = 0.0
    bsdf.inputs["Anisotropic"].default_value = 0.0
    return bsdf


def shape_mesh(spec, detail):
    # The mesh of one primitive in its own space (ours: y up), as the SDF
    # defines it (src/sdf/sdf_primitives.h).
    bm = bmesh.new()
    shape = spec["shape"]
    if shape == "box":
        lo, hi = spec["min"], spec["max"]
        bmesh.ops.create_cube(bm, size=1.0)
        bmesh.ops.transform(bm, verts=bm.verts, matrix=Matrix.Translation(
            [(a + b) / 2 for a, b in zip(lo, hi)]) @ Matrix.Diagonal(
            [b - a for a, b in zip(lo, hi)] + [1]))
    elif shape == "box_frame":
        # Twelve bars of width 2 thickness, flush with the faces of the box
        # of half sizes `half` (Inigo Quilez's sdBoxFrame).
        h, t = spec["half"], spec["thickness"]
        for axis in range(3):
            for s1 in (-1, 1):
                for s2 in (-1, 1):
                    center, size = [0.0] * 3, [2 * t] * 3
                    size[axis] = 2 * h[axis]
                    others = [a for a in range(3) if a != axis]
                    center[others[0]] = s1 * (h[others[0]] - t)
                    center[others[1]] = s2 * (h[others[1]] - t)
                    bar = bmesh.ops.create_cube(bm, size=1.0)
                    bmesh.ops.transform(bm, verts=bar["verts"],
                                        matrix=Matrix.Translation(center) @
                                        Matrix.Diagonal(size + [1]))
    elif shape == "sphere":
        bmesh.ops.create_icosphere(bm, subdivisions=detail,
                                   radius=spec["radius"])
    elif shape == "torus":
        # Ring of radius r1 about the local y axis, tube radius r2.
        major, minor = 64 * 2 ** (detail - 4), 32 * 2 ** (detail - 4)
        r1, r2 = spec["r1"], spec["r2"]
        rows = []
        for i in range(major):
            u = 2 * math.pi * i / major
            row = []
            for j in range(minor):
                v = 2 * math.pi * j / minor
                r = r1 + r2 * math.cos(v)
                row.append(bm.verts.new((r * math.cos(u), r2 * math.sin(v),
                                         r * math.sin(u))))
            rows.append(row)
        for i in range(major):
            for j in range(minor):
                a, b = rows[i][j], rows[(i + 1) % major][j]
                c, d = rows[(i + 1) % major][(j + 1) % minor], rows[i][(j + 1) % minor]
                bm.faces.new((a, d, c, b))
    elif shape == "capped_cone":
        # Axis y, y in [-height, height], r1 at the bottom, r2 at the top.
        h = spec["height"]
        bmesh.ops.create_cone(bm, cap_ends=True, cap_tris=False,
                              segments=64 * 2 ** (detail - 4),
                              radius1=spec["r1"], radius2=spec["r2"],
                              depth=2 * h)
        bmesh.ops.rotate(bm, verts=bm.verts,
                         matrix=Matrix.Rotation(math.radians(-90), 3, "X"))
    else:
        raise ValueError("unknown shape: " + shape)
    # Curved surfaces smooth, flat faces (box sides, cone caps) flat.
    for face in bm.faces:
        face.smooth = shape in ("sphere", "torus") or (
            shape == "capped_cone" and abs(face.normal.y) < 0.999)
    return bm


def build_objects(desc, detail):
    # Every object of `desc["objects"]` (make_sdfunction.py), each with its
    # own world_from_local matrix and material.
    triangles = 0
    for k, spec in enumerate(desc["objects"]):
        bm = shape_mesh(spec, detail)
        triangles += sum(len(face.verts) - 2 for face in bm.faces)
        matrix = Matrix([row for row in spec["matrix"]])
        add_mesh_object(spec["name"], bm, matrix,
                        make_material(f"{spec['name']}_{k}", spec["material"]))
    print(f"blender_render.py: {len(desc['objects'])} objects, "
          f"{triangles} triangles")


def build_scene(desc, bounces, detail=6):
    clear_scene()
    scene = bpy.context.scene
    if "objects" in desc:
        build_objects(desc, detail)
        build_world_camera(scene, desc)
        build_settings(scene, desc, bounces)
        return

    # Floor: a box mesh with the same extent as our box.
    fmin, fmax = desc["floor"]["min"], desc["floor"]["max"]
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    floor_matrix = Matrix.Translation([(a + b) / 2 for a, b in zip(fmin, fmax)]) @ \
        Matrix.Diagonal([b - a for a, b in zip(fmin, fmax)] + [1])
    add_mesh_object("floor", bm, floor_matrix,
                    make_material("floor", {"node": "diffuse",
                                            "color": desc["floor"]["color"]}))

    # Light: one quad at y = min.y facing down (Cycles mesh emission is
    # two-sided in 3.4; the upper side lights nothing that is measured).
    lmin, lsize = desc["light"]["min"], desc["light"]["size"]
    bm = bmesh.new()
    corners = [(lmin[0], lmin[1], lmin[2]), (lmin[0] + lsize[0], lmin[1], lmin[2]),
               (lmin[0] + lsize[0], lmin[1], lmin[2] + lsize[1]),
               (lmin[0], lmin[1], lmin[2] + lsize[1])]
    verts = [bm.verts.new(c) for c in corners]
    bm.faces.new(verts)
    add_mesh_object("light", bm, Matrix.Identity(4),
                    make_material("light", {"node": "emission",
                                            "color": desc["light"]["emission"]}))

    # Sphere: finely tessellated, smooth shaded.
    sphere = desc["sphere"]
    bm = bmesh.new()
    bmesh.ops.create_icosphere(bm, subdivisions=6, radius=sphere["radius"])
    for face in bm.faces:
        face.smooth = True
    add_mesh_object("sphere", bm, Matrix.Translation(sphere["center"]),
                    make_material("sphere", sphere["material"]))
    build_world_camera(scene, desc)
    build_settings(scene, desc, bounces)


def build_world_camera(scene, desc):
    # World: constant colour, or a lat-long image (make_scenes.py samples it
    # at Cycles' texel centres) with linear interpolation.
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = rgba(desc["environment"])
    background.inputs["Strength"].default_value = 1.0
    if desc.get("environment_map"):
        texture = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
        texture.image = bpy.data.images.load(
            os.path.join(desc["directory"], desc["environment_map"]))
        texture.image.colorspace_settings.name = "Linear"
        texture.interpolation = "Linear"
        texture.projection = "EQUIRECTANGULAR"
        world.node_tree.links.new(texture.outputs["Color"],
                                  background.inputs["Color"])
    scene.world = world

    # Camera: our frame (x, y, z axes, origin; looks down -z like Blender's).
    f = desc["camera_frame"]
    frame = Matrix(((f[0], f[3], f[6], f[9]), (f[1], f[4], f[7], f[10]),
                    (f[2], f[5], f[8], f[11]), (0, 0, 0, 1)))
    camera_data = bpy.data.cameras.new("camera")
    camera_data.lens = desc["lens_mm"]
    camera_data.sensor_fit = "HORIZONTAL"
    camera_data.sensor_width = desc["sensor_mm"]
    camera_data.clip_start = 1e-3
    camera_data.clip_end = 1e4
    camera = bpy.data.objects.new("camera", camera_data)
    camera.matrix_world = Y_UP_TO_Z_UP @ frame
    scene.collection.objects.link(camera)
    scene.camera = camera


def build_settings(scene, desc, bounces):
    # Render settings.
    render = scene.render
    render.engine = "CYCLES"
    render.resolution_x = desc["width"]
    render.resolution_y = desc["height"]
    render.resolution_percentage = 100
    render.film_transparent = False
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    render.image_settings.color_mode = "RGBA"
    render.image_settings.exr_codec = "ZIP"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    cycles.blur_glossy = 0.0
    cycles.caustics_reflective = True
    cycles.caustics_refractive = True
    cycles.light_sampling_threshold = 0.0
    limit = max(bounces - 2, 0)
    cycles.max_bounces = limit
    cycles.diffuse_bounces = limit
    cycles.glossy_bounces = limit
    cycles.transmission_bounces = limit
    cycles.transparent_max_bounces = limit
    cycles.volume_bounces = limit
    cycles.pixel_filter_type = "BOX"
    cycles.filter_width = 1.0
    cycles.use_animated_seed = False
    cycles.film_exposure = 1.0


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) < 4:
        raise SystemExit("usage: blender -b -P blender_render.py -- "
                         "SCENE.cycles.json OUTPUT_PREFIX SAMPLES BATCHES "
                         "[FIRST_SEED [BOUNCES]]")
    with open(argv[0]) as f:
        desc = json.load(f)
    desc["directory"] = os.path.dirname(os.path.abspath(argv[0]))
    prefix, samples, batches = argv[1], int(argv[2]), int(argv[3])
    first_seed = int(argv[4]) if len(argv) > 4 else 1
    bounces = int(argv[5]) if len(argv) > 5 else 16
    detail = int(argv[6]) if len(argv) > 6 else 6
    build_scene(desc, bounces, detail)
    scene = bpy.context.scene
    scene.cycles.samples = samples
    for k in range(batches):
        scene.cycles.seed = first_seed + k
        scene.render.filepath = f"{prefix}_{k}.exr"
        bpy.ops.render.render(write_still=True)


main()
