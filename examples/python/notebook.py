# %% [markdown]
# # crashrig from Python: read a model, calibrate, map, plot
#
# A notebook-style script (cells marked `# %%`, runnable as `python examples/python/notebook.py`
# from the repository root, or cell by cell in Jupyter/VS Code). Needs `pip install
# ./crates/python matplotlib pandas`. Writes its figures to `out/python-example/`.

# %%
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

import crashrig

ROOT = pathlib.Path(__file__).resolve().parents[2]
FIX = ROOT / "fixtures"
OUT = ROOT / "out" / "python-example"
OUT.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## 1. Read a COLMAP model (like pycolmap)

# %%
model = crashrig.read_model(FIX / "rig" / "paper")
print(model)
cam = next(iter(model.cameras.values()))
print(cam.model, cam.width, cam.height, cam.params)
# Projection centres C = -Rᵀ t of every image.
centres = np.array([
    -im.cam_from_world()[:, :3].T @ im.cam_from_world()[:, 3] for im in model.images.values()
])
print(f"{len(centres)} images, {len(model.points3D)} points")

# %% [markdown]
# ## 2. Calibrate the rig (the same dict as `crashrig calibrate --json`)

# %%
link = crashrig.calibrate(FIX / "rig" / "paper", camera_a="cam_out/", camera_b="cam_in/",
                          mm_per_unit=1000.0)
print({k: link[k] for k in ("epochs_used", "base_mm", "omega_phi_kappa_deg") if k in link})

# %% [markdown]
# ## 3. Map the precision over the car interior (`crashrig grid`) into pandas

# %%
grid = pd.DataFrame(crashrig.grid(FIX / "scenarios" / "three_cameras_z0.toml", samples=500,
                                  seed=1))
print(grid.describe().T[["min", "50%", "max"]])

# %% [markdown]
# ## 4. Plot σ_max over the grid

# %%
fig, ax = plt.subplots(figsize=(6, 4))
sc = ax.scatter(grid.x_mm, grid.y_mm, c=grid.sigma_max_mm, cmap="viridis")
fig.colorbar(sc, ax=ax, label="σ_max [mm]")
ax.set_xlabel("x [mm]")
ax.set_ylabel("y [mm]")
ax.set_title("Monte Carlo σ_max, three cameras, z = 0")
fig.savefig(OUT / "sigma_max.png", dpi=120, bbox_inches="tight")
print("wrote", OUT / "sigma_max.png")
