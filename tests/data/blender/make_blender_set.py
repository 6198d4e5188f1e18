# Builds the Blender test set from scratch (no .blend file) and renders it with Cycles.
#
#   blender -b --factory-startup --python tests/data/blender/make_blender_set.py -- OUTDIR
#
# Written for Blender 3.4 (Debian 12). Sequences (see README.md for what the files contain):
#   quad/     orthographic camera, still; a checker quad moves exactly +4 px right and 2 px
#             down per frame in front of a still checker backdrop; world background around.
#   camera/   same objects, still; a perspective camera translates and yaws; jitter.json holds
#             its view and projection per frame (our conventions, DESIGN.md §3).
#   jitter/   quad's scene with per-frame sub-pixel camera-shift jitter, Halton(2,3) with
#             index 0 skipped (as camera/camera.h), jitter.json in pixels, y down;
#             jitter/reference/ the same frames unjittered with many samples and a 1-px box
#             filter (the anti-aliased target).
import json
import math
import os
import sys

import bpy

W, H = 64, 48
PX = 0.1  # orthographic world units per pixel: ortho_scale spans the wider side (width)
STEP = (4 * PX, -2 * PX)  # +4 px right, 2 px down per frame (world +y is image up)


def halton(index, base):
    f, r = 1.0, 0.0
    while index > 0:
        f /= base
        r += f * (index % base)
        index //= base
    return r


def jitter_px(k):
    # Our JitterSequence::at(k): Halton(2,3) index k + 1, centred on 0; pixels, y down.
    return (halton(k + 1, 2) - 0.5, halton(k + 1, 3) - 0.5)


def reset_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.render.resolution_x, sc.render.resolution_y = W, H
    sc.render.resolution_percentage = 100
    sc.render.use_motion_blur = False  # the Vector pass exists only without motion blur
    sc.render.image_settings.file_format = "OPEN_EXR_MULTILAYER"
    sc.render.image_settings.color_depth = "16"
    sc.render.image_settings.exr_codec = "ZIP"
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.use_denoising = False
    sc.cycles.max_bounces = 2
    sc.cycles.use_animated_seed = True
    vl = sc.view_layers[0]
    for p in ("use_pass_combined", "use_pass_z", "use_pass_normal", "use_pass_vector",
              "use_pass_diffuse_color", "use_pass_object_index"):
        setattr(vl, p, True)
    world = bpy.data.worlds.new("World")
    sc.world = world
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.25, 0.35, 0.6, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    # No light sampling of the uniform world: cosine-sampled diffuse under a uniform sky is
    # then noise-free wherever nothing occludes the sky.
    world.cycles.sampling_method = "NONE"
    return sc


def checker_material(name, c1, c2, scale):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
    tex = nt.nodes.new("ShaderNodeTexChecker")
    tex.inputs["Color1"].default_value = c1
    tex.inputs["Color2"].default_value = c2
    tex.inputs["Scale"].default_value = scale
    nt.links.new(tex.outputs["Color"], bsdf.inputs["Color"])
    nt.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    return m


def add_plane(name, size_x, size_y, location, material, pass_index):
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=location)
    ob = bpy.context.active_object
    ob.name = name
    ob.scale = (size_x, size_y, 1.0)
    ob.data.materials.append(material)
    ob.pass_index = pass_index
    return ob


def build_objects():
    # Backdrop: still, at z = -1, covering the left 3/4 of the frame (world shows on the right).
    back = checker_material("Back", (0.8, 0.8, 0.75, 1), (0.1, 0.12, 0.1, 1), 6.0)
    add_plane("Backdrop", 4.8, 4.0, (-0.8, 0.0, -1.0), back, 2)
    # Mover: 2.0 x 1.6 units = 20 x 16 px, at z = 0.
    front = checker_material("Front", (0.9, 0.3, 0.1, 1), (0.05, 0.05, 0.3, 1), 5.0)
    return add_plane("Mover", 2.0, 1.6, (0.0, 0.0, 0.0), front, 1)


