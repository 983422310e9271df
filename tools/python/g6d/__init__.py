"""g6d: learning-free 6D object pose from RGB-D, in Python.

The same solver as g6d-service and g6d-solve (C++, CPU only): numpy arrays in, poses out.

Frames and units, everywhere in this package:
  * poses are 4x4 numpy float64 rigid transforms named target_from_source:
    ``cam_from_object`` maps a point in the object's frame (the mesh's coordinates, metres)
    to the camera frame (x right, y down, z along the optical axis, metres);
  * lengths are metres, times milliseconds, scores unitless (S_A: lower is better);
  * images are (H, W[, 3]) numpy arrays, RGB order; pixel (u, v) = (column, row) covers
    [u, u+1) x [v, v+1), so its centre is (u + 0.5, v + 0.5) under K (the BOP convention).

Typical use::

    import g6d
    bank = g6d.load_cache("caches/obj_000005.g6dcache")
    frame = g6d.Frame(rgb, depth, K, depth_scale=0.001)     # uint16 depth in millimetres
    result = g6d.estimate_pose(frame, bank, mask=mask)
    print(result.cam_from_object, result.score, result.confidence)

The LCM message classes of g6d-service live in this package too:
``from g6d import pose_array_t, rgbd_frame_t``.

Solves release the GIL: several Python threads solve at once. Bad arguments raise
ValueError naming the argument and what was expected; a bad file or cache raises
g6d.Error (a RuntimeError).
"""

import copy as _copy
import enum as _enum
import os as _os

from . import _core
from ._core import (AppearanceOptions, ConfidenceWeights, CropOptions, DetectOptions, Error, GridOptions, IcpOptions,
                    IdentifyOptions, MaskTrust, MatchOptions, MhpoOptions, OrbOptions, PnpMinimalSolver,
                    PnpOptions, PpfModelOptions, PpfSearchOptions, RegionOptions, ScoreOptions, SegmentOptions, SilhouetteOptions,
                    SolverOptions, SymmetryOptions, TemplateBank, TemplateBuildOptions, TrackSolveOptions,
                    ViewSamplingOptions)

# The LCM message classes (lcm-gen's package g6d): image_t, instance_t, rgbd_frame_t,
# pose_estimate_t, pose_array_t, service_status_t. Absent only in a package copied without
# them.
try:
    from ._messages import *  # noqa: F401,F403
except ImportError:  # pragma: no cover
    pass

__all__ = [
    "Frame", "TemplateBank", "PoseResult", "Detections", "Error",
    "build_templates", "load_cache", "estimate_pose", "track_pose",
    "estimate_pose_of_unknown_object", "find_objects", "draw_overlay", "read_image", "write_image",
    "SolverOptions", "DetectOptions", "IdentifyOptions", "TrackSolveOptions", "TemplateBuildOptions",
    "MaskTrust", "PnpMinimalSolver",
]

_OPTION_CLASSES = (AppearanceOptions, ConfidenceWeights, CropOptions, DetectOptions, GridOptions, IcpOptions,
                   IdentifyOptions, MatchOptions, MhpoOptions, OrbOptions, PnpOptions, PpfModelOptions,
                   PpfSearchOptions, RegionOptions,
                   ScoreOptions, SegmentOptions, SilhouetteOptions, SolverOptions, SymmetryOptions, TemplateBuildOptions,
                   TrackSolveOptions, ViewSamplingOptions)


# --------------------------------------------------------------------------------------
# Options: one generic layer over every options class of _core (keyword construction,
# nested dictionaries, enum names as strings, repr, equality, as_dict).

def _is_options(value):
    return type(value) in _OPTION_CLASSES


