# Imports a .glb into Blender (background) and prints what it holds, for tests/cli/export.sh:
#   blender -b --python tests/blender_import.py -- FILE.glb
# Lines: "BLENDER_IMPORT meshes M vertices V triangles T materials K", the attribute names,
# and the first colours of the vertex-colour attribute.
import bpy, sys
import numpy
if not hasattr(numpy, "bool"):  # Debian 12: blender 3.4 importer vs numpy 1.24
    numpy.bool = bool
path = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=path)
meshes = [o for o in bpy.context.scene.objects if o.type == 'MESH']
tris = sum(len(o.data.polygons) for o in meshes)
verts = sum(len(o.data.vertices) for o in meshes)
attrs = sorted({a.name for o in meshes for a in o.data.attributes})
cols = [a for o in meshes for a in o.data.color_attributes] if hasattr(meshes[0].data, "color_attributes") else []
mats = sorted({m.name for o in meshes for m in o.data.materials if m})
print("BLENDER_IMPORT meshes", len(meshes), "vertices", verts, "triangles", tris, "materials", len(mats))
print("BLENDER_ATTRS", attrs)
if cols:
    a = cols[0]
    vals = [tuple(round(x, 4) for x in d.color[:3]) for d in a.data[:3]]
    print("BLENDER_COLOR", a.name, a.domain, a.data_type, vals)
