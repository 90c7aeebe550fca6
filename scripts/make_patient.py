#!/usr/bin/python3
"""A patient-specific scene from a liver segmentation (scripts/make_patient.sh runs this).

Reads a closed liver surface (STL, ASCII or binary, or OBJ), brings it into the project's world
frame, tetrahedralizes it twice with gmsh (the patient's mesh of about --nodes nodes and the
controller's model mesh, a separate mesh of another size), reports their quality, places the
markers, the target, the entry, the skin patch, the ribs, the diaphragm and the anchor box, and
writes DIR/scenario.yaml (configs/scenarios/liver_breathing.yaml with the patient's values),
DIR/liver.msh, DIR/liver_model.msh, DIR/skin.msh and DIR/quality.txt.

Units and frames expected of the segmentation:
  - millimetres (--units mm, the default: what 3D Slicer exports) or metres (--units m);
  - any origin: the surface is recentred on its bounding-box centre;
  - RAS axes (+x patient right, +y anterior, +z superior), the project's world frame, or LPS
    (+x left, +y posterior, +z superior) with --lps, which flips x and y. 3D Slicer writes
    LPS model files by default since version 4.11 ("coordinate system" in its export dialog).
  - one closed (watertight) surface; its triangles may be in any orientation.
The world frame of the scenario: origin at the liver's bounding-box centre, RAS axes, metres.
--entry, --target and the plan file are in that frame (metres), unless the plan says
"frame: input": then they are in the segmentation's own coordinates and units.

Exit code 0 on success, 2 on bad input (a message names it), 1 when meshing fails."""

import argparse
import datetime
import math
import os
import re
import shutil
import struct
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# the scene's fixed dimensions, those of configs/scenarios/liver_breathing.yaml (m)
SKIN_HALF = (0.05, 0.002, 0.05)  # configs/meshes/skin_patch.msh: 100 x 4 x 100 mm, y = thickness
SKIN_GAP = 0.008                 # skin inner face above the highest liver node under it
RIB_HALF_X, RIB_HALF_Z = 0.06, 0.007
RIB_MAX_THICKNESS = 0.02         # antero-posterior
BOX_MARGIN = 0.015               # diaphragm and anchor boxes beyond the liver's extent
NEEDLE_LENGTH = 0.13             # shared.needle.length of the template
APPROACH = 0.01                  # shared.approach_distance of the template


class InputProblem(Exception):
    """Bad input: exit code 2."""


def log(message):
    print("make_patient: " + message, flush=True)


# ---------------------------------------------------------------- reading the surface

def read_stl(path):
    with open(path, "rb") as f:
        data = f.read()
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if len(data) == 84 + 50 * count:  # binary: the size says so, whatever the header
            rows = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                                       ("a", "<u2")]), count=count, offset=84)
            return rows["v"].astype(float)
    text = data.decode("ascii", errors="replace")
    if not text.lstrip().startswith("solid"):
        raise InputProblem(path + ": neither binary STL (size does not match its triangle count) "
                           "nor ASCII STL (no 'solid')")
    values = re.findall(r"vertex\s+(\S+)\s+(\S+)\s+(\S+)", text)
    if not values or len(values) % 3:
        raise InputProblem(path + ": ASCII STL with %d vertices (expected 3 per facet)"
                           % len(values))
    try:
        return np.array(values, dtype=float).reshape(-1, 3, 3)
    except ValueError as e:
        raise InputProblem(path + ": " + str(e))


def read_obj(path):
    vertices, faces = [], []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            parts = line.split()
            try:
                if parts and parts[0] == "v":
                    vertices.append([float(p) for p in parts[1:4]])
                elif parts and parts[0] == "f":
                    ids = [int(p.split("/")[0]) for p in parts[1:]]
                    ids = [i - 1 if i > 0 else len(vertices) + i for i in ids]
                    faces.extend([ids[0], ids[k], ids[k + 1]] for k in range(1, len(ids) - 1))
            except (ValueError, IndexError):
                raise InputProblem("%s:%d: cannot read '%s'" % (path, number, line.strip()))
    if not faces:
        raise InputProblem(path + ": no faces")
    v, f = np.array(vertices, dtype=float), np.array(faces)
    if f.min() < 0 or f.max() >= len(v):
        raise InputProblem(path + ": a face uses a vertex that does not exist")
    return v[f]


def read_surface(path):
    if not os.path.isfile(path):
        raise InputProblem(path + ": no such file")
    ext = os.path.splitext(path)[1].lower()
    if ext == ".stl":
        tris = read_stl(path)
    elif ext == ".obj":
        tris = read_obj(path)
    else:
        raise InputProblem(path + ": expected a .stl or .obj surface")
    if len(tris) < 4 or not np.all(np.isfinite(tris)):
        raise InputProblem(path + ": fewer than 4 triangles or a coordinate that is not finite")
    return tris


def check_closed(tris, path):
    """Welds vertices and checks every edge is shared by exactly two triangles."""
    flat = np.round(tris.reshape(-1, 3), 9)
    _, index = np.unique(flat, axis=0, return_inverse=True)
    faces = index.reshape(-1, 3)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    bad = int(np.sum(counts != 2))
    if bad:
        raise InputProblem("%s: the surface is not closed: %d edges are not shared by exactly two "
                           "triangles (fill the holes and remove self-intersections in the "
                           "segmentation tool)" % (path, bad))


