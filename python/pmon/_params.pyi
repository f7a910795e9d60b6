# Type stub of pmon._params: the fields of Params (generated at run time from the Rust defaults; the test
# tests/test_stubs.py checks that this list matches them).
import os
from typing import Any, Dict, List, Mapping, Optional, Union

class Params:
    grid_size_m: float
    cell_size_m: float
    ground_z_m: float
    min_obstacle_height_m: float
    max_obstacle_height_m: float
    ego_footprint_m: List[float]
    hit_probability: float
    safety_margin_m: float
    tau_tp: float
    tau_fn: float
    gamma_sens: float
    min_cluster_cells: int
    conflict_association_m: float
    ghost_visible_fraction: float
    visibility_bins: int
    spill_over_fit: str
    seen_over: bool
    face_in_front: bool
    returns_beyond_cells: int
    jump_from_returns: bool
    jump_first_return: bool
    jump_evidence_at_prediction: bool
    jump_coincident_boxes: bool
    jump_jumped_boxes: bool
    seen_body: bool
    memory_gate: bool
    follow_gate: bool
    front_cluster: bool
    spill_in_front: bool
    spill_near_side: bool
    spill_least_stretch: bool
    spill_gap_m: float
    memory_hold_s: float
    parked_hold_s: float
    shadow_gate: bool
    follow_owner_fit: bool
    release_flagged_claims: bool
    release_to_confirmed: bool
    evidence_runs_on: bool
    seen_through_near_side: bool
    roi_graze_fraction: float
    roi_graze_height_m: float
    motion_limits: Dict[str, Any]
    per_class_limits: Dict[str, Any]
    gamma_plaus: float
    default_uncertainty: Dict[str, Any]
    max_time_step_s: float
    plausibility_mode: str
    false_alarm_probability: float
    baseline_s: float
    warmup_frames: int
    warmup_speed_sigma_mps: float
    heading_min_speed_mps: float
    tracker_noise: Dict[str, Any]
    per_class_noise: Dict[str, Any]
    max_points: int
    max_objects: int
    max_clusters: int
    max_object_size_m: float
    def __init__(self, **overrides: Any) -> None: ...
    @classmethod
    def from_dict(cls, values: Mapping[str, Any], base: Optional[Params] = ...) -> Params: ...
    @classmethod
    def from_toml(cls, path: Union[str, os.PathLike[str]], base: Optional[Params] = ...) -> Params: ...
    @classmethod
    def profile(cls, name: str, base: Optional[Params] = ...) -> Params: ...
    @staticmethod
    def profiles() -> List[str]: ...
    @staticmethod
    def profile_text(name: str) -> str: ...
    def replace(self, **changes: Any) -> Params: ...
    @staticmethod
    def fields() -> List[str]: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def to_json(self) -> str: ...
    def to_toml(self) -> str: ...

ParamsLike = Union[None, Params, Mapping[str, Any], str, os.PathLike[str]]

def as_params(params: ParamsLike) -> Params: ...
