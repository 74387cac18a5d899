"""Joint centres from Plug-in-Gait skin markers: an optical reference for the clinical angles.

Plug-in-Gait markers (:class:`~fusion.io.mocap_files.MarkerData`, e.g. from
:func:`fusion.io.formats.ui_prmd.read_ui_prmd_vicon`) sit on the skin over bony landmarks, not on
joint centres. :func:`marker_reference` estimates, per frame, the points the ISB angles of
:mod:`fusion.merge.angles` need, in the markers' own frame (metres, z up):

- **thorax** (Wu et al. 2005, J Biomech 38:981, ISB part II): ``thorax_upper`` = midpoint of ``C7``
  and ``CLAV`` (incisura jugularis), ``thorax_lower`` = midpoint of ``T10`` and ``STRN``. Plug-in-Gait
  has ``T10`` and ``STRN`` where the ISB names T8 and the processus xiphoideus, so they stand in for
  them. :attr:`MarkerReference.R_world_thorax` is the ISB thorax frame itself (``Y`` lower to upper
  midpoint, ``Z`` normal to the plane of ``CLAV``, ``C7`` and the lower midpoint, to the right).
- **glenohumeral centres**: a functional centre, fitted once per episode by the least-squares common
  centre of rotation of Gamage & Lasenby (2002, J Biomech 35:87; :mod:`fusion.merge.centre_fit`) to
  the humerus markers ``xUPA`` and ``xELB`` (Plug-in-Gait has only two humerus markers, too few for
  a rigid humerus frame and Ehrig's SCoRE, which needs one). The markers are taken relative to the
  acromion marker ``xSHO`` in thorax axes (:attr:`GhAnchor.ACROMION`: the centre rides with the
  shoulder girdle, which rises by centimetres when the arm is raised) or relative to ``CLAV``
  (:attr:`GhAnchor.THORAX`, a thorax-fixed centre). The fit's normal matrix says how far the markers
  moved along each direction (its principal "spreads" [m]); along a direction with a spread below
  ``min_spread_m`` the centre is not determined (a rotation about one axis leaves the centre free
  along that axis) and takes the component of the regression of Rab, Petuskey & Bagley (2002, Gait
  Posture 15:113): 17% of the acromion-to-acromion distance below ``xSHO`` along the thorax's ``Y``.
  Method per side: ``functional`` (all three directions determined), ``functional_partial`` (one or
  two), or ``regression`` (none, e.g. an arm that does not move).
- **elbow centres**: Plug-in-Gait has the lateral epicondyle ``xELB`` only. The centre lies half the
  elbow width plus the marker radius from ``xELB``, medially. Plug-in-Gait's chord rule (Vicon
  Plug-in-Gait reference guide) puts it in the plane of the glenohumeral centre, ``xELB`` and the
  wrist centre, with the line from ``xELB`` to the centre perpendicular to the humerus' long axis:
  exact for a straight elbow, but the plane tilts toward the wrist as the elbow bends (2 cm off at
  10 deg of flexion, 5 cm at 90 deg; :func:`chord_centre`). So the rule is applied only at the
  episode's straightest frames (the 5% with the longest shoulder-to-wrist distance), and the centre
  found there is carried rigidly by a humerus frame of the glenohumeral centre, ``xELB`` and ``xUPA``
  (its median offset in that frame) through the episode (method ``chord_offset``;
  :attr:`MarkerReference.elbow_calibration_deg` is the elbow flexion at those frames, the error of the
  rule grows with it). The elbow width is not measured in every data set (not in UI-PRMD):
  ``elbow_width_m`` defaults to 67 mm, between the adult median elbow breadths of women (about
  63 mm) and men (about 72 mm) in Frisancho (1990, Anthropometric standards for the assessment of
  growth and nutritional status, NHANES I/II). A functional flexion axis (SARA, Ehrig et al. 2007,
  J Biomech 40:2150) is not used: straight-arm movements do not bend the elbow enough to determine one.
- **wrist centres**: midpoint of the wrist-bar markers ``xWRA`` and ``xWRB``.
- **hips**: midpoint of ``xASI`` and ``xPSI`` (marker stand-ins, as in the ``plug_in_gait`` map of
  :mod:`fusion.io.marker_map`; only the level pelvis of the trunk angles uses them). The
  reference skeleton's ``SpineBase`` is their midpoint, so its thorax axis runs from the pelvis to
  the upper thorax as a Kinect skeleton's does (:func:`fusion.facing.trunk_axes`): comparing a
  pelvis-based axis with a T10-based one would count the lumbar spine's bending as the camera's
  elevation error.

What the reference cannot see: skin movement of ``xSHO`` over the acromion (centimetres at high
elevation, so an acromion-anchored centre inherits it) and of ``xUPA`` under humeral axial rotation
(it blurs the sphere fit and turns the humerus frame that carries the elbow centre); the scapula's
own rotation (the centre is a point fixed relative to ``xSHO`` in thorax axes); the subject's real
elbow width (an error of ``e`` in it moves the elbow centre by ``e / 2``); and the centres of frames
whose markers are lost (NaN, never guessed).

:func:`reference_skeleton` turns the centres into a :data:`~fusion.topology.KINECT_V2` skeleton stream
whose clinical angles (:func:`fusion.merge.angles.joint_angles`, the code used for Kinect skeletons)
are the reference's: ``SpineMid`` and ``SpineShoulder`` are the two thorax midpoints (so the thorax
``Y`` is the ISB's; ``SpineBase`` is left absent), and the thorax ``Z`` is the glenohumeral line made
orthogonal to ``Y``, the project's definition (:func:`fusion.facing.thorax_frame`), not the ISB's
marker plane.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from fusion.arrays import frozen, nanmedian, unit
from fusion.errors import BadInputError, UnknownNameError
from fusion.io.mocap_files import MarkerData
from fusion.merge.centre_fit import CentreFit, fit_common_centre
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState

REFERENCE_JOINTS = ("thorax_upper", "thorax_lower", "gh_left", "gh_right", "elbow_left", "elbow_right",
                    "wrist_left", "wrist_right", "hip_left", "hip_right")
"""The joints of a :class:`MarkerReference`, in order."""

_SKELETON_JOINTS = {"thorax_upper": "SpineShoulder", "thorax_lower": "SpineMid", "gh_left": "ShoulderLeft",
                    "gh_right": "ShoulderRight", "elbow_left": "ElbowLeft", "elbow_right": "ElbowRight",
                    "wrist_left": "WristLeft", "wrist_right": "WristRight", "hip_left": "HipLeft",
                    "hip_right": "HipRight"}


class CentreMethod(enum.Enum):
    """How a joint centre of a :class:`MarkerReference` was found (module docstring)."""

    MARKER_MIDPOINT = "marker_midpoint"
    FUNCTIONAL = "functional"
    FUNCTIONAL_PARTIAL = "functional_partial"
    REGRESSION = "regression"
    CHORD_OFFSET = "chord_offset"
    MISSING = "missing"


class GhAnchor(enum.Enum):
    """What the glenohumeral centre is fixed to: the acromion marker (in thorax axes) or the thorax."""

    ACROMION = "acromion"
    THORAX = "thorax"


@dataclass(frozen=True)
class ReferenceOptions:
    """Constants of :func:`marker_reference`.

    Attributes
    ----------
    elbow_width_m : elbow (humeral biepicondylar) width [m] when not measured.
    marker_diameter_m : diameter of the skin markers [m] (14 mm Vicon markers).
    gh_regression_ratio : depth of the glenohumeral centre below ``xSHO`` as a fraction of the
        acromion-to-acromion distance (Rab et al. 2002).
    min_spread_m : smallest RMS marker excursion [m] along a direction for the functional fit to
        determine the centre along it.
    anchor : what the glenohumeral centre is fixed to.
    """

    elbow_width_m: float = 0.067
    marker_diameter_m: float = 0.014
    gh_regression_ratio: float = 0.17
    min_spread_m: float = 0.02
    anchor: GhAnchor = GhAnchor.ACROMION

    def __post_init__(self) -> None:
        for name in ("elbow_width_m", "marker_diameter_m", "gh_regression_ratio", "min_spread_m"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0.0):
                raise BadInputError(f"{name} must be a finite non-negative number, got {v!r}")
        if not isinstance(self.anchor, GhAnchor):
            raise BadInputError(f"anchor must be a GhAnchor, got {self.anchor!r}")


@dataclass(frozen=True, eq=False)
class MarkerReference:
    """Joint centres estimated from Plug-in-Gait markers, per frame (module docstring).

    Attributes
    ----------
    joints : (J,) names, :data:`REFERENCE_JOINTS`.
    times : (T,) [s] the markers' times.
    positions : (T, J, 3) [m] in the markers' frame (z up); NaN where a needed marker is absent.
    R_world_thorax : (T, 3, 3) ISB thorax frame (columns ``X`` forward, ``Y`` up, ``Z`` right); NaN
        where a thorax marker is absent.
    methods : (J,) how each centre was found.
    fits : side (``left``/``right``) -> the glenohumeral :class:`CentreFit` (in thorax axes, relative
        to the anchor), absent where the side had no usable marker.
    elbow_calibration_deg : side -> elbow flexion [deg] at the frames where the chord rule placed the
        elbow centre (NaN where it could not); small is good (module docstring).
    options : the constants used.
    """

    joints: tuple[str, ...]
    times: np.ndarray
    positions: np.ndarray
    R_world_thorax: np.ndarray
    methods: tuple[CentreMethod, ...]
    fits: dict[str, CentreFit] = field(default_factory=dict)
    elbow_calibration_deg: dict[str, float] = field(default_factory=dict)
    options: ReferenceOptions = ReferenceOptions()

    def __post_init__(self) -> None:
        t = np.array(self.times, dtype=float)
        P = np.array(self.positions, dtype=float)
        R = np.array(self.R_world_thorax, dtype=float)
        J = len(self.joints)
        if t.ndim != 1 or P.shape != (len(t), J, 3) or R.shape != (len(t), 3, 3):
            raise BadInputError(f"positions must be ({len(t)}, {J}, 3) and R_world_thorax ({len(t)}, 3, 3), "
                                f"got {P.shape} and {R.shape}")
        if len(self.methods) != J or not all(isinstance(m, CentreMethod) for m in self.methods):
            raise BadInputError(f"methods must hold one CentreMethod per joint ({J})")
        for name, arr in (("times", t), ("positions", P), ("R_world_thorax", R)):
            object.__setattr__(self, name, frozen(arr))

    def __getitem__(self, joint: str) -> np.ndarray:
        """(T, 3) positions [m] of one joint."""
        if joint not in self.joints:
            raise UnknownNameError("reference joint", joint, self.joints)
        return self.positions[:, self.joints.index(joint)]

    def method(self, joint: str) -> CentreMethod:
        """How ``joint``'s centre was found."""
        if joint not in self.joints:
            raise UnknownNameError("reference joint", joint, self.joints)
        return self.methods[self.joints.index(joint)]


