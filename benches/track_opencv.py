#!/usr/bin/env python3
"""The OpenCV pipeline `crashrig track` is timed against (issue 43, docs/performance.md):
decode every PNG frame (cv2.imread, grey) and refine each marker with cv2.cornerSubPix
(winSize (5, 5), zeroZone (-1, -1), EPS|COUNT 1e-4 / 100), seeded from the marker's previous
position (the seeds file in the first frame), one thread. Prints one JSON line:
{"frames", "observations", "wall_s", "observations_per_second"}.

Usage: track_opencv.py FRAMES_DIR SEEDS.csv
"""

import csv
import json
import os
import sys
import time

import cv2
import numpy as np

cv2.setNumThreads(1)


def main():
    frames_dir, seeds = sys.argv[1], sys.argv[2]
    t0 = time.perf_counter()
    with open(seeds) as fh:
        rows = list(csv.DictReader(fh))
    # COLMAP convention → OpenCV's (pixel centres at integers).
    pos = np.array([[float(r["u_px"]) - 0.5, float(r["v_px"]) - 0.5] for r in rows], dtype=np.float32)
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
    names = sorted(f for f in os.listdir(frames_dir) if f.endswith(".png"))
    n_obs = 0
    for name in names:
        img = cv2.imread(os.path.join(frames_dir, name), cv2.IMREAD_GRAYSCALE)
        h, w = img.shape
        for k in range(len(pos)):
            p = pos[k]
            if not (6 <= p[0] < w - 6 and 6 <= p[1] < h - 6):
                continue
            got = cv2.cornerSubPix(img, p.reshape(1, 1, 2).copy(), (5, 5), (-1, -1), crit)
            pos[k] = got.reshape(2)
            n_obs += 1
    wall = time.perf_counter() - t0
    print(json.dumps({"frames": len(names), "observations": n_obs, "wall_s": wall,
                      "observations_per_second": n_obs / wall}))


if __name__ == "__main__":
    main()