class Frame:
    """Input coordinates -> world (m, RAS, origin at the liver's bounding-box centre)."""

    def __init__(self, scale, lps, liver_tris):
        self.scale = scale
        self.flip = np.array([-1.0, -1.0, 1.0]) if lps else np.ones(3)
        p = liver_tris.reshape(-1, 3) * scale * self.flip
        self.offset = 0.5 * (p.min(axis=0) + p.max(axis=0))

    def apply(self, points):
        return np.asarray(points, dtype=float) * self.scale * self.flip - self.offset


def write_binary_stl(path, tris):
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    rows = np.zeros(len(tris), dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                               ("a", "<u2")]))
    rows["n"], rows["v"] = normals, tris
    with open(path, "wb") as f:
        f.write(b"nsim make_patient".ljust(80, b" "))
        f.write(struct.pack("<I", len(tris)))
        f.write(rows.tobytes())


# ---------------------------------------------------------------- meshing

class TetMesh:
    def __init__(self, nodes, tets):
        self.nodes, self.tets = nodes, tets
        p = nodes[tets]
        vol = np.einsum("ij,ij->i", p[:, 1] - p[:, 0],
                        np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0])) / 6.0
        flip = vol < 0  # orient positively, as the project's reader does
        self.tets = tets.copy()
        self.tets[flip, 2], self.tets[flip, 3] = tets[flip, 3], tets[flip, 2]
        faces = np.concatenate([self.tets[:, [1, 2, 3]], self.tets[:, [0, 3, 2]],
                                self.tets[:, [0, 1, 3]], self.tets[:, [0, 2, 1]]])
        _, first, counts = np.unique(np.sort(faces, axis=1), axis=0, return_index=True,
                                     return_counts=True)
        self.surface = faces[first[counts == 1]]  # outward
        self.surface_nodes = np.unique(self.surface)
        self.tri_points = nodes[self.surface]

    def contains(self, points, tolerance=1e-12):
        """True for each point inside some tetrahedron."""
        p = self.nodes[self.tets]
        m = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]], axis=2)
        inv = np.linalg.inv(m)
        out = []
        for q in np.atleast_2d(points):
            b = np.einsum("kij,kj->ki", inv, q - p[:, 0])
            inside = (b >= -tolerance).all(axis=1) & (b.sum(axis=1) <= 1 + tolerance)
            out.append(bool(inside.any()))
        return np.array(out)


def gmsh_mesh(gmsh, stl_path, target_nodes, what, fixed_h=None):
    """Meshes the closed surface to about target_nodes nodes (or at element size fixed_h);
    returns (h, TetMesh)."""
    def generate(h):
        # the whole pipeline each time: clearing the mesh alone would drop the triangles the
        # reparametrized surfaces are built on
        gmsh.clear()
        gmsh.merge(stl_path)
        # patches that can be remeshed: the segmentation's triangles are replaced at size h
        gmsh.model.mesh.classifySurfaces(40 * math.pi / 180, True, True, math.pi)
        gmsh.model.mesh.createGeometry()
        surfaces = [tag for _, tag in gmsh.model.getEntities(2)]
        loop = gmsh.model.geo.addSurfaceLoop(surfaces)
        gmsh.model.geo.addVolume([loop])
        gmsh.model.geo.synchronize()
        for name, value in (("Mesh.MeshSizeMin", 0), ("Mesh.MeshSizeMax", h),
                            ("Mesh.MeshSizeFromCurvature", 0), ("Mesh.Optimize", 1),
                            ("Mesh.OptimizeThreshold", 0.6), ("Mesh.RandomSeed", 1),
                            ("General.NumThreads", 1), ("Mesh.ElementOrder", 1)):
            gmsh.option.setNumber(name, value)
        gmsh.model.mesh.generate(3)
        return len(gmsh.model.mesh.getNodes()[0])

    # a regular tetrahedron of edge h has volume h^3 / (6 sqrt 2); a Delaunay mesh has about 5
    # tets per node: first guess, then secant steps on log(nodes) against log(h)
    volume = abs(enclosed_volume(stl_path_tris(stl_path)))
    h = fixed_h or (volume / (5.0 * target_nodes) * 6 * math.sqrt(2)) ** (1 / 3)
    tried = []
    for _ in range(1 if fixed_h else 6):
        n = generate(h)
        tried.append((h, n))
        log("%s: h = %.2f mm -> %d nodes" % (what, 1e3 * h, n))
        if fixed_h or abs(n - target_nodes) <= 0.05 * target_nodes:
            break
        if len(tried) >= 2 and tried[-1][1] != tried[-2][1]:
            (h0, n0), (h1, n1) = tried[-2], tried[-1]
            slope = math.log(n1 / n0) / math.log(h1 / h0)
            slope = min(-1.5, max(-4.0, slope))
        else:
            slope = -2.7
        h = h * (target_nodes / n) ** (1 / slope)
    best_h, _ = min(tried, key=lambda t: abs(t[1] - target_nodes))
    if best_h != tried[-1][0]:
        generate(best_h)
    tags, coords, _ = gmsh.model.mesh.getNodes()
    types, _, element_nodes = gmsh.model.mesh.getElements(3)
    if 4 not in list(types):
        raise RuntimeError(what + ": gmsh made no tetrahedra")
    index = {int(t): i for i, t in enumerate(tags)}
    tets = np.array([index[int(t)] for t in element_nodes[list(types).index(4)]]).reshape(-1, 4)
    nodes = np.asarray(coords, dtype=float).reshape(-1, 3)
    used = np.unique(tets)
    remap = -np.ones(len(nodes), dtype=int)
    remap[used] = np.arange(len(used))
    return best_h, TetMesh(nodes[used], remap[tets])


