#!/usr/bin/python3
"""Reads a DXF with ezdxf (Debian's python3-ezdxf), runs ezdxf's audit and
prints what it found as JSON, for tests/core/plan/plan_writers_test.cc to
compare with the FloorPlan that was written:

  {"dxfversion": "AC1009", "insunits": 6, "extmin": [x, y, z], "extmax": [...],
   "layers": ["0", "WALLS", ...],
   "counts": {"LINE": {"WALLS": n, ...}, "TEXT": {...}, "POINT": {...}},
   "lines": [{"layer": "WALLS", "start": [x, y], "end": [x, y], "length": l}, ...],
   "texts": [{"layer": "DIMENSIONS", "text": "5.000", "at": [x, y]}, ...],
   "polylines": [{"layer": "ROOMS", "closed": true, "vertices": [[x, y], ...],
                  "area": a}, ...],   (area: the shoelace over the vertices)
   "audit": {"errors": n, "fixes": n, "messages": [...]}}

Usage: check_dxf.py FILE.dxf   (exit 0 when read; the caller judges the audit)
"""
import json
import math
import sys

import ezdxf


def main():
    doc = ezdxf.readfile(sys.argv[1])
    auditor = doc.audit()
    msp = doc.modelspace()
    counts, lines, texts, polylines = {}, [], [], []
    for e in msp:
        kind, layer = e.dxftype(), e.dxf.layer
        counts.setdefault(kind, {}).setdefault(layer, 0)
        counts[kind][layer] += 1
        if kind == "LINE":
            s, t = e.dxf.start, e.dxf.end
            lines.append({"layer": layer, "start": [s.x, s.y], "end": [t.x, t.y],
                          "length": math.hypot(t.x - s.x, t.y - s.y)})
        elif kind == "POLYLINE":
            vs = [[v.x, v.y] for v in e.points()]
            twice = sum(vs[i][0] * vs[(i + 1) % len(vs)][1] - vs[(i + 1) % len(vs)][0] * vs[i][1]
                        for i in range(len(vs)))
            polylines.append({"layer": layer, "closed": bool(e.is_closed), "vertices": vs,
                              "area": 0.5 * twice})
        elif kind == "TEXT":
            p = e.dxf.align_point if e.dxf.hasattr("align_point") else e.dxf.insert
            texts.append({"layer": layer, "text": e.dxf.text, "at": [p.x, p.y]})
    header = doc.header
    out = {
        "dxfversion": doc.dxfversion,
        "insunits": header.get("$INSUNITS", None),
        "extmin": list(header.get("$EXTMIN", (0, 0, 0))),
        "extmax": list(header.get("$EXTMAX", (0, 0, 0))),
        "layers": [layer.dxf.name for layer in doc.layers],
        "counts": counts,
        "lines": lines,
        "texts": texts,
        "polylines": polylines,
        "audit": {"errors": len(auditor.errors), "fixes": len(auditor.fixes),
                  "messages": [str(m.message) for m in auditor.errors + auditor.fixes]},
    }
    json.dump(out, sys.stdout)
    print()


if __name__ == "__main__":
    main()
