#!/usr/bin/python3
"""Per-pixel analysis of `apo render` outputs (issue 43, part 4).

Loads a render folder's normal buffers (viewNN_{reference,apo,baseline}_normals.pfm)
and its cameras (render.json), draws a mesh from the same cameras (depth and
the mesh's interpolated vertex normals, by a dense z-buffered point sample:
Open3D's cast_rays answers nothing on this machine's build), and prints:

  compare  RENDER MESH        the render's reference, APO and m against the
                              mesh's own normals drawn at the same pixels
                              (how far the reference itself is from the mesh)
  edges    RENDER MESH [K..]  where the APO's rendered error sits: the share
                              of the error sum (and mean) on pixels within K
                              pixels of a silhouette or a depth jump (from
                              the drawn depth: neighbours > 2% of the
                              view's depth range apart), on M's ridges (the
                              reference normal turns > 30 deg between
                              neighbours, within 1 px), and elsewhere, for
                              the APO and for m

Needs Debian's python3-numpy and python3-open3d: run with /usr/bin/python3.
"""
import glob, json, os, sys
import numpy as np


def pfm(path):
    with open(path, 'rb') as f:
        assert f.readline().strip() == b'PF'
        w, h = map(int, f.readline().split())
        f.readline()
        return np.fromfile(f, '<f4').reshape(h, w, 3)[::-1]  # top row first


def read_ply_mesh(path):
    import open3d as o3d
    mesh = o3d.io.read_triangle_mesh(path)
    if not mesh.has_vertex_normals():
        mesh.compute_vertex_normals()
    return mesh


_samples = {}


def draw_mesh(mesh, view, size, samples=None):
    """Depth (eye space, inf where M is not drawn) and M's interpolated vertex normal per pixel, top row first.

    Open3D's cast_rays answers nothing on this machine's build, so M is drawn
    as a dense z-buffered point sample (4 points per pixel of the image's
    area on average, nearest per pixel kept): holes only where M is thinner
    than that sample."""
    cam = view['camera']
    eye = np.array(view['eye'], float)
    target = np.array(cam['target'], float)
    up = np.array(cam['up'], float)
    f = target - eye; f /= np.linalg.norm(f)
    r = np.cross(f, up); r /= np.linalg.norm(r)
    u = np.cross(r, f)
    t = np.tan(np.radians(cam['fov_y_degrees']) / 2)
    if id(mesh) not in _samples:
        import open3d as o3d
        o3d.utility.random.seed(1)
        pc = mesh.sample_points_uniformly(samples or 3_000_000, use_triangle_normal=False)
        _samples[id(mesh)] = (np.asarray(pc.points), np.asarray(pc.normals))
    P, N = _samples[id(mesh)]
    q = P - eye
    z = q @ f
    x = (q @ r) / (z * t); y = (q @ u) / (z * t)
    col = np.floor((x + 1) / 2 * size).astype(np.int64)
    row = np.floor((1 - y) / 2 * size).astype(np.int64)
    ok = (z > 0) & (col >= 0) & (col < size) & (row >= 0) & (row < size)
    idx = (row * size + col)[ok]; zz = z[ok]; nn = N[ok]; pp = q[ok]
    order = np.lexsort((zz, idx))
    idx, zz, nn, pp = idx[order], zz[order], nn[order], pp[order]
    first = np.ones(idx.size, bool); first[1:] = idx[1:] != idx[:-1]
    depth = np.full(size * size, np.inf); depth[idx[first]] = zz[first]
    n = np.zeros((size * size, 3)); n[idx[first]] = nn[first]
    d = np.zeros((size * size, 3)); d[idx[first]] = pp[first]
    flip = (n * d).sum(1) > 0
    n[flip] *= -1
    depth = depth.reshape(size, size); n = n.reshape(size, size, 3)
    return depth, n, np.isfinite(depth)


def angle(a, b):
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), (a * b).sum(-1)))


def covered(n):
    return np.linalg.norm(n, axis=2) > 0.5


def dilate(mask, k):
    out = mask.copy()
    for _ in range(k):
        m = out.copy()
        m[1:] |= out[:-1]; m[:-1] |= out[1:]; m[:, 1:] |= out[:, :-1]; m[:, :-1] |= out[:, 1:]
        out = m
    return out


def views(render):
    j = json.load(open(os.path.join(render, 'render.json')))
    return j['views'], j['options']['size']


def load(render, i):
    return {k: pfm(os.path.join(render, f'view{i:02d}_{k}_normals.pfm')) for k in ('reference', 'apo', 'baseline')}


