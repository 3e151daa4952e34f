#!/usr/bin/env python3
"""An independent evaluation of an RGL-EPFL tensor file (Dupuy & Jakob 2018) in the plane
of incidence, written from the reference reader rgl-epfl/brdf-loader in plain Python (no
gonio code): prints f_r = eval / cos(theta_o) in 1/sr.

- An RGB file (powitacq_rgb.inl: Tensor, Marginal2D::invert/eval, BRDF::eval, negative
  RGB clamped to 0): R, G, B and Rec. 709 Y.
- A spectral file (powitacq.inl: the `spectra` field interpolated over phi_i, theta_i and
  `wavelengths`, not clamped): CIE 1931 Y (the spectrum weighted by ybar times the
  trapezoid weight of each of the file's wavelengths, normalised: an equal-energy
  illuminant), then f_r at each of the file's wavelengths, then at each --nm NM (the
  reference interpolant's own linear interpolation along its wavelength parameter).

Usage: rgl_reference.py FILE.bsdf [--nm NM ...] THETA_I THETA_R [THETA_I THETA_R ...]
(degrees; theta_r signed, positive on the specular side), or
rgl_reference.py --make-spectral FILE.bsdf to write the small hand-made spectral material
the tests use. gonio's tests hold this script's output.
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
        elif dt == 11:
            data = list(struct.unpack_from("<%dd" % count, b, off))
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


# CIE 1931 2-degree observer ybar at 360, 365, ..., 830 nm: the 5 nm table of CIE 015
# (as CVRL publishes it), typed independently of gonio's 1 nm table; linear between.
YBAR_5NM = [
    0.000003917, 0.000006965, 0.00001239, 0.00002202, 0.000039, 0.000064, 0.00012,
    0.000217, 0.000396, 0.00064, 0.00121, 0.00218, 0.004, 0.0073, 0.0116, 0.01684,
    0.023, 0.0298, 0.038, 0.048, 0.06, 0.0739, 0.09098, 0.1126, 0.13902, 0.1693,
    0.20802, 0.2586, 0.323, 0.4073, 0.503, 0.6082, 0.71, 0.7932, 0.862, 0.9148501,
    0.954, 0.9803, 0.9949501, 1.0, 0.995, 0.9786, 0.952, 0.9154, 0.87, 0.8163, 0.757,
    0.6949, 0.631, 0.5668, 0.503, 0.4412, 0.381, 0.321, 0.265, 0.217, 0.175, 0.1382,
    0.107, 0.0816, 0.061, 0.04458, 0.032, 0.0232, 0.017, 0.01192, 0.00821, 0.005723,
    0.004102, 0.002929, 0.002091, 0.001484, 0.001047, 0.00074, 0.00052, 0.0003611,
    0.0002492, 0.0001719, 0.00012, 0.0000848, 0.00006, 0.0000424, 0.00003, 0.0000212,
    0.00001499, 0.0000106, 0.0000074657, 0.0000052578, 0.0000037029, 0.0000026078,
    0.0000018366, 0.0000012934, 0.00000091093, 0.00000064153, 0.00000045181,
]


def ybar(nm):
    x = (nm - 360.0) / 5.0
    if x < 0 or x > len(YBAR_5NM) - 1:
        return 0.0
    i = min(int(x), len(YBAR_5NM) - 2)
    return YBAR_5NM[i] + (x - i) * (YBAR_5NM[i + 1] - YBAR_5NM[i])


def y_weights(wl):
    """ybar(lambda_k) times the trapezoid weight of lambda_k on the file's grid, summing to 1."""
    n = len(wl)
    dl = [((wl[min(k + 1, n - 1)] - wl[max(k - 1, 0)]) / 2.0) for k in range(n)]
    w = [ybar(wl[k]) * dl[k] for k in range(n)]
    return [x / sum(w) for x in w]


