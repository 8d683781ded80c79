#!/usr/bin/env python3
"""The rendered neural BTF against its raw data (docs/neural-btf.md, "The rendered cloth against
its raw data"): relative RMSE over the cloth's pixels, in linear RGB decoded from 8-bit sRGB PNGs,
and optionally the side-by-side image (neural | reference | |difference| x 8).

usage: bench/btf_reference_compare.py NEURAL.png REFERENCE.png BLACK.png [PANEL.png]

NEURAL and REFERENCE are the same scene rendered with the model and with "mode": "reference";
BLACK is the neural render with the cloth's tint 0. The cloth's pixels are those where BLACK
differs from REFERENCE or NEURAL differs from REFERENCE. Python 3 only (no numpy or PIL)."""
import math
import struct
import sys
import zlib


def read_png(path):
    """8-bit RGB or RGBA, not interlaced: (width, height, channels, rows of bytes)."""
    data = open(path, 'rb').read()
    if data[:8] != b'\x89PNG\r\n\x1a\n':
        sys.exit(f"{path}: not a PNG file")
    pos, idat, header = 8, b'', None
    while pos + 8 <= len(data):
        n, kind = struct.unpack('>I4s', data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b'IHDR':
            header = struct.unpack('>IIBBBBB', body)
        elif kind == b'IDAT':
            idat += body
        pos += 12 + n
    if header is None:
        sys.exit(f"{path}: no IHDR chunk")
    w, h, depth, ctype, _, _, interlace = header
    if depth != 8 or interlace != 0 or ctype not in (2, 6):
        sys.exit(f"{path}: {depth}-bit colour type {ctype}, interlace {interlace}; this reads 8-bit RGB/RGBA only")
    ch = 3 if ctype == 2 else 4
    raw = zlib.decompress(idat)
    stride = w * ch
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - ch] if i >= ch else 0
            b = prev[i]
            c = prev[i - ch] if i >= ch else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prev = line
    return w, h, ch, rows


LINEAR = [(v / 255) / 12.92 if v / 255 <= 0.04045 else ((v / 255 + 0.055) / 1.055) ** 2.4 for v in range(256)]


def to_srgb(x):
    x = min(max(x, 0.0), 1.0)
    return round(255 * (12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055))


def write_png(path, w, h, rows):
    def chunk(kind, body):
        return struct.pack('>I', len(body)) + kind + body + struct.pack('>I', zlib.crc32(kind + body) & 0xffffffff)
    raw = b''.join(b'\x00' + bytes(r) for r in rows)
    with open(path, 'wb') as f:
        f.write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 2, 0, 0, 0)) +
                chunk(b'IDAT', zlib.compress(raw, 9)) + chunk(b'IEND', b''))


def main():
    if len(sys.argv) in (1, 2) or sys.argv[1] in ('-h', '--help') or len(sys.argv) not in (4, 5):
        print(__doc__)
        sys.exit(0 if len(sys.argv) > 1 and sys.argv[1] in ('-h', '--help') else 2)
    neural, ref, black = (read_png(p) for p in sys.argv[1:4])
    if {(neural[0], neural[1]), (ref[0], ref[1]), (black[0], black[1])} != {(neural[0], neural[1])}:
        sys.exit("the three images differ in size")
    w, h = neural[0], neural[1]
    se = sr = 0.0
    n = 0
    for y in range(h):
        a, b, k = neural[3][y], ref[3][y], black[3][y]
        for x in range(w):
            pa, pb, pk = (img[x * c:x * c + 3] for img, c in ((a, neural[2]), (b, ref[2]), (k, black[2])))
            if pa == pb and pk == pb:
                continue  # not the cloth
            n += 1
            for c in range(3):
                d = LINEAR[pa[c]] - LINEAR[pb[c]]
                se += d * d
                sr += LINEAR[pb[c]] ** 2
    if n == 0:
        sys.exit("no cloth pixels: the neural, reference and black renders are identical")
    rmse, rms = math.sqrt(se / (3 * n)), math.sqrt(sr / (3 * n))
    print(f"cloth pixels {n}: RMSE {rmse:.4f}, reference RMS {rms:.4f}, relative RMSE {100 * rmse / rms:.1f} %")
    if len(sys.argv) == 5:
        rows = []
        for y in range(h):
            a, b = neural[3][y], ref[3][y]
            line = bytearray()
            for img, c in ((a, neural[2]), (b, ref[2])):
                for x in range(w):
                    line += img[x * c:x * c + 3]
            for x in range(w):
                line += bytes(to_srgb(8 * abs(LINEAR[a[x * neural[2] + c]] - LINEAR[b[x * ref[2] + c]])) for c in range(3))
            rows.append(line)
        write_png(sys.argv[4], 3 * w, h, rows)
        print(f"wrote {sys.argv[4]} ({3 * w} x {h})")


if __name__ == '__main__':
    main()