def _set_options(options, values, where):
    """Sets the fields `values` (a mapping) of `options`; `where` names it in errors."""
    fields = type(options)._fields
    for name, value in values.items():
        if name not in fields:
            raise ValueError(f"{where}: unknown option {name!r}; the options of {type(options).__name__} "
                             f"are: {', '.join(fields)}")
        current = getattr(options, name)
        if _is_options(current):
            if isinstance(value, dict):
                _set_options(current, value, f"{where}.{name}")
                continue
            if type(value) is not type(current):
                raise ValueError(f"{where}.{name}: expected a {type(current).__name__} or a dict of its "
                                 f"fields, got {value!r}")
        elif isinstance(current, _enum.Enum) or type(current).__name__ in ("MaskTrust", "PnpMinimalSolver"):
            if isinstance(value, str):
                members = type(current).__members__
                key = value.upper()
                if key not in members:
                    raise ValueError(f"{where}.{name}: expected one of "
                                     f"{', '.join(m.lower() for m in members)}, got {value!r}")
                value = members[key]
        elif isinstance(current, bool):
            if type(value).__name__ not in ("bool", "bool_"):  # numpy.bool_ too
                raise ValueError(f"{where}.{name}: expected True or False, got {value!r}")
            value = bool(value)
        try:
            setattr(options, name, value)
        except TypeError:
            raise ValueError(f"{where}.{name}: expected {type(current).__name__}, got {value!r}") from None


def _options_init(cls):
    base_init = cls.__init__

    def __init__(self, **fields):
        base_init(self)
        _set_options(self, fields, cls.__name__)

    __init__.__doc__ = (f"{cls.__name__}(**fields): the defaults (the service's), with the fields given "
                        "changed; a nested options field also takes a dict of its fields. "
                        "Unknown names and wrong types raise ValueError; validate() checks the values.")
    return __init__


def _as_dict(self):
    """The fields as a dict (nested options as dicts, enums by name in lower case)."""
    out = {}
    for name in type(self)._fields:
        value = getattr(self, name)
        if _is_options(value):
            value = value.as_dict()
        elif type(value).__name__ in ("MaskTrust", "PnpMinimalSolver"):
            value = value.name.lower()
        out[name] = value
    return out


def _validate(self):
    """Raises ValueError with the C++ Check() message (which names the bad field) when a value
    is out of range; returns self otherwise."""
    problem = self.check()
    if problem:
        raise ValueError(f"{type(self).__name__}: {problem}")
    return self


def _changed(values, default):
    """The entries of `values` that differ from `default`, recursively."""
    out = {}
    for k, v in values.items():
        if isinstance(v, dict):
            v = _changed(v, default[k])
            if v:
                out[k] = v
        elif v != default[k]:
            out[k] = v
    return out


def _repr(self):
    changed = _changed(self.as_dict(), type(self)().as_dict())
    return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in changed.items())})"


def _eq(self, other):
    return type(self) is type(other) and self.as_dict() == other.as_dict()


for _cls in _OPTION_CLASSES:
    _cls.__init__ = _options_init(_cls)
    _cls.as_dict = _as_dict
    _cls.validate = _validate
    _cls.__repr__ = _repr
    _cls.__eq__ = _eq
    _cls.__hash__ = None
    _cls.copy = lambda self: _copy.copy(self)
del _cls


def _options(cls, given, fields, where="options"):
    """A copy of `given` (an instance of cls, a dict, or None for the defaults) with `fields`
    (keyword arguments) set."""
    if given is None:
        options = cls()
    elif isinstance(given, cls):
        options = _copy.copy(given)
    elif isinstance(given, dict):
        options = cls()
        _set_options(options, given, where)
    else:
        raise ValueError(f"{where}: expected a {cls.__name__}, a dict of its fields or None, got {given!r}")
    _set_options(options, fields, where)
    return options


def _threads(threads):
    if isinstance(threads, bool) or not isinstance(threads, int):
        raise ValueError(f"threads: expected a whole number >= 1, got {threads!r}")
    return threads


# --------------------------------------------------------------------------------------
# Frames and results

class Frame(_core.Frame):
    """One RGB-D frame with its intrinsics, as the solver sees it (immutable; copies the arrays).

    Frame(rgb, depth, K, depth_scale=None, nan_as_missing=False)

    rgb:   uint8 (H, W, 3), RGB order.
    depth: uint16 (H, W) with ``depth_scale`` in metres per unit (0.001 for millimetres; a
           BOP scene_camera.json's depth_scale is millimetres per unit: divide it by 1000),
           or float32 (H, W) in metres along the optical axis (depth_scale None). 0 = no
           measurement. NaN, infinite or negative float depths raise ValueError unless
           ``nan_as_missing=True`` reads them as no measurement (as g6d-service does).
    K:     3x3 intrinsics [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] in pixels; pixel (u, v) is
           centred at (u + 0.5, v + 0.5) (the BOP convention).

    Properties: width, height (pixels), K, rgb and depth (read-only views; depth float32 metres).
    Raises ValueError naming the argument on a wrong dtype, shape or K.
    """

    def __init__(self, rgb, depth, K, depth_scale=None, nan_as_missing=False):
        super().__init__(rgb, depth, K, depth_scale, bool(nan_as_missing))

    def __repr__(self):
        return f"<g6d.Frame {self.width}x{self.height}>"


