"""Prismatic, a physically based spectral renderer, from Python.

    import prismatic
    scene = prismatic.load("scenes/prism-exercise.pbrt")
    image = scene.render(spp=16, resolution=(400, 300), seed=1)
    image.rgb          # NumPy float32, height x width x 3, linear RGB

A scene that cannot be read raises prismatic.SceneError with .file, .line, .column and .message.
"""

from ._prismatic import Image, Scene, SceneError, __version__, load, loads

__all__ = ["Image", "Scene", "SceneError", "__version__", "load", "loads"]
