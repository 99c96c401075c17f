"""bench/peers.sh's check of a peer's normal map: a PNG of N x N texels, of
which a good share decode ((rgb / 255) * 2 - 1) to unit vectors with many
distinct values, not a blank, constant or dummy image. Prints one line,
"texels W x H, normals P% of the texels (|n| within 0.1 of 1), D distinct
colours, mean n (x, y, z)"; exits 1 (naming why) if the image is not such a
map. Needs Pillow and NumPy (Debian: python3-pil python3-numpy).
Usage: python3 bench/peers_png.py IMAGE.png SIDE"""
import sys

import numpy as np
from PIL import Image

path, side = sys.argv[1], int(sys.argv[2])
image = Image.open(path)
rgb = np.asarray(image.convert("RGB"), dtype=np.float64)
h, w, _ = rgb.shape
n = rgb / 255.0 * 2.0 - 1.0
length = np.linalg.norm(n, axis=2)
unit = np.abs(length - 1.0) < 0.1
share = unit.mean()
distinct = len(np.unique(rgb.reshape(-1, 3) @ np.array([65536.0, 256.0, 1.0])))
mean = n[unit].mean(axis=0) if unit.any() else np.zeros(3)
print(f"texels {w} x {h}, normals {100 * share:.1f}% of the texels (|n| within 0.1 of 1), {distinct} distinct "
      f"colours, mean n ({mean[0]:+.2f}, {mean[1]:+.2f}, {mean[2]:+.2f})")
problems = []
if (w, h) != (side, side):
    problems.append(f"not {side} x {side}")
if share < 0.3:
    problems.append("fewer than 30% of the texels are unit normals")
if distinct < 1000:
    problems.append("fewer than 1000 distinct colours")
if problems:
    sys.exit(f"peers_png.py: {path}: " + "; ".join(problems))
