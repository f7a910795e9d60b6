"""pmon: a lightweight perception monitor for automated driving (Rust core, numpy in, verdicts out).

>>> import numpy as np, pmon
>>> monitor = pmon.Monitor()                                   # the paper's Table I
>>> objects = {"id": [1], "class": ["car"], "x": [10.0], "y": [0.0], "heading": [0.0],
...            "speed": [5.0], "length": [4.5], "width": [1.8]}
>>> r = monitor.check(np.zeros((0, 3), np.float32), objects, timestamp_s=0.0)
>>> r.objects["verdict"][0], r.objects["reason"][0]
('not_monitored', 'empty_cloud')

See ``docs/python.md`` in the repository.
"""

from ._pmon import __version__
from ._inputs import CLASS_NAMES, OBJECT_COLUMNS
from ._params import Params
from ._monitor import CheckResult, Monitor
from ._frames import Dataset, Frame, Recording, read_recording, write_recording
from . import datasets

__all__ = [
    "CLASS_NAMES",
    "OBJECT_COLUMNS",
    "CheckResult",
    "Dataset",
    "Frame",
    "Monitor",
    "Params",
    "Recording",
    "datasets",
    "read_recording",
    "write_recording",
    "__version__",
]
