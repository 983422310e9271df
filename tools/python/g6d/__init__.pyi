"""Type stub of the package g6d (tools/python/g6d/__init__.py; the compiled core is g6d._core).

Poses are 4x4 float64 arrays named target_from_source (cam_from_object: object frame ->
camera frame), metres; times ms; images (H, W[, 3]) RGB; pixel (u, v) centred at
(u + 0.5, v + 0.5) under K.
"""

import enum
import os
from typing import Any, Callable, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

# The LCM message classes (lcm-gen, package g6d).
from .image_t import image_t as image_t
from .instance_t import instance_t as instance_t
from .pose_array_t import pose_array_t as pose_array_t
from .pose_estimate_t import pose_estimate_t as pose_estimate_t
from .rgbd_frame_t import rgbd_frame_t as rgbd_frame_t
from .service_status_t import service_status_t as service_status_t

_Path = Union[str, os.PathLike]
_Array = npt.NDArray[Any]
_Pose = npt.NDArray[np.float64]  # (4, 4), metres
_Box = Tuple[int, int, int, int]  # x, y, width, height, pixels

class Error(RuntimeError):
    """A bad file or cache, or a failure in the library (the message says what and where)."""

class MaskTrust(enum.Enum):
    EXACT: int
    DEPTH: int

class PnpMinimalSolver(enum.Enum):
    OPENCV_USAC: int
    P3P: int
    DEPTH_RIGID: int

class _Options:
    _fields: Tuple[str, ...]
    def __init__(self, **fields: Any) -> None: ...
    def check(self) -> str:
        """'' when valid, else the C++ Check() message naming the bad field."""
    def validate(self) -> "_Options":
        """Raises ValueError with check()'s message; returns self when valid."""
    def as_dict(self) -> Dict[str, Any]: ...
    def copy(self) -> "_Options": ...

class OrbOptions(_Options):
    max_features: int
    scale_factor: float
    num_levels: int
    edge_threshold: int
    fast_threshold: int
    mask_erosion_px: int

class RegionOptions(_Options):
    sensor_noise_at_1m: float
    noise_sigmas: float
    pose_tolerance_fraction: float
    ring_fraction: float
    limit_ring_fraction: float
    plane_iterations: int
    plane_samples: int
    min_plane_fraction: float
    min_plane_points: int
    far_fraction: float
    grow_fraction: float
    mask_decides_on_support: bool
    unsure_area_min_px: int
    seed: int

class SegmentOptions(_Options):
    sensor_noise_at_1m: float
    noise_sigmas: float
    max_incidence_deg: float
    min_segment_pixels: int
    crease_half_span_m: float
    crease_min_depth_m: float
    crease_erode_px: int

class MatchOptions(_Options):
    hamming_threshold: int
    max_sets: int
    min_correspondences: int
    simd: bool
    simd_avx512: bool

class PnpOptions(_Options):
    tau_fraction: float
    tau_min_px: float
    tau_max_px: float
    max_iterations: int
    confidence: float
    min_inliers: int
    seed: int
    minimal_solver: PnpMinimalSolver
    max_centre_depth_error: float
    progressive_sampling: bool
    local_optimization: bool

class ScoreOptions(_Options):
    omega_c: float
    lambda_s: float
    occlusion_margin_m: float
    cull_backfaces: bool
    depth_evidence: bool
    surface_tolerance_m: float
    segment_own_fraction: float
    max_object_extent_m: float
    unseen_is_hidden: bool
    max_unseen_background: float

class GridOptions(_Options):
    margin: float
    max_side_px: int
    unseen_area_min_px: int
    fill_thin_holes: bool

class IcpOptions(_Options):
    trim_fraction: float
    kappa_d: float
    r0_m: float
    max_iterations: int
    min_step_m: float
    stall_window: int
    min_rmse_decrease: float
    min_correspondences: int
    point_to_plane: bool
    point_to_point_iterations: int