_stl_cache = {}


def stl_path_tris(path):
    if path not in _stl_cache:
        _stl_cache[path] = read_stl(path)
    return _stl_cache[path]


def enclosed_volume(tris):
    return float(np.sum(np.einsum("ij,ij->i", tris[:, 0], np.cross(tris[:, 1], tris[:, 2])))) / 6


def write_msh(gmsh, path):
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.option.setNumber("Mesh.SaveAll", 0)
    gmsh.write(path)


# ---------------------------------------------------------------- quality (nsim::CalcMeshQuality)

def quality_text(mesh, name, h):
    """The report of common/mesh/mesh_quality.cpp (FormatMeshQuality), with the median radius
    ratio; radius ratio = 3 r_inscribed / r_circumscribed."""
    p = mesh.nodes[mesh.tets]
    a, b, c, d = p[:, 0], p[:, 1], p[:, 2], p[:, 3]
    u, v, w = b - a, c - a, d - a
    vol = np.einsum("ij,ij->i", u, np.cross(v, w)) / 6.0
    face = [(1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1)]
    normals = [np.cross(p[:, j] - p[:, i], p[:, k] - p[:, i]) for i, j, k in face]
    area = sum(0.5 * np.linalg.norm(n, axis=1) for n in normals)
    num = (np.sum(u * u, axis=1)[:, None] * np.cross(v, w) + np.sum(v * v, axis=1)[:, None]
           * np.cross(w, u) + np.sum(w * w, axis=1)[:, None] * np.cross(u, v))
    r_in = 3 * vol / area
    r_circ = np.linalg.norm(num, axis=1) / (2 * np.abs(6 * vol))
    rr = 3 * r_in / r_circ
    dihedral = []
    for k in range(4):
        for m in range(k + 1, 4):
            nk, nm = normals[k], normals[m]
            cos = -np.einsum("ij,ij->i", nk, nm) / (np.linalg.norm(nk, axis=1)
                                                    * np.linalg.norm(nm, axis=1))
            dihedral.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    dihedral = np.stack(dihedral, axis=1)
    edges = np.stack([np.linalg.norm(p[:, i] - p[:, j], axis=1)
                      for i in range(4) for j in range(i + 1, 4)], axis=1)
    tri = mesh.tri_points
    surface_volume = np.sum(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))) / 6
    lo, hi = mesh.nodes.min(axis=0), mesh.nodes.max(axis=0)
    hist = np.bincount(np.clip((rr * 10).astype(int), 0, 9), minlength=10)
    mm = lambda x: " ".join("%8.3f" % (1e3 * e) for e in x)  # noqa: E731
    lines = [
        "### " + name,
        "gmsh element size h = %.2f mm" % (1e3 * h),
        "nodes %d, tets %d, surface triangles %d" % (len(mesh.nodes), len(mesh.tets),
                                                     len(mesh.surface)),
        "bounding box (mm): %s .. %s (size %s)" % (mm(lo), mm(hi), mm(hi - lo)),
        "volume (cm^3): tets %.3f, enclosed by surface %.3f" % (1e6 * vol.sum(),
                                                                1e6 * surface_volume),
        "tet volume (mm^3): min %.4f, max %.4f, inverted %d" % (1e9 * vol.min(), 1e9 * vol.max(),
                                                                 int(np.sum(vol <= 0))),
        "radius ratio: min %.4f, median %.4f, mean %.4f, below 0.1: %d"
        % (rr.min(), np.median(rr), rr.mean(), int(np.sum(rr < 0.1))),
        "edge ratio: max %.4f, mean %.4f" % ((edges.max(1) / edges.min(1)).max(),
                                             (edges.max(1) / edges.min(1)).mean()),
        "dihedral angle (deg): min %.2f, max %.2f" % (dihedral.min(), dihedral.max()),
        "edge length (mm): min %.2f, mean %.2f, max %.2f" % (1e3 * edges.min(),
                                                             1e3 * edges.mean(),
                                                             1e3 * edges.max()),
        "radius ratio histogram [0,0.1) .. [0.9,1]: " + " ".join(str(int(x)) for x in hist),
    ]
    return "\n".join(lines) + "\n", rr.min()


# ---------------------------------------------------------------- geometry

def distance_to_triangles(points, tris, chunk=128):
    """Euclidean distance of each point to the nearest triangle (closest point on the triangle,
    by its Voronoi regions)."""
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    ab, ac = b - a, c - a
    out = np.empty(len(points))
    for s in range(0, len(points), chunk):
        p = points[s:s + chunk, None, :]
        ap = p - a
        d1, d2 = np.sum(ab * ap, -1), np.sum(ac * ap, -1)
        bp = p - b
        d3, d4 = np.sum(ab * bp, -1), np.sum(ac * bp, -1)
        cp = p - c
        d5, d6 = np.sum(ab * cp, -1), np.sum(ac * cp, -1)
        va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
        denom = va + vb + vc
        with np.errstate(divide="ignore", invalid="ignore"):
            v = vb / denom
            w = vc / denom
            # interior by default, then the edge and vertex regions
            q = a + v[..., None] * ab + w[..., None] * ac
            t_ab = d1 / (d1 - d3)
            on_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
            q = np.where(on_ab[..., None], a + t_ab[..., None] * ab, q)
            t_ac = d2 / (d2 - d6)
            on_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
            q = np.where(on_ac[..., None], a + t_ac[..., None] * ac, q)
            t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            q = np.where(((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0))[..., None],
                         b + t_bc[..., None] * (c - b), q)
        q = np.where(((d1 <= 0) & (d2 <= 0))[..., None], a, q)
        q = np.where(((d3 >= 0) & (d4 <= d3))[..., None], b, q)
        q = np.where(((d6 >= 0) & (d5 <= d6))[..., None], c, q)
        out[s:s + chunk] = np.sqrt(np.min(np.sum((p - q) ** 2, -1), axis=1))
    return out