def isb_thorax_frame(c7: np.ndarray, clav: np.ndarray, t10: np.ndarray, strn: np.ndarray) -> np.ndarray:
    """(..., 3, 3) ISB thorax frame from (..., 3) marker positions (module docstring), columns ``X``
    forward, ``Y`` up, ``Z`` right; NaN where a marker is NaN."""
    lower = 0.5 * (t10 + strn)
    y = unit(0.5 * (c7 + clav) - lower)
    z = unit(np.cross(c7 - clav, lower - clav))
    x = unit(np.cross(y, z))
    return np.stack([x, y, np.cross(x, y)], axis=-1)


def chord_centre(proximal: np.ndarray, marker: np.ndarray, distal: np.ndarray, radius: float) -> np.ndarray:
    """(..., 3) Plug-in-Gait's chord rule: the point ``radius`` [m] from ``marker``, in the plane of
    ``proximal``, ``marker`` and ``distal`` on the side of the line ``proximal``-``distal``, such that
    ``marker`` -> point is perpendicular to point -> ``proximal``. NaN where undefined (a point NaN,
    the three collinear, or ``proximal`` closer than ``radius``)."""
    a = proximal - marker
    L = np.linalg.norm(a, axis=-1, keepdims=True)
    u = unit(a)
    w = distal - marker
    v = unit(w - np.einsum("...k,...k->...", w, u)[..., None] * u)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = radius / L
        sin = np.sqrt(1.0 - cos ** 2)
    return marker + radius * (cos * u + sin * v)


