#!/usr/bin/env python3
"""Convert a fragtrace scene (TOML + OBJ meshes) into an equal-work POV-Ray 3.7 scene.

Written for issue 13's comparison (scenes/bunny.toml: a flat-shaded OBJ mesh on a mirror
checker quad, point lights, Whitted shading).  The goal is the same work for both
renderers -- the same triangles, the same lights with hard shadows, the same mirror
bounces -- not a pixel-identical image.

Mapping of fragtrace's model
    L = ka*A*albedo + sum_visible I_l*(kd*albedo*max(0,n.l) + ks*max(0,r.v)^ns) + kr*L_r
onto POV-Ray's finish:
    ka*A      -> finish ambient rgb <ka*A>  (global ambient_light stays 1)
    kd        -> finish diffuse kd          (brilliance 1 = Lambert)
    ks, ns    -> finish phong ks phong_size ns (POV's phong is the r.v Phong lobe; grey ks only)
    kr        -> finish reflection rgb <kr> (no fresnel, no conserve_energy: plain Whitted add)
    I_l       -> light_source colour = colour*intensity, no fade (fragtrace has no falloff)
    max_depth -> global max_trace_level max_depth+1 (POV counts the primary ray as level 1)
    assumed_gamma 1: every colour in the file is linear, as in fragtrace; the PNG is
    sRGB-encoded on output (run povray with File_Gamma=sRGB), as fragtrace's PNG is.

Geometry: every object is baked into world space here (scale, then rotate X, Y, Z in
degrees, then translate, fragtrace's order) and written as a flat `mesh2` (vertex_vectors
+ face_indices, no normals, so POV shades with the face normal, as fragtrace does for a
mesh without vertex normals).  Coordinates are written unchanged (fragtrace is
right-handed); the camera gets `right -x*W/H`, POV-Ray's documented way to render a
right-handed scene, so nothing is mirrored and the world-space checker keeps its parity.

Usage: obj2pov.py SCENE.toml OUT.pov [--width W --height H] [--models DIR]
"""

import argparse
import math
import os
import sys
import tomllib


def die(msg):
    sys.exit(f"obj2pov: {msg}")


def vec(v, what):
    if not (isinstance(v, list) and len(v) == 3):
        die(f"{what} must be three numbers, got {v!r}")
    return [float(x) for x in v]


def fmt(v):
    return "<" + ", ".join(repr(float(x)) for x in v) + ">"


def fmtc(v):
    return "rgb " + fmt(v)


def triple_or_scalar(v, what):
    if isinstance(v, (int, float)):
        return [float(v)] * 3
    if isinstance(v, list) and len(v) == 1:
        return [float(v[0])] * 3
    return vec(v, what)


# --- geometry --------------------------------------------------------------------------


def load_obj(path):
    """Positions and triangles of an OBJ (polygons fan-triangulated, negative indices ok)."""
    pos, tris, mtl = [], [], False
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                p = line.split()
                pos.append((float(p[1]), float(p[2]), float(p[3])))
            elif line.startswith("f "):
                idx = []
                for tok in line.split()[1:]:
                    i = int(tok.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(pos) + i)
                for k in range(1, len(idx) - 1):
                    tris.append((idx[0], idx[k], idx[k + 1]))
            elif line.startswith(("mtllib", "usemtl")):
                mtl = True
    return pos, tris, mtl


def quad(w, d):
    x, z = 0.5 * w, 0.5 * d
    return [(-x, 0, -z), (-x, 0, z), (x, 0, z), (x, 0, -z)], [(0, 1, 2), (0, 2, 3)]


def cuboid(s):
    h = [0.5 * c for c in s]
    pos, tris = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u, v = (axis + 1) % 3, (axis + 2) % 3
            base = len(pos)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[v] = sign * h[axis], a * h[u], b * h[v]
                pos.append(tuple(p))
            if sign > 0:
                tris += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
            else:
                tris += [(base, base + 2, base + 1), (base, base + 3, base + 2)]
    return pos, tris


def rot_matrix(deg):
    """Rotate about X, then Y, then Z (degrees): M = Rz*Ry*Rx."""
    ax, ay, az = (math.radians(a) for a in deg)
    cx, sx, cy, sy, cz, sz = (math.cos(ax), math.sin(ax), math.cos(ay), math.sin(ay),
                              math.cos(az), math.sin(az))
    rx = [[1, 0, 0], [0, cx, -sx], [0, sx, cx]]
    ry = [[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]]
    rz = [[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]

    def mul(a, b):
        return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]

    return mul(rz, mul(ry, rx))


