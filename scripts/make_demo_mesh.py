#!/usr/bin/env python3
"""Writes a procedurally coloured box (10 x 7 x 5 cm, 5 mm cells of random colours, PLY in
millimetres with vertex colours) for the demo when no dataset mesh is at hand. Stopgap
until g6d-make-sample exists. Usage: make_demo_mesh.py OUT.ply [SEED]"""
import random
import sys

def main():
    out = sys.argv[1]
    rng = random.Random(int(sys.argv[2]) if len(sys.argv) > 2 else 1)
    size = (100.0, 70.0, 50.0)
    cell = 5.0
    vertices, faces = [], []
    for axis in range(3):
        b, c = (axis + 1) % 3, (axis + 2) % 3
        nb, nc = int(size[b] / cell), int(size[c] / cell)
        for sign in (1.0, -1.0):
            for i in range(nb):
                for j in range(nc):
                    colour = tuple(rng.randrange(256) for _ in range(3))
                    corners = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = sign * size[axis] / 2
                        p[b] = -size[b] / 2 + (i + di) * cell
                        p[c] = -size[c] / 2 + (j + dj) * cell
                        corners.append(p)
                    base = len(vertices)
                    vertices.extend((p, colour) for p in corners)
                    # (b, c) is right-handed about +axis: counter-clockwise for sign +1.
                    if sign > 0:
                        faces += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
                    else:
                        faces += [(base, base + 2, base + 1), (base, base + 3, base + 2)]
    with open(out, "w") as f:
        f.write("ply\nformat ascii 1.0\ncomment g6d demo box (mm)\n")
        f.write(f"element vertex {len(vertices)}\n")
        f.write("property float x\nproperty float y\nproperty float z\n")
        f.write("property uchar red\nproperty uchar green\nproperty uchar blue\n")
        f.write(f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        for p, colour in vertices:
            f.write(f"{p[0]:.3f} {p[1]:.3f} {p[2]:.3f} {colour[0]} {colour[1]} {colour[2]}\n")
        for a, b, c in faces:
            f.write(f"3 {a} {b} {c}\n")

if __name__ == "__main__":
    main()
