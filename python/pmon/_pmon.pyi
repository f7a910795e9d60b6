# Type stub of the Rust extension module pmon._pmon (crates/python). Private API: use the `pmon` package.
import os
from typing import Any, Dict, Iterator, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Pose = Tuple[float, float, float]
_F32 = npt.NDArray[np.float32]

def default_params_json() -> str: ...
def validate_params_json(over: str, base: Optional[str] = None) -> str: ...
def params_json_from_toml_file(path: Union[str, os.PathLike[str]], base: Optional[str] = None) -> str: ...
def params_toml_from_json(json: str) -> str: ...
def class_names() -> List[str]: ...
def dataset_schemes() -> List[str]: ...
def synthetic_frames(which: str) -> List[Dict[str, Any]]: ...

class Monitor:
    def __init__(self, params_json: str) -> None: ...
    def check(
        self,
        timestamp_s: float,
        world_from_ego: _Pose,
        points: Optional[_F32],
        ego_from_sensor: Optional[_F32],
        objects: Dict[str, Any],
        roi: List[_F32],
        scenery: List[_F32],
        core_time: bool = False,
    ) -> Tuple[Dict[str, Any], Dict[str, Any], Dict[str, Any]]: ...

class DatasetFrames:
    name: str
    len: int
    params_json: str
    notes: List[str]
    def __init__(self, spec: str, roi: str = "auto", sidewalk_m: float = 0.0, grid_size_m: Optional[float] = None) -> None: ...
    def __iter__(self) -> Iterator[Dict[str, Any]]: ...
    def __next__(self) -> Dict[str, Any]: ...
    def __len__(self) -> int: ...

class RecordingFrames:
    name: str
    source: str
    frames: Optional[int]
    params_json: str
    params_file: Optional[str]
    def __init__(self, path: Union[str, os.PathLike[str]]) -> None: ...
    def __iter__(self) -> Iterator[Dict[str, Any]]: ...
    def __next__(self) -> Dict[str, Any]: ...

class RecordingWriter:
    def __init__(self, path: Union[str, os.PathLike[str]], name: str, source: str) -> None: ...
    def write(
        self,
        timestamp_s: float,
        world_from_ego: _Pose,
        points: Optional[_F32],
        ego_from_sensor: Optional[_F32],
        objects: Dict[str, Any],
        roi: List[_F32],
        scenery: List[_F32],
    ) -> None: ...
    def finish(self) -> int: ...

def run_campaign_task(task_json: str) -> str: ...
def run_evaluation_task(task_json: str) -> str: ...