def sample_in_tets(mesh, count, rng):
    """count points uniformly distributed in the mesh's volume."""
    p = mesh.nodes[mesh.tets]
    vol = np.abs(np.einsum("ij,ij->i", p[:, 1] - p[:, 0],
                           np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0])))
    tet = rng.choice(len(mesh.tets), size=count, p=vol / vol.sum())
    # uniform barycentric coordinates: sorted uniforms' gaps
    cuts = np.sort(rng.random((count, 3)), axis=1)
    bary = np.diff(np.concatenate([np.zeros((count, 1)), cuts, np.ones((count, 1))], axis=1),
                   axis=1)
    return np.einsum("ki,kij->kj", bary, p[tet])


class Box:
    def __init__(self, lo, hi):
        self.lo, self.hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)

    def contains(self, points, margin=0.0):
        points = np.atleast_2d(points)
        return np.all((points >= self.lo - margin) & (points <= self.hi + margin), axis=1)

    def yaml(self):
        centre, half = 0.5 * (self.lo + self.hi), 0.5 * (self.hi - self.lo)
        return "{center: %s, half_size: %s}" % (vec(centre), vec(half))


def vec(x, digits=4):
    return "[" + ", ".join(fmt(v, digits) for v in x) + "]"


def fmt(v, digits=4):
    text = "%.*f" % (digits, v)
    text = text.rstrip("0").rstrip(".") if "." in text else text
    return "0.0" if text in ("-0", "0") else text


def path_distance(points, a, b):
    d = b - a
    t = np.clip(((points - a) @ d) / (d @ d), 0, 1)
    return np.linalg.norm(points - (a + t[:, None] * d), axis=1)


# ---------------------------------------------------------------- the plan

def parse_point(text, what):
    parts = text.replace("[", "").replace("]", "").split(",")
    try:
        p = np.array([float(x) for x in parts])
    except ValueError:
        raise InputProblem("%s: expected X,Y,Z (three numbers), got '%s'" % (what, text))
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise InputProblem("%s: expected X,Y,Z (three finite numbers), got '%s'" % (what, text))
    return p


