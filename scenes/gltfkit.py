"""What the scene generators in scenes/ share: one glTF buffer of accessors (`Blob`), and
PNG images as data URIs (`png`). Imported by make_orbit.py, make_vertex_colors.py and
make_maps.py, run from the repository root."""
import base64
import struct
import zlib


class Blob:
    """One glTF buffer: its bytes, buffer views and accessors."""

    def __init__(self):
        self.bytes = bytearray()
        self.views, self.accessors = [], []

    def add(self, data, fmt, count, kind, comp=5126, normalized=False, target=None, minmax=None):
        """Appends packed `data` as a buffer view and an accessor; returns the accessor index."""
        while len(self.bytes) % 4:
            self.bytes.append(0)
        offset = len(self.bytes)
        self.bytes.extend(struct.pack("<" + fmt * len(data), *data))
        view = {"buffer": 0, "byteOffset": offset, "byteLength": len(self.bytes) - offset}
        if target:
            view["target"] = target
        self.views.append(view)
        acc = {"bufferView": len(self.views) - 1, "componentType": comp, "count": count, "type": kind}
        if normalized:
            acc["normalized"] = True
        if minmax:
            acc["min"], acc["max"] = minmax
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def json(self):
        """The document's "accessors", "bufferViews" and "buffers" (the buffer as a data URI)."""
        uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.bytes)).decode()
        return {"accessors": self.accessors, "bufferViews": self.views,
                "buffers": [{"byteLength": len(self.bytes), "uri": uri}]}


def png(width, height, rows):
    """An RGBA8 PNG of `rows` (lists of (r, g, b, a)), as a data URI."""
    raw = b"".join(b"\0" + bytes(c for px in row for c in px) for row in rows)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    data = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    return "data:image/png;base64," + base64.b64encode(data).decode()