class PoseResult:
    """One answer of the solver. Poses are 4x4 float64 numpy arrays, metres.

    object_id          the object answered ('' when no candidate succeeded)
    success, message, termination   whether a pose was found, and why not
    cam_from_object    T_A: object frame -> camera frame (4x4)
    position_m, orientation_wxyz    T_A's translation (metres) and unit quaternion (w, x, y, z)
    score              S_A, the physical consistency score (eq. 12): lower is better
    confidence         P(pose within ADD(-S) 0.1 d), from S_A, in [0, 1]
    iou, coverage, depth_residual   J, C and the normalized depth residual of T_A
    truncated          the mask touches the image border (the object is cut off)
    ambiguous          a pose that is not a symmetry scores as well and appearance cannot tell
    cut_short          the time budget ran out: T_A is the best so far
    has_runner_up, runner_up_cam_from_object (4x4 or None), runner_up_score (S or None)
    appearance_agreement, runner_up_appearance_agreement   ZNCC in [-1, 1] or None
    corrected_mask     uint8 (H, W) 0/255: the mask T_A implies (None on failure)
    mask_iou           IoU of corrected_mask with the mask given; mask_refined_rounds
    stages             the stage report: counts, best scores and 'time_ms' per stage
    bank               the TemplateBank of object_id (draw_overlay uses it)
    identity           (estimate_pose_of_unknown_object) chosen, runner_up_object_id,
                       runner_up_object_score, ambiguous, candidates, total_ms
    request, region, region_box, region_pixels   (find_objects) which (bank, count) pair,
                       the region solved (uint8 mask) and its box (x, y, width, height)
    """

    def __init__(self, fields):
        self.__dict__.update(fields)

    def as_dict(self):
        """The fields as a dict (arrays stay numpy arrays; the bank is left out)."""
        return {k: v for k, v in self.__dict__.items() if k != "bank"}

    def __repr__(self):
        if not self.success:
            return f"<g6d.PoseResult {self.object_id or '(none)'}: failed ({self.termination}): {self.message}>"
        t = self.position_m
        return (f"<g6d.PoseResult {self.object_id}: t = ({t[0]:.4f}, {t[1]:.4f}, {t[2]:.4f}) m, "
                f"S_A {self.score:.4f}, confidence {self.confidence:.3f}>")


class Detections(list):
    """The answers of find_objects (PoseResult, best S_A first), with ``report``: what the
    detection saw and did (support planes, segments, regions, solves, trials, time_ms)."""

    def __init__(self, answers, report):
        super().__init__(answers)
        self.report = report


# --------------------------------------------------------------------------------------
# Templates

class _ProgressPrinter:
    """progress=True: a redrawn bar on a terminal, a line per 10% otherwise (as g6d-build-templates)."""

    def __init__(self):
        import sys
        self.stream = sys.stderr
        self.terminal = self.stream.isatty()
        self.last_decile = 0

    def __call__(self, done, total):
        if self.terminal:
            width = 30
            filled = width * done // total if total else width
            self.stream.write(f"\r[{'#' * filled}{' ' * (width - filled)}] {done}/{total}")
            if done == total:
                self.stream.write("\n")
        else:
            decile = 10 * done // total if total else 10
            if decile != self.last_decile or done == total:
                self.stream.write(f"templates {done}/{total}\n")
                self.last_decile = decile
        self.stream.flush()


