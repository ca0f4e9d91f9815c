#!/usr/bin/env python3
"""Writes the binary fixtures of the broken-input corpus (GeoTIFF, GLB,
glTF, LAS point clouds, non-UTF-8 grids) from a few lines each, so that
every byte is reproducible: `python3 make_fixtures.py` in this folder.
Standard library only."""

import json
import math
import struct
from pathlib import Path

HERE = Path(__file__).resolve().parent

# --- TIFF -------------------------------------------------------------------
SHORT, LONG, DOUBLE = 3, 4, 12
SIZE = {SHORT: 2, LONG: 4, DOUBLE: 8}
FMT = {SHORT: "H", LONG: "I", DOUBLE: "d"}


def tiff(width, height, pixels, extra, declared=None):
    """A little-endian, uncompressed, one-strip float32 TIFF.

    `extra` maps tag -> (type, values) (the GeoTIFF tags); `declared`
    overrides (width, height) in the header only."""
    data = struct.pack(f"<{len(pixels)}f", *pixels)
    w, h = declared or (width, height)
    tags = {
        256: (LONG, [w]),
        257: (LONG, [h]),
        258: (SHORT, [32]),
        259: (SHORT, [1]),
        262: (SHORT, [1]),
        273: (LONG, [0]),  # patched below
        277: (SHORT, [1]),
        278: (LONG, [h]),
        279: (LONG, [len(data)]),
        339: (SHORT, [3]),
    }
    tags.update(extra)
    n = len(tags)
    ifd_size = 2 + 12 * n + 4
    blob_at = 8 + ifd_size
    blobs = b""
    entries = []
    for tag in sorted(tags):
        typ, vals = tags[tag]
        raw = struct.pack(f"<{len(vals)}{FMT[typ]}", *vals)
        if len(raw) <= 4:
            entries.append((tag, typ, len(vals), raw.ljust(4, b"\0")))
        else:
            entries.append((tag, typ, len(vals), struct.pack("<I", blob_at + len(blobs))))
            blobs += raw
    pixel_at = blob_at + len(blobs)
    out = b"II*\0" + struct.pack("<I", 8) + struct.pack("<H", n)
    for tag, typ, count, value in entries:
        if tag == 273:
            value = struct.pack("<I", pixel_at)
        out += struct.pack("<HHI", tag, typ, count) + value
    return out + struct.pack("<I", 0) + blobs + data


GEO = {
    33550: (DOUBLE, [10.0, 10.0, 0.0]),
    33922: (DOUBLE, [0.0, 0.0, 0.0, 500.0, 800.0, 0.0]),
}


def geotiff():
    d = HERE / "geotiff"
    d.mkdir(exist_ok=True)
    good = tiff(3, 3, [float(i) for i in range(9)], GEO)
    (d / "good.tif").write_bytes(good)  # the valid baseline
    (d / "truncated.tif").write_bytes(good[:60])
    (d / "not_a_tiff.tif").write_bytes(b"ncols 3\nnrows 3\nthis is not a TIFF\n")
    (d / "no_geotags.tif").write_bytes(tiff(3, 3, [1.0] * 9, {}))
    c, s = math.cos(0.3), math.sin(0.3)
    rot = [10 * c, -10 * s, 0, 500, 10 * s, -10 * c, 0, 800, 0, 0, 0, 0, 0, 0, 0, 1]
    (d / "rotated.tif").write_bytes(tiff(3, 3, [1.0] * 9, {34264: (DOUBLE, rot)}))
    (d / "one_pixel.tif").write_bytes(tiff(1, 1, [5.0], GEO))
    bad = [math.nan, math.inf, -math.inf] * 3
    (d / "all_nan.tif").write_bytes(tiff(3, 3, bad, GEO))
    (d / "huge_dimensions.tif").write_bytes(
        tiff(3, 3, [1.0] * 9, GEO, declared=(4_000_000_000, 4_000_000_000))
    )
    # 9000 × 9000 pixels (under the cell limit) declared in a 200-byte file.
    (d / "huge_strip.tif").write_bytes(
        tiff(3, 3, [1.0] * 9, GEO, declared=(9000, 9000))
    )
    # A ModelPixelScaleTag declaring 2^28 doubles (2 GB) in a 300-byte file.
    t = bytearray(tiff(3, 3, [1.0] * 9, GEO))
    i = t.find(struct.pack("<HHI", 33550, DOUBLE, 3))
    t[i + 4 : i + 8] = struct.pack("<I", 1 << 28)
    (d / "huge_tag.tif").write_bytes(bytes(t))


# --- ESRI ASCII ---------------------------------------------------------------
def asc():
    d = HERE / "asc"
    d.mkdir(exist_ok=True)
    head = "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n"
    files = {
        "missing_nrows.asc": "ncols 3\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3\n4 5 6\n",
        "negative_cellsize.asc": head.replace("cellsize 1", "cellsize -2") + "1 2 3\n4 5 6\n",
        "zero_cellsize.asc": head.replace("cellsize 1", "cellsize 0") + "1 2 3\n4 5 6\n",
        "too_few_values.asc": head + "1 2 3\n4 5\n",
        "too_many_values.asc": head + "1 2 3 4\n5 6 7\n",
        "non_numeric.asc": head + "1 2 3\n4 five 6\n",
        "huge.asc": "ncols 1000000000\nnrows 1000000000\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n",
        "fractional_ncols.asc": head.replace("ncols 3", "ncols 2.5") + "1 2 3\n4 5 6\n",
        "nan_header.asc": head.replace("xllcorner 0", "xllcorner nan") + "1 2 3\n4 5 6\n",
        "empty.asc": "",
    }
    files["good.asc"] = head + "1 2 3\n4 5 6\n"  # the valid baseline
    for name, text in files.items():
        (d / name).write_text(text)
    (d / "non_utf8.asc").write_bytes(head.encode() + b"1 2 3\n4 \xff\xfe 6\n")