def brdf(fields, nms=()):
    phi_i, theta_i = fields["phi_i"][1], fields["theta_i"][1]
    ndf_s, ndf = fields["ndf"]
    sig_s, sig = fields["sigma"]
    vndf_s, vndf = fields["vndf"]
    w_ndf = Warp(ndf_s[1], ndf_s[0], ndf, [], False)
    w_sig = Warp(sig_s[1], sig_s[0], sig, [], False)
    w_vndf = Warp(vndf_s[3], vndf_s[2], vndf, [phi_i, theta_i], True)
    spectral = "rgb" not in fields
    if spectral:
        wl = fields["wavelengths"][1]
        val_s, val = fields["spectra"]
        third = list(wl) + list(nms)
        yw = y_weights(wl)
    else:
        val_s, val = fields["rgb"]
        wl, third = [0.0, 1.0, 2.0], [0.0, 1.0, 2.0]
    w_val = Warp(val_s[4], val_s[3], val, [phi_i, theta_i, wl], False)
    iso = len(phi_i) <= 2
    width = 1 + len(third) if spectral else 4

    def f_r(ti_deg, tr_deg):
        ti, tr = math.radians(ti_deg), math.radians(tr_deg)
        wi = (math.sin(ti), 0.0, math.cos(ti))
        wo = (-math.sin(tr), 0.0, math.cos(tr))
        if abs(tr_deg) >= 90 or wi[2] <= 0 or wo[2] <= 0:
            return [0.0] * width
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
        c = [w_val.eval(sample, (p_i, t_i, k)) for k in third]
        if not spectral:
            c = [max(0.0, x) for x in c]
        scale = w_ndf.eval(u_wm) / (4 * w_sig.eval(u_wi))
        fr = [x * scale / wo[2] for x in c]
        if spectral:
            return [sum(a * b for a, b in zip(yw, fr))] + fr
        return fr + [0.2126 * fr[0] + 0.7152 * fr[1] + 0.0722 * fr[2]]

    return f_r


def make_spectral(path):
    """A small spectral material (1 phi_i, 3 theta_i, 9 wavelengths 380..780 nm, 5 x 5
    tables) with every field and shape the reference constructor requires; smooth,
    non-uniform values so that the VNDF inversion and every interpolation matter."""
    n, thetas, wls = 5, [0.0, 0.7, math.pi / 2], [380.0 + 50.0 * k for k in range(9)]
    ndf = [1.0 + 0.5 * x + 0.25 * y * y for y in range(n) for x in range(n)]
    sigma = [2.0 + 0.1 * x + 0.2 * y for y in range(n) for x in range(n)]
    vndf = [1.0 + 0.3 * x + 0.2 * y + 0.5 * t * x / (y + 1)
            for t in range(3) for y in range(n) for x in range(n)]
    lum = [1.0] * (3 * n * n)
    spectra = [(0.5 + 0.1 * x + 0.05 * y * x + 0.2 * t) * (1.0 + 0.3 * math.sin(0.9 * k + t))
               for t in range(3) for k in range(len(wls)) for y in range(n) for x in range(n)]
    desc = b"hand-made spectral test material (gonio, rgl_reference.py --make-spectral)"
    fields = [
        ("description", 1, [len(desc)], desc),
        ("jacobian", 1, [1], b"\x01"),
        ("theta_i", 10, [3], thetas),
        ("phi_i", 10, [1], [0.0]),
        ("wavelengths", 10, [len(wls)], wls),
        ("ndf", 10, [n, n], ndf),
        ("sigma", 10, [n, n], sigma),
        ("vndf", 10, [1, 3, n, n], vndf),
        ("luminance", 10, [1, 3, n, n], lum),
        ("spectra", 10, [1, 3, len(wls), n, n], spectra),
    ]
    head_len = 18 + sum(2 + len(f[0]) + 2 + 1 + 8 + 8 * len(f[2]) for f in fields)
    head = b"tensor_file\0\x01\x00" + struct.pack("<I", len(fields))
    data = b""
    for name, dt, shape, values in fields:
        blob = bytes(values) if dt == 1 else struct.pack("<%df" % len(values), *values)
        head += struct.pack("<H", len(name)) + name.encode() + struct.pack("<H", len(shape))
        head += bytes([dt]) + struct.pack("<Q", head_len + len(data))
        head += b"".join(struct.pack("<Q", s) for s in shape)
        data += blob
    assert len(head) == head_len
    open(path, "wb").write(head + data)


if __name__ == "__main__":
    if sys.argv[1] == "--make-spectral":
        make_spectral(sys.argv[2])
        sys.exit(0)
    args, nms = sys.argv[2:], []
    while args and args[0] == "--nm":
        nms.append(float(args[1]))
        args = args[2:]
    f = brdf(read_tensor(sys.argv[1]), nms)
    a = [float(x) for x in args]
    for ti, tr in zip(a[::2], a[1::2]):
        print(ti, tr, " ".join(repr(v) for v in f(ti, tr)))
