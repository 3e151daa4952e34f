#!/usr/bin/env python3
"""An independent evaluation of an RGL-EPFL RGB tensor file (Dupuy & Jakob 2018) in the
plane of incidence, written from the reference reader rgl-epfl/brdf-loader
(powitacq_rgb.inl: Tensor, Marginal2D::invert/eval, BRDF::eval) in plain Python (no
gonio code): prints f_r = eval / cos(theta_o) in 1/sr for R, G, B and Rec. 709 Y.

Usage: rgl_reference.py FILE.bsdf THETA_I THETA_R [THETA_I THETA_R ...]  (degrees; theta_r
signed, positive on the specular side). gonio's tests hold this script's output.
"""
import math
import struct
import sys


def read_tensor(path):
    b = open(path, "rb").read()
    assert b[:12] == b"tensor_file\0" and b[12:14] == b"\x01\x00"
    (n,) = struct.unpack_from("<I", b, 14)
    p, fields = 18, {}
    for _ in range(n):
        (ln,) = struct.unpack_from("<H", b, p); p += 2
        name = b[p:p + ln].decode(); p += ln
        (nd,) = struct.unpack_from("<H", b, p); p += 2
        dt = b[p]; p += 1
        (off,) = struct.unpack_from("<Q", b, p); p += 8
        shape = struct.unpack_from("<%dQ" % nd, b, p); p += 8 * nd
        count = 1
        for s in shape:
            count *= s
        if dt == 10:
            data = list(struct.unpack_from("<%df" % count, b, off))
        else:
            data = list(b[off:off + count])
        fields[name] = (shape, data)
    return fields


def find_interval(size, pred):
    size_, first = size - 2, 1
    while size_ > 0:
        half = size_ >> 1
        middle = first + half
        if pred(middle):
            first = middle + 1
            size_ -= half + 1
        else:
            size_ = half
    return min(max(first - 1, 0), size - 2)


class Warp:
    """Marginal2D with params (param_values lists, outermost first)."""

    def __init__(self, nx, ny, data, params, normalize):
        self.nx, self.ny, self.params = nx, ny, params
        self.strides, slices = [0] * len(params), 1
        for i in range(len(params) - 1, -1, -1):
            self.strides[i] = slices if len(params[i]) > 1 else 0
            slices *= len(params[i])
        n = nx * ny
        self.data, self.cond, self.marg = [], [], []
        for s in range(slices):
            d = data[s * n:(s + 1) * n]
            if not normalize:
                # As the reference: scaled by the patch area, which eval multiplies back.
                self.data += [v / ((nx - 1) * (ny - 1)) for v in d]
                continue
            cond = [0.0] * n
            for y in range(ny):
                acc, i = 0.0, y * nx
                for x in range(nx - 1):
                    acc += 0.5 * (d[i + x] + d[i + x + 1])
                    cond[i + x + 1] = acc
            marg, acc = [0.0] * ny, 0.0
            for y in range(ny - 1):
                acc += 0.5 * (cond[(y + 1) * nx - 1] + cond[(y + 2) * nx - 1])
                marg[y + 1] = acc
            k = 1.0 / marg[ny - 1]
            self.cond += [c * k for c in cond]
            self.marg += [m * k for m in marg]
            self.data += [v * k for v in d]

    def weights(self, param):
        ws, off = [], 0
        for dim, values in enumerate(self.params):
            if len(values) == 1:
                ws.append((1.0, 0.0))
                continue
            i = find_interval(len(values), lambda j: values[j] <= param[dim])
            w1 = min(max((param[dim] - values[i]) / (values[i + 1] - values[i]), 0.0), 1.0)
            ws.append((1.0 - w1, w1))
            off += self.strides[dim] * i
        return ws, off

    def lookup(self, arr, base, i0, size, ws, dim=None):
        if dim is None:
            dim = len(self.params)
        if dim == 0:
            return arr[base + i0]
        i1 = i0 + self.strides[dim - 1] * size
        w0, w1 = ws[dim - 1]
        return (self.lookup(arr, base, i0, size, ws, dim - 1) * w0
                + self.lookup(arr, base, i1, size, ws, dim - 1) * w1)

    def eval(self, pos, param=()):
        ws, so = self.weights(param)
        px, py = pos[0] * (self.nx - 1), pos[1] * (self.ny - 1)
        ox, oy = min(int(px), self.nx - 2), min(int(py), self.ny - 2)
        w1x, w1y = px - ox, py - oy
        n = self.nx * self.ny
        idx = ox + oy * self.nx + so * n
        v00 = self.lookup(self.data, 0, idx, n, ws)
        v10 = self.lookup(self.data, 1, idx, n, ws)
        v01 = self.lookup(self.data, self.nx, idx, n, ws)
        v11 = self.lookup(self.data, self.nx + 1, idx, n, ws)
        return ((1 - w1y) * ((1 - w1x) * v00 + w1x * v10)
                + w1y * ((1 - w1x) * v01 + w1x * v11)) * (self.nx - 1) * (self.ny - 1)

    def invert(self, pos, param):
        ws, so = self.weights(param)
        nx, ny, n = self.nx, self.ny, self.nx * self.ny
        sx, sy = pos[0] * (nx - 1), pos[1] * (ny - 1)
        px, py = min(int(sx), nx - 2), min(int(sy), ny - 2)
        sx, sy = sx - px, sy - py
        off = px + py * nx + so * n
        v00 = self.lookup(self.data, 0, off, n, ws)
        v10 = self.lookup(self.data, 1, off, n, ws)
        v01 = self.lookup(self.data, nx, off, n, ws)
        v11 = self.lookup(self.data, nx + 1, off, n, ws)
        c0 = (1 - sy) * v00 + sy * v01
        c1 = (1 - sy) * v10 + sy * v11
        sx *= c0 + 0.5 * sx * (c1 - c0)
        v0 = self.lookup(self.cond, 0, off, n, ws)
        v1 = self.lookup(self.cond, nx, off, n, ws)
        sx += (1 - sy) * v0 + sy * v1
        off = py * nx + so * n
        r0 = self.lookup(self.cond, 0, off + nx - 1, n, ws)
        r1 = self.lookup(self.cond, 0, off + 2 * nx - 1, n, ws)
        sx /= (1 - sy) * r0 + sy * r1
        sy *= r0 + 0.5 * sy * (r1 - r0)
        sy += self.lookup(self.marg, 0, py + so * ny, ny, ws)
        return sx, sy


