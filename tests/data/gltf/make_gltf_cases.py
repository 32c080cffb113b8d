#!/usr/bin/env python3
"""Writes the small glTF files the scene tests import (tests/data/gltf/*.gltf).

Each malformed file breaks exactly one rule of the glTF 2.0 specification (or one limit of
Penumbra) in an otherwise valid scene, so the test can check the error code and that the message
names the file and the offending element. Re-run after editing: python3 make_gltf_cases.py
"""
import base64
import copy
import json
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))


def floats(values):
    return struct.pack("<%df" % len(values), *values)


def u16(values):
    data = struct.pack("<%dH" % len(values), *values)
    return data + b"\0" * (-len(data) % 4)


def build(positions, normals, indices, extra_views=()):
    """A buffer holding positions, normals and indices (in that order), plus views/accessors."""
    chunks = [floats(sum(positions, [])), floats(sum(normals, [])), u16(indices)] + [c for c, _ in extra_views]
    views, offset = [], 0
    for c in chunks:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(c)})
        offset += len(c)
    data = b"".join(chunks)
    lo = [min(p[i] for p in positions) for i in range(3)]
    hi = [max(p[i] for p in positions) for i in range(3)]
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3"},
        {"bufferView": 1, "componentType": 5126, "count": len(normals), "type": "VEC3"},
        {"bufferView": 2, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
    ]
    if all(math.isfinite(x) for x in lo + hi):  # min/max are required for POSITION, but JSON has no NaN
        accessors[0].update(min=lo, max=hi)
    for i, (_, accessor) in enumerate(extra_views):
        accessor = dict(accessor, bufferView=3 + i)
        accessors.append(accessor)
    return data, views, accessors


