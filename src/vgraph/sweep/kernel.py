"""The sweep (Retondaro 2008 fig. 2.13 and ch. 4; Farias, Mitchell and Silva 2000), compiled with
numba. Arrays are flat: vertex ``v = (k * ny + j) * nx + i`` for index (i, j, k) = (x, y, z);
cell ``(k * (ny - 1) + j) * (nx - 1) + i`` for the cell whose lowest vertex is (i, j, k).

1. Events: a binary heap of vertices keyed by depth. It starts with the seeds, the swept vertices
   with no swept neighbour nearer the eye (without a threshold: the box corner nearest the eye,
   or the nearest edge or face where several tie); each popped vertex sends its unsent neighbours
   (each vertex is sent once), so vertices leave the heap in depth order.
2. Faces: at a vertex's event each quad face incident to it is projected when none of its other
   three vertices was swept before (a face only once, from its nearest vertex). Projecting a face
   intersects the rays of the pixels its projected corners cover with the face's plane and
   inserts, per pixel hit, (t, scalar) into the pixel's list sorted by t: t is the ray parameter
   (world units from the near plane, as the reference's), the scalar the bilinear interpolation
   of the four vertex values at the hit (the trilinear field on the face, exactly).
3. Lazy compositing: when the sweep reaches the current target z (ZSweep: the depth of the
   farthest neighbour of the vertex that set it), every list's entries up to the plane are final
   (faces projected later lie behind it): consecutive ones are composited front to back and freed,
   the last kept as the start of the next segment. At the end all lists are flushed.
4. A segment from (t_c, s_c) to (t_n, s_n), l = t_n - t_c: C = (C(s_c) + C(s_n)) / 2,
   alpha = 1 - exp(-(tau(s_c) + tau(s_n)) / 2 * l), tau(s) = -ln(1 - a(s)) / min(spacing) (the TF's
   alpha is per sample at rate 1, as in the ray casters); in log space as the reference is. A pixel
   stops at A >= early_termination (checked before each segment, as the reference's samples).
   The per-pixel arrays come in holding what grids in front composited already (zero for one
   grid): this grid's segments go behind them.
"""

from __future__ import annotations

import math

import numba
import numpy as np

OVERFLOW = -1  # the entry pool was too small; the caller retries with a larger one
UV_SLACK = 1e-9  # face parameters this far outside [0, 1] still hit (rays along shared edges)
PIXEL_SLACK = 1e-3  # pixels this far outside a face's projected corners are still tested


@numba.njit(cache=True)
def _push(heap_d, heap_v, size, depth, vertex):
    i = size
    heap_d[i], heap_v[i] = depth, vertex
    while i > 0:
        parent = (i - 1) // 2
        if heap_d[parent] <= heap_d[i]:
            break
        heap_d[parent], heap_d[i] = heap_d[i], heap_d[parent]
        heap_v[parent], heap_v[i] = heap_v[i], heap_v[parent]
        i = parent
    return size + 1


@numba.njit(cache=True)
def _pop(heap_d, heap_v, size):
    vertex = heap_v[0]
    size -= 1
    heap_d[0], heap_v[0] = heap_d[size], heap_v[size]
    i = 0
    while True:
        left, smallest = 2 * i + 1, i
        if left < size and heap_d[left] < heap_d[smallest]:
            smallest = left
        if left + 1 < size and heap_d[left + 1] < heap_d[smallest]:
            smallest = left + 1
        if smallest == i:
            break
        heap_d[smallest], heap_d[i] = heap_d[i], heap_d[smallest]
        heap_v[smallest], heap_v[i] = heap_v[i], heap_v[smallest]
        i = smallest
    return vertex, size


@numba.njit(cache=True)
def _lookup(lut, s, out):
    x = min(max(s, 0.0), 1.0) * (lut.shape[0] - 1)
    base = min(int(math.floor(x)), lut.shape[0] - 2)
    frac = x - base
    for c in range(4):
        out[c] = lut[base, c] * (1.0 - frac) + lut[base + 1, c] * frac


@numba.njit(cache=True)
def _extinction(alpha, tau_scale):
    if alpha >= 1.0:
        return np.inf
    return -math.log1p(-alpha) * tau_scale


@numba.njit(cache=True)
def _in_kept_cell(point, inverse, dims, kept_cells):
    cell = 0
    stride = 1
    for axis in range(3):
        u = inverse[axis, 0] * point[0] + inverse[axis, 1] * point[1] + inverse[axis, 2] * point[2] \
            + inverse[axis, 3]
        c = min(max(int(math.floor(u)), 0), dims[axis] - 2)
        cell += c * stride
        stride *= dims[axis] - 1
    return kept_cells[cell]