def read_plan(path):
    """entry: [x, y, z], target: [x, y, z], optional frame: world|input; '#' comments."""
    if not os.path.isfile(path):
        raise InputProblem(path + ": no such plan file")
    plan = {"frame": "world"}
    with open(path) as f:
        for number, line in enumerate(f, 1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            key, sep, value = line.partition(":")
            key, value = key.strip(), value.strip()
            where = "%s:%d" % (path, number)
            if not sep or key not in ("entry", "target", "frame"):
                raise InputProblem("%s: expected 'entry: [x, y, z]', 'target: [x, y, z]' or "
                                   "'frame: world|input', got '%s'" % (where, line))
            if key == "frame":
                if value not in ("world", "input"):
                    raise InputProblem("%s: frame must be world or input, got '%s'"
                                       % (where, value))
                plan["frame"] = value
            else:
                plan[key] = parse_point(value, where + " (" + key + ")")
    return plan


# ---------------------------------------------------------------- the scene

class Scene:
    pass


def highest_liver_y(nodes, box_xz):
    """Largest y of the nodes whose (x, z) lie in the footprint (x0, x1, z0, z1)."""
    x0, x1, z0, z1 = box_xz
    inside = ((nodes[:, 0] >= x0) & (nodes[:, 0] <= x1) & (nodes[:, 2] >= z0)
              & (nodes[:, 2] <= z1))
    return float(nodes[inside, 1].max()) if inside.any() else None


def plan_scene(args, liver, model, skin_nodes, entry, target, rng):
    """Target, entry, skin pose, ribs, diaphragm, anchors and markers (world frame, m)."""
    s = Scene()
    nodes = np.concatenate([liver.nodes, model.nodes])
    lo, hi = liver.nodes.min(axis=0), liver.nodes.max(axis=0)
    size = hi - lo
    # breathing boxes: the superior fraction of the liver follows the diaphragm; posterior,
    # inferior nodes (the inferior half, the posterior 9 % as in liver_breathing.yaml) are fixed
    grow = np.array([BOX_MARGIN, BOX_MARGIN, 0])
    s.diaphragm = Box(np.array([lo[0], lo[1], hi[2] - args.diaphragm_fraction * size[2]]) - grow,
                      np.array([hi[0], hi[1], hi[2] + 0.03]) + grow)
    anchor_depth = 0.09 * size[1]
    while True:
        s.anchor = Box(np.array([lo[0] - BOX_MARGIN, lo[1] - 0.02, lo[2] - 0.01]),
                       np.array([hi[0] + BOX_MARGIN, lo[1] + anchor_depth, 0.5 * (lo[2] + hi[2])]))
        held = s.anchor.contains(liver.nodes) & ~s.diaphragm.contains(liver.nodes)
        if held.sum() >= 10 or anchor_depth > 0.5 * size[1]:
            break
        anchor_depth *= 1.5
    if held.sum() == 0:
        raise InputProblem("the anchor box (posterior-inferior) holds no liver node")

    candidates = sample_in_tets(liver, 6000, rng)
    depth = distance_to_triangles(candidates, liver.tri_points)
    free = ~s.diaphragm.contains(candidates, 0.005) & ~s.anchor.contains(candidates, 0.005)

    if target is None:
        # deep inside (2 cm, or the deepest tenth when the organ is thinner), near the centroid
        p = liver.nodes[liver.tets]
        vol = np.abs(np.einsum("ij,ij->i", p[:, 1] - p[:, 0],
                               np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0])))
        centroid = (p.mean(axis=1) * vol[:, None]).sum(axis=0) / vol.sum()
        deep = free & (depth >= min(0.02, np.quantile(depth[free], 0.9)))
        choice = np.flatnonzero(deep)[np.argmin(np.linalg.norm(candidates[deep] - centroid,
                                                               axis=1))]
        target = np.round(candidates[choice], 4)
    if not (liver.contains(target)[0] and model.contains(target)[0]):
        raise InputProblem("the target %s m is outside the liver" % vec(target))
    s.target = target

    # the skin patch over the entry, the ribs above and below it (the intercostal space)
    if entry is None:
        x_e, z_e = target[0], target[2]
    else:
        x_e, z_e = entry[0], entry[2]
    footprint = (x_e - RIB_HALF_X, x_e + RIB_HALF_X,
                 z_e - SKIN_HALF[2] - 2 * RIB_HALF_Z, z_e + SKIN_HALF[2] + 2 * RIB_HALF_Z)
    y_liver = highest_liver_y(nodes, footprint)
    if y_liver is None:
        raise InputProblem("no liver under the entry (x = %.3f, z = %.3f m): choose an entry "
                           "above the liver" % (x_e, z_e))
    if skin_nodes is None:
        if entry is None:
            skin_inner = y_liver + SKIN_GAP
            entry = np.array([x_e, skin_inner + 2 * SKIN_HALF[1], z_e])
        skin_inner = entry[1] - 2 * SKIN_HALF[1]
        if skin_inner < y_liver + 0.002:
            raise InputProblem("the entry %s m is too low: the skin patch under it would reach "
                               "the liver (highest liver node under the patch and ribs at y = "
                               "%.4f m); use an entry with y >= %.4f"
                               % (vec(entry), y_liver, y_liver + 0.002 + 2 * SKIN_HALF[1]))
        s.skin_position = np.array([x_e, skin_inner + SKIN_HALF[1], z_e])
        rib_top = skin_inner + 0.0005
    else:
        # the given skin, in the world frame: the entry on its outer side above the target
        s.skin_position = np.zeros(3)
        x0, x1, z0, z1 = footprint
        near = ((skin_nodes[:, 0] >= x0) & (skin_nodes[:, 0] <= x1)
                & (np.abs(skin_nodes[:, 2] - z_e) <= SKIN_HALF[2] + 2 * RIB_HALF_Z))
        if not near.any():
            raise InputProblem("the skin mesh does not cover the entry (x = %.3f, z = %.3f m)"
                               % (x_e, z_e))
        if entry is None:
            entry = np.array([x_e, float(skin_nodes[near, 1].max()), z_e])
        rib_top = float(skin_nodes[near, 1].min()) + 0.0005
        if rib_top < y_liver + 0.003:
            raise InputProblem("the skin is less than 3 mm above the liver under the entry: no "
                               "room for the ribs")
    s.entry = np.round(entry, 4)
    if np.linalg.norm(s.entry - s.target) + APPROACH > NEEDLE_LENGTH - 0.02:
        raise InputProblem("entry %s to target %s is %.3f m: the %.2f m needle (with its %.2f m "
                           "approach) cannot reach; choose a shallower target or another entry"
                           % (vec(s.entry), vec(s.target), np.linalg.norm(s.entry - s.target),
                              NEEDLE_LENGTH, APPROACH))
    s.ribs = []
    for side in (-1, 1):
        z_c = z_e + side * (SKIN_HALF[2] + RIB_HALF_Z)
        under = highest_liver_y(nodes, (x_e - RIB_HALF_X, x_e + RIB_HALF_X, z_c - RIB_HALF_Z,
                                        z_c + RIB_HALF_Z))
        bottom = rib_top - RIB_MAX_THICKNESS
        if under is not None:
            bottom = max(bottom, under + 0.001)  # the posterior face just above the liver
        if rib_top - bottom < 0.002:
            raise InputProblem("no room for a rib between the liver and the skin at z = %.3f m"
                               % z_c)
        s.ribs.append(Box([x_e - RIB_HALF_X, bottom, z_c - RIB_HALF_Z],
                          [x_e + RIB_HALF_X, rib_top, z_c + RIB_HALF_Z]))
    for r, rib in enumerate(s.ribs):
        if rib.contains(nodes).any():
            raise InputProblem("rib %d would overlap the liver" % r)

    # markers: well inside, away from the boxes and the needle path, spread out (farthest
    # point sampling from a seeded first pick)
    ok = (free & (depth >= args.marker_margin)
          & (path_distance(candidates, s.entry, s.target) >= 0.01)
          & (np.linalg.norm(candidates - s.target, axis=1) >= 0.015))
    pool = candidates[ok]
    if len(pool) < args.markers:
        raise InputProblem("only %d candidate marker positions are %.3f m inside the liver and "
                           "away from the boxes and the path; lower --marker-margin"
                           % (len(pool), args.marker_margin))
    chosen = [int(rng.integers(len(pool)))]
    gap = np.linalg.norm(pool - pool[chosen[0]], axis=1)
    while len(chosen) < args.markers:
        chosen.append(int(np.argmax(gap)))
        gap = np.minimum(gap, np.linalg.norm(pool - pool[chosen[-1]], axis=1))
    s.markers = np.round(pool[chosen], 4)
    s.marker_depth = distance_to_triangles(s.markers, liver.tri_points)
    inside = liver.contains(s.markers) & model.contains(s.markers)
    if not inside.all() or s.marker_depth.min() < args.marker_margin - 1e-4:
        raise RuntimeError("a marker fell outside the margin after rounding")
    s.lo, s.hi = lo, hi
    return s