def scene(data, views, accessors, primitives=None, **extra):
    doc = {
        "asset": {"version": "2.0", "generator": "penumbra make_gltf_cases.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "root", "translation": [0, 1, 0], "children": [1]}, {"name": "quad", "mesh": 0}],
        "meshes": [{"name": "quad", "primitives": primitives or [
            {"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"name": "grey", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}}],
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    doc.update(extra)
    return doc


QUAD_P = [[0, 0, 0], [1, 0, 0], [1, 0, -1], [0, 0, -1]]
QUAD_N = [[0, 1, 0]] * 4
QUAD_I = [0, 1, 2, 0, 2, 3]


def png_rgb(width, height, pixels):
    """A minimal 8-bit RGB PNG (filter type 0 on every row)."""
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)
    rows = b"".join(b"\0" + bytes(sum(pixels[y * width:(y + 1) * width], ())) for y in range(height))
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def write(name, doc):
    with open(os.path.join(HERE, name), "w") as f:
        if isinstance(doc, str):
            f.write(doc)
        else:
            json.dump(doc, f, indent=1)
            f.write("\n")


def main():
    data, views, accessors = build(QUAD_P, QUAD_N, QUAD_I)
    base = scene(data, views, accessors)

    # valid.gltf: hierarchy, two primitives (indexed and not), emissive strength, a spot light and a camera.
    valid = copy.deepcopy(base)
    valid["extensionsUsed"] = ["KHR_lights_punctual", "KHR_materials_emissive_strength"]
    # Non-indexed primitive: the first three vertices as a triangle list of its own.
    valid["accessors"].append({"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                               "min": [0, 0, -1], "max": [1, 0, 0]})
    valid["meshes"][0]["primitives"].append({"attributes": {"POSITION": 3}, "material": 1})
    valid["materials"].append({"name": "glow", "emissiveFactor": [1.0, 0.5, 0.25],
                               "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}})
    valid["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "spot", "color": [1.0, 0.9, 0.8], "intensity": 30.0, "range": 10.0,
         "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}]}}
    valid["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1, "zfar": 50.0, "aspectRatio": 1.5}}]
    valid["nodes"][0]["children"] = [1, 2, 3]
    valid["nodes"].append({"name": "spot", "translation": [0, 3, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}})
    valid["nodes"].append({"name": "eye", "translation": [0, 1, 5], "camera": 0})
    write("valid.gltf", valid)

    # valid_external.gltf + .bin: the same quad with its buffer in a file.
    external = copy.deepcopy(base)
    external["buffers"][0]["uri"] = "valid_external.bin"
    with open(os.path.join(HERE, "valid_external.bin"), "wb") as f:
        f.write(data)
    write("valid_external.gltf", external)

    # missing_buffer.gltf: the external .bin does not exist.
    missing = copy.deepcopy(base)
    missing["buffers"][0]["uri"] = "missing.bin"
    write("missing_buffer.gltf", missing)

    # short_buffer.gltf: the normals' buffer view runs 48 bytes past the end of the buffer.
    short = copy.deepcopy(base)
    short["bufferViews"][2]["byteLength"] += 48
    write("short_buffer.gltf", short)

    # accessor_past_view.gltf: the position accessor claims 8 vertices in a 4-vertex view.
    past = copy.deepcopy(base)
    past["accessors"][0]["count"] = 8
    write("accessor_past_view.gltf", past)

    # index_out_of_range.gltf: index 7 with 4 vertices.
    d, v, a = build(QUAD_P, QUAD_N, [0, 1, 2, 0, 2, 7])
    write("index_out_of_range.gltf", scene(d, v, a))

    # nan_position.gltf / inf_normal.gltf: non-finite attribute values.
    d, v, a = build([[0, 0, 0], [1, 0, 0], [1, 0, float("nan")], [0, 0, -1]], QUAD_N, QUAD_I)
    write("nan_position.gltf", scene(d, v, a))
    d, v, a = build(QUAD_P, [[0, 1, 0], [0, float("inf"), 0], [0, 1, 0], [0, 1, 0]], QUAD_I)
    write("inf_normal.gltf", scene(d, v, a))

    # degenerate.gltf: the quad plus a collinear triangle and one repeating an index (both dropped).
    d, v, a = build(QUAD_P + [[2, 0, 0], [3, 0, 0], [4, 0, 0]], QUAD_N + [[0, 1, 0]] * 3,
                    QUAD_I + [4, 5, 6, 0, 0, 1])
    write("degenerate.gltf", scene(d, v, a))

    # required_extension.gltf: requires Draco mesh compression, which Penumbra does not implement.
    required = copy.deepcopy(base)
    required["extensionsUsed"] = required["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    write("required_extension.gltf", required)

    # bad_json.gltf: truncated in the middle of an object.
    write("bad_json.gltf", json.dumps(base, indent=1)[:300])

    # joint_out_of_range.gltf: a two-joint skin whose vertices name joint 5.
    joints = (struct.pack("<16B", 0, 0, 0, 0, 1, 0, 0, 0, 5, 0, 0, 0, 1, 0, 0, 0),
              {"componentType": 5121, "count": 4, "type": "VEC4"})
    weights = (floats([1, 0, 0, 0] * 4), {"componentType": 5126, "count": 4, "type": "VEC4"})
    ibm = (floats([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1] * 2),
           {"componentType": 5126, "count": 2, "type": "MAT4"})
    d, v, a = build(QUAD_P, QUAD_N, QUAD_I, [joints, weights, ibm])
    skinned = scene(d, v, a, primitives=[
        {"attributes": {"POSITION": 0, "NORMAL": 1, "JOINTS_0": 3, "WEIGHTS_0": 4}, "indices": 2, "material": 0}])
    skinned["nodes"] = [{"name": "root", "children": [1, 2, 3]}, {"name": "skinned", "mesh": 0, "skin": 0},
                        {"name": "bone0"}, {"name": "bone1", "translation": [0, 1, 0]}]
    skinned["skins"] = [{"joints": [2, 3], "inverseBindMatrices": 5}]
    write("joint_out_of_range.gltf", skinned)

    # textured.gltf: a 2 x 2 base colour texture (red, green, blue, sRGB grey 128) as a data URI.
    textured = copy.deepcopy(base)
    png = png_rgb(2, 2, [(255, 0, 0), (0, 255, 0), (0, 0, 255), (128, 128, 128)])
    textured["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(png).decode()}]
    textured["textures"] = [{"source": 0}]
    textured["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    write("textured.gltf", textured)

    # cycle.gltf: the child node lists its parent as a child.
    cycle = copy.deepcopy(base)
    cycle["nodes"][1]["children"] = [0]
    write("cycle.gltf", cycle)

    # bad_key_times.gltf: an animation whose key times go backwards.
    times = (floats([0.0, 1.0, 0.5]), {"componentType": 5126, "count": 3, "type": "SCALAR"})
    moves = (floats([0, 0, 0, 1, 0, 0, 2, 0, 0]), {"componentType": 5126, "count": 3, "type": "VEC3"})
    d, v, a = build(QUAD_P, QUAD_N, QUAD_I, [times, moves])
    animated = scene(d, v, a)
    animated["animations"] = [{"channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}}],
                               "samplers": [{"input": 3, "output": 4, "interpolation": "LINEAR"}]}]
    write("bad_key_times.gltf", animated)

    # scaled_armature.gltf: a 0.5 x 1.8 x 0.3 m box skinned to two joints under an "Armature" node
    # scaled by 0.01 (joint translations in centimetres), as the common character pipelines export;
    # no lights, no cameras. Its inverse bind matrices undo the joints' world transforms, so the
    # skinned vertices are where the file's positions say (metres), while the mesh node's own world
    # transform, which skinning ignores, would shrink the box to 1.8 cm.
    box_p, box_n, box_i = [], [], []
    for axis in range(3):
        for sign in (1, -1):
            n = [0, 0, 0]
            n[axis] = sign
            u, w = (axis + 1) % 3, (axis + 2) % 3
            base_index = len(box_p)
            for a_, b_ in ((0, 0), (1, 0), (1, 1), (0, 1)):
                c = [0, 0, 0]
                c[axis] = 1 if sign > 0 else 0
                c[u], c[w] = (a_, b_) if sign > 0 else (b_, a_)
                box_p.append([(-0.25 + 0.5 * c[0]), 1.8 * c[1], (-0.15 + 0.3 * c[2])])
                box_n.append(n)
            box_i += [base_index, base_index + 1, base_index + 2, base_index, base_index + 2, base_index + 3]
    joints = (struct.pack("<%dB" % (4 * len(box_p)), *sum(([0 if p[1] < 0.9 else 1, 0, 0, 0] for p in box_p), [])),
              {"componentType": 5121, "count": len(box_p), "type": "VEC4"})
    weights = (floats([1, 0, 0, 0] * len(box_p)), {"componentType": 5126, "count": len(box_p), "type": "VEC4"})
    ibm = (floats([100, 0, 0, 0, 0, 100, 0, 0, 0, 0, 100, 0, 0, -90, 0, 1] +
                  [100, 0, 0, 0, 0, 100, 0, 0, 0, 0, 100, 0, 0, -160, 0, 1]),
           {"componentType": 5126, "count": 2, "type": "MAT4"})
    d, v, a = build(box_p, box_n, box_i, [joints, weights, ibm])
    armature = scene(d, v, a, primitives=[
        {"attributes": {"POSITION": 0, "NORMAL": 1, "JOINTS_0": 3, "WEIGHTS_0": 4}, "indices": 2, "material": 0}])
    armature["scenes"] = [{"nodes": [0]}]
    armature["nodes"] = [{"name": "Armature", "scale": [0.01, 0.01, 0.01], "children": [1, 2]},
                         {"name": "body", "mesh": 0, "skin": 0},
                         {"name": "hips", "translation": [0, 90, 0], "children": [3]},
                         {"name": "head", "translation": [0, 70, 0]}]
    armature["meshes"][0]["name"] = "body"
    armature["skins"] = [{"joints": [2, 3], "inverseBindMatrices": 5, "skeleton": 2}]
    write("scaled_armature.gltf", armature)

    # scaled_armature_limits.gltf: the same character declaring its pose-AO settings in the
    # lighting extension, with joint limits by name (one of which names no joint) and the ground.
    limits = copy.deepcopy(armature)
    limits["extensionsUsed"] = ["PENUMBRA_lighting"]
    limits["nodes"][1]["extensions"] = {"PENUMBRA_lighting": {"version": 1, "components": {
        "SkinnedPoseAO": {"preset": "draft", "joint_limits": "head=0.8, tail=0.3", "ground": True}}}}
    write("scaled_armature_limits.gltf", limits)

    # scaled_armature_wave.gltf: an animation of scaled_armature.gltf's skeleton delivered alone
    # (no mesh, no skin), as animation libraries ship them: its nodes carry a namespace prefix the
    # character's lack ("rig:hips"), and the clip "wave" turns the head 0.6 rad about Z in 1 s.
    keys = [0.0, 0.5, 1.0]
    turn = [0.0, 0.3, 0.6]
    quats = sum(([0.0, 0.0, math.sin(a / 2), math.cos(a / 2)] for a in turn), [])
    data = floats(keys) + floats(quats)
    wave = {
        "asset": {"version": "2.0", "generator": "penumbra make_gltf_cases.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "Armature", "scale": [0.01, 0.01, 0.01], "children": [1, 3]},
                  {"name": "rig:hips", "translation": [0, 90, 0], "children": [2]},
                  {"name": "rig:head", "translation": [0, 70, 0]},
                  {"name": "rig:prop"}],
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 12},
                        {"buffer": 0, "byteOffset": 12, "byteLength": 48}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "SCALAR", "min": [0.0], "max": [1.0]},
                      {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC4"}],
        "animations": [{"name": "wave",
                        "channels": [{"sampler": 0, "target": {"node": 2, "path": "rotation"}},
                                     {"sampler": 0, "target": {"node": 3, "path": "rotation"}}],
                        "samplers": [{"input": 0, "output": 1, "interpolation": "LINEAR"}]}],
    }
    write("scaled_armature_wave.gltf", wave)

    # lighting_extension.gltf: a small level authored with Penumbra's lighting components
    # (PENUMBRA_lighting on nodes): a floor, a movable crate that casts an AO field, a probe grid
    # whose box is its node's unit cube (scaled to the level), and a sun.
    d, v, a = build(QUAD_P, QUAD_N, QUAD_I)
    level = scene(d, v, a)
    level["extensionsUsed"] = ["KHR_lights_punctual", "PENUMBRA_lighting"]
    level["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.0}]}}
    level["nodes"] = [
        {"name": "level", "children": [1, 2, 3, 4]},
        {"name": "floor", "mesh": 0, "scale": [8, 1, 8], "translation": [-4, 0, 4]},
        {"name": "crate", "mesh": 0, "translation": [0, 0.5, 0], "rotation": [0.7071068, 0, 0, 0.7071068],
         "extensions": {"PENUMBRA_lighting": {"version": 1, "components": {
             "AOFieldCaster": {"preset": "draft", "falloff_distance": 1.5}}}}},
        {"name": "probes", "translation": [0, 1.5, 0], "scale": [7, 2.5, 7],
         "extensions": {"PENUMBRA_lighting": {"version": 1, "components": {
             "IrradianceProbeGrid": {"preset": "draft", "spacing": 1.0, "sh_order": "L1"}}}}},
        {"name": "sun", "rotation": [-0.5, 0, 0, 0.8660254], "extensions": {"KHR_lights_punctual": {"light": 0}}},
    ]
    level["animations"] = [{"channels": [{"sampler": 0, "target": {"node": 2, "path": "translation"}}],
                            "samplers": [{"input": 3, "output": 4, "interpolation": "LINEAR"}]}]
    times = (floats([0.0, 2.0]), {"componentType": 5126, "count": 2, "type": "SCALAR"})
    moves = (floats([0, 0.5, 0, 2, 0.5, 0]), {"componentType": 5126, "count": 2, "type": "VEC3"})
    d, v, a = build(QUAD_P, QUAD_N, QUAD_I, [times, moves])
    level["buffers"], level["bufferViews"], level["accessors"] = scene(d, v, a)["buffers"], v, a
    write("lighting_extension.gltf", level)

    # valid.glb and truncated.glb: the quad as binary glTF, then cut inside its BIN chunk.
    doc = copy.deepcopy(base)
    del doc["buffers"][0]["uri"]
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    binary = data + b"\0" * (-len(data) % 4)
    chunks = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(binary), 0x004E4942) + binary
    glb = struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks
    with open(os.path.join(HERE, "valid.glb"), "wb") as f:
        f.write(glb)
    with open(os.path.join(HERE, "truncated.glb"), "wb") as f:
        f.write(glb[:-40])


if __name__ == "__main__":
    main()
