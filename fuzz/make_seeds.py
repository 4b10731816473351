#!/usr/bin/env python3
"""Writes the seed corpora fuzz/corpus/<target>/: a few small valid inputs per parser (and the
regression inputs the fuzzers found, kept beside them by hand). Re-run after a format change:
    python3 fuzz/make_seeds.py"""
import json
import os
import struct

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")
SEP = b"\n--8<--\n"  # fuzz_util.hpp: kFileSeparator


def put(target, name, data):
    d = os.path.join(ROOT, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def ply_header(fmt, count, props, extra=""):
    lines = ["ply", f"format {fmt} 1.0", "comment seed", extra, f"element vertex {count}"]
    lines += [f"property {t} {n}" for t, n in props]
    return ("\n".join(l for l in lines if l) + "\nend_header\n").encode()


# Points PLY: ASCII, binary little-endian with uchar colours, big-endian after a face element.
put("ply", "ascii.ply",
    ply_header("ascii", 2, [("float", "x"), ("float", "y"), ("float", "z")]) + b"0 1 2\n-1.5 2e3 0\n")
props = [("float", "x"), ("float", "y"), ("float", "z"), ("uchar", "red"), ("uchar", "green"),
         ("uchar", "blue")]
put("ply", "binary_colour.ply",
    ply_header("binary_little_endian", 2, props) + struct.pack("<fffBBB", 1, 2, 3, 255, 0, 9) +
    struct.pack("<fffBBB", -1, 0.5, 7, 1, 2, 3))
put("ply", "big_endian_faces.ply",
    b"ply\nformat binary_big_endian 1.0\nelement face 1\nproperty list uchar int vertex_index\n"
    b"element vertex 1\nproperty double x\nproperty double y\nproperty double z\n"
    b"property float red\nproperty float green\nproperty float blue\nend_header\n" +
    struct.pack(">Biii", 3, 0, 0, 0) + struct.pack(">dddfff", 1, 2, 3, 0.5, 0.25, 1))

# 3DGS splat PLY (Inria layout): degree 0 and degree 1.
def splat(rest, n=2):
    names = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
    names += [f"f_rest_{i}" for i in range(rest)]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    body = b""
    for i in range(n):
        row = [0.1 * (i + k) for k in range(len(names))]
        row[names.index("rot_0")] = 1.0
        body += struct.pack("<" + "f" * len(names), *row)
    return ply_header("binary_little_endian", n, [("float", x) for x in names]) + body
put("splat_ply", "degree0.ply", splat(0))
put("splat_ply", "degree1.ply", splat(9, 1))

# .flo: 2x2, one unknown pixel.
put("flo", "2x2.flo", struct.pack("<fii", 202021.25, 2, 2) +
    struct.pack("<8f", 0.5, -1, 0, 0, 1e10, 1e10, 3, 4))
put("flo", "1x3.flo", struct.pack("<fii", 202021.25, 1, 3) + struct.pack("<6f", 1, 2, 3, 4, 5, 6))


def npy(descr, shape, values, fmt, major=1):
    dims = ", ".join(str(d) for d in shape) + ("," if len(shape) == 1 else "")
    header = f"{{'descr': '{descr}', 'fortran_order': False, 'shape': ({dims}), }}"
    prefix = 10 if major == 1 else 12
    header += " " * ((64 - (prefix + len(header) + 1) % 64) % 64) + "\n"
    size = struct.pack("<H" if major == 1 else "<I", len(header))
    return b"\x93NUMPY" + bytes([major, 0]) + size + header.encode() + struct.pack(
        "<" + fmt * len(values), *values)


put("npy", "f4_2x3.npy", npy("<f4", (2, 3), [1, 2, 3, 4, 5, 6], "f"))
put("npy", "f8_3.npy", npy("<f8", (3,), [0.5, -1, 1e300], "d"))
put("npy", "i4_v2.npy", npy("<i4", (2, 2), [1, -2, 3, 4], "i", major=2))

# poses_bounds.npy: [N, 17] float64, LLFF 3x5 (down, right, back, centre, (h, w, f)) + near, far.
def llff_row(cx):
    m = [[0, 1, 0, cx, 480], [1, 0, 0, 0, 640], [0, 0, -1, 0, 500]]
    # columns: down = (0,1,0)... rows are world axes; a rigid right-handed frame.
    return [v for r in m for v in r] + [0.1, 100]
put("poses_bounds", "two_cameras.npy", npy("<f8", (2, 17), llff_row(0) + llff_row(1), "d"))
put("poses_bounds", "one_camera.npy", npy("<f8", (1, 17), llff_row(0.5), "d"))

identity = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
shifted = [[1, 0, 0, 0.5], [0, 1, 0, 0], [0, 0, 1, 2], [0, 0, 0, 1]]
camera = {"name": "cam0", "width": 4, "height": 3, "fx": 5, "fy": 5, "cx": 2, "cy": 1.5,
          "world_to_camera": identity}
put("scene_json", "one_camera.json", json.dumps(
    {"format": "retimegs-scene", "version": 1, "num_frames": 2, "fps": 30, "cameras": [camera]}))
put("scene_json", "two_cameras_up.json", json.dumps(
    {"format": "retimegs-scene", "version": 1, "num_frames": 1, "fps": 29.97, "up": [0, -1, 0],
     "cameras": [camera, dict(camera, name="cam1", split="test", world_to_camera=shifted)]},
    indent=2))

c2w = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 2, 0, 0, 0, 1]
put("camera_path", "fps.json", json.dumps(
    {"render_width": 8, "render_height": 6, "fps": 24, "camera_type": "perspective",
     "camera_path": [{"camera_to_world": c2w, "fov": 50, "aspect": 1.33},
                     {"camera_to_world": identity, "fov": 60}]}))
