"""Checks the outputs of `splatphys run`: summary.json counts and non-blank PNG frames."""
import json
import pathlib
import struct
import sys
import zlib


def png_pixels(path):
    """Decodes an 8-bit RGB/RGBA non-interlaced PNG (what splatphys-render writes) to rows."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path}: not a PNG"
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and colour in (2, 6), f"{path}: unexpected PNG format"
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, prev = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
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
    return rows, channels


def main():
    out = pathlib.Path(sys.argv[1])
    s = json.loads((out / "summary.json").read_text())
    print(json.dumps({k: s.get(k) for k in ("frames", "frames_rendered", "frames_lost_by_recorder",
                                             "frames_dropped_by_renderer", "particles", "wall_s")}))
    assert (s.get("frames") or 0) > 0, "no frames published"
    assert s.get("frames_lost_by_recorder") == 0, "the lossless recorder lost frames"
    assert (out / "run.mcap").stat().st_size > 0, "empty recording"
    assert (out / "animation.gif").stat().st_size > 0, "no animation"
    csv = (out / "objects.csv").read_text().splitlines()
    assert csv[0] == "step,time_s,object,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,mass_kg", csv[0]
    assert len(csv) > 1, "objects.csv has no rows"
    pngs = sorted((out / "frames").glob("*.png"))
    assert pngs, "no PNG frames"
    for p in (pngs[0], pngs[-1]):
        rows, ch = png_pixels(p)
        first = rows[0][:ch]
        distinct = sum(1 for r in rows for i in range(0, len(r), ch) if r[i:i + ch] != first)
        print(f"{p.name}: {distinct} pixels differ from the corner")
        assert distinct > 100, f"{p}: blank frame"
    print("end-to-end run OK")


if __name__ == "__main__":
    main()