def brdf(fields):
    phi_i, theta_i = fields["phi_i"][1], fields["theta_i"][1]
    ndf_s, ndf = fields["ndf"]
    sig_s, sig = fields["sigma"]
    vndf_s, vndf = fields["vndf"]
    rgb_s, rgb = fields["rgb"]
    w_ndf = Warp(ndf_s[1], ndf_s[0], ndf, [], False)
    w_sig = Warp(sig_s[1], sig_s[0], sig, [], False)
    w_vndf = Warp(vndf_s[3], vndf_s[2], vndf, [phi_i, theta_i], True)
    w_rgb = Warp(rgb_s[4], rgb_s[3], rgb, [phi_i, theta_i, [0.0, 1.0, 2.0]], False)
    iso = len(phi_i) <= 2

    def f_r(ti_deg, tr_deg):
        ti, tr = math.radians(ti_deg), math.radians(tr_deg)
        wi = (math.sin(ti), 0.0, math.cos(ti))
        wo = (-math.sin(tr), 0.0, math.cos(tr))
        if abs(tr_deg) >= 90 or wi[2] <= 0 or wo[2] <= 0:
            return [0.0] * 4
        h = [a + b for a, b in zip(wi, wo)]
        ln = math.sqrt(sum(x * x for x in h))
        wm = [x / ln for x in h]
        t_i, p_i = math.acos(wi[2]), math.atan2(wi[1], wi[0])
        t_m, p_m = math.acos(wm[2]), math.atan2(wm[1], wm[0])
        theta2u = lambda t: math.sqrt(t * (2 / math.pi))
        phi2u = lambda p: (p + math.pi) / (2 * math.pi)
        u_wi = (theta2u(t_i), phi2u(p_i))
        uy = phi2u(p_m - p_i if iso else p_m)
        u_wm = (theta2u(t_m), uy - math.floor(uy))
        sample = w_vndf.invert(u_wm, (p_i, t_i))
        c = [max(0.0, w_rgb.eval(sample, (p_i, t_i, float(k)))) for k in range(3)]
        scale = w_ndf.eval(u_wm) / (4 * w_sig.eval(u_wi))
        fr = [x * scale / wo[2] for x in c]
        return fr + [0.2126 * fr[0] + 0.7152 * fr[1] + 0.0722 * fr[2]]

    return f_r


if __name__ == "__main__":
    f = brdf(read_tensor(sys.argv[1]))
    a = [float(x) for x in sys.argv[2:]]
    for ti, tr in zip(a[::2], a[1::2]):
        print(ti, tr, " ".join(repr(v) for v in f(ti, tr)))