def animate_linear(ob, frames, loc_of):
    # A key on every frame (one before and after the range too, for the Vector pass),
    # interpolated linearly so the motion between frames is exactly the step.
    for f in frames:
        ob.location = loc_of(f)
        ob.keyframe_insert("location", frame=f)
    for fc in ob.animation_data.action.fcurves:
        for k in fc.keyframe_points:
            k.interpolation = "LINEAR"


def add_ortho_camera(sc):
    cd = bpy.data.cameras.new("Cam")
    cd.type = "ORTHO"
    cd.ortho_scale = W * PX  # spans the width (sensor fit AUTO, W > H)
    cd.clip_start, cd.clip_end = 0.1, 100.0
    cam = bpy.data.objects.new("Cam", cd)
    sc.collection.objects.link(cam)
    cam.location = (0.0, 0.0, 10.0)  # looks down -z, +y up: our view space exactly
    sc.camera = cam
    return cam


def matrix_rows(m):
    return [m[i][j] for i in range(4) for j in range(4)]


def camera_record(sc, cam, frame, jitter):
    """view and unjittered projection (row-major, our conventions) of `frame`."""
    sc.frame_set(frame)
    sx, sy = cam.data.shift_x, cam.data.shift_y
    cam.data.shift_x = cam.data.shift_y = 0.0
    dg = bpy.context.evaluated_depsgraph_get()
    proj = cam.calc_matrix_camera(dg, x=W, y=H)
    cam.data.shift_x, cam.data.shift_y = sx, sy
    view = cam.matrix_world.inverted()
    record = {"frame": frame, "jitter": list(jitter),
              "view": [round(v, 7) for v in matrix_rows(view)],
              "projection": [round(v, 7) for v in matrix_rows(proj)]}
    lens = camera_lens(cam, view)
    if lens:
        record["lens"] = lens
    return record


def camera_lens(cam, view):
    """The thin lens of a camera with depth of field on (the sidecar's "lens", which
    `afterimage run --pipeline dof` takes), or None: Blender's files carry no lens. The
    sets below leave depth of field off, so their sidecars have none."""
    cd = cam.data
    if cd.type != "PERSP" or not cd.dof.use_dof:
        return None
    if cd.sensor_fit == "VERTICAL" or (cd.sensor_fit == "AUTO" and H > W):
        raise SystemExit("camera_lens: the sensor must span the image width (ours does)")
    focus = cd.dof.focus_distance
    if cd.dof.focus_object is not None:  # view depth of the object's origin
        focus = -(view @ cd.dof.focus_object.matrix_world.translation).z
    if cd.dof.aperture_blades >= 3:
        # Cycles's blade rotation has not been checked against ours (camera/camera.h): say so
        # rather than write a polygon that may be turned.
        print("camera_lens: bladed aperture written as a disc; set dof.blades and "
              "dof.blade_rotation by hand")
    return {"f_number": cd.dof.aperture_fstop, "focal_length_mm": cd.lens,
            "focus_distance": focus, "sensor_width_mm": cd.sensor_width}


def render(sc, path_stem, first, last):
    sc.frame_start, sc.frame_end = first, last
    sc.render.filepath = path_stem  # Blender appends #### and .exr: stem0001.exr
    bpy.ops.render.render(animation=True)


def write_sidecar(path, records):
    # One frame per line; matrices row-major (m[row][col]), 16 numbers each.
    with open(path, "w") as f:
        f.write('{"units": "jitter in pixels, y down; view (world to camera, -z forward) and '
                'unjittered OpenGL projection, row-major; DESIGN.md section 3",\n "frames": [\n')
        f.write(",\n".join("  " + json.dumps(r) for r in records))
        f.write("\n ]}\n")


def quad_scene(frames):
    sc = reset_scene()
    mover = build_objects()
    add_ortho_camera(sc)
    # Frame 1 centre at (-2.2, 1.0): after 11 frames at (2.2, -1.2), inside the frame.
    animate_linear(mover, range(0, frames + 2),
                   lambda f: (-2.2 + STEP[0] * (f - 1), 1.0 + STEP[1] * (f - 1), 0.0))
    return sc