@numba.njit(cache=True)
def sweep(values, positions, pixel_x, pixel_y, depths, kept_vertices, kept_cells, dims, origins,
          directions, cosines, t_far, near, width, height, lut, tau_scale, threshold_on, inverse,
          early_termination, capacity, colour, log_transparency, first_t, segments):
    """Render into the per-pixel arrays (module docstring); ``pixel_x``, ``pixel_y`` are the
    vertices' projections in pixel coordinates (pixel centres at whole numbers). Returns (vertices swept, faces
    projected, largest pool use) or (OVERFLOW, 0, 0) when ``capacity`` entries were too few."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    n = nx * ny * nz
    strides = np.array([1, nx, nx * ny])
    pixels = width * height
    # per-pixel lists of (t, s) sorted by t, in a pool with a free list
    entry_t = np.empty(capacity)
    entry_s = np.empty(capacity)
    entry_next = np.full(capacity, -1, dtype=np.int64)
    head = np.full(pixels, -1, dtype=np.int64)
    free, used, peak, live = -1, 0, 0, 0
    last_t = np.full(pixels, np.nan)
    last_s = np.zeros(pixels)
    done = np.zeros(pixels, dtype=np.bool_)
    for p in range(pixels):  # a grid behind others continues their compositing (vgraph.sweep.leaves)
        done[p] = -math.expm1(log_transparency[p]) >= early_termination
    front, back, point = np.empty(4), np.empty(4), np.empty(3)

    sent = np.zeros(n, dtype=np.bool_)
    swept = np.zeros(n, dtype=np.bool_)
    heap_d = np.empty(n)
    heap_v = np.empty(n, dtype=np.int64)
    size = 0
    index = np.empty(3, dtype=np.int64)
    for v in range(n):  # seeds (module docstring)
        if not kept_vertices[v]:
            continue
        index[0], index[1], index[2] = v % nx, (v // nx) % ny, v // (nx * ny)
        seed = True
        for axis in range(3):
            for step in (-1, 1):
                c = index[axis] + step
                if 0 <= c < dims[axis]:
                    other = v + step * strides[axis]
                    if kept_vertices[other] and depths[other] < depths[v]:
                        seed = False
        if seed:
            sent[v] = True
            size = _push(heap_d, heap_v, size, depths[v], v)

    target = -np.inf
    swept_count, face_count = 0, 0
    corner = np.empty(4, dtype=np.int64)
    px = np.empty(4)
    py = np.empty(4)
    base, edge_u, edge_w, normal = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    cell = np.empty(3, dtype=np.int64)
    while size > 0 or target < np.inf:
        if size > 0:
            plane = heap_d[0]
        else:
            plane = np.inf
        if plane >= target:  # a target-z event: composite every list up to the plane
            for p in range(pixels):
                cur = head[p]
                while cur != -1 and (plane == np.inf or near + entry_t[cur] * cosines[p] <= plane):
                    t, s = entry_t[cur], entry_s[cur]
                    length = t - last_t[p]
                    if length > 0.0 and not done[p]:
                        inside = True
                        if threshold_on:
                            middle = 0.5 * (t + last_t[p])
                            for c in range(3):
                                point[c] = origins[p, c] + middle * directions[p, c]
                            inside = _in_kept_cell(point, inverse, dims, kept_cells)
                        if inside:
                            _lookup(lut, last_s[p], front)
                            _lookup(lut, s, back)
                            depth = 0.5 * (_extinction(front[3], tau_scale)
                                           + _extinction(back[3], tau_scale)) * length
                            alpha = -math.expm1(-depth)
                            weight = math.exp(log_transparency[p]) * alpha * 0.5
                            for c in range(3):
                                colour[p, c] += weight * (front[c] + back[c])
                            log_transparency[p] -= depth
                            segments[p] += 1
                            if alpha > 0.0 and math.isnan(first_t[p]):
                                first_t[p] = last_t[p]
                            if -math.expm1(log_transparency[p]) >= early_termination:
                                done[p] = True
                    last_t[p], last_s[p] = t, s
                    nxt = entry_next[cur]
                    entry_next[cur] = free
                    free = cur
                    live -= 1
                    cur = nxt
                head[p] = cur
            if size == 0:
                break
        v, size = _pop(heap_d, heap_v, size)
        swept[v] = True
        swept_count += 1
        index[0], index[1], index[2] = v % nx, (v // nx) % ny, v // (nx * ny)
        if plane >= target:  # the next target: the farthest neighbour of this vertex
            target = plane
            for axis in range(3):
                for step in (-1, 1):
                    if 0 <= index[axis] + step < dims[axis]:
                        target = max(target, depths[v + step * strides[axis]])
        for axis in range(3):  # send the neighbours not sent yet
            for step in (-1, 1):
                if 0 <= index[axis] + step < dims[axis]:
                    other = v + step * strides[axis]
                    if kept_vertices[other] and not sent[other]:
                        sent[other] = True
                        size = _push(heap_d, heap_v, size, depths[other], other)
        # the 12 faces incident to v: normal along ``axis``, spanning b and c
        for axis in range(3):
            b, c = (axis + 1) % 3, (axis + 2) % 3
            for sb in (-1, 1):
                for sc in (-1, 1):
                    ib, ic = index[b] + sb, index[c] + sc
                    if not (0 <= ib < dims[b] and 0 <= ic < dims[c]):
                        continue
                    corner[0] = v
                    corner[1] = v + sb * strides[b]
                    corner[2] = v + sc * strides[c]
                    corner[3] = corner[1] + sc * strides[c]
                    if swept[corner[1]] or swept[corner[2]] or swept[corner[3]]:
                        continue  # projected already, from a vertex swept before
                    if threshold_on and not _face_kept(index, axis, b, c, min(index[b], ib),
                                                       min(index[c], ic), dims, kept_cells, cell):
                        continue
                    face_count += 1
                    for q in range(4):
                        px[q], py[q] = pixel_x[corner[q]], pixel_y[corner[q]]
                    x0 = max(0, int(math.ceil(px.min() - PIXEL_SLACK)))
                    x1 = min(width - 1, int(math.floor(px.max() + PIXEL_SLACK)))
                    y0 = max(0, int(math.ceil(py.min() - PIXEL_SLACK)))
                    y1 = min(height - 1, int(math.floor(py.max() + PIXEL_SLACK)))
                    for m in range(3):
                        base[m] = positions[corner[0], m]
                        edge_u[m] = positions[corner[1], m] - base[m]
                        edge_w[m] = positions[corner[2], m] - base[m]
                    normal[0] = edge_u[1] * edge_w[2] - edge_u[2] * edge_w[1]
                    normal[1] = edge_u[2] * edge_w[0] - edge_u[0] * edge_w[2]
                    normal[2] = edge_u[0] * edge_w[1] - edge_u[1] * edge_w[0]
                    uu = edge_u[0] * edge_u[0] + edge_u[1] * edge_u[1] + edge_u[2] * edge_u[2]
                    ww = edge_w[0] * edge_w[0] + edge_w[1] * edge_w[1] + edge_w[2] * edge_w[2]
                    s00, s10 = values[corner[0]], values[corner[1]]
                    s01, s11 = values[corner[2]], values[corner[3]]
                    for y in range(y0, y1 + 1):
                        for x in range(x0, x1 + 1):
                            p = y * width + x
                            if done[p]:
                                continue
                            den = directions[p, 0] * normal[0] + directions[p, 1] * normal[1] \
                                + directions[p, 2] * normal[2]
                            if den == 0.0:
                                continue  # seen edge-on: the neighbouring faces bound the ray
                            t = ((base[0] - origins[p, 0]) * normal[0] + (base[1] - origins[p, 1]) * normal[1]
                                 + (base[2] - origins[p, 2]) * normal[2]) / den
                            if t < 0.0 or t > t_far[p]:
                                continue  # outside the near and far planes, as the reference clips
                            for m in range(3):
                                point[m] = origins[p, m] + t * directions[p, m] - base[m]
                            u = (point[0] * edge_u[0] + point[1] * edge_u[1] + point[2] * edge_u[2]) / uu
                            w = (point[0] * edge_w[0] + point[1] * edge_w[1] + point[2] * edge_w[2]) / ww
                            if u < -UV_SLACK or u > 1.0 + UV_SLACK or w < -UV_SLACK or w > 1.0 + UV_SLACK:
                                continue
                            u, w = min(max(u, 0.0), 1.0), min(max(w, 0.0), 1.0)
                            s = (s00 * (1.0 - u) + s10 * u) * (1.0 - w) + (s01 * (1.0 - u) + s11 * u) * w
                            if free != -1:
                                node = free
                                free = entry_next[node]
                            elif used < capacity:
                                node = used
                                used += 1
                            else:
                                return OVERFLOW, 0, 0
                            live += 1
                            peak = max(peak, live)
                            entry_t[node], entry_s[node] = t, s
                            prev, cur = -1, head[p]
                            while cur != -1 and entry_t[cur] <= t:
                                prev, cur = cur, entry_next[cur]
                            entry_next[node] = cur
                            if prev == -1:
                                head[p] = node
                            else:
                                entry_next[prev] = node
    return swept_count, face_count, peak


@numba.njit(cache=True)
def _face_kept(index, axis, b, c, low_b, low_c, dims, kept_cells, cell):
    """Whether a kept cell has this face: the cells on either side of it along ``axis`` (``cell``
    is scratch space)."""
    cell[b], cell[c] = min(low_b, dims[b] - 2), min(low_c, dims[c] - 2)
    for side in (-1, 0):
        a = index[axis] + side
        if 0 <= a <= dims[axis] - 2:
            cell[axis] = a
            if kept_cells[(cell[2] * (dims[1] - 1) + cell[1]) * (dims[0] - 1) + cell[0]]:
                return True
    return False
