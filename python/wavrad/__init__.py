"""wavrad: view-independent global illumination with Haar wavelets, after
Pattanaik & Bouatouch, *Haar Wavelet: A Solution to Global Illumination With
General Surface Properties* (EG Rendering Workshop 1994).

>>> import wavrad
>>> scene = wavrad.load_scene("scenes/cornell-box/scene.xml", res=64)
>>> solution = wavrad.solve(scene)
>>> image = solution.render()  # (64, 64, 3) float32, linear RGB
>>> wavrad.write_image("cornell.exr", image)
"""

from wavrad._native import (
    Scene,
    SceneError,
    Solution,
    SolveError,
    WavradError,
    __version__,
    load_scene,
    read_exr,
    relative_rmse,
    solve,
    write_image,
)

__all__ = [
    "__version__",
    "Scene",
    "SceneError",
    "Solution",
    "SolveError",
    "WavradError",
    "load_scene",
    "read_exr",
    "relative_rmse",
    "solve",
    "write_image",
]