def place(pos, scale, rotate, translate):
    if scale == [1, 1, 1] and rotate == [0, 0, 0] and translate == [0, 0, 0]:
        return pos
    m = rot_matrix(rotate)
    out = []
    for p in pos:
        q = [p[i] * scale[i] for i in range(3)]
        out.append(tuple(sum(m[i][k] * q[k] for k in range(3)) + translate[i] for i in range(3)))
    return out


# --- materials -------------------------------------------------------------------------

DEFAULT_MAT = dict(albedo=[0.8] * 3, ka=1.0, kd=1.0, ks=[0.0] * 3, ns=32.0, kr=[0.0] * 3)


def material(d, name):
    m = dict(DEFAULT_MAT)
    for k, v in d.items():
        if k in ("albedo", "ks", "kr"):
            m[k] = triple_or_scalar(v, f"{name}.{k}")
        elif k in ("ka", "kd", "ns"):
            m[k] = float(v)
        elif k == "checker":
            m[k] = v
        elif k in ("kt", "ior", "fresnel"):
            # Only what the comparison scenes use is mapped; refusing beats a silent mismatch.
            if k == "kt" and max(triple_or_scalar(v, k)) == 0 or k == "fresnel" and not v:
                continue
            if k == "ior":
                continue
            die(f"material {name}: `{k}` (refraction/Fresnel) is not mapped to POV-Ray here")
        else:
            die(f"material {name}: unknown field `{k}`")
    return m


def finish(m, ambient):
    ks = m["ks"]
    if max(ks) - min(ks) > 1e-9:
        print(f"obj2pov: warning: coloured ks {ks} -> grey phong {sum(ks) / 3}", file=sys.stderr)
    parts = [f"ambient {fmtc([m['ka'] * a for a in ambient])}", f"diffuse {m['kd']!r}"]
    if max(ks) > 0:
        parts.append(f"phong {round(sum(ks) / 3, 9)!r} phong_size {m['ns']!r}")
    if max(m["kr"]) > 0:
        parts.append(f"reflection {{ {fmtc(m['kr'])} }}")
    return "finish { " + " ".join(parts) + " }"


def pigment(m, pos, name):
    c = m.get("checker")
    if c is None:
        return f"pigment {{ {fmtc(m['albedo'])} }}"
    axes = c.get("axes", "xz")
    s = float(c.get("scale", 1.0))
    a, b = vec(c["a"], f"{name}.checker.a"), vec(c["b"], f"{name}.checker.b")
    # fragtrace's checker is 2D: colour a where floor(u/s)+floor(v/s) is even.  POV's is 3D
    # (floor(x)+floor(y)+floor(z)); on a plane of constant third coordinate w0 the third
    # term is constant, so scale that axis by 1 and move the pattern so that the plane reads
    # 0.5 there (POV evaluates a pattern at (p - translate) / scale: w0 - (w0 - 0.5) = 0.5).
    third = {"xy": 2, "xz": 1, "yz": 0}[axes]
    ws = {p[third] for p in pos}
    if max(ws) - min(ws) > 1e-9:
        die(f"{name}: checker on a non-planar object is not mapped (POV's checker is 3D)")
    w0 = next(iter(ws))
    sc = [s, s, s]
    sc[third] = 1.0
    sh = [0.0, 0.0, 0.0]
    sh[third] = w0 - 0.5
    return (f"pigment {{ checker {fmtc(a)}, {fmtc(b)} scale {fmt(sc)} "
            f"translate {fmt(sh)} }}")


# --- output ----------------------------------------------------------------------------


def mesh2(out, pos, tris, tex, name):
    out.write(f"// {name}: {len(pos)} vertices, {len(tris)} triangles\nmesh2 {{\n")
    out.write(f"  vertex_vectors {{ {len(pos)},\n")
    out.write(",\n".join(f"    <{p[0]!r},{p[1]!r},{p[2]!r}>" for p in pos))
    out.write("\n  }\n")
    out.write(f"  face_indices {{ {len(tris)},\n")
    out.write(",\n".join(f"    <{t[0]},{t[1]},{t[2]}>" for t in tris))
    out.write("\n  }\n")
    out.write(f"  texture {{ {tex} }}\n}}\n\n")