# ---------------------------------------------------------------- the scenario file

class YamlText:
    """Line edits of the template scenario that keep its structure and comments."""

    KEY = re.compile(r"^(\s*)([A-Za-z_][A-Za-z0-9_]*):(.*)$")

    def __init__(self, path):
        self.path = path
        with open(path) as f:
            self.lines = f.read().split("\n")

    def find(self, dotted):
        keys, stack = dotted.split("."), []
        for i, line in enumerate(self.lines):
            m = self.KEY.match(line)
            if not m or line.lstrip().startswith("#"):
                continue
            indent = len(m.group(1))
            while stack and stack[-1][0] >= indent:
                stack.pop()
            stack.append((indent, m.group(2)))
            if [k for _, k in stack] == keys:
                return i, indent
        raise RuntimeError("%s: no key %s (the template changed; update make_patient.py)"
                           % (self.path, dotted))

    def set(self, dotted, value, comment=None):
        i, indent = self.find(dotted)
        key = dotted.split(".")[-1]
        old = self.lines[i]
        if comment is None and "#" in old:
            comment = old.split("#", 1)[1].strip()
        text = " " * indent + key + ": " + value
        if comment:
            text = text.ljust(max(len(text) + 1, 29)) + "# " + comment
        self.lines[i] = text

    def set_list(self, dotted, items, comment=None):
        """A block list: the key alone on its line, then one '- item' line per item."""
        i, indent = self.find(dotted)
        old = self.lines[i]
        if comment is None and "#" in old:
            comment = old.split("#", 1)[1].strip()
        text = " " * indent + dotted.split(".")[-1] + ":"
        if comment:
            text = text.ljust(29) + "# " + comment
        j = i + 1
        while j < len(self.lines) and self.lines[j].strip().startswith("- "):
            j += 1
        self.lines[i:j] = [text] + [" " * (indent + 2) + "- " + item for item in items]

    def set_comment_above(self, dotted, comment_lines):
        """Replaces the comment lines right above the key."""
        i, indent = self.find(dotted)
        j = i
        while j > 0 and self.lines[j - 1].strip().startswith("#"):
            j -= 1
        self.lines[j:i] = [" " * indent + "# " + c for c in comment_lines]

    def replace_header(self, header_lines, keep_from):
        """The leading comment block: header_lines, then the template's from the line starting
        with keep_from."""
        end = 0
        while end < len(self.lines) and self.lines[end].startswith("#"):
            end += 1
        kept = self.lines[:end]
        start = next((k for k, line in enumerate(kept) if line.startswith(keep_from)), end)
        self.lines[:end] = ["# " + h for h in header_lines] + kept[start:]

    def text(self):
        return "\n".join(self.lines)