# --- glTF -------------------------------------------------------------------
def gltf_doc(positions, indices, buffer_len=None, uri=None, pos_count=None, extra=None):
    pos = struct.pack(f"<{len(positions)}f", *positions)
    idx = struct.pack(f"<{len(indices)}H", *indices)
    if len(idx) % 4:
        idx += b"\0\0"
    bin_ = pos + idx
    n = len(positions) // 3
    finite = [p for p in positions if math.isfinite(p)] or [0.0]
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "roof"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": buffer_len if buffer_len is not None else len(bin_)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
            {"buffer": 0, "byteOffset": len(pos), "byteLength": len(indices) * 2},
        ],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": pos_count if pos_count is not None else n,
                "type": "VEC3",
                "min": [min(finite)] * 3,
                "max": [max(finite)] * 3,
            },
            {"bufferView": 1, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
        ],
    }
    if uri is not None:
        doc["buffers"][0]["uri"] = uri
    if extra:
        extra(doc)
    return doc, bin_


def glb(doc, bin_):
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    bin_ += b"\0" * (-len(bin_) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(bin_), 0x004E4942) + bin_
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


SQUARE = [0, 0, 0, 10, 0, 0, 10, 0, 10, 0, 0, 10]


def gltf():
    d = HERE / "gltf"
    d.mkdir(exist_ok=True)
    good = glb(*gltf_doc(SQUARE, [0, 1, 2, 0, 2, 3]))
    (d / "good.glb").write_bytes(good)  # the valid baseline
    (d / "truncated.glb").write_bytes(good[: len(good) // 2])
    (d / "bad_magic.glb").write_bytes(b"glTX" + good[4:])
    (d / "empty.glb").write_bytes(b"")
    (d / "not_gltf.gltf").write_text('{"type": "FeatureCollection", "features": []}\n')

    doc, _ = gltf_doc(SQUARE, [0, 1, 2, 0, 2, 3], uri="missing.bin")
    (d / "missing_buffer.gltf").write_text(json.dumps(doc, indent=1))

    # The binary chunk holds 24 bytes; the buffer claims 60.
    doc, bin_ = gltf_doc(SQUARE, [0, 1, 2, 0, 2, 3])
    (d / "buffer_too_short.glb").write_bytes(glb(doc, bin_[:24]))

    # The POSITION accessor counts 1000 vertices in a 48-byte view.
    (d / "accessor_past_buffer.glb").write_bytes(
        glb(*gltf_doc(SQUARE, [0, 1, 2, 0, 2, 3], pos_count=1000))
    )
    nan = [math.nan] * 12
    (d / "nan_positions.glb").write_bytes(glb(*gltf_doc(nan, [0, 1, 2, 0, 2, 3])))
    (d / "index_out_of_range.glb").write_bytes(
        glb(*gltf_doc(SQUARE, [0, 1, 2, 0, 2, 77]))
    )

    def zero_count(doc):
        doc["accessors"][1]["count"] = 0

    (d / "zero_count.glb").write_bytes(
        glb(*gltf_doc(SQUARE, [0, 1, 2, 0, 2, 3], extra=zero_count))
    )

    def huge_count(doc):
        doc["accessors"][0]["count"] = 2**62

    (d / "huge_count.glb").write_bytes(
        glb(*gltf_doc(SQUARE, [0, 1, 2, 0, 2, 3], extra=huge_count))
    )


# --- LAS point clouds -----------------------------------------------------------
def las(points, scale=(0.01, 0.01, 0.01)):
    """A LAS 1.2 file of point format 0 (20-byte records)."""
    n = len(points)
    h = bytearray(227)
    h[0:4] = b"LASF"
    h[24], h[25] = 1, 2
    h[26:58] = b"corpus".ljust(32, b"\0")
    h[58:90] = b"make_fixtures.py".ljust(32, b"\0")
    struct.pack_into("<HHHIIBHI", h, 90, 1, 2026, 227, 227, 0, 0, 20, n)
    struct.pack_into("<5I", h, 111, n, 0, 0, 0, 0)
    struct.pack_into("<3d3d", h, 131, *scale, 0.0, 0.0, 0.0)
    xs = [p[0] for p in points] or [0]
    ys = [p[1] for p in points] or [0]
    zs = [p[2] for p in points] or [0]
    struct.pack_into("<6d", h, 179, max(xs), min(xs), max(ys), min(ys), max(zs), min(zs))
    body = b""
    for x, y, z in points:
        body += struct.pack("<3iHBBbBH", round(x / scale[0]), round(y / scale[1]), round(z / scale[2]), 0, 0x09, 2, 0, 0, 0)
    return bytes(h) + body


def cloud():
    d = HERE / "cloud"
    d.mkdir(exist_ok=True)
    pts = [(x * 0.5, y * 0.5, 1.0) for x in range(4) for y in range(4)]
    good = las(pts)
    (d / "good.las").write_bytes(good)  # the valid baseline
    (d / "no_points.las").write_bytes(las([]))
    (d / "empty.las").write_bytes(b"")
    (d / "truncated.las").write_bytes(good[:150])
    (d / "truncated_points.las").write_bytes(good[: 227 + 20 * 5 + 7])
    nan = bytearray(good)
    struct.pack_into("<d", nan, 131, math.nan)  # the X scale factor
    (d / "scale_nan.las").write_bytes(bytes(nan))
    (d / "not_las.laz").write_bytes(b"x,y,z\n1,2,3\n")


if __name__ == "__main__":
    geotiff()
    asc()
    gltf()
    cloud()