put("camera_path", "timed_seconds.json", json.dumps(
    {"render_width": 4, "render_height": 4, "seconds": 2,
     "camera_path": [{"camera_to_world": c2w, "fov": 40, "render_time": 0},
                     {"camera_to_world": c2w, "fov": 40, "render_time": 1}]}))

put("retime_csv", "ramp.csv", "output_frame,t\n0,0\n10,2.5\n20,3 # hold\n")
put("retime_csv", "plain.csv", "# comment\n0 1\n3 1.5\n\n4,-2\n")
# Found by fuzzing: a keyframe far beyond the output-frame limit (refused where it is read).
put("retime_csv", "far_keyframe.csv", "9-9\n9992992 5\n")

# COLMAP models: cameras, images, points3D, as text and as binary.
cams = [(1, "PINHOLE", 4, 3, [5, 5, 2, 1.5]), (2, "OPENCV", 4, 3, [5, 5, 2, 1.5, 0.1, 0, 0, 0])]
images = [(1, [1, 0, 0, 0], [0, 0, 0], 1, "a.png"), (2, [0.9, 0.1, 0, 0], [1, 0, 0], 2, "b.jpg")]
points = [(1, [0, 0, 1], [255, 0, 0], 0.5, [(1, 0), (2, 0)]), (7, [1, 1, 3], [0, 9, 9], 1, [])]
txt_c = "# cameras\n" + "".join(f"{i} {m} {w} {h} " + " ".join(map(str, p)) + "\n"
                                for i, m, w, h, p in cams)
txt_i = "# images\n" + "".join(
    f"{i} {' '.join(map(str, q))} {' '.join(map(str, t))} {c} {n}\n" + ("1.5 2.5 1\n" if i == 1 else "\n")
    for i, q, t, c, n in images)
txt_p = "# points\n" + "".join(
    f"{i} {' '.join(map(str, x))} {' '.join(map(str, c))} {e}" +
    "".join(f" {a} {b}" for a, b in tr) + "\n" for i, x, c, e, tr in points)
put("colmap_txt", "model.txt", txt_c.encode() + SEP + txt_i.encode() + SEP + txt_p.encode())
put("colmap_txt", "no_points.txt", txt_c.encode() + SEP + txt_i.encode())
models = {"PINHOLE": 1, "OPENCV": 4}
bin_c = struct.pack("<Q", len(cams)) + b"".join(
    struct.pack("<IiQQ", i, models[m], w, h) + struct.pack("<" + "d" * len(p), *p)
    for i, m, w, h, p in cams)
bin_i = struct.pack("<Q", len(images))
for i, q, t, c, n in images:
    pts = [(1.5, 2.5, 1)] if i == 1 else []
    bin_i += struct.pack("<I7dI", i, *q, *t, c) + n.encode() + b"\0" + struct.pack("<Q", len(pts))
    bin_i += b"".join(struct.pack("<ddQ", *p) for p in pts)
