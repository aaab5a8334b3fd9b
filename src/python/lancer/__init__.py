"""lancer, the measured Whitted ray tracer, from Python (docs/python.md).

    import lancer
    scene = lancer.Scene.load("scenes/lorenzi-reflections.json")
    rgb = scene.render()                      # float32 (ny, nx, 3), `lancer render`'s bits
    t, ids, normals = scene.intersect(origins, directions)   # (n, 3) arrays, unit directions

Bad input raises ValueError with the command line's one-line message.
"""

from ._lancer import Scene, bench, flux, png, trade, validate, version

__all__ = ["Scene", "Image", "bench", "flux", "png", "trade", "validate", "version"]
__version__ = version


class Image:
    """A linear RGB image (ny, nx, 3) that Jupyter shows inline, as `lancer render` writes
    it to PNG (each channel clamped to [0, 1], rounded to 256 levels; no tone curve)."""

    def __init__(self, rgb):
        self.rgb = rgb

    def _repr_png_(self):
        return png(self.rgb)

    def __array__(self, dtype=None):
        import numpy

        return numpy.asarray(self.rgb, dtype=dtype)

    def __repr__(self):
        return "<lancer.Image %dx%d>" % (self.rgb.shape[1], self.rgb.shape[0])