def build_templates(mesh_path, object_id, units, *, views=324, inplane=3, threads=2, progress=None,
                    options=None, **fields):
    """Renders a metric CAD mesh into a template bank, as g6d-build-templates does (offline;
    about a second per 10 templates on 2 cores).

    mesh_path: a PLY (vertex colours) or OBJ/MTL (texture) file.
    object_id: the id the bank answers with, e.g. 'obj_000005'.
    units:     'mm' or 'm', the units of the mesh file's coordinates (the bank is in metres).
    views:     N_T, the number of templates: ``views / inplane`` viewing directions times
               ``inplane`` in-plane rotations (a multiple of ``inplane``).
    threads:   render threads (the result is the same for any number).
    progress:  None, True (a bar on stderr) or a callable progress(done, total), called from
               the build's threads, one call at a time; if it raises, the build stops and the
               exception is raised here.
    options, **fields: TemplateBuildOptions (or a dict) and fields to change, e.g. online_mesh_faces=2000.

    Returns a TemplateBank; save it with bank.save(path). Raises ValueError for bad
    arguments and g6d.Error for a mesh that cannot be read.
    """
    build = _options(TemplateBuildOptions, options, fields)
    if isinstance(views, bool) or not isinstance(views, int) or isinstance(inplane, bool) \
            or not isinstance(inplane, int) or inplane < 1 or views < 1 or views % inplane:
        raise ValueError(f"views: expected a positive multiple of inplane ({inplane!r}), got {views!r} "
                         "(or pass inplane=1)")
    build.views.num_directions = views // inplane
    build.views.num_inplane = inplane
    build.validate()
    if progress is True:
        progress = _ProgressPrinter()
    elif progress is False:
        progress = None
    return _core.build_templates(_os.fspath(mesh_path), str(object_id), str(units), build, _threads(threads), progress)


_core_save = TemplateBank.save


def _save(self, path, zstd_level=9):
    """Writes the bank to a cache file (atomically: a temporary file, then a rename), as
    g6d-build-templates does; load it with g6d.load_cache. Raises g6d.Error when it cannot write."""
    _core_save(self, _os.fspath(path), zstd_level)


TemplateBank.save = _save


def load_cache(path, mesh_path=None):
    """Reads a template cache file (g6d-build-templates, bank.save).

    With ``mesh_path`` a stale cache (the mesh file changed since the build) is refused too.
    Raises g6d.Error (a RuntimeError) naming the file and the problem: missing, not a cache,
    wrong format version, truncated or corrupted (checksum), a field out of range.
    """
    return _core.load_cache(_os.fspath(path), "" if mesh_path is None else _os.fspath(mesh_path))


# --------------------------------------------------------------------------------------
# Solving

def estimate_pose(frame, bank, *, mask=None, box=None, options=None, threads=1, **fields):
    """Estimates cam_from_object of one object instance: the G6D pipeline (match, MSAC-PnP,
    observable selection, trimmed ICP, MHPO), exactly g6d-solve's and the service's.

    frame:  a g6d.Frame.
    bank:   the object's TemplateBank.
    mask:   bool or uint8 (H, W), non-zero = the object's visible pixels (read as evidence
            that the depth checks, unless mask_trust='exact'); or
    box:    (x, y, width, height) in pixels, a detector's box (clipped to the image).
    options, **fields: SolverOptions (or a dict) and fields to change, e.g.
            num_hypotheses=4 (K), budget_ms=50, mask_trust='exact', mhpo={'max_rounds': 3}.
            The defaults are the service's.
    threads: threads of this call (the answer is the same for any number). The GIL is
            released while solving: Python threads may solve at once.

    Returns a PoseResult: cam_from_object (4x4, object frame -> camera frame, metres),
    score (S_A, lower is better), confidence, flags, corrected_mask, runner-up, stages.
    A solve that finds no pose is not an error: success False and a message. Raises
    ValueError for bad arguments (naming the argument or the options field).
    """
    solver = _options(SolverOptions, options, fields)
    return PoseResult(_core.estimate_pose(frame, bank, mask, box, solver, _threads(threads)))


def track_pose(frame, bank, starts, *, mask=None, box=None, options=None, track=None, threads=1, **fields):
    """Solves one instance from known poses (tracking): trimmed ICP and MHPO from each start,
    the best by S; no template search.

    starts: a 4x4 cam_from_object (metres) or a list of them, e.g. the last answer and a
            constant-velocity prediction.
    track:  TrackSolveOptions (or a dict): iterations, points, MHPO rounds, appearance search.
    mask, box, options, **fields, threads: as estimate_pose.

    Returns a PoseResult (no runner-up: only the starts' neighbourhood is searched).
    """
    solver = _options(SolverOptions, options, fields)
    track_options = _options(TrackSolveOptions, track, {}, "track")
    if hasattr(starts, "shape") and getattr(starts, "ndim", 0) == 2:
        starts = [starts]
    return PoseResult(_core.track_pose(frame, bank, list(starts), mask, box, solver, track_options,
                                       _threads(threads)))