bin_p = struct.pack("<Q", len(points)) + b"".join(
    struct.pack("<Q3d3Bd", i, *x, *c, e) + struct.pack("<Q", len(tr)) +
    b"".join(struct.pack("<II", *t) for t in tr) for i, x, c, e, tr in points)
put("colmap_bin", "model.bin", bin_c + SEP + bin_i + SEP + bin_p)
put("colmap_bin", "no_points.bin", bin_c + SEP + bin_i + SEP + struct.pack("<Q", 0))


def fnv1a64(data):
    h = 0xcbf29ce484222325
    for b in data:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


# .rgs (model_file.hpp): magic, version, header length, JSON header, float32 fields, checksum.
FIELDS = [("mu", 3), ("velocity", 9), ("log_scale", 3), ("q0", 4), ("q1", 4), ("sh", 48),
          ("opacity_logit", 1), ("mu_tau", 1), ("tau_l", 1), ("tau_r", 1),
          ("temporal_log_scale", 1)]
def rgs(n, colors=None):
    table, data, offset = [], b"", 0
    for name, width in FIELDS:
        values = [1.0 if name == "q0" and k % 4 == 0 else 0.01 * k for k in range(n * width)]
        if name in ("tau_l", "tau_r"):
            values = [0.5] * n
        blob = struct.pack("<" + "f" * len(values), *values)
        table.append({"name": name, "width": width, "dtype": "<f4", "offset": offset,
                      "bytes": len(blob)})
        data += blob
        offset += len(blob)
    header = {"count": n, "time_grid": {"first": 0, "step": 1, "count": 3},
              "model": {"representation": "retime", "trajectory": "catmull-rom", "gamma": 1,
                        "epsilon": 0.01, "sh_degree": 1},
              "fields": table, "training_config": {"iters": 10}}
    if colors:
        header["camera_colors"] = colors
    text = json.dumps(header, separators=(",", ":")).encode()
    body = b"RETIMEGS" + struct.pack("<II", 1, len(text)) + text + data
    return body + struct.pack("<Q", fnv1a64(body))
put("rgs", "two.rgs", rgs(2))
put("rgs", "colours.rgs", rgs(1, {"cam0": {"m": [1, 1, 1], "c": [0, 0, 0.1]}}))
put("rgs", "empty.rgs", rgs(0))

put("config", "empty.json", "{}")
put("config", "some_keys.json", json.dumps(
    {"iters": 300, "cap": 5000, "scale_schedule": False, "sh_degree_every": 100,
     "max_sh_degree": 3, "lr_means": 1.6e-4, "ablate": {"linear": True}, "seed": 7}))

# transforms.json beside a.png (4x3 RGB) and b.png (4x3 RGBA) (transforms_json_fuzz.cpp).
m = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 2], [0, 0, 0, 1]]
m2 = [[1, 0, 0, 1], [0, 1, 0, 0], [0, 0, 1, 2], [0, 0, 0, 1]]
put("transforms_json", "static.json", json.dumps(
    {"fl_x": 5, "fl_y": 5, "cx": 2, "cy": 1.5, "w": 4, "h": 3, "k1": 0.01,
     "frames": [{"file_path": "a.png", "transform_matrix": m},
                {"file_path": "b.png", "transform_matrix": m2}]}))
put("transforms_json", "timed.json", json.dumps(
    {"camera_angle_x": 1.0, "camera_model": "OPENCV_FISHEYE", "fps": 10,
     "frames": [{"file_path": "a.png", "mask_path": "a.png", "transform_matrix": m, "time": 0,
                 "camera": "left"},
                {"file_path": "b.png", "transform_matrix": m, "time": 1, "camera": "left"}]}))

# Panoptic train_meta.json / test_meta.json (panoptic_fuzz.cpp: ims/0, ims/1 and seg/0 exist).
k = [[5, 0, 2], [0, 5, 1.5], [0, 0, 1]]
meta = {"w": 4, "h": 3, "k": [[k, k]], "w2c": [[identity, shifted]],
        "fn": [["0/000000.png", "1/000000.png"]], "cam_id": [[0, 1]]}
put("panoptic", "train_only.json", json.dumps(meta))
train = dict(meta, k=[[k]], w2c=[[identity]], fn=[["0/000000.png"]], cam_id=[[0]])
test = dict(meta, k=[[k]], w2c=[[shifted]], fn=[["1/000000.png"]], cam_id=[[1]])
put("panoptic", "train_and_test.json", json.dumps(train).encode() + SEP + json.dumps(test).encode())
