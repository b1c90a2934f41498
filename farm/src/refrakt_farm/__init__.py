"""refrakt-farm: long refrakt animations on a Ray cluster.

The driver packs the scene into one bundle (``refrakt pack``), puts it in Ray's object store,
and runs each chunk of frames as one ``refrakt render BUNDLE --frames A..B`` on a worker that
holds a GPU (or a custom resource); the worker sends the finished frames back and the driver
writes them atomically into ``--out``. No shared filesystem is needed.
"""

from refrakt_farm.driver import FarmJob, Summary, render

__all__ = ["FarmJob", "Summary", "render"]
