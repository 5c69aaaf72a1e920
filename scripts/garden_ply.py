"""The real garden half's PLY (gardens/wageningen_west/garden_west.ply: binary, x y z as float,
r g b as bytes) as an (n, 3) array of metres, for the scripts that turn and score it."""
import numpy as np


def read_garden_xyz(path):
    with open(path, "rb") as f:
        n = 0
        while True:
            line = f.readline().decode().strip()
            if line.startswith("element vertex"):
                n = int(line.split()[-1])
            if line == "end_header":
                break
        dt = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("r", "u1"), ("g", "u1"), ("b", "u1")])
        pts = np.frombuffer(f.read(n * dt.itemsize), dtype=dt, count=n)
    return np.stack([pts["x"], pts["y"], pts["z"]], axis=1).astype(np.float64)
