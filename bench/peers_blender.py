"""Blender's Cycles normal bake, selected to active, as bench/peers.sh runs it
against apo bake: M's normals onto a 1024x1024 image on m, the usual user's
route in Blender 3.4 (Debian 12).
  - both PLYs imported (bpy.ops.import_mesh.ply), M shaded smooth (the
    normals of its vertices, as apo and MeshLab take them, not its facets');
  - m unwrapped by Smart UV Project (angle limit 66 degrees, its default;
    island margin 0.005 of the UV square, ~5 px at 1024);
  - an Image Texture node with a new 1024x1024 image, active in m's
    material (the bake's target);
  - Cycles on the CPU (all threads), 1 sample, no denoising, bake type
    NORMAL, selected (M) to active (m), normal space OBJECT (the PNG holds
    (n + 1) / 2 in m's object space, comparable to apo's object-space
    normals), no cage object: extrusion 1% of m's bounding-box diagonal
    outward and a maximum ray distance of 2% (so the hits are sought within
    1% of m on either side, as apo bake's --max-distance 0.01 default),
    margin 16 px (the default);
  - the image saved as PNG;
  - with a fourth argument (peers.sh --accuracy's untimed run only), m with
    the UVs of this unwrap exported as that OBJ after all the above and
    its prints (so the timed work is the same): Blender's legacy OBJ
    exporter with forward Y and up Z, which keeps the PLY's coordinates
    as they are (the PLY importer converts no axes either, and m's object
    matrix is the identity), so that normal_eval.py --map reads the
    PNG's object-space normals in m.ply's own frame.
Prints "peers_blender: bake_seconds S" (the bake call's own time) and the
import / unwrap seconds.
Usage: blender -b --factory-startup --python bench/peers_blender.py -- HIGH.ply LOW.ply OUT.png [M_UV.obj]
"""
import sys
import time

import bpy
from mathutils import Vector

RESOLUTION = 1024
ISLAND_MARGIN = 0.005
CAGE_EXTRUSION = 0.01  # of m's bounding-box diagonal
MAX_RAY_DISTANCE = 0.02  # idem
MARGIN_PX = 16

args = sys.argv[sys.argv.index("--") + 1:]
high_path, low_path, out_path = args[:3]
obj_path = args[3] if len(args) > 3 else None
start = time.perf_counter()

# The factory startup scene's cube, camera and light go.
bpy.ops.object.select_all(action="SELECT")
bpy.ops.object.delete()


def import_ply(path):
    bpy.ops.import_mesh.ply(filepath=path)
    return bpy.context.selected_objects[0]


high = import_ply(high_path)
low = import_ply(low_path)
high.data.polygons.foreach_set("use_smooth", [True] * len(high.data.polygons))
high.data.update()
imported = time.perf_counter()

corners = [low.matrix_world @ Vector(c) for c in low.bound_box]
diagonal = (Vector(map(max, *corners)) - Vector(map(min, *corners))).length

# Smart UV Project on m.
bpy.ops.object.select_all(action="DESELECT")
low.select_set(True)
bpy.context.view_layer.objects.active = low
bpy.ops.object.mode_set(mode="EDIT")
bpy.ops.mesh.select_all(action="SELECT")
bpy.ops.uv.smart_project(island_margin=ISLAND_MARGIN)
bpy.ops.object.mode_set(mode="OBJECT")
unwrapped = time.perf_counter()

# The bake's target: an image texture node, active in m's material.
image = bpy.data.images.new("peers_normals", RESOLUTION, RESOLUTION, alpha=False)
material = bpy.data.materials.new("peers_m")
material.use_nodes = True
node = material.node_tree.nodes.new("ShaderNodeTexImage")
node.image = image
node.select = True
material.node_tree.nodes.active = node
low.data.materials.clear()
low.data.materials.append(material)

scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 1
# Debian's Blender is built without OpenImageDenoise, and with the factory
# settings' denoising on, every Cycles bake silently yields zeros.
scene.cycles.use_denoising = False
bake = scene.render.bake
bake.use_selected_to_active = True
bake.use_cage = False
bake.cage_extrusion = CAGE_EXTRUSION * diagonal
bake.max_ray_distance = MAX_RAY_DISTANCE * diagonal
bake.normal_space = "OBJECT"
bake.margin = MARGIN_PX

high.select_set(True)
low.select_set(True)
bpy.context.view_layer.objects.active = low
before = time.perf_counter()
result = bpy.ops.object.bake(type="NORMAL", use_selected_to_active=True, cage_extrusion=CAGE_EXTRUSION * diagonal,
                             max_ray_distance=MAX_RAY_DISTANCE * diagonal, normal_space="OBJECT",
                             margin=MARGIN_PX)
baked = time.perf_counter()
if result != {"FINISHED"}:
    sys.exit(f"peers_blender: the bake returned {result}")

image.filepath_raw = out_path
image.file_format = "PNG"
image.save()
print(f"peers_blender: high {len(high.data.polygons)} faces, low {len(low.data.polygons)} faces, "
      f"diagonal {diagonal:.6g}, threads {scene.render.threads}")
print(f"peers_blender: import_seconds {imported - start:.2f} unwrap_seconds {unwrapped - imported:.2f} "
      f"bake_seconds {baked - before:.2f} save_seconds {time.perf_counter() - baked:.2f}")
sys.stdout.flush()

if obj_path:
    if low.matrix_world != low.matrix_world.Identity(4):
        sys.exit(f"peers_blender: m's object matrix is not the identity: {low.matrix_world}")
    bpy.ops.object.select_all(action="DESELECT")
    low.select_set(True)
    bpy.context.view_layer.objects.active = low
    result = bpy.ops.export_scene.obj(filepath=obj_path, check_existing=False, use_selection=True, use_uvs=True,
                                      use_normals=True, use_materials=False, use_mesh_modifiers=False,
                                      use_triangles=False, axis_forward="Y", axis_up="Z", global_scale=1.0,
                                      path_mode="AUTO")
    if result != {"FINISHED"}:
        sys.exit(f"peers_blender: the OBJ export returned {result}")
    print(f"peers_blender: m with its UVs exported to {obj_path}")
    sys.stdout.flush()