def write_scenario(args, s, template, nodes_liver, nodes_model, skin_text):
    y = YamlText(template)
    relative = os.path.relpath(template, ROOT)
    y.replace_header([
        "Patient-specific scenario written by scripts/make_patient.sh on %s from"
        % datetime.date.today().isoformat(),
        "%s: world (m) = %s%s x input (%s) - %s (its bounding-box centre)."
        % (os.path.basename(args.liver), "diag(-1, -1, 1) x " if args.lps else "",
           "0.001" if args.units == "mm" else "1", args.units + (", LPS" if args.lps else ", RAS"),
           vec(s.offset)),
        "Structure and every value not about the geometry: %s." % relative,
        "Liver mesh: liver.msh (%d nodes); the controller's model: liver_model.msh (%d nodes),"
        % (nodes_liver, nodes_model),
        "a separate mesh of the same surface. Mesh quality: quality.txt.",
    ], "# SI units")
    y.set_list("shared.markers", [vec(m) for m in s.markers],
               "%d fiducial markers in the liver at rest (m), >= %.0f mm inside, seed %d"
               % (len(s.markers), 1e3 * args.marker_margin, args.seed))
    y.set("shared.target", vec(s.target), "tumour (m)" + s.target_source)
    y.set("shared.entry", vec(s.entry),
          "planned skin entry, on the skin's outer side (m)" + s.entry_source)
    base = s.entry + np.array([0.56, -0.167, 0.0])  # liver_breathing.yaml: 0.6 - 0.04, -0.1 - 0.067
    i, _ = y.find("shared.robot_base")
    y.lines[i] = re.sub(r"position: \[[^\]]*\]", "position: " + vec(base), y.lines[i])
    y.set("patient.liver.mesh", "liver.msh")
    y.set("patient.skin.mesh", "skin.msh", skin_text)
    y.set("patient.skin.pose", "{position: %s, rpy: [0, 0, 0]}" % vec(s.skin_position))
    y.set_comment_above("patient.skin.pose", [
        "over the anterior liver surface around the entry, its inner side %.0f mm above the"
        % (1e3 * SKIN_GAP) if args.skin is None else "the given skin surface, already in the "
        "world frame",
        "highest liver node under the patch and the ribs; outer side anterior"
        if args.skin is None else "(the entry on its outer side above the target)"])
    y.set_list("patient.ribs", [r.yaml() for r in s.ribs])
    y.set("patient.diaphragm", s.diaphragm.yaml())
    y.set_comment_above("patient.diaphragm", [
        "liver nodes in this box follow the breathing motion exactly (the diaphragm, top %.0f mm,"
        % (1e3 * args.diaphragm_fraction * (s.hi[2] - s.lo[2])),
        "%.0f %% of the liver's height)" % (100 * args.diaphragm_fraction)])
    y.set_list("patient.anchors", [s.anchor.yaml()])
    lo = np.minimum(s.lo, s.entry) - 0.2
    hi = np.maximum(s.hi, s.entry + (NEEDLE_LENGTH + APPROACH) * np.array([0, 1, 0])) + 0.2
    y.set("robot.workspace_min", vec(lo, 2))
    y.set("robot.workspace_max", vec(hi, 2))
    # the view of liver_breathing.yaml, scaled with the liver's size (its diagonal 0.286 m)
    scale = np.linalg.norm(s.hi - s.lo) / 0.286
    look_at = 0.5 * (s.entry + s.target)
    y.set("view.eye", vec(look_at + scale * np.array([0.43, 0.37, 0.2]), 3))
    y.set("view.look_at", vec(look_at, 3))
    y.set("inverse.mesh", "liver_model.msh",
          "a separate mesh of the same surface: the model is not the patient's mesh")
    return y.text()


# ---------------------------------------------------------------- main

def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="make_patient.sh", description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="\n\n".join(__doc__.split("\n\n")[1:]))
    p.add_argument("--liver", required=True, help="closed liver surface (.stl or .obj)")
    p.add_argument("--skin", help="closed skin surface (.stl or .obj), same units and frame as "
                   "the liver; default: configs/meshes/skin_patch.msh over the entry")
    p.add_argument("--skin-size", type=float, default=0.008,
                   help="element size of the --skin mesh (m, default 0.008)")
    p.add_argument("--nodes", type=int, required=True, help="about this many nodes in liver.msh")
    p.add_argument("--model-nodes", type=int,
                   help="nodes of the controller's model mesh (default: N / 2 when that is at "
                   "least 2000, else 2000 when N > 2200, else N / 2)")
    p.add_argument("--out", required=True, help="output directory (created)")
    p.add_argument("--units", choices=("mm", "m"), default="mm",
                   help="units of the surfaces and of a plan with frame: input (default mm)")
    p.add_argument("--lps", action="store_true", help="the surfaces are in LPS: flip x and y")
    p.add_argument("--entry", help="X,Y,Z: skin entry in the world frame (m)")
    p.add_argument("--target", help="X,Y,Z: target in the world frame (m)")
    p.add_argument("--plan", help="a plan file: 'entry: [x, y, z]', 'target: [x, y, z]', "
                   "optional 'frame: world' (m, the default) or 'frame: input'")
    p.add_argument("--markers", type=int, default=5, help="number of markers (default 5)")
    p.add_argument("--marker-margin", type=float, default=0.01,
                   help="markers at least this far inside the liver surface (m, default 0.01)")
    p.add_argument("--diaphragm-fraction", type=float, default=0.15,
                   help="superior fraction of the liver's height driven by the diaphragm "
                   "(default 0.15)")
    p.add_argument("--seed", type=int, default=1, help="seed of the marker placement")
    p.add_argument("--template",
                   default=os.path.join(ROOT, "configs/scenarios/liver_breathing.yaml"),
                   help="the scenario whose structure and other values are copied")
    args = p.parse_args(argv)
    if args.nodes < 200 or args.nodes > 200000:
        p.error("--nodes must be in [200, 200000], got %d" % args.nodes)
    if args.model_nodes is None:
        n = args.nodes
        args.model_nodes = n // 2 if n // 2 >= 2000 else (2000 if n > 2200 else max(200, n // 2))
    if args.model_nodes < 200:
        p.error("--model-nodes must be >= 200")
    if abs(args.model_nodes - args.nodes) < 0.1 * args.nodes:
        p.error("--model-nodes (%d) must differ from --nodes (%d) by at least 10 %%: the "
                "controller's model must not be the patient's mesh"
                % (args.model_nodes, args.nodes))
    if not 0.001 <= args.skin_size <= 0.05:
        p.error("--skin-size must be in [0.001, 0.05] m")
    if not 1 <= args.markers <= 64:
        p.error("--markers must be in [1, 64]")
    if not 0 < args.diaphragm_fraction < 0.5:
        p.error("--diaphragm-fraction must be in (0, 0.5)")
    if not 0 <= args.marker_margin < 0.05:
        p.error("--marker-margin must be in [0, 0.05) m")
    if args.plan and (args.entry or args.target):
        p.error("--plan and --entry/--target exclude each other")
    return args