def humerus_frame_from_markers(gh: np.ndarray, elb: np.ndarray, upa: np.ndarray) -> np.ndarray:
    """(..., 3, 3) a humerus-fixed orthonormal frame (not the ISB's) from (..., 3) points: first
    column toward ``elb``, second toward ``upa`` made orthogonal to it; NaN where a point is NaN or the
    three are collinear."""
    e1 = unit(elb - gh)
    w = upa - gh
    e2 = unit(w - np.einsum("...k,...k->...", w, e1)[..., None] * e1)
    return np.stack([e1, e2, np.cross(e1, e2)], axis=-1)


def elbow_centre(gh: np.ndarray, elb: np.ndarray, upa: np.ndarray, wrist: np.ndarray, radius: float,
                 straightest: float = 0.05) -> tuple[np.ndarray, float]:
    """(T, 3) elbow centres [m] of one arm (module docstring) and the elbow flexion [deg] at the
    frames that placed them (NaN, with NaN centres, where no frame has all four points).

    The chord rule (:func:`chord_centre`) at the ``straightest`` fraction of the frames with the longest
    ``gh``-``wrist`` distance gives the centre's offset in :func:`humerus_frame_from_markers`; its
    median carries the centre through every frame. Inputs are (T, 3) [m], NaN where absent."""
    R = humerus_frame_from_markers(gh, elb, upa)
    chord = chord_centre(gh, elb, wrist, radius)
    reach = np.linalg.norm(wrist - gh, axis=-1)
    ok = np.isfinite(reach) & np.isfinite(chord).all(axis=-1) & np.isfinite(R).all(axis=(-2, -1))
    if not ok.any():
        return np.full(gh.shape, np.nan), float("nan")
    cut = np.quantile(reach[ok], 1.0 - straightest)
    use = ok & (reach >= cut)
    offset = nanmedian(np.einsum("tki,tk->ti", R[use], chord[use] - gh[use]), axis=0)
    centre = gh + np.einsum("tij,j->ti", R, offset)
    u, f = unit(gh[use] - centre[use]), unit(wrist[use] - centre[use])
    flexion = 180.0 - np.degrees(np.arccos(np.clip(np.einsum("ti,ti->t", u, f), -1.0, 1.0)))
    return centre, float(np.median(flexion))