def resolve_mesh(path, scene_dir, models):
    cands = [os.path.join(scene_dir, path)] + [os.path.join(d, path) for d in models]
    for c in cands:
        if os.path.isfile(c):
            return c
    die(f"mesh {path} not found in {cands}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--width", type=int, default=1024)
    ap.add_argument("--height", type=int, default=1024)
    ap.add_argument("--models", default=os.environ.get("FRAGTRACE_MODEL_PATH", ""),
                    help="mesh search path (default: $FRAGTRACE_MODEL_PATH)")
    args = ap.parse_args()

    with open(args.scene, "rb") as f:
        sc = tomllib.load(f)
    scene_dir = os.path.dirname(os.path.abspath(args.scene))
    models = [d for d in args.models.split(os.pathsep) if d]

    background = vec(sc.get("background", [0, 0, 0]), "background")
    ambient = triple_or_scalar(sc.get("ambient", 0.1), "ambient")
    max_depth = int(sc.get("max_depth", 5))
    cam = sc["camera"]
    eye, look = vec(cam["eye"], "camera.eye"), vec(cam["look_at"], "camera.look_at")
    up = vec(cam.get("up", [0, 1, 0]), "camera.up")
    vfov = float(cam["fov"])
    aspect = args.width / args.height
    # POV's `angle` is the horizontal field of view; fragtrace's fov is vertical.
    hfov = math.degrees(2 * math.atan(math.tan(math.radians(vfov) / 2) * aspect))

    mats = {n: material(d, n) for n, d in sc.get("materials", {}).items()}

    with open(args.out, "w") as out:
        out.write(f"// Generated by obj2pov.py from {os.path.abspath(args.scene)}\n")
        out.write(f"// for {args.width}x{args.height}; equal work, not pixel-identical.\n")
        out.write("#version 3.7;\n")
        out.write(f"global_settings {{ assumed_gamma 1.0 max_trace_level {max_depth + 1} "
                  "ambient_light rgb 1 }\n")
        out.write(f"background {{ {fmtc(background)} }}\n")
        out.write("camera {\n  perspective\n"
                  f"  location {fmt(eye)}\n"
                  f"  up y\n  right -x*{aspect!r}  // right-handed scene\n"
                  f"  sky {fmt(up)}\n  angle {hfov!r}  // = vertical {vfov} at {aspect!r}:1\n"
                  f"  look_at {fmt(look)}\n}}\n")
        for i, l in enumerate(sc.get("lights", [])):
            col = vec(l.get("color", [1, 1, 1]), f"lights[{i}].color")
            inten = float(l.get("intensity", 1.0))
            out.write(f"light_source {{ {fmt(vec(l['position'], 'position'))} "
                      f"color {fmtc([c * inten for c in col])} }}\n")
        out.write("\n")

        total = 0
        for i, o in enumerate(sc.get("objects", [])):
            name = f"objects[{i}]"
            if "mesh" in o:
                path = resolve_mesh(o["mesh"], scene_dir, models)
                pos, tris, has_mtl = load_obj(path)
                name += f" ({o['mesh']})"
            elif o.get("shape") == "quad":
                size = o.get("size", 1.0)
                if isinstance(size, (int, float)):
                    size = [size, size]
                if not (isinstance(size, list) and len(size) in (1, 2)):
                    die(f"{name}: quad size must be one or two numbers, got {size!r}")
                w, d = float(size[0]), float(size[-1])
                pos, tris, has_mtl = *quad(w, d), False
                name += " (quad)"
            elif o.get("shape") == "box":
                pos, tris, has_mtl = *cuboid(triple_or_scalar(o.get("size", 1.0), "size")), False
                name += " (box)"
            else:
                die(f"{name}: only meshes, quads and boxes are mapped (got {o!r})")
            pos = place(pos,
                        triple_or_scalar(o.get("scale", 1.0), "scale"),
                        vec(o.get("rotate", [0, 0, 0]), "rotate"),
                        vec(o.get("translate", [0, 0, 0]), "translate"))
            mref = o.get("material")
            if isinstance(mref, str):
                m = mats[mref]
            elif isinstance(mref, dict):
                m = material(mref, name + ".material")
            else:
                if has_mtl:
                    die(f"{name}: the OBJ's own MTL materials are not mapped; name a material")
                m = dict(DEFAULT_MAT)
            tex = pigment(m, pos, name) + " " + finish(m, ambient)
            mesh2(out, pos, tris, tex, name)
            total += len(tris)
    print(f"obj2pov: wrote {args.out}: {total} triangles, {len(sc.get('lights', []))} lights, "
          f"vfov {vfov} -> POV angle {hfov:.4f}", file=sys.stderr)


if __name__ == "__main__":
    main()