def run(args):
    import gmsh  # python3-gmsh (Debian)

    scale = 1e-3 if args.units == "mm" else 1.0
    liver_in = read_surface(args.liver)
    check_closed(liver_in, args.liver)
    frame = Frame(scale, args.lps, liver_in)
    liver_tris = frame.apply(liver_in)
    extent = liver_tris.reshape(-1, 3).max(axis=0) - liver_tris.reshape(-1, 3).min(axis=0)
    volume = abs(enclosed_volume(liver_tris))
    log("%s: %d triangles, %.1f x %.1f x %.1f mm, %.1f cm^3" % (
        args.liver, len(liver_tris), *(1e3 * extent), 1e6 * volume))
    if extent.max() > 0.5 or extent.max() < 0.03:
        raise InputProblem("%s: the liver would be %.3f m across: wrong --units (%s)?"
                           % (args.liver, extent.max(), args.units))

    entry = target = None
    entry_source = target_source = ""
    if args.plan:
        plan = read_plan(args.plan)
        to_world = frame.apply if plan["frame"] == "input" else (lambda q: q)
        entry = to_world(plan["entry"]) if "entry" in plan else None
        target = to_world(plan["target"]) if "target" in plan else None
        entry_source = target_source = "; from " + os.path.basename(args.plan)
    if args.entry:
        entry, entry_source = parse_point(args.entry, "--entry"), "; from --entry"
    if args.target:
        target, target_source = parse_point(args.target, "--target"), "; from --target"
    if target is None:
        target_source = "; default: deep inside, near the centroid"
    if entry is None:
        entry_source = "; default: above the target"

    os.makedirs(args.out, exist_ok=True)
    work = tempfile.mkdtemp(prefix="make_patient_")
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        stl = os.path.join(work, "liver.stl")
        write_binary_stl(stl, liver_tris)
        h_liver, liver = gmsh_mesh(gmsh, stl, args.nodes, "liver.msh")
        write_msh(gmsh, os.path.join(args.out, "liver.msh"))
        h_model, model = gmsh_mesh(gmsh, stl, args.model_nodes, "liver_model.msh")
        write_msh(gmsh, os.path.join(args.out, "liver_model.msh"))
        skin_nodes = None
        if args.skin:
            skin_in = read_surface(args.skin)
            check_closed(skin_in, args.skin)
            skin_stl = os.path.join(work, "skin.stl")
            write_binary_stl(skin_stl, frame.apply(skin_in))
            h_skin, skin = gmsh_mesh(gmsh, skin_stl, 0, "skin.msh", args.skin_size)
            write_msh(gmsh, os.path.join(args.out, "skin.msh"))
            skin_nodes = skin.nodes
        else:
            shutil.copyfile(os.path.join(ROOT, "configs/meshes/skin_patch.msh"),
                            os.path.join(args.out, "skin.msh"))
    finally:
        gmsh.finalize()
        shutil.rmtree(work, ignore_errors=True)

    rng = np.random.default_rng(args.seed)
    scene = plan_scene(args, liver, model, skin_nodes, entry, target, rng)
    scene.offset = frame.offset
    scene.entry_source, scene.target_source = entry_source, target_source

    reports = []
    for mesh, name, h in ((liver, "liver.msh (the patient)", h_liver),
                          (model, "liver_model.msh (the controller's model)", h_model)):
        text, min_rr = quality_text(mesh, name, h)
        reports.append(text)
        if min_rr < 0.05:
            log("warning: %s has a sliver (radius ratio %.3f)" % (name, min_rr))
    if args.skin:
        reports.append(quality_text(skin, "skin.msh", h_skin)[0])
    markers = "\n".join("marker %d: %s m, %.1f mm inside the surface" % (i, vec(m), 1e3 * d)
                        for i, (m, d) in enumerate(zip(scene.markers, scene.marker_depth)))
    quality = ("# make_patient.sh: mesh quality (radius ratio = 3 r_inscribed / r_circumscribed, "
               "1 for a regular tetrahedron), as nsim::CalcMeshQuality\n"
               + "\n".join(reports) + "\n### scene\n" + markers + "\n"
               + "target: %s m\nentry: %s m\n" % (vec(scene.target), vec(scene.entry)))
    with open(os.path.join(args.out, "quality.txt"), "w") as f:
        f.write(quality)
    skin_text = ("configs/meshes/skin_patch.msh: 100 x 100 x 4 mm, thickness along y"
                 if args.skin is None else "from " + os.path.basename(args.skin))
    scenario = write_scenario(args, scene, args.template, len(liver.nodes), len(model.nodes),
                              skin_text)
    with open(os.path.join(args.out, "scenario.yaml"), "w") as f:
        f.write(scenario)
    print(quality, end="")
    log("wrote %s/{scenario.yaml,liver.msh,liver_model.msh,skin.msh,quality.txt}" % args.out)
    log("run it: scripts/run.sh %s" % os.path.join(args.out, "scenario.yaml"))


def main(argv):
    args = parse_args(argv)
    try:
        run(args)
    except InputProblem as e:
        print("make_patient: " + str(e), file=sys.stderr)
        return 2
    except ImportError as e:
        print("make_patient: %s (apt-get install python3-gmsh python3-numpy)" % e, file=sys.stderr)
        return 2
    except Exception as e:  # gmsh failures and the like
        print("make_patient: failed: %s" % e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