def make_quad(out, frames=6):
    sc = quad_scene(frames)
    # Light-path passes too, to test layouts that sum two file channels (DiffDir + DiffInd).
    vl = sc.view_layers[0]
    for p in ("use_pass_emit", "use_pass_diffuse_direct", "use_pass_diffuse_indirect",
              "use_pass_glossy_direct", "use_pass_glossy_indirect"):
        setattr(vl, p, True)
    sc.cycles.samples = 4
    render(sc, os.path.join(out, "quad", "quad_"), 1, frames)


def make_jitter(out, frames=12):
    sc = quad_scene(frames)
    cam = sc.camera
    # Tiny pixel filter: each sample sits at the pixel centre (point sampling, like a
    # rasterizer), so the jitter is the only sub-pixel offset and the input aliases.
    sc.cycles.pixel_filter_type = "BOX"
    sc.cycles.filter_width = 0.01
    sc.cycles.samples = 1
    # Sample for pixel (i, j) at (i + 0.5 + jx, j + 0.5 + jy), y down (DESIGN.md §3): the
    # view window moves right by jx pixels and down by jy. Shift is in units of the wider
    # side (sensor fit AUTO), +shift_y moves the window up.
    records = []
    for f in range(1, frames + 1):
        j = jitter_px(f - 1)
        cam.data.shift_x = j[0] / max(W, H)
        cam.data.shift_y = -j[1] / max(W, H)
        cam.data.keyframe_insert("shift_x", frame=f)
        cam.data.keyframe_insert("shift_y", frame=f)
        records.append(j)
    for fc in cam.data.animation_data.action.fcurves:
        for k in fc.keyframe_points:
            k.interpolation = "CONSTANT"
    seq = os.path.join(out, "jitter")
    render(sc, os.path.join(seq, "jitter_"), 1, frames)
    write_sidecar(os.path.join(seq, "jitter.json"),
                  [camera_record(sc, cam, f, records[f - 1]) for f in range(1, frames + 1)])
    # Reference: unjittered, 1-px box filter, many samples.
    cam.data.animation_data_clear()
    cam.data.shift_x = cam.data.shift_y = 0.0
    sc.cycles.filter_width = 1.0
    sc.cycles.samples = 256
    render(sc, os.path.join(seq, "reference", "jitter_"), 1, frames)


def make_camera(out, frames=6):
    sc = reset_scene()
    build_objects()
    cd = bpy.data.cameras.new("Cam")
    cd.type = "PERSP"
    cd.lens, cd.sensor_width, cd.sensor_fit = 35.0, 36.0, "HORIZONTAL"
    cd.clip_start, cd.clip_end = 0.1, 100.0
    cam = bpy.data.objects.new("Cam", cd)
    sc.collection.objects.link(cam)
    sc.camera = cam
    cam.rotation_mode = "XYZ"
    # Frame 1: looking straight down -z at the backdrop (planar depth = 7 on it); then the
    # camera moves right and yaws left a little each frame.
    for f in range(0, frames + 2):
        cam.location = (0.1 * (f - 1), 0.05 * (f - 1), 6.0)
        cam.rotation_euler = (0.0, math.radians(1.5 * (f - 1)), 0.0)
        cam.keyframe_insert("location", frame=f)
        cam.keyframe_insert("rotation_euler", frame=f)
    for fc in cam.animation_data.action.fcurves:
        for k in fc.keyframe_points:
            k.interpolation = "LINEAR"
    sc.cycles.samples = 4
    seq = os.path.join(out, "camera")
    render(sc, os.path.join(seq, "camera_"), 1, frames)
    write_sidecar(os.path.join(seq, "jitter.json"),
                  [camera_record(sc, cam, f, (0.0, 0.0)) for f in range(1, frames + 1)])


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    out = os.path.abspath(argv[0] if argv else os.path.dirname(os.path.abspath(__file__)))
    make_quad(out)
    make_camera(out)
    make_jitter(out)


main()