def compare(render, mesh_path):
    mesh = read_ply_mesh(mesh_path)
    vs, size = views(render)
    acc = {k: [] for k in ('reference', 'apo', 'baseline')}
    iou = []
    for v in vs:
        b = load(render, v['index'])
        depth, n, hit = draw_mesh(mesh, v, size)
        ref = covered(b['reference'])
        both = hit & ref & covered(b['apo'])
        iou.append((hit & ref).sum() / max((hit | ref).sum(), 1))
        for k in acc:
            acc[k].append(angle(b[k][both], n[both]))
    print(f'coverage IoU render reference / mesh drawn by this script: {np.mean(iou):.3f}')
    for k in acc:
        a = np.concatenate(acc[k])
        print(f'{k:9s} against the mesh drawn by this script: mean {a.mean():.3f} median {np.median(a):.3f} p95 {np.percentile(a, 95):.3f} ({a.size} px)')


def edges(render, mesh_path, ks):
    mesh = read_ply_mesh(mesh_path)
    vs, size = views(render)
    rows = {}
    for v in vs:
        b = load(render, v['index'])
        depth, n, hit = draw_mesh(mesh, v, size)
        ref = covered(b['reference'])
        both = ref & covered(b['apo'])
        ea = np.zeros(ref.shape); eb = np.zeros(ref.shape)
        ea[both] = angle(b['apo'][both], b['reference'][both])
        eb[both] = angle(b['baseline'][both], b['reference'][both])
        # silhouette: covered pixels with an uncovered 4-neighbour
        sil = ref & dilate(~ref, 1)
        # depth jump: neighbouring drawn depths differ by > 2% of the depth range
        dz = np.where(hit, depth, np.nan)
        span = np.nanmax(dz) - np.nanmin(dz)
        jump = np.zeros(ref.shape, bool)
        for ax in (0, 1):
            dd = np.abs(np.diff(dz, axis=ax)) > 0.02 * span
            if ax == 0:
                jump[1:] |= dd; jump[:-1] |= dd
            else:
                jump[:, 1:] |= dd; jump[:, :-1] |= dd
        # M's ridges: the reference normal turns > 30 degrees to a neighbour
        rn = b['reference']
        ridge = np.zeros(ref.shape, bool)
        for ax in (0, 1):
            a0 = rn[1:] if ax == 0 else rn[:, 1:]
            a1 = rn[:-1] if ax == 0 else rn[:, :-1]
            t = angle(a0, a1) > 30
            c = (covered(a0) & covered(a1))
            t &= c
            if ax == 0:
                ridge[1:] |= t; ridge[:-1] |= t
            else:
                ridge[:, 1:] |= t; ridge[:, :-1] |= t
        for k in ks:
            silk = dilate(sil, k)
            jumpk = dilate(jump, k) & ~silk
            edge = silk | jumpk
            rid = dilate(ridge, 1) & ~edge
            rest = ~edge & ~rid
            for name, m in (('silhouette', silk), ('depth jump', jumpk), ('ridge', rid), ('rest', rest)):
                m = m & both
                r = rows.setdefault((k, name), [0, 0.0, 0.0])
                r[0] += int(m.sum()); r[1] += float(ea[m].sum()); r[2] += float(eb[m].sum())
        r = rows.setdefault('all', [0, 0.0, 0.0])
        r[0] += int(both.sum()); r[1] += float(ea[both].sum()); r[2] += float(eb[both].sum())
    N, SA, SB = rows['all']
    print(f'all: {N} px, APO mean {SA / N:.3f}, m mean {SB / N:.3f}, m / APO {SB / SA:.2f}')
    print('| k px | region | pixels | APO mean | m mean | m / APO | share of APO error | share of m error |')
    print('|---|---|---|---|---|---|---|---|')
    for k in ks:
        for name in ('silhouette', 'depth jump', 'ridge', 'rest'):
            n_, a, bb = rows[(k, name)]
            print(f'| {k} | {name} | {100 * n_ / N:.1f}% | {a / max(n_, 1):.3f} | {bb / max(n_, 1):.3f} | {bb / max(a, 1e-9):.2f} | {100 * a / SA:.1f}% | {100 * bb / SB:.1f}% |')


if __name__ == '__main__':
    cmd = sys.argv[1]
    if cmd == 'compare':
        compare(sys.argv[2], sys.argv[3])
    elif cmd == 'edges':
        edges(sys.argv[2], sys.argv[3], [int(k) for k in sys.argv[4:]] or [1, 2, 4])
    else:
        sys.exit(__doc__)