class MhpoOptions(_Options):
    lambda_d: float
    huber_beta: float
    silhouette_robust_px: float
    max_rounds: int
    lm_iterations: int
    max_contour_points: int
    max_depth_points: int
    early_stop_score: float
    min_rounds: int
    patience: int

class AppearanceOptions(_Options):
    sample_points: int
    seed: int
    min_color_std: float
    texture_max_side_px: int
    grid_max_side_px: int
    visibility_tolerance_m: float
    min_facing_cos: float
    edge_margin_px: int
    min_chroma_std: float
    min_visible_points: int

class SilhouetteOptions(_Options):
    """Poses from the mask's outline (lib/solver/silhouette_poses.h)."""
    rotations: int
    candidates: int
    min_iou: float
    min_mask_pixels: int

class PpfSearchOptions(_Options):
    """Point-pair-feature voting on the depth (lib/solver/ppf.h)."""
    reference_stride: int
    max_reference_points: int
    neighbour_spread: float
    max_bucket_fraction: float
    peaks_per_reference: int
    peak_ratio: float
    cluster_distance_fraction: float
    cluster_angle_deg: float
    max_poses: int
    min_cluster_ratio: float
    normal_radius_steps: float
    max_scene_points: int

class PpfModelOptions(_Options):
    """The point-pair-feature model of a cache (lib/templates/ppf_model.h)."""
    step_fraction: float
    angle_step_deg: float
    normal_cluster_deg: float
    surface_samples: int
    max_points: int
    seed: int

class ConfidenceWeights(_Options):
    bias: float
    score: float
    ambiguous: float
    on_surface: float
    contour: float
    mask_iou: float

class SolverOptions(_Options):
    """All options of estimate_pose; defaults are the service's (lib/solver/pipeline.h)."""
    query_orb: OrbOptions
    mask_trust: MaskTrust
    region: RegionOptions
    segments: SegmentOptions
    split_merged_at_creases: bool
    max_search_regions: int
    region_candidates: int
    unsure_score: float
    unsure_ambiguous_score: float
    explain_neighbours: bool
    neighbour_min_fraction: float
    resolve_duplicates: bool
    mask_refine_rounds: int
    match: MatchOptions
    pnp: PnpOptions
    use_ppf: bool
    ppf: PpfSearchOptions
    ppf_hypotheses: int
    ppf_skip_agreement: int
    use_silhouettes: bool
    silhouette: SilhouetteOptions
    silhouette_hypotheses: int
    silhouette_skip_agreement: int
    check_flips: bool
    check_flips_max_score: float
    num_hypotheses: int
    score: ScoreOptions
    selection_grid: GridOptions
    refine_grid: GridOptions
    icp: IcpOptions
    run_icp: bool
    max_observed_points: int
    max_source_points: int
    icp_coarse_points: int
    icp_merge_fraction: float
    icp_probe_iterations: int
    icp_finish_hypotheses: int
    icp_source_in_mask: bool
    mhpo: MhpoOptions
    run_mhpo: bool
    post_refine: bool
    post_refine_trigger_s: float
    post_refine_margin: float
    min_valid_depth_pixels: int
    reject_border_masks: bool
    budget_ms: float
    distinct_pose_fraction: float
    merge_pnp_poses: bool
    pnp_min_quality_ratio: float
    cull_backfaces: bool
    coarse_selection_mesh: bool
    ambiguity_distance_fraction: float
    ambiguity_margin: float
    appearance_tiebreak: bool
    appearance_margin: float
    appearance_min_gain: float
    appearance: AppearanceOptions
    support_penetration_fraction: float
    support_margin: float
    confidence: ConfidenceWeights
    wide_mask_confidence: ConfidenceWeights
    check_surface_fraction: float
    check_step_m: float
    confidence_bias: float
    confidence_score_weight: float
    confidence_ambiguous_weight: float

class TrackSolveOptions(_Options):
    icp_iterations: int
    max_source_points: int
    max_observed_points: int
    mhpo_rounds: int
    appearance_search_deg: float
    appearance_step_deg: float
    score_appearance: bool

class IdentifyOptions(_Options):
    prescreen: bool
    extent_trim_fraction: float
    extent_margin_px: float

