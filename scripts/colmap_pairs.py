#!/usr/bin/env python3
"""Which image pairs of a COLMAP database carry wrong matches, judged by a known calibration.

    python3 scripts/colmap_pairs.py DATABASE SCENE [--px 4] [--show 40]

DATABASE is the database.db of a COLMAP run on one image per camera, named <camera>.<ext> (as
`import videos` without --calib names them); SCENE is a scene folder whose scene.json holds the
true cameras under the same names (`import panoptic`, `import colmap`, a rig). For every verified
pair (two_view_geometries) it counts the inlier matches that lie within --px pixels of the true
epipolar line, and prints the pairs with the smallest such fraction first, then a histogram of
pairs by inlier count: a threshold on the count separates right from wrong pairs only where no
wrong pair reaches it. Python's standard library only (sqlite3, json).
"""
import argparse
import json
import math
import os
import sqlite3
import struct
import sys

PAIR_ID_FACTOR = 2147483647  # COLMAP: pair_id = image_id1 * 2147483647 + image_id2, id1 < id2


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def transpose(a):
    return [list(r) for r in zip(*a)]


def intrinsics_inverse(fx, fy, cx, cy):
    return [[1 / fx, 0, -cx / fx], [0, 1 / fy, -cy / fy], [0, 0, 1]]


def fundamental(c1, c2):
    """F with x2^T F x1 = 0 for pixel coordinates (pixel centres at integers) of c1 and c2."""
    r1 = [row[:3] for row in c1["world_to_camera"][:3]]
    r2 = [row[:3] for row in c2["world_to_camera"][:3]]
    t1 = [row[3] for row in c1["world_to_camera"][:3]]
    t2 = [row[3] for row in c2["world_to_camera"][:3]]
    r = mat_mul(r2, transpose(r1))
    t = [t2[i] - sum(r[i][k] * t1[k] for k in range(3)) for i in range(3)]
    tx = [[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]]
    k1 = intrinsics_inverse(c1["fx"], c1["fy"], c1["cx"], c1["cy"])
    k2 = intrinsics_inverse(c2["fx"], c2["fy"], c2["cx"], c2["cy"])
    return mat_mul(transpose(k2), mat_mul(mat_mul(tx, r), k1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("database")
    ap.add_argument("scene")
    ap.add_argument("--px", type=float, default=4.0, help="epipolar distance of a right match")
    ap.add_argument("--show", type=int, default=40, help="pairs listed, worst first")
    args = ap.parse_args()

    with open(os.path.join(args.scene, "scene.json")) as f:
        truth = {c["name"]: c for c in json.load(f)["cameras"]}
    db = sqlite3.connect(args.database)
    sizes = {i: (w, h) for i, w, h in db.execute("select camera_id, width, height from cameras")}
    images = {}
    for image_id, name, camera_id in db.execute("select image_id, name, camera_id from images"):
        camera = os.path.splitext(os.path.basename(name))[0]
        if camera not in truth:
            sys.exit(f"{args.database}: image {name}: no camera '{camera}' in {args.scene}")
        w, h = sizes[camera_id]
        # Keypoints in COLMAP's convention (pixel centres at +0.5), scaled to the scene's size.
        images[image_id] = (name, camera, truth[camera]["width"] / w, truth[camera]["height"] / h)
    keypoints = {}
    for image_id, rows, cols, data in db.execute("select image_id, rows, cols, data from keypoints"):
        v = struct.unpack(f"{rows * cols}f", data)
        keypoints[image_id] = [(v[r * cols], v[r * cols + 1]) for r in range(rows)]

    pairs = []
    for pair_id, rows, data in db.execute("select pair_id, rows, data from two_view_geometries"):
        if rows == 0:
            continue
        i2 = pair_id % PAIR_ID_FACTOR
        i1 = (pair_id - i2) // PAIR_ID_FACTOR
        (n1, c1, sx1, sy1), (n2, c2, sx2, sy2) = images[i1], images[i2]
        f = fundamental(truth[c1], truth[c2])
        v = struct.unpack(f"{2 * rows}I", data)
        right = 0
        for r in range(rows):
            x1, y1 = keypoints[i1][v[2 * r]]
            x2, y2 = keypoints[i2][v[2 * r + 1]]
            p1 = [x1 * sx1 - 0.5, y1 * sy1 - 0.5, 1]
            p2 = [x2 * sx2 - 0.5, y2 * sy2 - 0.5, 1]
            line = [sum(f[i][k] * p1[k] for k in range(3)) for i in range(3)]
            distance = abs(sum(line[i] * p2[i] for i in range(3))) / math.hypot(line[0], line[1])
            right += distance < args.px
        pairs.append((right / rows, rows, n1, n2))

    pairs.sort()
    wrong = [p for p in pairs if p[0] < 0.5]
    print(f"{len(pairs)} verified pairs; {len(wrong)} with most inliers off the true epipolar "
          f"lines (> {args.px:g} px), holding {sum(p[1] for p in wrong)} of "
          f"{sum(p[1] for p in pairs)} inlier matches")
    for fraction, rows, n1, n2 in pairs[:args.show]:
        print(f"  {n1} {n2}: {rows} inliers, {100 * fraction:.0f} % right")
    print("inliers: pairs mostly right / mostly wrong")
    bins = {}
    for fraction, rows, _, _ in pairs:
        b = bins.setdefault(25 * (rows // 25), [0, 0])
        b[fraction < 0.5] += 1
    for lo in sorted(bins):
        print(f"  {lo}-{lo + 24}: {bins[lo][0]} / {bins[lo][1]}")


if __name__ == "__main__":
    main()
