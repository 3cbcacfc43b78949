"""wavrad: view-independent global illumination with Haar wavelets, after
Pattanaik & Bouatouch, *Haar Wavelet: A Solution to Global Illumination With
General Surface Properties* (EG Rendering Workshop 1994).

>>> import wavrad
>>> scene = wavrad.load_scene("scenes/cornell-box/scene.xml", res=64)
>>> solution = wavrad.solve(scene)
>>> image = solution.render()  # (64, 64, 3) float32, linear RGB
>>> wavrad.write_image("cornell.exr", image)
>>> solution.save("cornell.wavrad")  # wavrad.load_solution() renders it again

A solve's kernel projection can run elsewhere in blocks: :func:`plan`, then
for each of ``plan.blocks(n)`` its items (:meth:`Plan.items`, bytes)
projected by a :func:`projector` of the same scene and settings in another
process or on another machine, then :meth:`Plan.finish` of the links they
return; :mod:`wavrad.distributed` does so on Ray.
"""

from wavrad import _docs, _native

# help() shows the stubs' docstrings and signatures (wavrad/_docs.py).
_docs.document(_native)

from wavrad._native import (  # noqa: E402  (documented first)
    ArgumentError,
    Plan,
    Projector,
    Scene,
    SceneError,
    Solution,
    SolveError,
    SolveWarning,
    WavradError,
    __version__,
    load_scene,
    load_solution,
    plan,
    projector,
    read_exr,
    relative_rmse,
    solve,
    write_image,
)

__all__ = [
    "__version__",
    "ArgumentError",
    "Plan",
    "Projector",
    "Scene",
    "SceneError",
    "Solution",
    "SolveError",
    "SolveWarning",
    "WavradError",
    "load_scene",
    "load_solution",
    "plan",
    "projector",
    "read_exr",
    "relative_rmse",
    "solve",
    "write_image",
]