class DetectOptions(_Options):
    segments: SegmentOptions
    max_planes: int
    plane_iterations: int
    plane_samples: int
    plane_flatness_m: float
    measure_plane_flatness: bool
    min_plane_fraction: float
    support_extent_factor: float
    raised_sigmas: float
    raised_window_px: int
    raised_level_px: int
    raised_min_height_m: float
    raised_flatness: float
    raised_outline_edge: float
    raised_outline_ring_px: int
    raised_outline_min_noise: float
    island_open_px: int
    island_split_core: float
    island_split_window: float
    island_split_min_core_px: int
    island_split_max_pieces: int
    island_pieces_uncoloured_only: bool
    island_silhouettes: bool
    uncoloured_island_bonus: float
    bridge_holes_px: int
    neighbour_gap_px: int
    gap_neighbour_reach_m: float
    gap_occluder_margin_m: float
    max_union_segments: int
    max_regions: int
    extent_margin_px: float
    min_extent_fraction: float
    min_area_fraction: float
    extra_candidates: int
    colour_weight: float
    rank_uncoloured_by_shape: bool
    shape_references: int
    accept_confidence: float
    accept_region_iou: float
    fill_gap_px: int
    explain_away_passes: int
    found_object_passes: int
    refuse_behind_support: bool
    sure_first_confidence: float
    support_limit_from_frame: bool
    max_solve_hypotheses: int
    solve_pnp_min_quality: float
    solve_silhouettes: bool
    solve_check_flips: bool
    area_weight: float
    identity_check_below: float
    max_score: float
    max_overlap: float
    ppf_extra: int
    ppf_reference_stride: int
    ppf_max_scene_points: int
    ppf_surface_fraction: float
    ppf_max_free_space: float
    ppf_min_contour_support: float
    ppf_contour_step_m: float
    max_free_space: float
    free_space_fraction: float
    min_contour_support: float
    confidence_bias: float
    confidence_score_weight: float
    confidence_ambiguous_weight: float
    confidence_on_surface_weight: float
    confidence_free_space_weight: float
    confidence_contour_weight: float
    confidence_region_iou_weight: float
    confidence_colour_weight: float
    confidence_in_image_weight: float
    confidence_edge_weight: float
    confidence_runner_up_weight: float
    confidence_free_band_weight: float
    min_confidence: float

class ViewSamplingOptions(_Options):
    num_directions: int
    num_inplane: int
    fill_fraction: float

class CropOptions(_Options):
    padding: float
    size_px: int
    background_gray: int
    normalized_mean: float
    normalized_std: float
    min_std: float

class SymmetryOptions(_Options):
    sample_points: int
    mean_tolerance: float
    max_tolerance: float
    max_order: int
    seed: int

class TemplateBuildOptions(_Options):
    views: ViewSamplingOptions
    crop: CropOptions
    orb: OrbOptions
    render_size_px: int
    render_focal_px: float
    online_mesh_faces: int
    max_view_angle_deg: float
    thumbnail_size_px: int
    find_symmetries: bool
    symmetry: SymmetryOptions
    sample_appearance: bool
    appearance: AppearanceOptions
    build_ppf: bool
    ppf: PpfModelOptions

class Frame:
    """One RGB-D frame: rgb uint8 (H, W, 3); depth uint16 with depth_scale (metres per unit)
    or float32 metres; K 3x3 pixels."""
    def __init__(self, rgb: _Array, depth: _Array, K: _Array, depth_scale: Optional[float] = ...,
                 nan_as_missing: bool = ...) -> None: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def K(self) -> npt.NDArray[np.float64]: ...
    @property
    def rgb(self) -> npt.NDArray[np.uint8]: ...
    @property
    def depth(self) -> npt.NDArray[np.float32]: ...