def estimate_pose_of_unknown_object(frame, banks, *, mask=None, box=None, options=None, identify=None,
                                    threads=1, **fields):
    """The pose of a masked object whose identity is not known: estimate_pose for every
    candidate bank; the lowest S_A wins (as g6d-solve --candidates).

    banks:    the candidate objects' TemplateBanks (each object once).
    identify: IdentifyOptions (or a dict), e.g. {'prescreen': False} to solve every candidate.
    mask, box, options, **fields, threads: as estimate_pose.

    Returns a PoseResult of the chosen object (object_id, bank) with ``identity``: chosen,
    runner_up_object_id and runner_up_object_score (None when none), ambiguous, screened_out,
    total_ms and per candidate object_id, success, score, ms, message.
    """
    solver = _options(SolverOptions, options, fields)
    identify_options = _options(IdentifyOptions, identify, {}, "identify")
    return PoseResult(_core.estimate_pose_of_unknown_object(frame, list(banks), mask, box, solver,
                                                           identify_options, _threads(threads)))


def find_objects(frame, objects, *, options=None, detect=None, threads=1, **fields):
    """Finds known objects without a mask or a box (as g6d-solve --find): support planes
    removed, depth segments and their unions proposed, ranked per object by size and colour,
    the best solved, answers kept by S_A with non-maximum suppression.

    objects: a list of (TemplateBank, count) pairs (at most count instances of that object),
             or of TemplateBanks (count 1).
    detect:  DetectOptions (or a dict), e.g. {'max_score': 0.3}.
    options, **fields, threads: as estimate_pose (mask_trust is 'depth' for these solves).

    Returns Detections: a list of PoseResult, best S_A first, each with request (the index
    into objects), region (uint8 mask it was solved on), region_box and region_pixels; and
    .report (counts, trials and time_ms per stage). No object found is an empty list.
    """
    solver = _options(SolverOptions, options, fields)
    detect_options = _options(DetectOptions, detect, {}, "detect")
    answers, report = _core.find_objects(frame, list(objects), solver, detect_options, _threads(threads))
    return Detections([PoseResult(a) for a in answers], report)


# --------------------------------------------------------------------------------------
# Pictures and files

def draw_overlay(frame, results, *, labels=True):
    """Draws each successful result's model contour (green) and axes (x red, y green,
    z blue) over the frame's colour image, as g6d-solve --overlay does.

    results: a PoseResult, or a list of them (failed ones are skipped).
    labels:  write '<object_id> S <S_A>' beside each contour.
    Returns a new uint8 (H, W, 3) RGB image (save it with g6d.write_image).
    """
    if isinstance(results, PoseResult):
        results = [results]
    drawn = [r for r in results if isinstance(r, PoseResult) and r.success and r.bank is not None]
    for i, r in enumerate(results):
        if not isinstance(r, PoseResult):
            raise ValueError(f"results[{i}]: expected a g6d.PoseResult, got {type(r).__name__}")
    poses = [(r.bank, r.cam_from_object) for r in drawn]
    texts = [f"{r.object_id} S {r.score:.3f}" if labels else "" for r in drawn]
    return _core.draw_overlay(frame, poses, texts)


def read_image(path, mode="unchanged"):
    """Reads an image file (PNG, JPEG, ...) into a numpy array, with OpenCV as g6d-solve does.

    mode 'unchanged': as stored: colour as uint8 (H, W, 3) RGB, a 16-bit depth PNG as uint16
    (H, W), an 8-bit grey image as uint8 (H, W). 'rgb': always uint8 (H, W, 3) RGB
    (g6d-solve --rgb). 'gray': always uint8 (H, W) (g6d-solve --mask).
    Raises g6d.Error when the file cannot be read.
    """
    return _core.read_image(_os.fspath(path), mode)


def write_image(path, image):
    """Writes a uint8 or uint16 (H, W) or (H, W, 3) RGB array to an image file; the format
    follows the extension (.png, .jpg). Raises g6d.Error when it cannot write."""
    _core.write_image(_os.fspath(path), image)
