#!/usr/bin/env python3
"""Independent check of every point format lidarsim writes, on a run of
scripts/fixtures/two-planes.toml (roof strips 5 m above the ground, two
echoes per pulse, projected coordinates in EPSG:25832 with an offset).

Readers: laspy (LAS 1.4 point format 9, Extra Bytes VLR, Waveform Packet
Descriptor VLRs, WKT VLR), laspy + lazrs (LAZ), pyproj (the CRS), and for
PLY and the external .wdp waveform file plain numpy following the PLY
specification and LAS 1.4 R15 (no lidarsim code). The sensor positions come
from DIR/trajectory_true.csv.

Waveforms, as LASlib reads them: the samples of a point's packet start at
byte `wavepacket_offset` of points.wdp (offsets count from the start of the
file, whose first 60 bytes are the EVLR header of the waveform data packet
record); sample s lies at point + (location - s * spacing) * (Xt, Yt, Zt),
so the first sample, the "anchor", is at point + location * (Xt, Yt, Zt).
Checked: the local maximum of the samples lies within one sample of each
echo's return point waveform location; the echoes of one pulse share their
packet and their anchor (within 1 cm); the anchor lies on the beam at the
range of the first sample (within 1 cm of sensor + direction * (range -
location * c/2)); (Xt, Yt, Zt) points from the echo to the sensor with
length c/2 per ps.

Prints the figures it checked and "N passed, N failed".
"""

import json
import sys
from pathlib import Path

import laspy
import numpy as np

C = 299_792_458.0
passed = 0
failed = 0


def check(cond, what):
    global passed, failed
    if cond:
        passed += 1
        print(f"ok: {what}")
    else:
        failed += 1
        print(f"FAILED: {what}")


