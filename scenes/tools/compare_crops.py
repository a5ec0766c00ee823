#!/usr/bin/env python3
"""Stacks the same part of two images, enlarged, one above the other with a gap, for before/after comparisons in the
README (the rainbow under a point-like sun and under the sun's 0.53-degree disc).

Usage: compare_crops.py A.png B.png OUT.png X Y W H [SCALE]   (region's top-left corner and size in pixels; SCALE
defaults to 2, each pixel becoming SCALE x SCALE pixels, no smoothing)

Needs Pillow.
"""
import sys

from PIL import Image


def main():
    if len(sys.argv) not in (8, 9):
        sys.exit(__doc__)
    a, b, dst = sys.argv[1:4]
    x, y, w, h = (int(v) for v in sys.argv[4:8])
    scale = int(sys.argv[8]) if len(sys.argv) == 9 else 2
    crops = [
        Image.open(p).convert("RGB").crop((x, y, x + w, y + h)).resize((scale * w, scale * h), Image.NEAREST)
        for p in (a, b)
    ]
    out = Image.new("RGB", (scale * w, 2 * scale * h + 6), (0, 0, 0))
    out.paste(crops[0], (0, 0))
    out.paste(crops[1], (0, scale * h + 6))
    out.save(dst)


if __name__ == "__main__":
    main()