class TemplateBank:
    object_id: str
    diameter_m: float
    mesh_path: str
    mesh_hash: int
    @property
    def mesh_units(self) -> str: ...
    @property
    def num_templates(self) -> int: ...
    @property
    def num_keypoints(self) -> int: ...
    @property
    def bounding_box_m(self) -> npt.NDArray[np.float64]: ...
    @property
    def has_appearance(self) -> bool: ...
    @property
    def options(self) -> TemplateBuildOptions: ...
    def save(self, path: _Path, zstd_level: int = ...) -> None: ...

class PoseResult:
    object_id: str
    success: bool
    message: str
    termination: str
    cam_from_object: _Pose
    position_m: npt.NDArray[np.float64]
    orientation_wxyz: npt.NDArray[np.float64]
    score: float
    confidence: float
    iou: float
    coverage: float
    depth_residual: float
    truncated: bool
    ambiguous: bool
    cut_short: bool
    has_runner_up: bool
    runner_up_cam_from_object: Optional[_Pose]
    runner_up_score: Optional[float]
    appearance_agreement: Optional[float]
    runner_up_appearance_agreement: Optional[float]
    corrected_mask: Optional[npt.NDArray[np.uint8]]
    mask_iou: float
    on_surface: float
    free_space: float
    free_space_band_px: float
    contour_support: float
    in_image: float
    edge_support: float
    oriented_edge: float
    mask_refined_rounds: int
    stages: Dict[str, Any]
    bank: Optional[TemplateBank]
    identity: Dict[str, Any]  # estimate_pose_of_unknown_object only
    request: int  # find_objects only
    region: npt.NDArray[np.uint8]  # find_objects only
    region_box: _Box  # find_objects only
    region_pixels: int  # find_objects only
    def __init__(self, fields: Dict[str, Any]) -> None: ...
    def as_dict(self) -> Dict[str, Any]: ...

class Detections(List[PoseResult]):
    report: Dict[str, Any]

def build_templates(mesh_path: _Path, object_id: str, units: str, *, views: int = ..., inplane: int = ...,
                    threads: int = ..., progress: Union[None, bool, Callable[[int, int], Any]] = ...,
                    options: Union[None, TemplateBuildOptions, Dict[str, Any]] = ..., **fields: Any) -> TemplateBank: ...
def load_cache(path: _Path, mesh_path: Optional[_Path] = ...) -> TemplateBank: ...
def estimate_pose(frame: Frame, bank: TemplateBank, *, mask: Optional[_Array] = ..., box: Optional[Sequence[int]] = ...,
                  options: Union[None, SolverOptions, Dict[str, Any]] = ..., threads: int = ...,
                  **fields: Any) -> PoseResult: ...
def track_pose(frame: Frame, bank: TemplateBank, starts: Union[_Pose, Sequence[_Pose]], *,
               mask: Optional[_Array] = ..., box: Optional[Sequence[int]] = ...,
               options: Union[None, SolverOptions, Dict[str, Any]] = ...,
               track: Union[None, TrackSolveOptions, Dict[str, Any]] = ..., threads: int = ...,
               **fields: Any) -> PoseResult: ...
def estimate_pose_of_unknown_object(frame: Frame, banks: Iterable[TemplateBank], *, mask: Optional[_Array] = ...,
                                    box: Optional[Sequence[int]] = ...,
                                    options: Union[None, SolverOptions, Dict[str, Any]] = ...,
                                    identify: Union[None, IdentifyOptions, Dict[str, Any]] = ...,
                                    threads: int = ..., **fields: Any) -> PoseResult: ...
def find_objects(frame: Frame, objects: Iterable[Union[TemplateBank, Tuple[TemplateBank, int]]], *,
                 options: Union[None, SolverOptions, Dict[str, Any]] = ...,
                 detect: Union[None, DetectOptions, Dict[str, Any]] = ..., threads: int = ...,
                 **fields: Any) -> Detections: ...
def draw_overlay(frame: Frame, results: Union[PoseResult, Sequence[PoseResult]], *,
                 labels: bool = ...) -> npt.NDArray[np.uint8]: ...
def read_image(path: _Path, mode: str = ...) -> _Array: ...
def write_image(path: _Path, image: _Array) -> None: ...
