#!/usr/bin/env python3
"""Puts a 4x enlargement of part of an image beside it, for the lens gallery (README.md): the chart's edge and an
out-of-focus lamp, where a lens's colour fringes are a pixel or two wide.

Usage: crop4x.py IN.png OUT.png X Y W H   (the region's top-left corner and size, in pixels of IN.png)

Each pixel of the region becomes 4 x 4 pixels (no smoothing, so the fringes stay what the renderer wrote); the
region is outlined in the full image. Needs Pillow.
"""
import sys

from PIL import Image, ImageDraw


def main():
    if len(sys.argv) != 7:
        sys.exit(__doc__)
    src, dst = sys.argv[1], sys.argv[2]
    x, y, w, h = (int(v) for v in sys.argv[3:])
    full = Image.open(src).convert("RGB")
    crop = full.crop((x, y, x + w, y + h)).resize((4 * w, 4 * h), Image.NEAREST)
    marked = full.copy()
    ImageDraw.Draw(marked).rectangle((x - 1, y - 1, x + w, y + h), outline=(255, 210, 0))
    out = Image.new("RGB", (marked.width + 8 + crop.width, max(marked.height, crop.height)), (0, 0, 0))
    out.paste(marked, (0, 0))
    out.paste(crop, (marked.width + 8, 0))
    out.save(dst)


if __name__ == "__main__":
    main()