def _markers(data: MarkerData, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    missing = [n for n in names if n not in data.names]
    if missing:
        raise UnknownNameError("Plug-in-Gait marker", missing[0], data.names)
    return {n: np.asarray(data.positions[:, data.names.index(n)], dtype=float) for n in names}


def marker_reference(data: MarkerData, options: ReferenceOptions = ReferenceOptions()) -> MarkerReference:
    """Joint centres of one episode of Plug-in-Gait markers (module docstring).

    Parameters
    ----------
    data : markers [m], z up; needs ``C7 T10 CLAV STRN`` and, per side, ``SHO UPA ELB WRA WRB ASI PSI``.
    options : constants of the estimates.

    Returns
    -------
    MarkerReference
        (T, 10, 3) centres [m] in the markers' frame, methods and the glenohumeral fits.

    Raises
    ------
    UnknownNameError
        A needed marker is not in ``data`` (lists the markers it has).
    """
    sides = {"left": "L", "right": "R"}
    names = ("C7", "T10", "CLAV", "STRN") + tuple(f"{s}{m}" for s in "LR" for m in
                                                   ("SHO", "UPA", "ELB", "WRA", "WRB", "ASI", "PSI"))
    mk = _markers(data, names)
    R = isb_thorax_frame(mk["C7"], mk["CLAV"], mk["T10"], mk["STRN"])
    thorax_ok = np.isfinite(R).all(axis=(1, 2))
    out = {"thorax_upper": 0.5 * (mk["C7"] + mk["CLAV"]), "thorax_lower": 0.5 * (mk["T10"] + mk["STRN"])}
    methods = {"thorax_upper": CentreMethod.MARKER_MIDPOINT, "thorax_lower": CentreMethod.MARKER_MIDPOINT}
    width = float(nanmedian(np.linalg.norm(mk["LSHO"] - mk["RSHO"], axis=-1)))
    fits: dict[str, CentreFit] = {}
    calibration: dict[str, float] = {}
    for side, s in sides.items():
        anchor = mk[f"{s}SHO"] if options.anchor is GhAnchor.ACROMION else mk["CLAV"]
        local = np.stack([np.einsum("tki,tk->ti", R, mk[f"{s}{m}"] - anchor) for m in ("UPA", "ELB")], axis=1)
        below = np.array([0.0, -options.gh_regression_ratio * width, 0.0])
        if options.anchor is GhAnchor.ACROMION:
            prior = below
        else:
            prior = nanmedian(np.einsum("tki,tk->ti", R, mk[f"{s}SHO"] - mk["CLAV"]), axis=0) + below
        prior = prior if np.isfinite(prior).all() else None
        fit = fit_common_centre(local, min_spread_m=options.min_spread_m, prior=prior)
        c = fit.centre
        if fit.n_frames >= 2:
            fits[side] = fit
        if np.isfinite(c).all() and thorax_ok.any():
            out[f"gh_{side}"] = anchor + np.einsum("tij,j->ti", R, c)
            methods[f"gh_{side}"] = (CentreMethod.FUNCTIONAL if fit.n_determined == 3 else
                                     CentreMethod.REGRESSION if fit.n_determined == 0 else
                                     CentreMethod.FUNCTIONAL_PARTIAL)
        else:
            out[f"gh_{side}"] = np.full((len(data.times), 3), np.nan)
            methods[f"gh_{side}"] = CentreMethod.MISSING
        out[f"wrist_{side}"] = 0.5 * (mk[f"{s}WRA"] + mk[f"{s}WRB"])
        methods[f"wrist_{side}"] = CentreMethod.MARKER_MIDPOINT
        radius = 0.5 * (options.elbow_width_m + options.marker_diameter_m)
        out[f"elbow_{side}"], calibration[side] = elbow_centre(out[f"gh_{side}"], mk[f"{s}ELB"], mk[f"{s}UPA"],
                                                              out[f"wrist_{side}"], radius)
        methods[f"elbow_{side}"] = (CentreMethod.CHORD_OFFSET if np.isfinite(out[f"elbow_{side}"]).any()
                                    else CentreMethod.MISSING)
        out[f"hip_{side}"] = 0.5 * (mk[f"{s}ASI"] + mk[f"{s}PSI"])
        methods[f"hip_{side}"] = CentreMethod.MARKER_MIDPOINT
    for j in REFERENCE_JOINTS:
        if methods[j] is not CentreMethod.MISSING and not np.isfinite(out[j]).any():
            methods[j] = CentreMethod.MISSING
    positions = np.stack([out[j] for j in REFERENCE_JOINTS], axis=1)
    positions[~np.isfinite(positions).all(axis=-1)] = np.nan
    return MarkerReference(REFERENCE_JOINTS, np.asarray(data.times, dtype=float), positions, R,
                           tuple(methods[j] for j in REFERENCE_JOINTS), fits, calibration, options)


def reference_skeleton(reference: MarkerReference) -> SkeletonStream:
    """The reference's centres as a :data:`~fusion.topology.KINECT_V2` stream in the markers' z-up
    frame (module docstring): the joints of :data:`REFERENCE_JOINTS` filled (TRACKED where finite),
    ``SpineBase`` the hips' midpoint; every other joint NaN and NOT_TRACKED; timestamps the markers'
    times [s]."""
    T = len(reference.times)
    P = np.full((T, KINECT_V2.n_joints, 3), np.nan)
    for joint, kinect in _SKELETON_JOINTS.items():
        P[:, KINECT_V2.index(kinect)] = reference[joint]
    P[:, KINECT_V2.index("SpineBase")] = 0.5 * (reference["hip_left"] + reference["hip_right"])
    states = np.where(np.isfinite(P).all(axis=-1), TrackingState.TRACKED, TrackingState.NOT_TRACKED).astype(np.int8)
    return SkeletonStream(KINECT_V2, reference.times, P, states)