def read_ply(path):
    """Binary little-endian PLY with one vertex element, read per the spec."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    lines = data[:end].decode("ascii").splitlines()
    assert lines[0] == "ply" and lines[1] == "format binary_little_endian 1.0", lines[:2]
    types = {"double": "<f8", "float": "<f4", "uint": "<u4", "ushort": "<u2", "uchar": "u1"}
    count, fields = None, []
    for line in lines:
        w = line.split()
        if w[0] == "element":
            assert w[1] == "vertex", line
            count = int(w[2])
        elif w[0] == "property":
            fields.append((w[2], types[w[1]]))
    return np.frombuffer(data, dtype=np.dtype(fields), count=count, offset=end), len(data) - end


def main(out):
    out = Path(out)
    summary = json.loads((out / "summary.json").read_text())
    las = laspy.read(out / "points.las")
    h = las.header
    n = len(las.points)

    # LAS header and point format 9.
    enc = int(h.global_encoding.value)
    check(h.point_format.id == 9, f"points.las point format {h.point_format.id} == 9")
    check(n == summary["points"] == h.point_count, f"{n} points == summary {summary['points']}")
    check(enc & 0x04 and not enc & 0x02, f"global encoding {enc:#x}: waveforms external (bit 2), not internal (bit 1)")
    check(enc & 0x10, "global encoding bit 4 (WKT)")
    check(h.start_of_waveform_data_packet_record == 0, "start of waveform data packet record 0 (external)")

    # Extra bytes by name.
    names = list(las.point_format.extra_dimension_names)
    check(names == ["amplitude", "echo_width", "range", "incidence_angle", "object_id"], f"extra bytes {names}")

    # CRS: WKT VLR that pyproj identifies as the survey's EPSG code.
    crs = h.parse_crs()
    check(crs is not None and crs.to_epsg() == 25832, f"CRS {crs and crs.name} is EPSG:{crs and crs.to_epsg()}")

    # Sensor positions at each point's time, from the trajectory (offset
    # applied like the points).
    traj = np.genfromtxt(out / "trajectory_true.csv", delimiter=",", names=True)
    t = np.asarray(las.gps_time)
    sensor = np.stack([np.interp(t, traj["gps_time_s"], traj[k]) for k in ("x_m", "y_m", "z_m")], axis=1)
    xyz = np.stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)], axis=1)
    check(np.all(np.abs(xyz[:, 0] - 500000) < 60) and np.all(np.abs(xyz[:, 1] - 6200000) < 60),
          f"coordinates offset to projected: x {xyz[:, 0].min():.1f}..{xyz[:, 0].max():.1f}")
    z = xyz[:, 2]
    roof = np.abs(z - 45) < 0.05
    ground = np.abs(z - 40) < 0.05
    check(np.all(roof | ground), f"points on the roof strips ({roof.sum()}) or the ground ({ground.sum()})")
    rng = np.asarray(las["range"], dtype=np.float64)
    dist = np.linalg.norm(xyz - sensor, axis=1)
    check(np.max(np.abs(rng - dist)) < 0.01, f"range extra byte = |point - sensor|, max error {np.max(np.abs(rng - dist)):.4f} m")
    # Level surfaces: incidence angle = beam angle from the vertical.
    beam_from_vertical = np.degrees(np.arccos((sensor[:, 2] - z) / dist))
    inc = np.asarray(las.incidence_angle, dtype=np.float64)
    check(np.max(np.abs(inc - beam_from_vertical)) < 0.01,
          f"incidence angle = beam angle from vertical on level surfaces, max error {np.max(np.abs(inc - beam_from_vertical)):.5f} deg, max {inc.max():.2f} deg")
    oid = np.asarray(las.object_id)
    check(len(set(oid[ground])) == 1 and not set(oid[ground]) & set(oid[roof]),
          f"object ids: ground {sorted(set(oid[ground]))}, {len(set(oid[roof]))} roof strips")
    amp = np.asarray(las.amplitude)
    check(np.allclose(np.asarray(las.intensity), np.clip(np.round(summary["intensity_gain"] * amp), 0, 65535), atol=1),
          "intensity = gain x amplitude extra byte")
    check(np.all(np.asarray(las.echo_width) > 3.5), f"echo width >= pulse FWHM: min {np.min(las.echo_width):.3f} ns")

    # Waveform packet descriptors.
    desc = {}
    for v in h.vlrs:
        if 100 <= v.record_id <= 354 and v.user_id == "LASF_Spec":
            r = v.parsed_record
            desc[v.record_id - 99] = r
    check(len(desc) == 255, f"{len(desc)} waveform packet descriptors")
    d1 = desc[1]
    check((d1.bits_per_sample, d1.waveform_compression_type, d1.number_of_samples, d1.temporal_sample_spacing) == (16, 0, 16, 500),
          f"descriptor 1: {d1.bits_per_sample} bits, compression {d1.waveform_compression_type}, {d1.number_of_samples} samples, {d1.temporal_sample_spacing} ps")

    # The .wdp file.
    wdp = (out / "points.wdp").read_bytes()
    check(wdp[2:11] == b"LASF_Spec" and int.from_bytes(wdp[18:20], "little") == 65535
          and int.from_bytes(wdp[20:28], "little") == len(wdp) - 60,
          "points.wdp starts with the waveform data packet EVLR header (record 65535, length)")
    idx = np.asarray(las.wavepacket_index)
    off = np.asarray(las.wavepacket_offset)
    size = np.asarray(las.wavepacket_size)
    loc = np.asarray(las.return_point_wave_location, dtype=np.float64)
    dt = np.stack([np.asarray(las.x_t), np.asarray(las.y_t), np.asarray(las.z_t)], axis=1).astype(np.float64)
    check(np.all(idx > 0), "every point has a waveform packet")
    check(off.min() == 60 and off.max() + size[off.argmax()] == len(wdp), f"packets fill points.wdp from byte 60 to {len(wdp)}")
    worst_peak = 0.0
    ok_peak = 0
    anchors = xyz + loc[:, None] * dt
    gain, offset = d1.digitizer_gain, d1.digitizer_offset
    for i in range(n):
        d = desc[int(idx[i])]
        check_size = size[i] == d.number_of_samples * 2
        s = np.frombuffer(wdp, dtype="<u2", count=d.number_of_samples, offset=int(off[i])).astype(np.float64)
        s = offset + gain * s
        j = loc[i] / d.temporal_sample_spacing
        lo, hi = max(0, int(round(j)) - 3), min(len(s), int(round(j)) + 4)
        k = lo + int(np.argmax(s[lo:hi]))
        worst_peak = max(worst_peak, abs(k - j))
        ok_peak += int(abs(k - j) <= 1.0 and check_size)
    check(ok_peak == n, f"sample maximum within one sample of the return point location: {ok_peak}/{n}, worst {worst_peak:.2f} samples")
    # Echoes of one pulse: same packet, same anchor.
    same = (t[1:] == t[:-1])
    check(np.all(off[1:][same] == off[:-1][same]), f"{same.sum()} echo pairs share their packet")
    gap = np.linalg.norm(anchors[1:][same] - anchors[:-1][same], axis=1)
    check(gap.max() < 0.01, f"echoes of a pulse share the anchor within {gap.max() * 1000:.2f} mm")
    # The anchor on the beam at the first sample's range.
    u = (xyz - sensor) / dist[:, None]
    first_range = rng - loc * 1e-12 * C / 2
    expect = sensor + u * first_range[:, None]
    err = np.linalg.norm(anchors - expect, axis=1)
    check(err.max() < 0.01, f"anchor = sensor + direction x first-sample range, max error {err.max() * 1000:.2f} mm")
    # And back: point = anchor - location * (Xt, Yt, Zt).
    back = np.linalg.norm(anchors - loc[:, None] * dt - xyz, axis=1)
    check(back.max() < 0.01, f"anchor - location x (Xt,Yt,Zt) reproduces the point, max error {back.max() * 1000:.3f} mm")
    norm = np.linalg.norm(dt, axis=1)
    check(np.allclose(norm, C / 2 * 1e-12, rtol=1e-5) and np.all(np.einsum("ij,ij->i", dt / norm[:, None], -u) > 0.99999),
          f"(Xt,Yt,Zt) points to the sensor, |.| = {norm.mean() * 1000:.6f} mm/ps (c/2)")

    # LAZ: the same points as the LAS file, point format 9 too (the run asks
    # for "las-waveform"), referring to the same points.wdp.
    laz = laspy.read(out / "points.laz")
    check(laz.header.point_format.id == 9 and len(laz.points) == n, f"points.laz point format {laz.header.point_format.id}, {len(laz.points)} points")
    check(int(laz.header.global_encoding.value) & 0x04, "points.laz: waveforms external (bit 2)")
    fields = ["X", "Y", "Z", "intensity", "return_number", "number_of_returns", "classification",
              "gps_time", "scan_angle", "point_source_id", "user_data", "wavepacket_index",
              "wavepacket_offset", "wavepacket_size", "return_point_wave_location",
              "x_t", "y_t", "z_t"] + names
    differ = [f for f in fields if not np.array_equal(np.asarray(laz[f]), np.asarray(las[f]), equal_nan=True)]
    check(not differ, f"points.laz fields (wave packets included) equal points.las fields {differ}")
    check(laz.header.parse_crs().to_epsg() == 25832, "points.laz CRS EPSG:25832")

    # PLY.
    ply, body = read_ply(out / "points.ply")
    check(len(ply) == n and body == n * ply.dtype.itemsize, f"points.ply: {len(ply)} vertices of {ply.dtype.itemsize} bytes")
    perr = np.max(np.abs(np.stack([ply["x"], ply["y"], ply["z"]], axis=1) - xyz))
    check(perr <= 0.0005 + 1e-9, f"PLY x y z (double) match LAS within its 1 mm grid: {perr * 1000:.3f} mm")
    check(np.array_equal(ply["gps_time"], np.asarray(las.gps_time)) and np.array_equal(ply["intensity"], np.asarray(las.intensity))
          and np.array_equal(ply["object_id"], oid) and np.array_equal(ply["return_number"], np.asarray(las.return_number)),
          "PLY gps_time, intensity, return number, object id equal LAS")
    check(all(np.array_equal(ply[k], np.asarray(las[k])) for k in ["amplitude", "echo_width", "range", "incidence_angle"]),
          "PLY float attributes equal the LAS extra bytes")

    # XYZ text in the same projected coordinates.
    xyz_txt = np.loadtxt(out / "points.xyz", skiprows=1, usecols=(0, 1, 2))
    check(np.max(np.abs(xyz_txt - xyz)) <= 0.0005 + 1e-6, "points.xyz coordinates equal LAS")

    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
